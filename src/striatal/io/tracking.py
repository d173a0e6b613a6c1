"""Experiment tracking: the hooks that training and sweeps call, and TensorBoard as one sink.

:func:`striatal.train` calls ``on_trial(state, record)`` after each trial's history row
is recorded; :func:`striatal.experiments.sweeps.run_sweep` calls ``on_run(row)`` as each
run's runs.csv row is written. Any callable does; a :class:`Tracker` has both, and
:class:`TensorBoardTracker` writes them as TensorBoard scalars (the ``tracking`` extra):

- per trial, step = trial number: every history.csv column as ``trial/<column>``
  (``trial/reward``, ``trial/W1`` .. ``trial/W6``, ``trial/theta_c``, ``trial/sigma``,
  ...) and ``trial/simulations``, the simulations counted so far;
- per finished run of a sweep, step = runs of that (arm, init) done before it:
  ``run/<arm>/<init>/success``, ``.../trials``, ``.../simulations``,
  ``.../simulated_seconds``.

``striatal train --tensorboard DIR`` and ``striatal sweep --tensorboard DIR`` use it;
``tensorboard --logdir DIR`` shows the curves.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Protocol

from striatal.errors import DataFileError, StriatalError

if TYPE_CHECKING:
    from striatal.learners import LearnerState, TrialRecord

__all__ = ["RUN_SCALARS", "TRACKING_EXTRA", "TensorBoardTracker", "Tracker"]

TRACKING_EXTRA = "pip install 'striatal[tracking]' (from a clone: pip install -e '.[tracking]')"
#: The columns of a runs.csv row written per finished run of a sweep.
RUN_SCALARS = ("success", "trials", "simulations", "simulated_seconds")


class Tracker(Protocol):
    """What training and sweeps report to, as they go."""

    def on_trial(self, state: LearnerState, record: TrialRecord) -> None:
        """After each trial of a training run, once its history row is recorded."""

    def on_run(self, row: Mapping[str, Any]) -> None:
        """After each run of a sweep, once its runs.csv row is written."""

    def close(self) -> None:
        """Write out what is buffered."""


class TensorBoardTracker:
    """A :class:`Tracker` writing TensorBoard event files into ``logdir`` (created)."""

    def __init__(self, logdir: str | Path) -> None:
        try:
            from tensorboard.compat.proto.event_pb2 import Event
            from tensorboard.compat.proto.summary_pb2 import Summary
            from tensorboard.summary.writer.event_file_writer import EventFileWriter
        except ModuleNotFoundError:
            raise StriatalError(
                f"--tensorboard writes TensorBoard files: {TRACKING_EXTRA}"
            ) from None
        self.logdir = Path(logdir)
        try:
            self.logdir.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DataFileError(
                f"cannot use --tensorboard folder {logdir}: {exc.strerror}"
            ) from None
        self._event, self._summary = Event, Summary
        self._writer = EventFileWriter(str(self.logdir))
        self._runs: Counter[tuple[str, str]] = Counter()

    def scalars(self, values: Mapping[str, float], step: int) -> None:
        """One event holding ``values`` (tag -> number) at ``step``; non-finite ones left out."""
        kept = [
            self._summary.Value(tag=tag, simple_value=float(v))
            for tag, v in values.items()
            if math.isfinite(float(v))
        ]
        if kept:
            self._writer.add_event(
                self._event(wall_time=time.time(), step=step, summary=self._summary(value=kept))
            )

    def on_trial(self, state: LearnerState, record: TrialRecord) -> None:
        values = {
            f"trial/{c}": float(v)
            for c, v in zip(record.columns, record.row(), strict=True)
            if c != "trial"
        }
        values["trial/simulations"] = float(state.simulations)
        self.scalars(values, record.trial)

    def on_run(self, row: Mapping[str, Any]) -> None:
        key = (str(row["arm"]), str(row["init"]))
        step = self._runs[key]
        self._runs[key] += 1
        self.scalars({f"run/{key[0]}/{key[1]}/{c}": float(row[c]) for c in RUN_SCALARS}, step)

    def close(self) -> None:
        self._writer.close()

    def __enter__(self) -> TensorBoardTracker:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()
