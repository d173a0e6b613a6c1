"""Sweeps in lockstep (``striatal sweep --engine batch|simd``): a sweep's runs side by side.

The process engine (:func:`striatal.experiments.pool.execute`) runs each (arm, init, seed)
as its own :func:`striatal.experiments.runner.run_one`. Here every run of the sweep is
the same code, :func:`striatal.experiments.runner.run_steps` (the rule's own plan and
update, the loop's success test, the evaluation), advanced together by
:class:`striatal.sim.batch.Lockstep`: each round, the trials that the unfinished runs
ask for (their learning trial, a success test's noise-free rerun, the robustness set,
a rule's own simulations such as ac's online trial and forward's imagined learning, a
baseline's candidates, the evaluation's draws) run in batched kernel calls, and a run's
row is yielded as soon as it is finished, so the sweep writes it to runs.csv and a
rerun skips it. The trials no batch kernel takes (recorded ones, for the shaped reward
or forward's model) run one by one on the scalar kernel; trials on one learned model
share a call of :func:`striatal.sim.kernel.run_learned_trials_batch`.

``--engine batch``: :func:`striatal.sim.kernel.run_trials_batch`,
a parallel loop over the scalar kernel that equals it bit for bit; every run draws its
noise from its own generator in the order the process engine draws it, so the rows
are the process engine's, bit for bit (apart from ``wall_seconds``).
tests/test_lockstep_sweep.py compares whole sweeps.

``--engine simd``: the trials run on the SIMD kernel
:func:`striatal.sim.kernel.run_trials_lockstep` where it applies (u held, no force
limit, no track; the exact kernel otherwise). Its trials equal the scalar kernel's only
within round-off (its polynomial sin/cos are within 1 ulp of libm's), and a chaotic
swing-up and learning over many trials amplify that, so its rows are a different sample
of the same experiment: the arms' success rates agree within their intervals
(tests/test_lockstep_sweep.py, docs/performance.md), a given run's row need not.

W(0)'s evaluation, which the runs of one init and seed share (a learner and its control:
:func:`striatal.experiments.runner.shared_w0`), runs once, as a computation of its own
beside the runs from the first round (all of them together taking at most about
:data:`SHARED_DRAWS` draws a round); a run takes its result when it gets there (it
makes its own should it get there first) and its row counts the trials as before.

``wall_seconds`` of a row is its share of the engine's time: its run's own Python plus
an even share of each batched call it was in (preparing it, the kernel, reading the
outcomes), and an even share of a shared W(0) evaluation's time. The runs' Python and
the lanes' kernel calls overlap (:class:`striatal.sim.batch.Lockstep`'s two lanes, each
on a thread of its own), so the rows of a sweep sum to between its wall time and twice it.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any, Literal

from striatal.errors import ParameterError
from striatal.experiments.evaluate import DRAWS_AT_ONCE, PassProbability
from striatal.experiments.runner import W0Key, W0Source, run_steps, shared_w0, w0_steps
from striatal.experiments.spec import RunSpec
from striatal.learners import check_config
from striatal.sim.batch import BATCH_ENGINES, Lockstep, Steps

__all__ = ["BATCH_ENGINES", "SHARED_DRAWS", "check_specs", "execute_batch"]

#: The noisy trials the shared W(0) evaluations of a sweep ask for in one round, at most
#: about (each draws 6 000 normals, 48 kB, for a 60-s trial): they all start in the
#: first round, so they take their draws in chunks that sum to this.
SHARED_DRAWS = 2048


def check_specs(specs: Sequence[RunSpec]) -> None:
    """ParameterError (one line) unless every spec's config is one its rule accepts and
    its trials run on the kernel (not on the spiking network)."""
    for s in specs:
        check_config(s.config)
        if s.network is not None:
            raise ParameterError("runs on the spiking network take --engine processes only")


def execute_batch(
    specs: Sequence[RunSpec], *, engine: Literal["batch", "simd"] = "batch"
) -> Iterator[dict[str, Any]]:
    """Rows of ``specs`` (RUN_COLUMNS), each yielded when its run is finished and evaluated.

    "batch": the rows equal :func:`striatal.experiments.runner.run_one`'s for the same specs
    except ``wall_seconds``. "simd": the trials on
    :func:`striatal.sim.kernel.run_trials_lockstep` where it applies, so its rows are not
    the process engine's, only the same experiment (module docstring).
    """
    if engine not in BATCH_ENGINES:
        raise ParameterError(f"engine must be one of {', '.join(BATCH_ENGINES)}, got {engine!r}")
    check_specs(specs)
    groups = shared_w0(specs)
    keys = list(groups)
    index = {key: n for n, key in enumerate(keys)}
    group_of = {i: key for key, members in groups.items() for i in members}
    made: dict[W0Key, PassProbability] = {}

    def source(key: W0Key | None) -> W0Source | None:
        return None if key is None else lambda: made.get(key)

    # the shared evaluations first (indices 0 .. len(keys) - 1), then the runs; together
    # they ask for at most about SHARED_DRAWS trials a round (their noise's memory)
    chunk = max(1, min(DRAWS_AT_ONCE, SHARED_DRAWS // max(len(keys), 1)))
    steps: list[Steps[Any]] = [w0_steps(specs[groups[k][0]], chunk) for k in keys]
    steps += [run_steps(s, w0=source(group_of.get(i))) for i, s in enumerate(specs)]
    runs = Lockstep(steps, engine)
    for i, value in runs.run():
        if i < len(keys):
            made[keys[i]] = value
            continue
        run = i - len(keys)
        key = group_of.get(run)
        share = 0.0 if key is None else runs.seconds[index[key]] / len(groups[key])
        yield {**value, "wall_seconds": float(runs.seconds[i] + share)}
