"""Figures and animations: the plotted data are the trajectory, not just a file on disk."""

from __future__ import annotations

import json
import sys
import types
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import striatal
from striatal.cli import main
from striatal.errors import DataFileError, ParameterError
from striatal.learners.state import history_columns
from striatal.params import CHAPTER_FINAL_W, Controller, Plant, Simulation
from striatal.sim.control import switch_weights
from striatal.sim.rollout import Trajectory, simulate
from striatal.viz import plots

HISTORY_COLUMNS = history_columns(("sigma",))


@pytest.fixture(scope="module")
def chapter_run() -> Trajectory:
    return simulate(Plant(), Controller(), Simulation())


def _line(ax, gid: str):  # type: ignore[no-untyped-def]
    hits = [ln for ln in ax.get_lines() if ln.get_gid() == gid]
    assert len(hits) == 1, gid
    return hits[0]


# --------------------------------------------------------------------------- Figure 5


def test_figure5_has_four_panels_and_a_snapshot_every_0_2_s(chapter_run: Trajectory) -> None:
    fig = plots.figure5(chapter_run)
    assert len(fig.axes) == 4
    snaps = fig.figure5_parts.snapshots
    # the pole settles (balanced within 0.05 rad of upright to the end) at 26.35 s: the
    # snapshots end with that 10-s row, at 30 s, and a note stands for the 30 s left
    assert plots.settled_from(chapter_run) == pytest.approx(26.35)
    idx, end = plots.drawn_snapshots(chapter_run)
    assert end == 30.0 and len(plots.snapshot_indices(chapter_run)) == 301
    assert len(snaps.get_segments()) == len(idx) == round(30.0 / 0.2) + 1 == 151
    t, th = chapter_run.t[idx], chapter_run.column("theta")[idx]
    np.testing.assert_allclose(t, np.arange(151) * 0.2, atol=1e-9)
    theta = plots.display_theta(chapter_run)
    after = chapter_run.t >= 26.35 - 1e-9
    assert np.abs(theta[after] - plots.final_upright(theta)).max() <= plots.SETTLED_BAND
    notes = [x for x in fig.axes[0].texts if x.get_gid() == "settled_note"]
    assert len(notes) == 1 and notes[0].get_text().startswith("30–60 s: the pole stays")
    assert "every 0.2 s up to 30 s (151 poses; from 30 s to 60 s it stays" in (
        fig.figure5_parts.caption
    )
    seg = np.array(snaps.get_segments())
    # One row per 10 s, top to bottom; 50 poses a row, POSE_GAP pole lengths apart;
    # the last snapshot (t = 30 s) ends the third row rather than starting a fourth.
    row = np.minimum(np.floor(t / 10.0 + 1e-9), 2)
    slot = np.rint((t - 10.0 * row) / 0.2)
    assert slot.max() == 50 and row.max() == 2
    np.testing.assert_allclose(seg[:, 0, 0], slot * plots.POSE_GAP)
    np.testing.assert_allclose(seg[:, 0, 1], -row * plots.ROW_HEIGHT)
    # pole tip at l (sin, cos) theta from the pivot: the pose, as simulated
    np.testing.assert_allclose(seg[:, 1, 0] - seg[:, 0, 0], np.sin(th), atol=1e-12)
    np.testing.assert_allclose(seg[:, 1, 1] - seg[:, 0, 1], np.cos(th), atol=1e-12)
    # Poses of one row do not sit on each other, and rows do not overlap.
    assert plots.POSE_GAP > 0.5 and plots.ROW_HEIGHT > 2.0
    # The snapshots take less of the figure than the three panels under them
    renderer = fig.canvas.get_renderer()
    heights = [ax.get_window_extent(renderer).height for ax in fig.axes]
    assert heights[0] < sum(heights[1:])


def test_a_run_that_never_settles_draws_every_snapshot() -> None:
    """The printed balancing sign: the cart runs away, nothing settles, all 301 poses."""
    run = simulate(Plant(), Controller(balance_sign="chapter"), Simulation())
    assert plots.settled_from(run) is None
    idx, end = plots.drawn_snapshots(run)
    assert end == pytest.approx(float(run.t[-1])) and len(idx) == len(plots.snapshot_indices(run))


