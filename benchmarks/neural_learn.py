"""Dopamine on the network's pathways against the rate-based learner, from the same start.

Both sides: the chapter's W(0) and theta_c(0) = 0.6, the chapter learner's options
(alpha 5, gamma 0.999, b = 0, sparse reward of eq 25), ``--trials`` trials of
``--duration`` s from theta0 = 3.12, per seed. ``--side network`` runs
:func:`striatal.neural.driver.learn_network` (seed: network and exploration noise);
``--side rate`` runs ``striatal.train`` (seed: its policy noise). One JSON line per
trial is appended to ``--out`` as it ends, then one line with the final W. Example
(what docs/neural.md reports):

    OPENBLAS_NUM_THREADS=1 python benchmarks/neural_learn.py --side network --seeds 0-2 \
        --trials 20 --duration 30 --neurons 1500 --out docs/data/neural_learn.jsonl
    python benchmarks/neural_learn.py --side rate --seeds 0-2 --trials 20 --duration 30 \
        --out docs/data/neural_learn.jsonl
    python benchmarks/neural_learn.py --summary docs/data/neural_learn.jsonl

``--simulator brian2`` runs the network side on the compiled Brian2 program;
``--compare FILES --trials N [--figure PNG]`` prints each arm's +10 rate with its
Wilson interval and the paired tests, and draws the learning curves.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from striatal.learners import default_config
from striatal.params import CHAPTER_INITIAL_THETA_C, CHAPTER_INITIAL_W, Controller, Simulation


def seed_list(text: str) -> list[int]:
    """``"0-9"`` or ``"1,3,5"`` as a list of seeds."""
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def append(path: Path, row: dict[str, Any]) -> None:
    with path.open("a") as fh:
        fh.write(json.dumps(row) + "\n")


def run_network_side(args: argparse.Namespace, seed: int) -> None:
    from striatal.neural.driver import NeuralTrial, learn_network
    from striatal.neural.network import NetworkConfig
    from striatal.params import Plant

    base = {
        "side": "network",
        "seed": seed,
        "neurons_requested": args.neurons,
        "duration": args.duration,
        "alpha": args.alpha,
        "simulator": args.simulator,
        "init": args.init,
    }

    def on_trial(t: NeuralTrial) -> None:
        append(args.out, {**base, "kind": "trial", **t.to_dict()})
        print(
            f"network seed={seed} trial={t.trial} reward={t.reward:+g} W={np.round(t.W, 3)} "
            f"cpu={t.cpu_time:.1f}s",
            file=sys.stderr,
            flush=True,
        )

    from striatal.experiments.spec import initial_gains

    r = learn_network(
        Controller(gains=initial_gains(args.init, seed), theta_c=CHAPTER_INITIAL_THETA_C),
        Plant(),
        Simulation(duration=args.duration),
        NetworkConfig(neurons=args.neurons),
        seed,
        trials=args.trials,
        alpha=args.alpha,
        on_trial=on_trial,
        simulator=args.simulator,
    )
    append(
        args.out,
        {
            **base,
            "kind": "final",
            "W": list(r.W),
            "theta_c": r.theta_c,
            "solved": r.solved,
            "neurons": r.neurons,
        },
    )


def _lockstep(
    args: argparse.Namespace,
    base: Callable[[int, float], dict[str, Any]],
    step: Callable[[int, float, int, dict[str, Any] | None], tuple[list[dict[str, Any]], Any]],
) -> None:
    """Trial k of every seed and alpha before trial k + 1, so that a run stopped at any
    time leaves every arm with the same trials per seed.

    ``step(seed, alpha, k, old)`` continues the run of (seed, alpha) from ``old`` (its last
    ``"state"`` row, None for a new run) up to k trials and returns that trial's rows and
    the new state row (a :class:`LearnerState` dict under ``"state"``, written with the
    rows in one write: a stopped run has both or none). A rerun with the same ``--out``
    continues each (seed, alpha) from its last state row of the same settings."""
    own = ("seed", "alpha", "kind", "state", "neurons")
    settings = {k: v for k, v in base(0, 0.0).items() if k not in own}
    last: dict[tuple[int, float], dict[str, Any]] = {}
    if args.out.exists():
        for line in args.out.read_text().splitlines():
            row = json.loads(line) if line else {}
            if (
                row.get("kind") != "state"
                or {k: v for k, v in row.items() if k not in own} != settings
            ):
                continue
            key = (int(row["seed"]), float(row["alpha"]))
            if key[0] in args.seeds and key[1] in args.alpha:
                last[key] = row
    for k in range(1, args.trials + 1):
        for seed in args.seeds:
            for alpha in args.alpha:
                old = last.get((seed, alpha))
                if old is not None and (
                    old["state"]["trials_done"] >= k or old["state"]["success"]
                ):
                    continue
                rows, state_row = step(seed, alpha, k, old)
                last[(seed, alpha)] = state_row
                with args.out.open("a") as fh:
                    fh.write("".join(json.dumps(row) + "\n" for row in rows))
                    fh.write(json.dumps(state_row) + "\n")


def run_network_lockstep(args: argparse.Namespace) -> None:
    """``--side network --lockstep``: :func:`_lockstep` of the chapter's rule on the network.

    Each (seed, alpha) is one :func:`striatal.neural.driver.learn_network` run continued
    one trial at a time (``resume=``, equal to one run in one go, tested)."""
    from striatal.experiments.spec import initial_gains
    from striatal.learners.state import LearnerState
    from striatal.neural.driver import NeuralLearning, NeuralTrial, learn_network
    from striatal.neural.network import NetworkConfig
    from striatal.params import Plant

    def base(seed: int, alpha: float) -> dict[str, Any]:
        return {
            "side": "network",
            "seed": seed,
            "neurons_requested": args.neurons,
            "duration": args.duration,
            "alpha": alpha,
            "simulator": args.simulator,
            "init": args.init,
        }

    def step(
        seed: int, alpha: float, k: int, old: dict[str, Any] | None
    ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
        ctl = Controller(gains=initial_gains(args.init, seed), theta_c=CHAPTER_INITIAL_THETA_C)
        resume = None
        if old is not None:
            state = LearnerState.from_dict(old["state"])
            resume = NeuralLearning(
                trials=(),
                W=state.W,
                theta_c=state.theta_c,
                W0=tuple(float(w) for w in ctl.gains),
                theta_c0=float(ctl.theta_c),
                solved=state.success,
                seed=seed,
                neurons=int(old["neurons"]),
                config=default_config("chapter", reward="sparse", alpha=alpha),
                state=state,
            )
        rows: list[dict[str, Any]] = []

        def on_trial(t: NeuralTrial) -> None:
            rows.append({**base(seed, alpha), "kind": "trial", **t.to_dict()})
            print(
                f"network seed={seed} alpha={alpha:g} trial={t.trial} "
                f"reward={t.reward:+g} cpu={t.cpu_time:.2f}s",
                file=sys.stderr,
                flush=True,
            )

        r = learn_network(
            ctl,
            Plant(),
            Simulation(duration=args.duration),
            NetworkConfig(neurons=args.neurons),
            seed,
            trials=k,
            alpha=alpha,
            on_trial=on_trial,
            simulator=args.simulator,
            resume=resume,
        )
        state_row = {**base(seed, alpha), "kind": "state", "neurons": r.neurons}
        return rows, {**state_row, "state": r.state.to_dict()}

    _lockstep(args, base, step)


def run_loop_lockstep(args: argparse.Namespace) -> None:
    """``--side loop --lockstep``: :func:`_lockstep` of rule ``--learner`` through the
    project's learning loop on the network (:func:`striatal.neural.driver.learn_with_rule`
    continued from its state, equal to one run in one go, tested)."""
    from striatal.experiments.spec import initial_gains
    from striatal.learners.state import LearnerState
    from striatal.neural.driver import learn_with_rule
    from striatal.neural.network import NetworkConfig
    from striatal.params import Plant

    def base(seed: int, alpha: float) -> dict[str, Any]:
        return {
            **_loop_base(args, seed, alpha),
            "neurons_requested": args.neurons,
            "simulator": args.simulator,
        }

    def step(
        seed: int, alpha: float, k: int, old: dict[str, Any] | None
    ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
        rows: list[dict[str, Any]] = []

        def on_trial(_state: Any, rec: Any) -> None:
            rows.append({**base(seed, alpha), "kind": "trial", **_record(rec)})
            print(
                f"loop-{args.learner} seed={seed} alpha={alpha:g} trial={rec.trial} "
                f"reward={rec.reward:+g}",
                file=sys.stderr,
                flush=True,
            )

        state = learn_with_rule(
            args.learner,
            Controller(gains=initial_gains(args.init, seed), theta_c=CHAPTER_INITIAL_THETA_C),
            Plant(),
            Simulation(duration=args.duration),
            NetworkConfig(neurons=args.neurons),
            seed,
            trials=k,
            simulator=args.simulator,
            on_trial=on_trial,
            state=None if old is None else LearnerState.from_dict(old["state"]),
            **_options(args, alpha),
        )
        return rows, {**base(seed, alpha), "kind": "state", "state": state.to_dict()}

    _lockstep(args, base, step)


def _options(args: argparse.Namespace, alpha: float) -> dict[str, Any]:
    """The rule's options: alpha, its declared control's (pgpe: sigma_rate 0 with alpha 0),
    and ``--theta-c-rule`` if given."""
    options: dict[str, Any] = {"alpha": alpha}
    if args.learner == "pgpe" and alpha == 0:
        options["sigma_rate"] = 0.0
    if args.theta_c_rule is not None:
        options["theta_c_rule"] = args.theta_c_rule
    return options


def _loop_base(args: argparse.Namespace, seed: int, alpha: float) -> dict[str, Any]:
    chapter_rate = args.side == "rate" and args.learner == "chapter"
    side = "rate" if chapter_rate else f"{args.side}-{args.learner}"
    row = {"side": side, "seed": seed, "duration": args.duration, "alpha": alpha}
    row["init"] = args.init
    if args.theta_c_rule is not None:
        row["theta_c_rule"] = args.theta_c_rule
    return row


def _record(rec: Any) -> dict[str, Any]:
    return {
        "trial": rec.trial,
        "W": list(rec.W),
        "theta_c": rec.theta_c,
        "reward": rec.reward,
        "success": rec.success,
        "fault": rec.fault,
    }


def run_loop_side(args: argparse.Namespace, seed: int) -> None:
    """``--side loop``: rule ``--learner`` through the project's learning loop, its trials
    on the network (:func:`striatal.neural.driver.learn_with_rule`); alpha 0 (and pgpe's
    sigma_rate 0) is the rule's no-learning control."""
    from striatal.experiments.spec import initial_gains
    from striatal.neural.driver import learn_with_rule
    from striatal.neural.network import NetworkConfig
    from striatal.params import Plant

    base = {
        **_loop_base(args, seed, args.alpha),
        "neurons_requested": args.neurons,
        "simulator": args.simulator,
    }

    def on_trial(_state: Any, rec: Any) -> None:
        append(args.out, {**base, "kind": "trial", **_record(rec)})
        print(
            f"loop-{args.learner} seed={seed} trial={rec.trial} reward={rec.reward:+g}",
            file=sys.stderr,
            flush=True,
        )

    state = learn_with_rule(
        args.learner,
        Controller(gains=initial_gains(args.init, seed), theta_c=CHAPTER_INITIAL_THETA_C),
        Plant(),
        Simulation(duration=args.duration),
        NetworkConfig(neurons=args.neurons),
        seed,
        trials=args.trials,
        simulator=args.simulator,
        on_trial=on_trial,
        **_options(args, args.alpha),
    )
    final = {"W": list(state.W), "theta_c": state.theta_c, "solved": state.success}
    append(args.out, {**base, "kind": "final", **final})


