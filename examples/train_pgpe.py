"""Train pgpe from random gains, then plot its learning curves and its Figure 5.

Uses ``striatal`` and its figures, ``striatal.viz.plots``. Run: ``python examples/train_pgpe.py [OUT_FOLDER]``
(set STRIATAL_EXAMPLE_TRIALS to cut the run short, as tests/test_chapter.py does).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import striatal
from striatal.viz import plots

out = Path(sys.argv[1] if len(sys.argv) > 1 else "pgpe-example")
max_trials = int(os.environ.get("STRIATAL_EXAMPLE_TRIALS", "300"))

# the tuned pgpe preset, W(0) uniform in [-1, 1]^6 drawn from the seed
run = striatal.train(learner="pgpe", init="random", seed=0, max_trials=max_trials, out=out)
print(f"{'success' if run.success else 'no success'} after {run.trials} trials")
print("W =", " ".join(f"{w:.4f}" for w in run.W), f"theta_c = {run.theta_c:.4f}")

# one row per trial, in memory (also in out/history.csv)
print("history columns:", ", ".join(run.history.columns))
curves = plots.learning_curves(run.history, window=20)
plots.save_figure(curves, out / "curves.png")

# the learned controller from theta = 3.12 at rest, 60 s, the mean policy
trajectory = striatal.simulate(run.plant, run.controller)
figure = plots.figure5(trajectory)
plots.save_figure(figure, out / "figure5.png")
print(f"wrote {out / 'curves.png'}, {out / 'figure5.png'}")
