"""``striatal simulate`` as a user runs it."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from conftest import cli_process

from striatal.cli import main


def test_simulate_chapter_final_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--chapter-final", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["success"] is True
    assert len(out["final_state"]) == 4
    assert len(out["switch_times"]) == 1
    assert out["max_abs_x"] > 1.0 and out["max_abs_force"] > 1.0
    assert out["settings"]["controller"]["theta_c"] == 0.9035
    assert out["settings"]["controller"]["balance_sign"] == "corrected"


def test_simulate_chapter_sign_fails(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["simulate", "--chapter-final", "--balance-sign", "chapter", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["success"] is False


def test_simulate_out_writes_trajectory_and_summary(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    assert main(["simulate", "--chapter-initial", "--duration", "5", "--out", str(out)]) == 0
    with (out / "trajectory.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "x", "x_dot", "theta", "theta_dot", "u", "force", "mode"]
    assert len(rows) == 1 + 501
    summary = json.loads((out / "summary.json").read_text())
    assert summary["settings"]["duration"] == 5.0
    assert "success" in capsys.readouterr().out


@pytest.mark.parametrize(
    "args",
    [
        ["--pole-mass", "-1"],
        ["--cart-mass", "0"],
        ["--length", "0"],
        ["--gravity", "nan"],
        ["--dt", "0"],
        ["--dt", "-0.01"],
        ["--gains", "nan", "0", "0", "0", "0", "0", "--theta-c", "0.5"],
        ["--gains", "1", "0", "0", "0", "inf", "0", "--theta-c", "0.5"],
        ["--gains", "0", "0", "0", "0", "0", "0", "--theta-c", "0.5"],
        ["--gains", "-1", "0", "0", "0", "0", "0", "--theta-c", "0.5"],
        ["--theta-c", "0"],
        ["--theta-c", "4"],
        ["--duration", "0"],
        ["--gains", "1", "2"],
        ["--balance-sign", "other"],
    ],
)
def test_bad_input_is_one_line_exit_2_nothing_written(args: list[str], tmp_path: Path) -> None:
    out = tmp_path / "never"
    r = cli_process("simulate", *args, "--out", str(out))
    assert r.rc == 2
    assert r.out == ""
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    assert "Traceback" not in r.err
    assert not out.exists()


def test_python_m_and_console_script_help() -> None:
    r = cli_process("--help")
    assert r.rc == 0 and "simulate" in r.out


def test_simulate_result_of_train_uses_its_gains_and_readings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--result takes W, theta_c, readings and plant from a result.json of train."""
    out = tmp_path / "t"
    argv = ["train", "--max-trials", "2", "--seed", "3", "--out", str(out), "--no-progress"]
    assert main([*argv, "--pole-mass", "0.12"]) == 0
    result = json.loads((out / "result.json").read_text())
    capsys.readouterr()
    assert main(["simulate", "--result", str(out / "result.json"), "--json"]) == 0
    got = json.loads(capsys.readouterr().out)
    assert got["settings"]["controller"]["gains"] == result["W"]
    assert got["settings"]["controller"]["theta_c"] == result["theta_c"]
    assert got["settings"]["plant"]["pole_mass"] == 0.12
    gains = [str(w) for w in result["W"]]
    assert main(["simulate", "--json", "--pole-mass", "0.12", "--gains", *gains,
                 "--theta-c", str(result["theta_c"])]) == 0  # fmt: skip
    assert json.loads(capsys.readouterr().out)["final_state"] == got["final_state"]
    assert main(["simulate", "--result", str(out / "result.json"), "--chapter-final"]) == 2