def run_rate_side(args: argparse.Namespace, seed: int) -> None:
    """``--side rate``: ``striatal.train`` of rule ``--learner`` from the same W(0) and
    theta_c(0), with the same options and the sparse reward of eq 25."""
    import striatal
    from striatal.experiments.spec import initial_gains

    base = _loop_base(args, seed, args.alpha)

    def on_trial(_state: Any, rec: Any) -> None:
        append(args.out, {**base, "kind": "trial", **_record(rec)})

    run = striatal.train(
        args.learner,
        init_gains=initial_gains(args.init, seed),
        seed=seed,
        sim=Simulation(duration=args.duration),
        max_trials=args.trials,
        reward="sparse",
        on_trial=on_trial,
        **_options(args, args.alpha),
    )
    final = {"W": list(run.W), "theta_c": run.theta_c, "solved": run.success}
    append(args.out, {**base, "kind": "final", **final})


def summarize(paths: list[Path]) -> None:
    """Per side and alpha: rewards (+10 count), W(0) -> final W per seed, and the mean change."""
    from striatal.experiments.stats import wilson_interval

    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines() if line]
    groups: dict[tuple[str, float, int], list[dict]] = {}
    for r in rows:
        side = (
            r["side"] if r.get("simulator", "nengo") == "nengo" else f"{r['side']}-{r['simulator']}"
        )
        groups.setdefault((side, r["alpha"], r["duration"]), []).append(r)
    W0 = np.array(CHAPTER_INITIAL_W)
    for (side, alpha, dur), rs in sorted(groups.items(), key=lambda kv: (kv[0][0], str(kv[0][1]))):
        trials = [r for r in rs if r["kind"] == "trial"]
        finals = {r["seed"]: r for r in rs if r["kind"] == "final"}
        seeds = sorted({r["seed"] for r in trials})
        k = sum(r["reward"] > 0 for r in trials)
        ci = wilson_interval(k, len(trials))
        lo, hi = (ci.low or 0.0), (ci.high or 0.0)
        print(
            f"{side} alpha={alpha} {dur:g}-s trials: {len(trials)} trials over seeds {seeds}; "
            f"reward +10 in {k}/{len(trials)} (95 % Wilson {lo:.2f}-{hi:.2f}); "
            f"success test {sum(r['success'] for r in trials)}/{len(trials)}"
        )
        deltas = []
        for s in seeds:
            ts = sorted((r for r in trials if r["seed"] == s), key=lambda r: r["trial"])
            rew = "".join("+" if r["reward"] > 0 else "-" for r in ts)
            if s in finals:
                Wf = np.array(finals[s]["W"])
                deltas.append(Wf - W0)
                wf = " ".join(f"{w:+.3f}" for w in Wf)
                tail = f"final W [{wf}] theta_c {finals[s]['theta_c']:.3f}"
            else:
                tail = "(not finished)"
            print(f"  seed {s}: rewards {rew}  {tail}")
        if deltas:
            d = np.mean(deltas, axis=0)
            print("  mean W(final) - W(0): [" + " ".join(f"{v:+.3f}" for v in d) + "]")
        half = max(1, max((r["trial"] for r in trials), default=1) // 2)
        first = [r["reward"] > 0 for r in trials if r["trial"] <= half]
        second = [r["reward"] > 0 for r in trials if r["trial"] > half]
        if first and second:
            print(
                f"  +10 rewards: trials 1-{half} {sum(first)}/{len(first)}, "
                f"later {sum(second)}/{len(second)}"
            )


#: The columns of a trimmed trial table (``--trim``): what ``--compare``, its figure and
#: ``benchmarks/eq21_ratchet.py`` read, the trial's end (x, theta at T; network only) and
#: the gains W it ran with (4 decimals).
TRIM_COLUMNS = (
    "side", "simulator", "init", "theta_c_rule", "alpha", "seed", "trial",
    "reward", "success", "fault", "theta_c", "x_final", "theta_final",
    "W1", "W2", "W3", "W4", "W5", "W6",
)  # fmt: skip


def trial_rows(paths: list[Path]) -> list[dict[str, Any]]:
    """The trial rows of ``benchmarks/neural_learn.py`` files (JSONL; a last line without its
    newline, still being written, is left out) or of their trimmed tables (``.csv``,
    :data:`TRIM_COLUMNS`; empty cells are absent keys)."""
    import csv

    rows: list[dict[str, Any]] = []
    for path in paths:
        if path.suffix != ".csv":
            # a file being appended to may end in a line not yet whole: left out
            lines = path.read_text().split("\n")[:-1]
            got = (json.loads(line) for line in lines if line)
            rows += [r for r in got if r["kind"] == "trial"]
            continue
        with path.open(newline="") as fh:
            for r in csv.DictReader(fh):
                row: dict[str, Any] = {k: v for k, v in r.items() if v != ""}
                for k in ("alpha", "reward", "theta_c", "x_final", "theta_final"):
                    if k in row:
                        row[k] = float(row[k])
                row["W"] = [float(row.pop(f"W{i}")) for i in range(1, 7)]
                for k in ("seed", "trial"):
                    row[k] = int(row[k])
                for k in ("success", "fault"):
                    row[k] = row[k] == "True"
                rows.append({**row, "kind": "trial"})
    return rows


def trim(path: Path, out: Path) -> None:
    """Write ``path``'s trial rows as a table of :data:`TRIM_COLUMNS` (atomically)."""
    import csv
    import io
    import os

    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=TRIM_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for r in trial_rows([path]):
        end = r.get("final_state")
        row = {k: r.get(k, "") for k in TRIM_COLUMNS}
        row["x_final"] = "" if end is None else f"{end[0]:.4f}"
        row["theta_final"] = "" if end is None else f"{end[2]:.4f}"
        row["theta_c"] = f"{r['theta_c']:.5f}"
        row.update({f"W{i + 1}": f"{w:.4f}" for i, w in enumerate(r["W"])})
        writer.writerow(row)
    tmp = out.with_name(out.name + ".tmp")
    tmp.write_text(buf.getvalue())
    os.replace(tmp, out)


def trials_done(paths: list[Path]) -> int:
    """The number of trials every run of these files has: the least last trial of the runs
    not ended by a passed success test (a lockstep file stopped mid-round: the round
    before)."""
    last: dict[tuple[str, str, float, int], int] = {}
    solved: set[tuple[str, str, float, int]] = set()
    for r in trial_rows(paths):
        key = (r["side"], str(r.get("init")) + str(r.get("theta_c_rule")), r["alpha"], r["seed"])
        last[key] = max(last.get(key, 0), r["trial"])
        if r["success"]:
            solved.add(key)
    return min((k for key, k in last.items() if key not in solved), default=0)


def _groups(
    paths: list[Path], max_trial: int
) -> tuple[dict[str, dict[int, list[bool]]], dict[str, dict[int, int]], dict[str, set[int]]]:
    """``"side[-simulator] alpha=A"`` -> seed -> +10 or not per trial 1..max_trial;
    group -> seed -> the number of those trials the run ran (the rest were filled in
    after a passed success test); group -> the seeds whose run passed it.

    A run that passed the chapter's success test ended there (as ``striatal train`` does);
    its later trials count as +10 (the success box at T_f lies inside eq 25's)."""
    out: dict[str, dict[int, list[bool]]] = {}
    solved: dict[str, set[int]] = {}
    for r in sorted(
        (r for r in trial_rows(paths) if r["trial"] <= max_trial), key=lambda r: r["trial"]
    ):
        simulator = r.get("simulator", "nengo")
        side = (
            r["side"] if simulator == "nengo" or r["side"] != "network" else f"network-{simulator}"
        )
        init = "" if r.get("init", "chapter") == "chapter" else f" init={r['init']}"
        rule = f" theta_c={r['theta_c_rule']}" if r.get("theta_c_rule") else ""
        name = f"{side}{init}{rule} alpha={r['alpha']:g}"
        out.setdefault(name, {}).setdefault(r["seed"], []).append(r["reward"] > 0)
        if r["success"]:
            solved.setdefault(name, set()).add(r["seed"])
    ran = {name: {s: len(v) for s, v in seeds.items()} for name, seeds in out.items()}
    for name, seeds in solved.items():
        for s in seeds:
            got = out[name][s]
            got.extend([True] * (max_trial - len(got)))
    return out, ran, {name: solved.get(name, set()) for name in out}


def compare(paths: list[Path], max_trial: int) -> None:
    """Per group: +10 rate with its Wilson interval over trials 1..max_trial; then paired
    tests on the seeds two groups share: learning against its alpha = 0 control, and the
    network against the rate learner at the same alpha (Wilcoxon signed-rank on each
    seed's count of +10, and McNemar on "+10 in the last trial" and on "passed the
    success test")."""
    import itertools

    from scipy.stats import wilcoxon

    from striatal.experiments.stats import mcnemar_test, wilson_interval

    groups, ran, solved = _groups(paths, max_trial)
    for name, seeds in groups.items():
        k = sum(sum(v) for v in seeds.values())
        n = sum(len(v) for v in seeds.values())
        ci = wilson_interval(k, n)
        last = [v[-1] for v in seeds.values()]
        print(
            f"{name}: {len(seeds)} seeds, {n} trials; +10 in {k}/{n} = {k / n:.2f} "
            f"(95 % Wilson {ci.low or 0:.2f}-{ci.high or 0:.2f}); last trial +10 in "
            f"{sum(last)}/{len(last)} seeds"
        )
        f = n - sum(ran[name].values())
        if solved[name]:
            c = wilson_interval(len(solved[name]), len(seeds))
            print(
                f"  passed the success test in {len(solved[name])}/{len(seeds)} seeds "
                f"(95 % Wilson {c.low or 0:.2f}-{c.high or 0:.2f}); {f} trials after it "
                f"counted +10; in the {n - f} trials run +10 in {k - f} = {(k - f) / (n - f):.2f}"
            )
        third = min(len(v) for v in seeds.values()) // 3
        if third >= 1:
            parts = []
            for label, cut in (("first", slice(0, third)), ("last", slice(-third, None))):
                kk = sum(sum(v[cut]) for v in seeds.values())
                nn = third * len(seeds)
                c = wilson_interval(kk, nn)
                parts.append(
                    f"{label} {third} trials {kk}/{nn} = {kk / nn:.2f} "
                    f"({c.low or 0:.2f}-{c.high or 0:.2f})"
                )
            print("  +10 in the " + ", in the ".join(parts))

    def rule(side: str) -> str:
        return "pgpe" if "pgpe" in side else "chapter"

    def init(side: str) -> str:
        return side.split(" init=")[1] if " init=" in side else "chapter"

    for a, b in itertools.combinations(sorted(groups), 2):
        sa, sb = a.split(" alpha="), b.split(" alpha=")
        same_arm_pair = sa[0] == sb[0]  # learning against its control
        same_rule = sa[1] == sb[1] and rule(sa[0]) == rule(sb[0]) and init(sa[0]) == init(sb[0])
        if not (same_arm_pair or same_rule):  # or the network against the rate learner
            continue
        shared = sorted(set(groups[a]) & set(groups[b]))
        shared = [s for s in shared if len(groups[a][s]) == len(groups[b][s])]
        if len(shared) < 2:
            continue
        ca = np.array([sum(groups[a][s]) for s in shared])
        cb = np.array([sum(groups[b][s]) for s in shared])
        diff = ca - cb
        p = float(wilcoxon(ca, cb).pvalue) if np.any(diff != 0) else 1.0
        mc = mcnemar_test(
            {s: groups[a][s][-1] for s in shared}, {s: groups[b][s][-1] for s in shared}
        )
        print(
            f"{a} vs {b}: {len(shared)} shared seeds; mean +10 per seed {ca.mean():.2f} vs "
            f"{cb.mean():.2f} (Wilcoxon signed-rank p = {p:.3g}); last trial +10 "
            f"{mc.only_a} seeds only in the first, {mc.only_b} only in the second "
            f"(McNemar p = {mc.p_value:.3g})"
        )
        if solved[a] or solved[b]:
            ms = mcnemar_test(
                {s: s in solved[a] for s in shared}, {s: s in solved[b] for s in shared}
            )
            print(
                f"  passed the success test: {ms.only_a} seeds only in the first, {ms.only_b} "
                f"only in the second (McNemar p = {ms.p_value:.3g})"
            )


def drift(paths: list[Path], max_trial: int) -> None:
    """Per learning arm (alpha > 0), over its updates between trials 1..max_trial: the
    median of the largest |W_i change| (W1..W5) per update (all, after the first and the
    last third of the trials), the share of updates with a gain at the max step (1), the
    dip share (reward -5), the mean |W(last) - W(0)| and W4 (eq 23's energy pump) at the
    end (a negative W4 drains the swing-up's energy)."""
    runs: dict[str, dict[int, list[dict[str, Any]]]] = {}
    for r in trial_rows(paths):
        if r["alpha"] > 0 and r["trial"] <= max_trial and not r.get("theta_c_rule"):
            name = f"{r['side']}{'' if r.get('init', 'chapter') == 'chapter' else ' init=random'}"
            runs.setdefault(f"{name} alpha={r['alpha']:g}", {}).setdefault(r["seed"], []).append(r)
    for name, seeds in sorted(runs.items()):
        biggest, at_max, dips, far = [], 0, 0, []
        by_trial: dict[int, list[float]] = {}
        for rows in seeds.values():
            rows.sort(key=lambda r: r["trial"])
            W = np.array([r["W"] for r in rows])[:, :5]
            step = np.abs(np.diff(W, axis=0))
            biggest += list(step.max(axis=1, initial=0.0))
            for r, b in zip(rows, step.max(axis=1, initial=0.0), strict=False):
                by_trial.setdefault(r["trial"], []).append(float(b))
            at_max += int(np.any(np.abs(step - 1.0) < 5e-4, axis=1).sum())
            dips += sum(r["reward"] < 0 for r in rows)
            far.append(np.abs(W[-1] - W[0]))
        n = len(biggest)
        if n == 0:
            continue
        print(
            f"{name}: {len(seeds)} seeds, {n} updates; largest |dW| per update median "
            f"{np.median(biggest):.3f}, a gain at the max step in {at_max / n:.2f}; reward -5 "
            f"in {dips / sum(len(v) for v in seeds.values()):.2f} of the trials; mean "
            f"|W(last) - W(0)| (W1..W5) {np.round(np.mean(far, axis=0), 2).tolist()}"
        )
        last = max(by_trial)
        third = max(1, last // 3)
        parts = [
            f"after trials {lo}-{lo + third - 1} "
            f"{np.median([b for k in range(lo, lo + third) for b in by_trial.get(k, [])]):.3f}"
            for lo in (1, last - third + 1)
        ]
        print("  largest |dW| per update, median: " + ", ".join(parts))
        pump = [rows[-1]["W"][3] for rows in seeds.values() if not rows[-1]["success"]]
        if pump:
            print(
                f"  W4 (the swing-up's energy pump) in the last trial of the {len(pump)} runs "
                f"not ended by a success: median {np.median(pump):+.2f}, negative in "
                f"{sum(w < 0 for w in pump)}"
            )


def curve_figure(
    paths: list[Path],
    max_trial: int,
    out: Path,
    *,
    block: int = 1,
    title: str | None = None,
    ran_only: bool = False,
) -> None:
    """Fraction rewarded +10 per block of ``block`` trials (over the block's trials of all
    seeds), with its 95 % Wilson band, per group (the rate learner dashed). ``ran_only``:
    over the trials the runs ran, leaving out those filled in after a passed success test
    (a block no run ran is not drawn)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from striatal.experiments.stats import wilson_interval

    groups, ran, _solved = _groups(paths, max_trial)
    fig, ax = plt.subplots(figsize=(7, 4), constrained_layout=True)
    for i, (name, seeds) in enumerate(sorted(groups.items())):
        n_trials = min(len(v) for v in seeds.values())
        points = []
        for j in range(0, n_trials - block + 1, block):
            cut = {
                s: v[j : min(j + block, ran[name][s])] if ran_only else v[j : j + block]
                for s, v in seeds.items()
            }
            n = sum(len(v) for v in cut.values())
            if n:
                k = sum(sum(v) for v in cut.values())
                points.append((j + (block + 1) / 2, k / n, wilson_interval(k, n)))
        t, frac, cis = zip(*points, strict=True)
        style = "--" if name.startswith("rate") else "-"
        label = f"{name} ({len(seeds)} seeds)"
        ax.plot(t, frac, style, marker="o", ms=3, color=f"C{i}", label=label)
        ax.fill_between(
            t, [c.low or 0 for c in cis], [c.high or 0 for c in cis], color=f"C{i}", alpha=0.12
        )
    ax.set_xlabel("trial" if block == 1 else f"trial (blocks of {block})")
    ran_text = ", of the trials run" if ran_only else ""
    ax.set_ylabel(f"fraction rewarded +10 (eq 25){ran_text}")
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=7)
    ax.set_title(title or "from the chapter's W(0), 30-s trials, seeds 0-19", fontsize=10)
    fig.savefig(out, dpi=110)


def learn_figure(paths: list[Path], out: Path) -> None:
    """W1..W6 per trial, network (solid) and rate learner (dashed), one colour per seed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [json.loads(line) for p in paths for line in p.read_text().splitlines() if line]
    trials = [r for r in rows if r["kind"] == "trial" and r["alpha"] > 0]
    fig, axes = plt.subplots(2, 3, figsize=(10, 5.5), sharex=True, constrained_layout=True)
    seeds = sorted({r["seed"] for r in trials})
    for side, style in (("network", "-"), ("rate", "--")):
        for ci, s in enumerate(seeds):
            ts = sorted(
                (r for r in trials if r["side"] == side and r["seed"] == s),
                key=lambda r: r["trial"],
            )
            if not ts:
                continue
            W = np.array([r["W"] for r in ts])
            t = [r["trial"] for r in ts]
            for i, ax in enumerate(axes.ravel()):
                ax.plot(
                    t,
                    W[:, i],
                    style,
                    color=f"C{ci}",
                    marker="o",
                    ms=3,
                    label=f"{side} seed {s}" if i == 0 else None,
                )
    for i, ax in enumerate(axes.ravel()):
        ax.set_title(f"W{i + 1}", fontsize=9)
        ax.axhline(CHAPTER_INITIAL_W[i], color="0.7", lw=0.8)
    for ax in axes[1]:
        ax.set_xlabel("trial (W used in it)")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(
        "chapter's rule from the chapter's W(0): spiking network (solid) vs rate learner (dashed)",
        fontsize=10,
    )
    fig.savefig(out, dpi=110)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--summary", type=Path, nargs="+", help="summarize these files and stop")
    parser.add_argument(
        "--compare",
        type=Path,
        nargs="+",
        help="rates with Wilson intervals and paired tests over trials 1..--trials of these "
        "files (with --figure: the learning curves) and stop",
    )
    parser.add_argument(
        "--trim",
        type=Path,
        nargs=2,
        metavar=("JSONL", "CSV"),
        help="write JSONL's trial rows as a small table (the columns --compare reads) and stop",
    )
    parser.add_argument(
        "--done",
        type=Path,
        nargs="+",
        help="print the number of trials every run of these files has (the runs a passed "
        "success test ended aside) and stop",
    )
    parser.add_argument(
        "--drift",
        type=Path,
        nargs="+",
        help="the learning arms' steps in W over trials 1..--trials of these files, and stop",
    )
    parser.add_argument(
        "--block", type=int, default=1, help="with --compare --figure: trials per point"
    )
    parser.add_argument("--title", help="with --compare --figure: the figure's title")
    parser.add_argument(
        "--ran-only",
        action="store_true",
        help="with --compare --figure: the fractions over the trials run, leaving out those "
        "filled in as +10 after a passed success test",
    )
    parser.add_argument("--side", choices=("network", "rate", "loop"))
    parser.add_argument(
        "--learner",
        default=None,
        help="the rule: with --side loop (default pgpe) or --side rate (default chapter; "
        "another rule's side is named rate-RULE)",
    )
    parser.add_argument(
        "--init",
        choices=("chapter", "random"),
        default="chapter",
        help="W(0): the chapter's, or uniform in [-1, 1]^6 per seed (experiments.spec)",
    )
    parser.add_argument("--seeds", type=seed_list, default=[0, 1, 2])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--duration", type=float, default=30.0)
    parser.add_argument("--neurons", type=int, default=1500)
    parser.add_argument(
        "--alpha",
        type=float,
        nargs="+",
        default=[5.0],
        help="learning rate(s); with several, each seed runs every one in turn (so an "
        "interrupted run leaves the arms with the same seeds)",
    )
    parser.add_argument("--out", type=Path)
    parser.add_argument(
        "--theta-c-rule",
        choices=("swingup", "trial", "clamped", "fixed", "learned"),
        default=None,
        help="--side rate or loop: the rule's eq-21 reading instead of its preset's "
        "(learners.common.theta_c_rule; 'fixed' keeps theta_c(0))",
    )
    parser.add_argument(
        "--lockstep",
        action="store_true",
        help="--side network or loop: trial k of every seed and alpha before trial k + 1 (a "
        "stopped run leaves every arm with the same trials per seed); a rerun continues --out",
    )
    parser.add_argument("--figure", type=Path, help="with --summary: also draw W per trial here")
    parser.add_argument(
        "--simulator", choices=("nengo", "brian2"), default="nengo", help="the network's simulator"
    )
    args = parser.parse_args()
    if args.block < 1:
        parser.error(f"--block must be >= 1, got {args.block}")
    if args.compare:
        compare(args.compare, args.trials)
        if args.figure is not None:
            curve_figure(
                args.compare,
                args.trials,
                args.figure,
                block=args.block,
                title=args.title,
                ran_only=args.ran_only,
            )
        return 0
    if args.trim:
        trim(*args.trim)
        return 0
    if args.done:
        print(trials_done(args.done))
        return 0
    if args.drift:
        drift(args.drift, args.trials)
        return 0
    if args.summary:
        summarize(args.summary)
        if args.figure is not None:
            learn_figure(args.summary, args.figure)
        return 0
    if args.out is None or args.side is None:
        parser.error("--side and --out are required")
    if args.side == "network" and args.theta_c_rule is not None:
        parser.error(
            "--side network runs the chapter's options: give --side loop --learner chapter "
            "for another --theta-c-rule"
        )
    if args.lockstep and args.side == "rate":
        parser.error("--lockstep runs the network sides (network, loop) only")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    side = {"network": run_network_side, "rate": run_rate_side, "loop": run_loop_side}
    if args.learner is None:
        args.learner = "pgpe" if args.side == "loop" else "chapter"
    if args.lockstep:
        (run_network_lockstep if args.side == "network" else run_loop_lockstep)(args)
        return 0
    for seed in args.seeds:
        for alpha in args.alpha:
            side[args.side](argparse.Namespace(**{**vars(args), "alpha": alpha}), seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
