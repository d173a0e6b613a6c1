"""benchmarks/neural_learn.py's tables: a trimmed trial table gives the tables of its
JSONL, a passed success test's filled-in trials are counted apart, the rate side's
--theta-c-rule, and bad options."""

from __future__ import annotations

import itertools
import json
import sys
from pathlib import Path
from typing import Any

import pytest

from striatal.params import CHAPTER_INITIAL_THETA_C

ROUND3 = Path(__file__).resolve().parents[1] / "docs" / "data" / "neural_learn_rate_r3.jsonl"


def run(bench: Any, monkeypatch: pytest.MonkeyPatch, *argv: str) -> int:
    monkeypatch.setattr(sys, "argv", ["neural_learn.py", *argv])
    return int(bench.main())


def trial(seed: int, k: int, reward: float, success: bool = False) -> dict[str, object]:
    return {
        "side": "rate", "seed": seed, "duration": 30.0, "alpha": 0.0, "init": "chapter",
        "kind": "trial", "trial": k, "W": [0.0] * 6, "theta_c": 0.6, "reward": reward,
        "success": success, "fault": False,
    }  # fmt: skip


def test_a_trimmed_table_gives_the_tables_of_its_jsonl(
    neural_learn_bench: Any,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    table = tmp_path / "rate.csv"
    assert run(neural_learn_bench, monkeypatch, "--trim", str(ROUND3), str(table)) == 0
    assert table.read_text().splitlines()[0].split(",") == list(neural_learn_bench.TRIM_COLUMNS)
    capsys.readouterr()
    outs = []
    for path in (ROUND3, table):
        for what in ("--compare", "--drift"):
            assert run(neural_learn_bench, monkeypatch, what, str(path), "--trials", "52") == 0
        outs.append(capsys.readouterr().out)
    assert outs[0] == outs[1]
    assert "rate alpha=5: 20 seeds, 955 updates" in outs[0]  # 975 trials run, 20 seeds
    # round 3's rate arms: 20 seeds x 52 trials, some ended by a passed success test
    assert "rate alpha=0: 20 seeds, 1040 trials; +10 in 575/1040" in outs[0]
    assert "22 trials after it counted +10; in the 1018 trials run +10 in 553" in outs[0]
    assert not list(tmp_path.glob("*.tmp"))


def test_a_passed_success_test_fills_the_later_trials_and_is_counted_apart(
    neural_learn_bench: Any, tmp_path: Path
) -> None:
    path = tmp_path / "runs.jsonl"
    rows = [trial(0, 1, -5.0), trial(0, 2, 10.0, success=True)]
    rows += [trial(1, k, -5.0) for k in (1, 2, 3, 4)]
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    groups, ran, solved = neural_learn_bench._groups([path], 4)
    assert groups == {"rate alpha=0": {0: [False, True, True, True], 1: [False] * 4}}
    assert ran == {"rate alpha=0": {0: 2, 1: 4}}
    assert solved == {"rate alpha=0": {0}}
    # every run not ended by a success has 4 trials; a run stopped mid-round has fewer
    assert neural_learn_bench.trials_done([path]) == 4
    with path.open("a") as fh:  # a line still being written is left out
        fh.write(json.dumps(trial(1, 5, -5.0))[:40])
    assert neural_learn_bench.trials_done([path]) == 4
    path.write_text(path.read_text()[:-40])
    with path.open("a") as fh:
        fh.write("".join(json.dumps(trial(2, k, -5.0)) + "\n" for k in (1, 2, 3)))
    assert neural_learn_bench.trials_done([path]) == 3


def test_the_rate_side_keeps_theta_c_with_the_fixed_reading(
    neural_learn_bench: Any, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """With eq 21 as preset (under the swing-up) theta_c only rises at alpha 0; with
    --theta-c-rule fixed it stays theta_c(0), and its rows say so (their own arm)."""
    out = tmp_path / "rate.jsonl"
    common = ["--side", "rate", "--seeds", "0", "--trials", "4", "--alpha", "0", "--out", str(out)]
    assert run(neural_learn_bench, monkeypatch, *common) == 0
    assert run(neural_learn_bench, monkeypatch, *common, "--theta-c-rule", "fixed") == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    preset = [r["theta_c"] for r in rows if r["kind"] == "trial" and "theta_c_rule" not in r]
    fixed = [r["theta_c"] for r in rows if r["kind"] == "trial" and "theta_c_rule" in r]
    assert preset[0] == fixed[0] == CHAPTER_INITIAL_THETA_C
    assert all(b >= a for a, b in itertools.pairwise(preset)) and preset[-1] > 0.6
    assert fixed == [CHAPTER_INITIAL_THETA_C] * 4
    groups, _, _ = neural_learn_bench._groups([out], 4)
    assert sorted(groups) == ["rate alpha=0", "rate theta_c=fixed alpha=0"]


@pytest.mark.parametrize(
    "argv",
    [
        ["--compare", str(ROUND3), "--trials", "5", "--block", "0"],
        ["--side", "network", "--theta-c-rule", "fixed", "--out", "x.jsonl"],
        ["--side", "rate", "--lockstep", "--out", "x.jsonl"],
    ],
)
def test_bad_options_are_refused_with_exit_2(
    neural_learn_bench: Any,
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    argv: list[str],
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as e:
        run(neural_learn_bench, monkeypatch, *argv)
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert [line for line in err if "error:" in line] == err[-1:]  # after the usage
    assert not (tmp_path / "x.jsonl").exists()
