"""Performance profiles: the curve maths on a synthetic runs.csv, the figure, the command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from striatal.cli import main
from striatal.errors import DataFileError, ParameterError
from striatal.experiments.profiles import (
    NOTE_TRIALS_FALLBACK,
    performance_profile,
    read_sweep_runs,
    sweep_profiles,
)
from striatal.experiments.stats import wilson_interval
from striatal.viz import plots

HEADER_OLD = "arm,method,init,seed,alpha,gamma,success,trials,wall_seconds\n"
HEADER_NEW = "arm,seed,success,trials,simulations,simulated_seconds\n"


def write_old(folder: Path, rows: list[tuple[str, int, int, int]]) -> Path:
    """runs.csv as today's sweep writes it (no simulations column); rows (arm, seed, ok, trials)."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = [f"{a},learn,chapter,{s},5.0,0.999,{ok},{t},0.1\n" for a, s, ok, t in rows]
    (folder / "runs.csv").write_text(HEADER_OLD + "".join(lines))
    return folder


def write_new(folder: Path, rows: list[tuple[str, int, int, int, int]]) -> Path:
    """runs.csv with the cost columns; rows (arm, seed, ok, trials, simulations)."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = [f"{a},{s},{ok},{t},{n},{60.0 * n}\n" for a, s, ok, t, n in rows]
    (folder / "runs.csv").write_text(HEADER_NEW + "".join(lines))
    return folder


def test_profile_steps_at_the_solved_costs() -> None:
    costs = [30, 10, 400, 20, 20, 400]
    solved = [True, True, False, True, True, False]
    p = performance_profile("a", costs, solved)
    assert p.budget.tolist() == [0.0, 10.0, 20.0, 30.0, 400.0]
    assert p.solved.tolist() == pytest.approx([0, 1 / 6, 3 / 6, 4 / 6, 4 / 6])
    assert p.success_rate == pytest.approx(4 / 6)


def test_profile_is_monotone_ends_at_the_rate_and_its_band_holds_it() -> None:
    rng = np.random.default_rng(4)
    costs = rng.integers(1, 500, size=57).astype(float)
    solved = rng.random(57) < 0.4
    costs[~solved] = 500.0
    p = performance_profile("a", costs, solved)
    assert np.all(np.diff(p.solved) >= 0)
    assert np.all(np.diff(p.budget) > 0)
    assert p.solved[0] == 0.0 and p.budget[0] == 0.0
    assert p.solved[-1] == pytest.approx(solved.mean())
    assert p.budget[-1] == 500.0
    assert np.all(p.low <= p.solved) and np.all(p.solved <= p.high)
    assert np.all((p.low >= 0) & (p.high <= 1))
    k = int(solved.sum())
    assert [p.low[-1], p.high[-1]] == pytest.approx(wilson_interval(k, 57).bounds)
    # a direct count at every budget
    for b, f in zip(p.budget, p.solved, strict=True):
        assert f == pytest.approx(np.mean(solved & (costs <= b)))


def test_profile_with_no_success_stays_at_zero() -> None:
    p = performance_profile("a", [100, 100], [False, False])
    assert p.solved.tolist() == [0.0, 0.0] and p.high[-1] > 0


@pytest.mark.parametrize(
    ("costs", "solved"), [([], []), ([1.0], [True, False]), ([np.nan], [True]), ([-1.0], [True])]
)
def test_profile_refuses_bad_input(costs: list[float], solved: list[bool]) -> None:
    with pytest.raises(ParameterError):
        performance_profile("a", costs, solved)


def test_old_runs_fall_back_to_trials_with_a_note(tmp_path: Path) -> None:
    rows = [("learner", 0, 1, 5), ("learner", 1, 0, 50), ("control", 0, 0, 50)]
    d = write_old(tmp_path / "s", rows)
    profiles, column, note = sweep_profiles([d])
    assert column == "trials" and note == NOTE_TRIALS_FALLBACK
    assert [p.arm for p in profiles] == ["learner", "control"]
    assert profiles[0].solved.tolist() == [0.0, 0.5, 0.5]
    with pytest.raises(ParameterError, match="simulations"):
        sweep_profiles([d], "simulations")


def test_new_runs_use_simulations_and_name_arms_by_folder(tmp_path: Path) -> None:
    a = write_new(tmp_path / "a", [("learner", 0, 1, 5, 7), ("learner", 1, 1, 3, 4)])
    b = write_new(tmp_path / "b", [("learner", 0, 0, 9, 9)])
    profiles, column, note = sweep_profiles([a, b])
    assert column == "simulations" and note == ""
    assert [p.arm for p in profiles] == ["a/learner", "b/learner"]
    assert profiles[0].budget.tolist() == [0.0, 4.0, 7.0]
    seconds, column, _ = sweep_profiles([a], "simulated_seconds")
    assert column == "simulated_seconds" and seconds[0].budget[-1] == 420.0
    # one folder without the column: the default falls back, an explicit --x is refused
    c = write_old(tmp_path / "c", [("learner", 0, 1, 5)])
    assert sweep_profiles([a, c])[1] == "trials"
    with pytest.raises(ParameterError):
        sweep_profiles([a, c], "simulations")


def test_reader_drops_a_cut_last_line_and_refuses_a_bad_one(tmp_path: Path) -> None:
    d = write_old(tmp_path / "s", [("learner", 0, 1, 5)])
    with (d / "runs.csv").open("a") as fh:
        fh.write("learner,learn,chapter,1,5.0,0.999,1,")
    assert len(read_sweep_runs(d)) == 1
    (d / "runs.csv").write_text(HEADER_OLD + "learner,learn,chapter,0,5,0.9,2,5,0.1\nx\n")
    with pytest.raises(DataFileError, match="line 2"):
        read_sweep_runs(d)
    (d / "runs.csv").write_text("arm,seed\nlearner,0\n")
    with pytest.raises(DataFileError, match="success"):
        read_sweep_runs(d)
    with pytest.raises(DataFileError):
        read_sweep_runs(tmp_path / "nothing")


def test_figure_has_a_line_and_a_band_per_arm(tmp_path: Path) -> None:
    d = write_old(tmp_path / "s", [("learner", 0, 1, 5), ("control", 0, 0, 50)])
    profiles, _, note = sweep_profiles([d])
    fig = plots.performance_profiles(profiles, xlabel="trials", note=note)
    ax = fig.axes[0]
    assert len(ax.get_lines()) == 2 and len(ax.collections) == 2
    assert "1/1 solved" in ax.get_legend().get_texts()[0].get_text()


def test_cli_writes_the_png_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = write_old(tmp_path / "s", [("learner", 0, 1, 5), ("control", 0, 0, 50)])
    out = tmp_path / "fig.png"
    assert main(["profile", str(d), "--out", str(out), "--json"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads(capsys.readouterr().out)
    assert data["x"] == "trials" and data["note"] == NOTE_TRIALS_FALLBACK
    assert data["profiles"][0]["solved"][-1] == 1.0


@pytest.mark.parametrize(
    ("folder", "extra"),
    [
        ("s", ["--x", "simulations"]),
        ("s", ["--x", "bogus"]),
        ("s", ["--dpi", "0"]),
        ("missing", []),
    ],
)
def test_cli_bad_input_is_one_line_exit_2(tmp_path: Path, folder: str, extra: list[str]) -> None:
    write_old(tmp_path / "s", [("learner", 0, 1, 5)])
    out = tmp_path / "f.png"
    command = [sys.executable, "-m", "striatal", "profile", str(tmp_path / folder)]
    proc = subprocess.run(
        [*command, "--out", str(out), *extra],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_help_texts_format(capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["--help"], ["profile", "--help"]):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 0
    assert "95 % band" in " ".join(capsys.readouterr().out.split())