def test_snapshot_layout_rows() -> None:
    t = np.arange(0.0, 25.0 + 1e-9, 0.5)
    row, slot = plots.snapshot_layout(t, 0.5, 10.0)
    assert list(row[[0, 19, 20, 39, 40, 50]]) == [0, 0, 1, 1, 2, 2]
    assert list(slot[[0, 19, 20, 50]]) == [0, 19, 0, 10]
    with pytest.raises(ParameterError):
        plots.snapshot_layout(t, 0.5, 0.1)


@pytest.mark.parametrize(
    ("duration", "every", "n"), [(7.0, 0.2, 36), (3.0, 0.5, 7), (2.1, 0.2, 11)]
)
def test_snapshot_count(duration: float, every: float, n: int) -> None:
    traj = simulate(Plant(), Controller(), Simulation(duration=duration))
    assert len(plots.snapshot_indices(traj, every)) == n
    fig = plots.figure5(traj, every=every)
    assert len(fig.figure5_parts.snapshots.get_segments()) == n


def test_figure5_series_equal_the_trajectory(chapter_run: Trajectory) -> None:
    fig = plots.figure5(chapter_run)
    _, ax_xy, ax_x, ax_th = fig.axes
    x, th, t = chapter_run.column("x"), chapter_run.column("theta"), chapter_run.t
    tip = _line(ax_xy, "tip_path")
    np.testing.assert_array_equal(tip.get_xdata(), x + np.sin(th))
    np.testing.assert_array_equal(tip.get_ydata(), np.cos(th))
    xl = _line(ax_x, "x")
    np.testing.assert_array_equal(xl.get_xdata(), t)
    np.testing.assert_array_equal(xl.get_ydata(), x)
    # x and theta on separate axes with their own units; theta_c lines only with theta
    assert ax_x.get_ylabel() == "x [m]" and ax_th.get_ylabel() == "θ [rad]"
    assert not [ln for ln in ax_x.get_lines() if ln.get_gid() == "theta_c"]
    thl = _line(ax_th, "theta")
    np.testing.assert_array_equal(thl.get_ydata(), th)  # theta(0) = 3.12 is in (-pi, pi]
    assert thl.get_ydata()[0] == pytest.approx(3.12)
    bounds = sorted(ln.get_ydata()[0] for ln in ax_th.get_lines() if ln.get_gid() == "theta_c")
    assert bounds == pytest.approx([-0.9035, 0.9035])
    # switch times as vertical lines in the x and theta panels: the one hand-over at 19.55 s
    for ax in (ax_x, ax_th):
        sw = [ln for ln in ax.get_lines() if ln.get_gid() == "switch"]
        assert len(sw) == len(chapter_run.switch_times) == 1
        assert sw[0].get_xdata()[0] == pytest.approx(19.55)
    # the parameters are in the caption, not in the image's title
    caption = fig.figure5_parts.caption
    assert "1.1736" in caption and "0.9035" in caption and "θ(0) = 3.12 rad" in caption
    assert "19.55" in caption and "passed" in caption
    assert "1.1736" not in fig.get_suptitle() and len(fig.get_suptitle()) < 80
    assert ax_th.get_xlabel() == "time t [s]" and "[m]" in ax_xy.get_xlabel()


def test_figure5_of_w0_starts_at_its_theta0() -> None:
    """W(0) swings the pole up over the other side: theta ends near 2 pi, starts at 3.12."""
    traj = simulate(
        Plant(),
        Controller(gains=striatal.CHAPTER_INITIAL_W, theta_c=striatal.CHAPTER_INITIAL_THETA_C),
        Simulation(),
    )
    fig = plots.figure5(traj)
    ax_th = fig.axes[3]
    shown = np.asarray(_line(ax_th, "theta").get_ydata())
    assert shown[0] == pytest.approx(3.12)
    assert abs(shown[-1] - 2 * np.pi) < 0.05
    assert _line(ax_th, "upright").get_ydata()[0] == pytest.approx(2 * np.pi)
    bounds = sorted(ln.get_ydata()[0] for ln in ax_th.get_lines() if ln.get_gid() == "theta_c")
    assert bounds == pytest.approx([2 * np.pi - 0.6, 2 * np.pi + 0.6])
    assert "θ(0) = 3.12 rad" in fig.figure5_parts.caption


def test_pole_tip_uses_the_pole_length() -> None:
    plant = Plant(length=0.5)
    traj = simulate(plant, Controller(), Simulation(duration=1.0))
    tx, ty = plots.pole_tip(traj)
    x = traj.column("x")
    np.testing.assert_allclose(np.hypot(tx - x, ty), 0.5)


