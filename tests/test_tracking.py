"""``--tensorboard DIR``: the scalars train and sweep write, read back with TensorBoard's
own reader and held against history.csv and runs.csv."""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
import pytest

from striatal.errors import StriatalError

pytest.importorskip("tensorboard")
from tensorboard.backend.event_processing.event_accumulator import (
    EventAccumulator,
)


def scalars(logdir: Path) -> dict[str, list[tuple[int, float]]]:
    acc = EventAccumulator(str(logdir), size_guidance={"scalars": 0})
    acc.Reload()
    return {tag: [(e.step, e.value) for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"]}


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_train_writes_every_trial_of_history(tmp_path: Path, cli) -> None:
    code, _, _ = cli(
        "train", "--max-trials", "30", "--seed", "2", "--no-progress",
        "--out", str(tmp_path / "run"), "--tensorboard", str(tmp_path / "tb"),
    )  # fmt: skip
    assert code == 0
    history = rows(tmp_path / "run" / "history.csv")
    got = scalars(tmp_path / "tb")
    for column in ("reward", "W1", "W6", "theta_c", "sigma", "success"):
        steps, values = zip(*got[f"trial/{column}"], strict=True)
        assert list(steps) == [int(r["trial"]) for r in history]
        # TensorBoard keeps float32
        np.testing.assert_allclose(values, [float(r[column]) for r in history], rtol=1e-6)
    sims = [v for _, v in got["trial/simulations"]]
    assert sims == sorted(sims) and sims[-1] >= len(history)


def test_sweep_writes_every_run(tmp_path: Path, cli) -> None:
    code, _, _ = cli(
        "sweep", "--seeds", "3", "--max-trials", "20", "--eval-draws", "0", "--no-progress",
        "--out", str(tmp_path / "sw"), "--tensorboard", str(tmp_path / "tb"),
    )  # fmt: skip
    assert code == 0
    runs = rows(tmp_path / "sw" / "runs.csv")
    got = scalars(tmp_path / "tb")
    for arm in ("learner", "control"):
        mine = [r for r in runs if r["arm"] == arm]
        for column in ("success", "trials", "simulations", "simulated_seconds"):
            values = got[f"run/{arm}/chapter/{column}"]
            assert [s for s, _ in values] == [0, 1, 2]
            assert sorted(v for _, v in values) == sorted(float(r[column]) for r in mine)
    # where the scalars go is not a setting of the sweep: its summary does not record it
    assert "tensorboard" not in (tmp_path / "sw" / "sweep.json").read_text()


def test_without_tensorboard_one_line_names_the_extra(
    tmp_path: Path, cli, monkeypatch: pytest.MonkeyPatch
) -> None:
    from striatal.io.tracking import TensorBoardTracker

    monkeypatch.setitem(sys.modules, "tensorboard.summary.writer.event_file_writer", None)
    with pytest.raises(StriatalError, match=r"striatal\[tracking\]"):
        TensorBoardTracker(tmp_path / "tb")
    code, _, err = cli(
        "train", "--max-trials", "5", "--no-progress", "--tensorboard", str(tmp_path / "tb")
    )
    assert code == 2 and "[tracking]" in err and len(err.strip().splitlines()) == 1
