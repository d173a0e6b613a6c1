"""Where the forward learner's real simulated seconds go, and how good its model is, per real trial.

    python benchmarks/forward_real_seconds.py [--root 0] [--first 0] [--seeds 15]
        [--forward-model generic-gains] [--imagine-margin M] [--json FILE]

Runs ``striatal.train("forward", robust=True, init="random", max_trials=300, ...)`` on
the run seeds ``spawn_seeds(root, first + seeds)[first:]`` one after the other (the runs
of ``benchmarks/forward_imagination.py``, unchanged: the rule's own functions are
wrapped, not copied) and sorts every real trial's counted seconds into

- **failed**: the candidate's real trial failed the success test on the nominal plant
  (its seconds: the trial's, which the eq-24 check may end early);
- **refused**: the trial passed, a case of the robustness set refused it (the trial's
  60 s and the cases run up to the refusal; the refusing case is named by its place in
  ``STOP_ORDER``);
- **passed**: the final trial and its whole set.

For the model it records, after each real trial that imagined, the model's error on
the *next* real trial (data it had not seen): the one-step angular acceleration error
(RMS, and relative to the data's spread), and the trial-level agreement: the candidate
run on the model's mean from the same start (the imagined trial) against the real
one, as the time until their angles part by more than 0.5 rad, and whether imagination
"solved" against whether the real trial passed the nominal test. Rows are grouped by
how many real trials the model was fitted on. Per-run CPU seconds are printed
(``time.process_time``).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import statistics
import time
from typing import Any

import numpy as np
from forward_runs import (  # beside this script (benchmarks/ is its sys.path[0])
    add_margin_option,
    add_run_options,
    margin_options,
    run_seeds,
    train_forward,
)

from striatal.learners.forward import rule as forward
from striatal.sim.batch import TrialRequest
from striatal.sim.robust import ROBUST_CASES, STOP_ORDER

#: How far the imagined and the real angle may part before the trial-level prediction
#: counts as lost [rad].
PART = 0.5
#: The rule's own transitions_of (the recorder wraps the module's name).
TRANSITIONS_OF = forward.transitions_of


def one_step_error(model: Any, rows: np.ndarray, dt: float) -> tuple[float, float]:
    """(RMS theta_ddot error [rad/s^2], RMS / std of the true theta_ddot) on ``rows``."""
    data = TRANSITIONS_OF(rows, per_trial=10**9)
    if len(data) < 2:
        return float("nan"), float("nan")
    true = (data[:, 8] - data[:, 3]) / dt
    pred = model.accelerations(data[:, :4], data[:, 4]).mean(axis=0)[:, 1]
    rms = float(np.sqrt(np.mean((pred - true) ** 2)))
    return rms, rms / max(float(np.std(true)), 1e-12)


def parting_time(imagined: np.ndarray, real: np.ndarray) -> float:
    """Seconds until the imagined and real angles part by more than :data:`PART`
    (the shorter run's end if they never do)."""
    n = min(len(imagined), len(real))
    apart = np.flatnonzero(np.abs(imagined[:n, 3] - real[:n, 3]) > PART)
    return float(real[apart[0], 0] if len(apart) else real[n - 1, 0])


class Recorder:
    """Wraps the rule's fit and imagination to keep each model, its candidate and the
    next real trial's rows."""

    def __init__(self) -> None:
        self.pending: dict[str, Any] | None = None
        self.models: list[dict[str, Any]] = []
        self.trial_rows: list[np.ndarray] = []
        fit, imagine, transitions_of = (
            forward.fit_generic,
            forward.imagine_steps,
            forward.transitions_of,
        )

        def fitting(data: Any, *args: Any, **kwargs: Any) -> Any:
            model = fit(data, *args, **kwargs)
            self.last_model = model
            self.last_transitions = len(data)
            return model

        def dreaming(world: Any, controller: Any, config: Any, sim: Any, protocol: Any, seed: int):
            dream = yield from imagine(world, controller, config, sim, protocol, seed)
            candidate = forward.replace(controller, gains=dream.W, theta_c=dream.theta_c)
            request = TrialRequest(
                world.plant, candidate, sim, protocol, hardware=config.hardware, record=True
            )
            self.pending = {
                "model": self.last_model,
                "transitions": self.last_transitions,
                "fitted_on": len(self.trial_rows),
                "imagined_rows": request.run().rows,
                "solved": bool(dream.solved),
                "dt": sim.dt,
            }
            return dream

        def keeping(rows: np.ndarray, factors: Any = (1.0, 1.0), *args: Any) -> Any:
            if factors == (1.0, 1.0) and not args:
                self.trial_rows.append(rows)
                if self.pending is not None:
                    p, self.pending = self.pending, None
                    rms, rel = one_step_error(p["model"], rows, p["dt"])
                    self.models.append(
                        {
                            "fitted_on": p["fitted_on"],
                            "transitions": p["transitions"],
                            "rms": rms,
                            "relative": rel,
                            "parting": parting_time(p["imagined_rows"], rows),
                            "solved": p["solved"],
                            "real_duration": float(rows[-1, 0]),
                        }
                    )
            return transitions_of(rows, factors, *args)

        forward.fit_generic = fitting  # type: ignore[assignment]
        forward.imagine_steps = dreaming  # type: ignore[assignment]
        forward.transitions_of = keeping  # type: ignore[assignment]

    def reset(self) -> None:
        self.pending, self.models, self.trial_rows = None, [], []


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_options(parser, seeds=15, forward_model="generic-gains")
    add_margin_option(parser)
    parser.add_argument("--json", default=None, help="write each run's record here")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    recorder = Recorder()
    runs = []
    for i, seed in enumerate(run_seeds(args)):
        recorder.reset()
        trials: list[dict[str, Any]] = []
        last = {"simulations": 0, "seconds": 0.0}

        def on_trial(state: Any, record: Any, trials: list = trials, last: dict = last) -> None:
            runs_made = state.simulations - last["simulations"]
            seconds = state.simulated_seconds - last["seconds"]
            last.update(simulations=state.simulations, seconds=state.simulated_seconds)
            if record.success:
                kind = "passed"
            elif runs_made == 1:
                kind = "failed"
            else:
                kind = "refused"
            trials.append(
                {
                    "kind": kind,
                    "seconds": seconds,
                    "trial_seconds": record.ended_at,
                    "cases": runs_made - 1,
                    "refused_by": (
                        ROBUST_CASES[STOP_ORDER[runs_made - 2]].name if kind == "refused" else None
                    ),
                }
            )

        cpu = time.process_time()
        run = train_forward(seed, args.forward_model, on_trial=on_trial, **margin_options(args))
        cpu = time.process_time() - cpu
        by_kind = collections.Counter()
        for t in trials:
            by_kind[t["kind"]] += t["seconds"]
        record = {
            "seed": args.first + i,
            "robust": run.success,
            "real_trials": run.trials,
            "real_seconds": run.state.simulated_seconds,
            "cpu": cpu,
            "trials": trials,
            "models": recorder.models,
            **{f"{k}_seconds": by_kind[k] for k in ("failed", "refused", "passed")},
        }
        runs.append(record)
        counts = collections.Counter(t["kind"] for t in trials)
        print(
            f"seed #{record['seed']}: robust {run.success}, {run.trials} real trials, "
            f"{record['real_seconds']:.0f} real s = "
            + " + ".join(f"{k} {counts[k]} x {by_kind[k]:.0f} s" for k in ("failed", "refused"))
            + f" + passed {by_kind['passed']:.0f} s; CPU {cpu:.1f} s",
            flush=True,
        )
    summarise(runs)
    print(f"load average after: {os.getloadavg()}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(runs, f, indent=1)


def summarise(runs: list[dict[str, Any]]) -> None:
    """The totals by kind of trial, the refusing cases, and the model's error by the
    number of real trials it was fitted on."""
    med = {k: statistics.median(r[k] for r in runs) for k in ("real_seconds", "cpu")}
    print(
        f"robust {sum(r['robust'] for r in runs)}/{len(runs)}; medians: "
        f"{med['real_seconds']:.0f} real s, CPU {med['cpu']:.1f} s"
    )
    total = sum(r["real_seconds"] for r in runs)
    for kind in ("failed", "refused", "passed"):
        ts = [t for r in runs for t in r["trials"] if t["kind"] == kind]
        s = sum(t["seconds"] for t in ts)
        lengths = [t["trial_seconds"] for t in ts]
        print(
            f"  {kind}: {len(ts)} trials, {s:.0f} s ({100 * s / total:.0f} % of all real s), "
            f"trial length median {statistics.median(lengths) if lengths else float('nan'):.1f} s, "
            f"per run median {statistics.median(r[f'{kind}_seconds'] for r in runs):.0f} s"
        )
    refusers = collections.Counter(
        t["refused_by"] for r in runs for t in r["trials"] if t["kind"] == "refused"
    )
    print("  refused by: " + ", ".join(f"{k} {v}" for k, v in refusers.most_common()))
    groups: dict[int, list[dict[str, Any]]] = collections.defaultdict(list)
    for r in runs:
        for m in r["models"]:
            # the model fitted on k trials chose trial k + 1: r["trials"][k]
            m["real_passed"] = r["trials"][m["fitted_on"]]["kind"] != "failed"
            groups[min(m["fitted_on"], 6)].append(m)
    print("  model fitted on k real trials -> error on trial k+1 (held out):")
    for k in sorted(groups):
        ms = groups[k]
        agree = sum(m["solved"] == m["real_passed"] for m in ms)
        print(
            f"    k = {k}{'+' if k == 6 else ''}: n = {len(ms)}, one-step theta_ddot RMS median "
            f"{statistics.median(m['rms'] for m in ms):.3f} rad/s^2 "
            f"(relative {statistics.median(m['relative'] for m in ms):.3f}), parting time median "
            f"{statistics.median(m['parting'] for m in ms):.1f} s, imagined solved & real "
            f"60 s agree {agree}/{len(ms)}"
        )


if __name__ == "__main__":
    main()
