"""Where the forward learner's imagined simulations go, per real trial, on the tuning root.

    python benchmarks/forward_imagination.py [--root 0] [--first 0] [--seeds 15]
        [--forward-model generic-gains] [--imagine-trials 2000] [--imagine-round N]
        [--imagine-duration SECONDS] [--imagine-margin M]
        [--json FILE]

Runs ``striatal.train("forward", robust=True, init="random", max_trials=300, ...)`` on
the run seeds ``spawn_seeds(root, first + seeds)[first:]`` one after the other, and
records each round of imagination (the inner learner from the candidate under one
seed: its trials, whether it solved the model's mean) and each family check after it
(refused or not, its runs), by wrapping the rule's own ``learn_steps`` and
``family_check_steps`` (the algorithm runs unchanged). Each real trial's imagination
ends one of three ways: **exhausted** (no round solved the mean), **refused** (rounds
solved the mean, the family refused each, the budget ran out) or **solved** (a
candidate passed the family). Per run it prints the real trials, real simulated
seconds, imagined simulations, the imagined simulations of each ending, and the CPU
seconds of this process (``time.process_time``; they hold up on a shared machine), then
the medians. The first run includes scikit-learn's import.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from typing import Any

from forward_runs import (  # beside this script (benchmarks/ is its sys.path[0])
    add_margin_option,
    add_run_options,
    margin_options,
    run_seeds,
    train_forward,
)

from striatal.learners.forward import rule as forward

ENDINGS = ("exhausted", "refused", "solved")


class Recorder:
    """The rounds and checks of each real trial's imagination, through wrappers."""

    def __init__(self) -> None:
        self.calls: list[list[dict[str, Any]]] = []
        learn_steps, check_steps, imagine = (
            forward.learn_steps,
            forward.family_check_steps,
            forward.imagine_steps,
        )

        def rounds(*args: Any, **kwargs: Any) -> Any:
            result = yield from learn_steps(*args, **kwargs)
            self.calls[-1].append(
                {"trials": result.trials_done, "solved": bool(result.success), "checks": 0}
            )
            return result

        def checks(*args: Any, **kwargs: Any) -> Any:
            verdict = yield from check_steps(*args, **kwargs)
            self.calls[-1][-1]["checks"] += verdict.simulations
            if not verdict.robust:
                self.calls[-1][-1]["refused"] = True
            return verdict

        def dreaming(*args: Any, **kwargs: Any) -> Any:
            self.calls.append([])
            dream = yield from imagine(*args, **kwargs)
            self.calls[-1].append({"simulations": dream.simulations, "end": dream.solved})
            return dream

        forward.learn_steps = rounds  # type: ignore[assignment]
        forward.family_check_steps = checks  # type: ignore[assignment]
        forward.imagine_steps = dreaming  # type: ignore[assignment]

    def endings(self) -> dict[str, list[int]]:
        """Imagined simulations per real trial, by how its imagination ended."""
        out: dict[str, list[int]] = {e: [] for e in ENDINGS}
        for call in self.calls:
            *rounds, last = call
            if last["end"]:
                ending = "solved"
            elif any(r["solved"] for r in rounds):
                ending = "refused"
            else:
                ending = "exhausted"
            out[ending].append(int(last["simulations"]))
        return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_options(parser, seeds=15, forward_model="generic-gains")
    parser.add_argument("--imagine-trials", type=int, default=2000)
    parser.add_argument("--imagine-round", type=int, default=None)
    parser.add_argument("--imagine-duration", type=float, default=None)
    add_margin_option(parser)
    parser.add_argument("--json", default=None, help="write each run's record here")
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    recorder = Recorder()
    runs = []
    for i, seed in enumerate(run_seeds(args)):
        recorder.calls.clear()
        cpu = time.process_time()
        run = train_forward(
            seed,
            args.forward_model,
            imagine_trials=args.imagine_trials,
            imagine_round=args.imagine_round,
            imagine_duration=args.imagine_duration,
            **margin_options(args),
        )
        cpu = time.process_time() - cpu
        endings = recorder.endings()
        record = {
            "seed": args.first + i,
            "robust": run.success,
            "real_trials": run.trials,
            "real_seconds": run.state.simulated_seconds,
            "imagined": forward.FORWARD.imagined(run.state)[0],
            "imagined_seconds": forward.FORWARD.imagined(run.state)[1],
            "cpu": cpu,
            **{f"{e}_trials": len(v) for e, v in endings.items()},
            **{f"{e}_imagined": sum(v) for e, v in endings.items()},
        }
        runs.append(record)
        print(
            f"seed #{record['seed']}: robust {run.success}, {run.trials} real trials, "
            f"{record['real_seconds']:.0f} real s, {record['imagined']} imagined "
            f"({record['imagined_seconds']:.0f} s; "
            + ", ".join(f"{e} {len(v)} x {sum(v)}" for e, v in endings.items())
            + f"), CPU {cpu:.1f} s",
            flush=True,
        )
    med = {
        k: statistics.median(r[k] for r in runs)
        for k in ("real_seconds", "imagined", "imagined_seconds", "cpu")
    }
    shares = {e: sum(r[f"{e}_imagined"] for r in runs) for e in ENDINGS}
    total = max(sum(shares.values()), 1)
    print(
        f"robust {sum(r['robust'] for r in runs)}/{len(runs)}; medians: "
        f"{med['real_seconds']:.0f} real s, {med['imagined']:.0f} imagined "
        f"({med['imagined_seconds']:.0f} s), "
        f"CPU {med['cpu']:.1f} s; "
        "imagined by ending: "
        + ", ".join(f"{e} {100 * v / total:.0f} %" for e, v in shares.items())
    )
    print(f"load average after: {os.getloadavg()}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(runs, f, indent=1)


if __name__ == "__main__":
    main()
