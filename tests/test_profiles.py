"""Performance profiles: the curve maths on a synthetic runs.csv, the figure, the command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

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
from striatal.viz.profiles import curve_points, legend_overlap

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
    assert note == NOTE_TRIALS_FALLBACK
    fig = plots.performance_profiles(profiles, xlabel="trials")
    ax = fig.axes[0]
    assert len(ax.get_lines()) == 2 and len(ax.collections) == 2
    assert "1/1 solved" in ax.get_legend().get_texts()[0].get_text()
    with pytest.raises(ParameterError):
        plots.performance_profiles(profiles, xlabel="trials", labels=["one"])


def test_cli_writes_the_png_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = write_old(tmp_path / "s", [("learner", 0, 1, 5), ("control", 0, 0, 50)])
    out = tmp_path / "fig.png"
    assert main(["profile", str(d), "--out", str(out), "--json"]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads(capsys.readouterr().out)
    assert data["x"] == "trials" and data["note"] == NOTE_TRIALS_FALLBACK
    assert data["profiles"][0]["solved"][-1] == 1.0
    assert data["profiles"][0]["label"] == "learner"


def write_inits(folder: Path, rows: list[tuple[str, str, int, int, int]]) -> Path:
    """runs.csv of a sweep of several inits; rows (arm, init, seed, ok, simulations)."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = [f"{a},{i},{s},{ok},{n},{n}\n" for a, i, s, ok, n in rows]
    (folder / "runs.csv").write_text("arm,init,seed,success,trials,simulations\n" + "".join(lines))
    return folder


INIT_ROWS = [
    ("learner", "chapter", 0, 1, 5),
    ("learner", "chapter", 1, 1, 7),
    ("learner", "random", 0, 0, 50),
    ("learner", "random", 1, 0, 50),
    ("control", "chapter", 0, 0, 50),
    ("control", "random", 0, 0, 50),
]


def test_a_sweep_of_several_inits_is_profiled_per_arm_and_init(tmp_path: Path) -> None:
    """Seeds started from the chapter's gains and from random ones are never pooled."""
    d = write_inits(tmp_path / "s", INIT_ROWS)
    profiles, _, _ = sweep_profiles([d])
    assert [(p.arm, p.init, p.runs, p.successes) for p in profiles] == [
        ("learner", "chapter", 2, 2),
        ("learner", "random", 2, 0),
        ("control", "chapter", 1, 0),
        ("control", "random", 1, 0),
    ]
    assert profiles[0].name == "learner (chapter init)"
    assert profiles[0].to_dict()["init"] == "chapter"
    # one init in the sweep: one profile per arm, no init in its name
    one = write_inits(tmp_path / "one", [r for r in INIT_ROWS if r[1] == "random"])
    single, _, _ = sweep_profiles([one])
    assert [(p.name, p.runs) for p in single] == [("learner", 2), ("control", 1)]
    assert single[0].to_dict()["init"] is None
    both, _, _ = sweep_profiles([d, one])
    assert [p.name for p in both] == [
        "s/learner (chapter init)",
        "s/learner (random init)",
        "s/control (chapter init)",
        "s/control (random init)",
        "one/learner",
        "one/control",
    ]