def test_figure_cli_writes_png_and_refuses_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "fig5.png"
    assert main(["figure", "--chapter-initial", "--duration", "4", "--out", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "21 snapshots" in capsys.readouterr().out
    assert main(["figure", "--out", str(tmp_path / "fig.jpg")]) == 2
    assert not (tmp_path / "fig.jpg").exists()
    assert main(["figure", "--gains", "1", "0", "0", "0", "0", "0", "--out", str(out)]) == 2
    assert "--theta-c" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["fig5.png"]  # no temp files left


def _result_json(path: Path, W: list[float], theta_c: float, sign: str = "corrected") -> Path:
    payload = {
        "success": True,
        "trials": 3,
        "W": W,
        "theta_c": theta_c,
        "seed": 0,
        "wall_seconds": 0.1,
        "learner": "chapter",
        "settings": {
            "controller": {"balance_sign": sign, "switch": "hard", "inhibition": 50.0},
            "plant": {"cart_mass": 1.0, "pole_mass": 0.1, "length": 1.0, "gravity": 9.8},
        },
    }
    path.write_text(json.dumps(payload))
    return path


def test_figure_from_result_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    res = _result_json(tmp_path / "result.json", list(CHAPTER_FINAL_W), 0.9035)
    out = tmp_path / "f.png"
    assert main(["figure", "--result", str(res), "--duration", "30", "--out", str(out)]) == 0
    printed = capsys.readouterr().out.splitlines()
    assert "151 snapshots, 1 switch(es)" in printed[0]
    # The caption follows, with this run's gains and its outcome at 30 s.
    assert printed[1].startswith("Figure 5. One run with the mean policy: W = [1.1736, ")
    verdict = printed[0].rsplit(" ", 1)[1]  # "passed" or "failed"
    assert f"success test at 30 s: {verdict}." in printed[1]
    assert "switches between the controllers at 19.55 s." in printed[1]
    assert main(["figure", "--result", str(res), "--chapter-initial", "--out", str(out)]) == 2
    (tmp_path / "bad.json").write_text('{"W": [1, 2]')
    assert main(["figure", "--result", str(tmp_path / "bad.json"), "--out", str(out)]) == 2


# --------------------------------------------------------------------------- curves


def _history_csv(path: Path, rewards: list[float], W: np.ndarray) -> Path:
    lines = [",".join(HISTORY_COLUMNS)]
    for k, (r, w) in enumerate(zip(rewards, W, strict=True)):
        sigma = 0.1 + 1.0 / (1.0 + np.exp(-w[5]))
        succ = int(k == len(rewards) - 1)
        cells = [k + 1, r, *w, 0.6 + 0.01 * k, sigma, "" if k == 0 else 0.7, 60.0, succ, 0, 0]
        lines.append(",".join(str(c) for c in cells))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_learning_curves_axes_and_series(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    W = rng.normal(size=(12, 6))
    rewards = [10.0, -5.0, 10.0, 10.0, -5.0, -5.0, 10.0, 10.0, 10.0, -5.0, 10.0, 10.0]
    h = plots.read_history(_history_csv(tmp_path / "history.csv", rewards, W))
    fig = plots.learning_curves(h, window=4)
    ax_r, ax_w, ax_c, ax_s, ax_rate = fig.axes
    assert "reward" in ax_r.get_ylabel() and ax_rate.get_ylabel() == "running fraction"
    assert ax_c.get_ylabel() == "θ_c [rad]" and ax_s.get_ylabel().startswith("σ")
    assert ax_s.get_xlabel() == "trial"
    gains = ax_w.get_lines()[:6]
    for i, ln in enumerate(gains):
        assert ln.get_label() == f"W{i + 1}"
        np.testing.assert_array_equal(ln.get_xdata(), np.arange(1, 13))
        np.testing.assert_allclose(ln.get_ydata(), W[:, i])
    np.testing.assert_allclose(ax_c.get_lines()[0].get_ydata(), 0.6 + 0.01 * np.arange(12))
    rate = ax_rate.get_lines()[0].get_ydata()
    pos = np.array(rewards) > 0
    assert rate[3] == pytest.approx(pos[:4].mean()) and rate[11] == pytest.approx(pos[8:].mean())
    assert ax_rate.get_lines()[1].get_ydata()[-1] == pytest.approx(0.25)


def test_running_mean_by_hand() -> None:
    np.testing.assert_allclose(plots.running_mean(np.array([1, 0, 1, 1]), 2), [1, 0.5, 0.5, 1])


def test_read_history_rejects_bad_files(tmp_path: Path) -> None:
    p = tmp_path / "h.csv"
    p.write_text("trial,reward\n1,10\n")
    with pytest.raises(DataFileError, match="lacks the column"):
        plots.read_history(p)
    _history_csv(p, [10.0], np.zeros((1, 6)))
    p.write_text(p.read_text().replace("10.0,", "ten,", 1))
    with pytest.raises(DataFileError, match="reward is not a number"):
        plots.read_history(p)
    p.write_text(",".join(HISTORY_COLUMNS) + "\n")
    with pytest.raises(DataFileError, match="no trials"):
        plots.read_history(p)


def test_curves_cli(tmp_path: Path) -> None:
    h = _history_csv(tmp_path / "history.csv", [10.0, -5.0, 10.0], np.ones((3, 6)))
    out = tmp_path / "c.png"
    assert main(["curves", str(h), "--out", str(out)]) == 0
    assert out.stat().st_size > 1000
    assert main(["curves", str(tmp_path / "missing.csv"), "--out", str(out)]) == 2


def history_of(h: Any, **columns: np.ndarray) -> Any:
    """``h`` with the named columns replaced."""
    from dataclasses import replace

    data = h.data.copy()
    for name, values in columns.items():
        data[:, h.columns.index(name)] = values
    return replace(h, data=data)


def _labels(fig: Any) -> list[str]:
    return [str(ln.get_label()) for ax in fig.axes for ln in ax.get_lines()]


def test_learning_curves_label_each_learner_correctly(tmp_path: Path) -> None:
    """pgpe: its exploration std, its shaped reward, no +10 panel; reward 0 is not '< 0'."""
    import striatal

    run = striatal.train(learner="pgpe", init="random", seed=0, max_trials=4, out=tmp_path / "p")
    for h in (run.history, plots.read_history(tmp_path / "p" / "history.csv")):
        assert h.learner == "pgpe" and h.reward_kind == "shaped"
        fig = plots.learning_curves(h, window=2)
        # its exploration std did not change in 4 trials: said in the title, no flat panel
        np.testing.assert_array_equal(h.column("explore"), np.ones(4))
        ax_r, _ax_w, _ax_c, _ax_rate = fig.axes
        titles = " ".join(ax.get_title() for ax in fig.axes) + fig.texts[0].get_text()
        assert "pgpe's s = 1 in every trial (not drawn)" in fig.texts[0].get_text()
        assert "σ" not in titles
        assert "+10" not in titles and "reward > 0" not in " ".join(_labels(fig))
        assert ax_r.get_ylabel() == "shaped reward"
        assert "W6 (unused)" in _labels(fig)
    changing = history_of(h, explore=np.array([1.0, 0.9, 0.8, 0.8]))
    ax_e = plots.learning_curves(changing, window=2).axes[3]
    assert "exploration std s of pgpe" in ax_e.get_title()
    np.testing.assert_array_equal(ax_e.get_lines()[0].get_ydata(), [1.0, 0.9, 0.8, 0.8])
    W = np.ones((3, 6))
    W[:, 5] = [0.0, 0.5, 1.0]  # sigma changes: its panel is drawn
    sparse = plots.read_history(_history_csv(tmp_path / "h.csv", [0.0, -5.0, 10.0], W))
    fig = plots.learning_curves(sparse, window=2)
    by_label = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    assert list(by_label["reward 0"].get_ydata()) == [0.0]
    assert list(by_label["reward < 0"].get_ydata()) == [-5.0]
    assert fig.axes[3].get_title().startswith("policy std σ")


# --------------------------------------------------------------------------- soft switch


def test_switch_figure_plots_control_switch_weights() -> None:
    theta_c, gammas = 0.9, [2.0, 20.0]
    fig = plots.switch_figure(theta_c, gammas)
    # one column per gamma: weights on top, their sum below
    assert len(fig.axes) == 4
    for k, g in enumerate(gammas):
        ax_w, ax_sum = fig.axes[k], fig.axes[len(gammas) + k]
        b, s = _line(ax_w, f"balancing:{g:g}"), _line(ax_w, f"swingup:{g:g}")
        a = np.asarray(b.get_xdata())
        wb, ws = switch_weights(a, theta_c, True, g)
        np.testing.assert_array_equal(b.get_ydata(), wb)
        np.testing.assert_array_equal(s.get_ydata(), ws)
        total = np.asarray(_line(ax_sum, f"sum:{g:g}").get_ydata())
        # dead zone: total < 1 exactly within 1/gamma of theta_c, 0 at theta_c
        inside = np.abs(a - theta_c) < 1.0 / g - 1e-9
        outside = np.abs(a - theta_c) > 1.0 / g + 1e-9
        assert np.all(total[inside] < 1.0) and np.all(total[outside] == 1.0)
        assert total[np.argmin(np.abs(a - theta_c))] < 2.0 * g * (a[1] - a[0])
        # no curve of another gamma on this panel
        assert {ln.get_gid() for ln in ax_w.get_lines()} == {
            f"balancing:{g:g}",
            f"swingup:{g:g}",
            None,
        }
    title = fig.get_suptitle()
    assert "NOTES" not in title and "swapped" not in title and "0.9 rad" in title
    with pytest.raises(ParameterError):
        plots.switch_figure(theta_c, [0.0])


def test_switch_figure_cli(tmp_path: Path) -> None:
    out = tmp_path / "s.png"
    assert main(["switch-figure", "--theta-c", "0.6", "--inhibition", "3", "--out", str(out)]) == 0
    assert out.exists()
    assert main(["switch-figure", "--theta-c", "4", "--out", str(tmp_path / "t.png")]) == 2


# --------------------------------------------------------------------------- animation


def test_frame_times() -> None:
    np.testing.assert_allclose(plots.frame_times(2.0, 10.0, 1.0), np.arange(21) * 0.1)
    assert len(plots.frame_times(60.0, 15.0, 3.0)) == 301
    with pytest.raises(ParameterError):
        plots.frame_times(1.0, 0.0, 1.0)


def _fake_frame(state, plant, *, mode, t, theta_c, width, height, x_limit):  # type: ignore[no-untyped-def]
    """A frame that differs at every time (so the GIF writer merges none)."""
    img = np.zeros((height, width, 3), dtype=np.uint8)
    img[:, int(t * 10) % width] = 255
    img[0, 0] = (0, 255 * int(mode), 0)
    return img


@pytest.fixture
def fake_render(monkeypatch: pytest.MonkeyPatch) -> None:
    mod = types.ModuleType("striatal.viz.render")
    mod.cartpole_frame = _fake_frame  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "striatal.viz.render", mod)
    monkeypatch.setattr(striatal, "render", mod, raising=False)


def test_gif_has_one_frame_per_speed_over_fps(tmp_path: Path, fake_render: None) -> None:
    from PIL import Image

    out = tmp_path / "run.gif"
    args = ["animate", "--duration", "2", "--fps", "10", "--speed", "1", "--out", str(out)]
    assert main([*args, "--width", "64", "--height", "48"]) == 0
    with Image.open(out) as im:
        assert im.n_frames == 21
        assert im.size == (64, 48)
        assert im.info["duration"] == 100


@pytest.mark.parametrize("fps", ["0.01", "0.0999", "100.5", "1e-300"])
def test_animate_refuses_a_frame_rate_a_gif_cannot_hold(
    tmp_path: Path, fake_render: None, fps: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A GIF's delay is a 16-bit count of 10 ms: 0.01 fps (100 s a frame, merged with
    the identical frames after it) overflowed Pillow's header with a traceback."""
    out = tmp_path / "a.gif"
    assert main(["animate", "--duration", "2", "--fps", fps, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--fps must be in [0.1, 100]" in err
    assert list(tmp_path.iterdir()) == []


def test_the_slowest_frame_rate_writes_a_gif(tmp_path: Path, fake_render: None) -> None:
    from PIL import Image

    out = tmp_path / "slow.gif"
    args = ["animate", "--duration", "30", "--fps", "0.1", "--speed", "1", "--out", str(out)]
    assert main([*args, "--width", "16", "--height", "16"]) == 0
    with Image.open(out) as im:
        assert im.info["duration"] == 10_000


def test_animate_refuses_bad_options(tmp_path: Path, fake_render: None) -> None:
    assert main(["animate", "--fps", "0", "--out", str(tmp_path / "a.gif")]) == 2
    assert main(["animate", "--out", str(tmp_path / "a.avi")]) == 2
    if plots.ffmpeg_path() is None:
        assert main(["animate", "--out", str(tmp_path / "a.mp4")]) == 2
    assert list(tmp_path.iterdir()) == []


def test_gif_with_the_real_renderer(tmp_path: Path) -> None:
    pytest.importorskip("striatal.viz.render")
    from PIL import Image

    out = tmp_path / "run.gif"
    argv = ["animate", "--duration", "3", "--fps", "10", "--speed", "2", "--out", str(out)]
    assert main(argv) == 0
    with Image.open(out) as im:
        assert im.n_frames == len(plots.frame_times(3.0, 10.0, 2.0)) == 16


def test_runaway_run_is_drawn_clipped_but_complete() -> None:
    """The printed balancing sign runs away (paper-notes.md 1): data stay whole, view clips."""
    traj = simulate(Plant(), Controller(balance_sign="chapter"), Simulation())
    assert traj.outcome.fault
    fig = plots.figure5(traj)
    ax_x = fig.axes[2]
    np.testing.assert_array_equal(_line(ax_x, "x").get_ydata(), traj.column("x"))
    assert ax_x.get_ylim() == (-plots.VIEW_LIMIT, plots.VIEW_LIMIT)
    assert any("clipped" in t.get_text() for t in ax_x.texts)
    assert len(fig.figure5_parts.switch_lines) == 2 * len(traj.switch_times)
    assert len(traj.switch_times) > 20
    assert "blew up" in fig.figure5_parts.caption


def test_mp4_goes_through_ffmpeg_on_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fake_render: None
) -> None:
    """A stand-in ffmpeg that stores its stdin: the frames reach it raw, in order, atomically."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "ffmpeg"
    fake.write_text('#!/bin/sh\nfor a; do out="$a"; done\ncat > "$out"\n')
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{bin_dir}:/usr/bin:/bin")
    out = tmp_path / "run.mp4"
    argv = ["animate", "--duration", "1", "--fps", "10", "--speed", "1", "--out", str(out)]
    assert main([*argv, "--width", "32", "--height", "16"]) == 0
    assert out.stat().st_size == 11 * 32 * 16 * 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bin", "run.mp4"]


# --------------------------------------------------------------------------- the public module


def test_plots_gathers_the_figure_modules() -> None:
    from striatal.viz import animation, curves, profiles, trajectory

    assert striatal.plots is plots
    assert plots.figure5 is trajectory.figure5
    assert plots.learning_curves is curves.learning_curves
    assert plots.RULE_PANELS is curves.RULE_PANELS
    assert plots.performance_profiles is profiles.performance_profiles
    assert plots.save_animation is animation.save_animation
    assert all(hasattr(plots, name) for name in plots.__all__)


def test_a_failed_save_leaves_no_file_and_no_temp(tmp_path: Path) -> None:
    fig = plots.switch_figure(0.9, [5.0])
    out = tmp_path / "f.png"
    out.write_bytes(b"old")
    with pytest.raises(ValueError):
        plots.save_figure(fig, tmp_path / "f.bogus")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png"]
    plots.save_figure(fig, out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.png"]
    assert out.stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask() -> int:
    import os

    mask = os.umask(0)
    os.umask(mask)
    return mask


# --------------------------------------------------------------------------- neural seed curve


def test_neural_upright_curve_reads_theta_as_the_other_figures_do() -> None:
    from scipy.stats import binomtest

    from striatal.neural.figures import upright_curve_figure

    rows = [
        {"selection": "cerebellum", "neurons": n, "upright_last_10s": i < k}
        for n, k in ((500, 1), (2500, 4))
        for i in range(4)
    ]
    rows.append({"selection": "basal-ganglia", "neurons": 500, "upright_last_10s": True})
    fig = upright_curve_figure(rows)
    ax = fig.axes[0]
    label = ax.get_ylabel()
    assert "θ" in label and "theta" not in label
    assert "theta" not in ax.get_title() + ax.get_xlabel()
    (line,) = ax.get_lines()[:1]
    np.testing.assert_array_equal(line.get_xdata(), [500, 2500])
    np.testing.assert_allclose(line.get_ydata(), [0.25, 1.0])
    assert [t.get_text() for t in ax.texts] == ["1/4", "4/4"]
    # the lower bar of the 1/4 point ends at the exact interval's lower bound
    lows = [seg[0, 1] for seg in ax.collections[0].get_segments()]
    exact = binomtest(1, 4).proportion_ci(0.95, method="exact")
    assert min(lows) == pytest.approx(exact.low)
    with pytest.raises(ParameterError):
        upright_curve_figure([r for r in rows if r["selection"] != "cerebellum"])
