"""Learning runs of the spiking network on the experiment runner.

``striatal neural --learn --seeds N`` is a sweep whose trials run on the network: the
same arms (the learner and its declared no-learning control, for each init), the same
spawned seeds, runs.csv rows, resume, progress and local or Ray workers as
``striatal sweep`` (:func:`striatal.experiments.sweeps.run_sweep`), with each spec's
trials sent to the network (:class:`striatal.experiments.spec.NetworkTrials`,
:func:`striatal.neural.driver.network_drive`; network seed = the run's seed). The rule
runs in the project's one learning loop, as on the kernel. A row with seed S is
``striatal.neural.driver.learn_with_rule(learner, ..., S, trials=max_trials)`` from that
init's W(0), followed by one mean-policy rerun of the final gains on the network
(``mean_policy_success``, in ``eval_simulations``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from striatal.experiments.pool import CONNECT_TIMEOUT, Backend
from striatal.experiments.results import Sweep
from striatal.experiments.spec import NetworkTrials
from striatal.experiments.sweeps import Plan, plan, run_sweep
from striatal.io.files import csv_text
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)

if TYPE_CHECKING:
    from striatal.neural.network import NetworkConfig
    from striatal.neural.run import Simulator

__all__ = ["TRIALS_COLUMNS", "network_plan", "network_sweep", "read_trials"]

#: trials.csv beside runs.csv: one line per learning trial of each run.
TRIALS_COLUMNS = ("arm", "init", "seed", "trial", "reward")


def network_plan(
    learner: str,
    *,
    network: NetworkConfig,
    simulator: Simulator,
    seeds: int,
    seed: int = 0,
    init: str | Sequence[str] = "chapter",
    max_trials: int,
    sim: Simulation,
    plant: Plant | None = None,
    template: Controller | None = None,
    **options: Any,
) -> Plan:
    """The specs and settings of a sweep of ``learner`` and its control whose trials run on
    the network: :func:`striatal.experiments.sweeps.plan` with the sparse reward, no
    pass-probability draws and no baselines, each spec sent to the network.
    ``template``: theta_c(0) and the readings (balance sign, switch); its gains are not
    used (W(0) is ``init``'s). ``options``: the learner's."""
    from striatal.learners import default_config
    from striatal.neural.driver import NET_DT, check_network_learning

    options = {**options, "reward": "sparse", "max_trials": max_trials}
    check_network_learning(default_config(learner, **options), sim)
    t = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C) if template is None else template
    base = plan(
        learner,
        seeds=seeds,
        seed=seed,
        init=init,
        control=True,
        eval_draws=0,
        sim=sim,
        plant=plant,
        theta_c0=t.theta_c,
        balance_sign=t.balance_sign,
        switch=t.switch,
        inhibition=t.inhibition,
        **options,
    )
    trials_on = NetworkTrials(network, simulator)
    settings = {k: v for k, v in base.settings.items() if k not in ("baselines", "reproduce")}
    settings.update(
        command="striatal neural",
        network=trials_on.to_dict(),
        reproduce="striatal.neural.driver.learn_with_rule(LEARNER, Controller(W(0) of INIT, "
        "theta_c0), Plant(), Simulation(duration=...), NetworkConfig(...), S, "
        "trials=max_trials, simulator=...) with the arm's options; then one mean-policy "
        "trial of the final gains",
    )
    specs = [replace(s, network=trials_on) for s in base.specs]
    # every run's trials, and its final mean-policy trial, on the network
    network.check_work(sim.duration, NET_DT, len(specs) * (max_trials + 1))
    return Plan(specs, settings, base.max_trials)


def network_sweep(
    learner: str,
    *,
    network: NetworkConfig,
    simulator: Simulator,
    seeds: int,
    seed: int = 0,
    init: str | Sequence[str] = "chapter",
    max_trials: int,
    sim: Simulation,
    plant: Plant | None = None,
    template: Controller | None = None,
    out: Path | None = None,
    backend: Backend = "local",
    workers: int = 1,
    address: str | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
    progress: bool = False,
    on_compile: Callable[[Path], None] | None = None,
    **options: Any,
) -> Sweep:
    """Run :func:`network_plan`'s specs (resumed from ``out``/runs.csv if there).

    Each finished run's learning trials go to ``out``/trials.csv (:data:`TRIALS_COLUMNS`,
    the reward of eq 25 of each; :func:`read_trials`) as its row goes to runs.csv. On the
    local backend the Brian2 program is made ready in this process first
    (:func:`striatal.neural.driver.prepare_simulator`; ``on_compile(folder)`` is told if
    it compiles), so a compile happens once, before any run."""
    p = network_plan(
        learner,
        network=network,
        simulator=simulator,
        seeds=seeds,
        seed=seed,
        init=init,
        max_trials=max_trials,
        sim=sim,
        plant=plant,
        template=template,
        **options,
    )
    if backend == "local" and p.specs:
        from striatal.neural.driver import prepare_simulator

        first = p.specs[0]
        prepare_simulator(
            simulator,
            first.template,
            first.plant,
            first.sim,
            network,
            first.seed,
            on_compile=on_compile,
        )
    on_run = None if out is None else _trials_writer(out / "trials.csv")
    return run_sweep(
        p.specs,
        p.settings,
        out=out,
        max_trials=p.max_trials,
        backend=backend,
        workers=workers,
        address=address,
        connect_timeout=connect_timeout,
        progress=progress,
        on_run=on_run,
    )


def _trials_writer(path: Path) -> Callable[[dict[str, Any]], None]:
    """``on_run`` of a network sweep: a row's learning trials appended to ``path``."""

    def write(row: dict[str, Any]) -> None:
        new = not path.exists() or path.stat().st_size == 0
        lines = [
            (row["arm"], row["init"], row["seed"], k + 1, r)
            for k, r in enumerate(row.get("trial_rewards", ()))
        ]
        text = csv_text(TRIALS_COLUMNS, lines)
        with path.open("a", encoding="utf-8", newline="") as fh:
            fh.write(text if new else text.split("\n", 1)[1])

    return write


def read_trials(path: Path) -> dict[tuple[str, str, int], list[float]]:
    """trials.csv as (arm, init, seed) -> the rewards of trials 1, 2, ...; a run written
    twice (rerun after a stop between runs.csv and trials.csv) counts once, its last."""
    import csv

    out: dict[tuple[str, str, int], dict[int, float]] = {}
    with path.open(encoding="utf-8", newline="") as fh:
        for rec in csv.DictReader(fh):
            key = (rec["arm"], rec["init"], int(rec["seed"]))
            out.setdefault(key, {})[int(rec["trial"])] = float(rec["reward"])
    return {k: [v[t] for t in sorted(v)] for k, v in out.items()}