def test_cli_labels_each_init(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = write_inits(tmp_path / "s", INIT_ROWS)
    chapter = {"method": "learn", "role": "learner", "config": {"learner": "chapter"}}
    write_summary(d, {"learner": chapter})
    out = tmp_path / "f.png"
    assert main(["profile", str(d), "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [(p["arm"], p["init"], p["runs"], p["label"]) for p in data["profiles"]] == [
        ("learner", "chapter", 2, "chapter (learner), chapter init"),
        ("learner", "random", 2, "chapter (learner), random init"),
        ("control", "chapter", 1, "control, chapter init"),
        ("control", "random", 1, "control, random init"),
    ]
    assert main(["profile", str(d), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "learner (chapter init) = chapter (learner), chapter init: 2/2 solved" in text
    assert "control (random init) = control, random init: 0/1 solved" in text


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


# --------------------------------------------------------------------------- labels and legend

PGPE_ARMS = {
    "learner": {"method": "learn", "role": "learner", "config": {"learner": "pgpe"}},
    "control": {"method": "learn", "role": "control", "config": {"learner": "pgpe"}},
    "lqr": {"method": "lqr", "role": "baseline"},
    "random": {"method": "random", "role": "baseline", "config": {"learner": "pgpe"}},
    "cmaes": {"method": "cmaes", "role": "baseline", "config": {"learner": "pgpe"}},
}


def write_summary(folder: Path, arms: dict[str, Any]) -> None:
    (folder / "summary.json").write_text(json.dumps({"arms": [], "settings": {"arms": arms}}))


def test_arm_label_reads_the_learner_and_the_method() -> None:
    assert [plots.arm_label(a, s) for a, s in PGPE_ARMS.items()] == [
        "pgpe (learner)",
        "pgpe control (no learning)",
        "LQR",
        "random search",
        "CMA-ES",
    ]
    # an older summary without roles: the arm name says which is the control
    old = {"method": "learn", "config": {"learner": "chapter"}}
    assert plots.arm_label("control", old) == "chapter control (no learning)"
    assert plots.arm_label("learner", old) == "chapter (learner)"
    # nothing usable recorded: the arm's own name
    assert plots.arm_label("learner", None) == "learner"
    assert plots.arm_label("learner", {"method": "learn", "config": {}}) == "learner"
    assert plots.arm_label("odd", {"method": "simplex"}) == "odd"


def test_arm_labels_name_the_source_only_of_a_repeated_label() -> None:
    labels = plots.arm_labels(
        [
            ("a", "learner", PGPE_ARMS["learner"]),
            ("a", "random", PGPE_ARMS["random"]),
            ("b", "random", PGPE_ARMS["random"]),
            ("b", "learner", None),
        ]
    )
    assert labels == ["pgpe (learner)", "random search (a)", "random search (b)", "learner"]


def _steep_and_flat(rng: np.random.Generator) -> list[Any]:
    """Arms like those of the pgpe/chapter sweeps: five that rise steeply to 0.75-1 early
    in the budget, two that stay low over all of it."""
    arms = []
    for name, rate, scale, cap in [
        ("learner", 1.0, 30, 290),
        ("control", 0.75, 80, 300),
        ("lqr", 1.0, 1, 1),
        ("random", 1.0, 33, 190),
        ("cmaes", 0.87, 28, 300),
        ("chapter", 0.28, 60, 600),
        ("chapter-control", 0.02, 2, 600),
    ]:
        ok = rng.random(100) < rate
        costs = np.where(ok, np.minimum(rng.exponential(scale, 100), cap), cap)
        arms.append(performance_profile(name, costs, ok))
    return arms


def _step_points_px(ax: Any) -> np.ndarray:
    """Points every pixel along each drawn line, read from the artists (post steps)."""
    pts = []
    for line in ax.get_lines():
        x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        vx, vy = np.repeat(x, 2)[1:], np.repeat(y, 2)[:-1]
        for i in range(len(vx) - 1):
            t = np.linspace(0.0, 1.0, 200)
            seg = np.column_stack(
                [vx[i] + t * (vx[i + 1] - vx[i]), vy[i] + t * (vy[i + 1] - vy[i])]
            )
            pts.append(ax.transData.transform(seg))
    return np.concatenate(pts)


def _inside(box: Any, pts: np.ndarray) -> int:
    x, y = pts[:, 0], pts[:, 1]
    return int(np.count_nonzero((x > box.x0) & (x < box.x1) & (y > box.y0) & (y < box.y1)))


def test_legend_covers_no_curve(tmp_path: Path) -> None:
    profiles = _steep_and_flat(np.random.default_rng(0))
    fig = plots.performance_profiles(profiles, xlabel="simulations")
    plots.save_figure(fig, tmp_path / "p.png")  # the drawn layout is the one checked
    ax = fig.axes[0]
    legend = ax.get_legend()
    box = legend.get_window_extent()
    pts = _step_points_px(ax)
    assert _inside(box, pts) == 0
    # the steep part is upper left: where the old legend sat, it covers curves
    legend.set_loc("upper left")
    assert _inside(legend.get_window_extent(), pts) > 100
    assert legend_overlap(legend, curve_points(ax, profiles)) > 0


def test_legend_goes_outside_when_no_place_inside_is_free() -> None:
    """Eleven flat lines 0.1 apart over the whole budget leave no gap a legend fits in."""
    costs = np.linspace(1.0, 100.0, 10)
    profiles = [
        performance_profile(
            f"arm{k}",
            np.r_[0.0 * costs[:k] + 1.0, costs[k:] * 0 + 100],
            [True] * k + [False] * (10 - k),
        )
        for k in range(11)
    ]
    fig = plots.performance_profiles(profiles, xlabel="trials")
    fig.canvas.draw()
    ax = fig.axes[0]
    box = ax.get_legend().get_window_extent()
    assert box.x0 >= ax.get_window_extent().x1
    assert _inside(box, _step_points_px(ax)) == 0


def test_cli_names_arms_from_the_settings_and_keeps_the_note_off_the_figure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    a = write_new(tmp_path / "pgpe-random", [(n, 0, 1, 5, 5) for n in PGPE_ARMS])
    write_summary(a, PGPE_ARMS)
    chapter = {"method": "learn", "role": "learner", "config": {"learner": "chapter"}}
    b = write_new(tmp_path / "chapter", [("learner", 0, 1, 5, 9)])
    write_summary(b, {"learner": chapter})
    c = write_old(tmp_path / "old", [("learner", 0, 1, 5)])
    drawn: list[Any] = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, out, dpi: drawn.append(fig))
    assert main(["profile", str(a), str(b), "--out", str(tmp_path / "f.png")]) == 0
    legend = [t.get_text() for t in drawn[0].axes[0].get_legend().get_texts()]
    assert legend == [
        "pgpe (learner): 1/1 solved",
        "pgpe control (no learning): 1/1 solved",
        "LQR: 1/1 solved",
        "random search: 1/1 solved",
        "CMA-ES: 1/1 solved",
        "chapter (learner): 1/1 solved",
    ]
    out = capsys.readouterr().out
    assert "pgpe-random/learner = pgpe (learner): 1/1 solved" in out
    # a sweep without simulations: the note goes to stderr, no text of it in the figure
    assert main(["profile", str(c), "--out", str(tmp_path / "g.png")]) == 0
    captured = capsys.readouterr()
    assert NOTE_TRIALS_FALLBACK in captured.err and "note" not in captured.out
    from matplotlib.text import Text

    texts = [t.get_text() for t in drawn[1].findobj(Text)]
    assert "learner: 1/1 solved" in texts
    assert not any("runs.csv" in t or "simulations" in t for t in texts)


def test_robust_profile_names_its_learner(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    arms = {k: v for k, v in PGPE_ARMS.items() if k != "lqr"}
    d = write_new(tmp_path / "robust", [(n, 0, 1, 5, 5) for n in arms])
    write_summary(d, arms)
    drawn: list[Any] = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, out, dpi: drawn.append(fig))
    assert main(["profile", str(d), "--x", "simulated_seconds", "--out", str(d / "f.png")]) == 0
    legend = [t.get_text() for t in drawn[0].axes[0].get_legend().get_texts()]
    assert legend[0] == "pgpe (learner): 1/1 solved"
    assert not any(t.startswith("learner") for t in legend)


def test_cli_refuses_a_broken_summary(tmp_path: Path) -> None:
    d = write_new(tmp_path / "s", [("learner", 0, 1, 5, 5)])
    (d / "summary.json").write_text("{not json")
    out = tmp_path / "f.png"
    assert main(["profile", str(d), "--out", str(out)]) == 2
    assert not out.exists()
