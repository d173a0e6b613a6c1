"""The forward learner (striatal.learners.forward.rule): imagined trials are counted apart,
real ones always; its solutions pass the project's robust check; on a plant outside its
model's family the real checks refuse what imagination found."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from striatal.errors import ParameterError
from striatal.experiments.spec import initial_gains
from striatal.learners import LEARNERS, control_config, default_config, learn
from striatal.learners.forward import rule as forward
from striatal.learners.forward.model import Transitions, fit_structured
from striatal.learners.state import LearnerState, TrialRecord
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim import kernel
from striatal.sim.learned import LearnedPlant
from striatal.sim.robust import ROBUST_HARDWARE, check_robust
from striatal.sim.rollout import NO_PROTOCOL, simulate


class Calls:
    """Kernel trial calls, split into those made while the rule imagines and the rest."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.real = self.imagined = 0
        self.real_steps = 0
        self.dreaming = False
        run_trial, imagine = kernel.run_trial, forward.imagine_steps

        def counted(*args: Any) -> Any:
            out = run_trial(*args)
            if self.dreaming:
                self.imagined += 1
            else:
                self.real += 1
                self.real_steps += int(args[-1][0][kernel.OUT_END_STEP])
            return out

        def dreaming(*args: Any, **kwargs: Any) -> Any:
            self.dreaming = True
            try:
                return (yield from imagine(*args, **kwargs))
            finally:
                self.dreaming = False

        monkeypatch.setattr(kernel, "run_trial", counted)
        monkeypatch.setattr(forward, "imagine_steps", dreaming)


def start(seed: int) -> Controller:
    return Controller(gains=initial_gains("random", seed), theta_c=CHAPTER_INITIAL_THETA_C)


def run(
    plant: Plant, seed: int, max_trials: int = 6, learn_seed: int | None = None
) -> tuple[LearnerState, list[TrialRecord]]:
    """Learn from W(0) of ``seed`` (``striatal sweep --init random``'s), with the robust
    stop rule, under ``learn_seed`` (default: ``seed``)."""
    rows: list[TrialRecord] = []
    config = default_config("forward", robust=True, max_trials=max_trials)
    result = learn(
        plant,
        start(seed),
        config,
        seed if learn_seed is None else learn_seed,
        on_trial=lambda s, r: rows.append(r),
    )
    return result, rows


def test_forward_is_registered_with_a_control_that_learns_nothing() -> None:
    assert "forward" in LEARNERS
    control = control_config(default_config("forward", robust=True))
    assert control.imagine_trials == 0
    from striatal.experiments.runner import control_note

    assert "no model is fitted and nothing is learned" in control_note("forward")
    with pytest.raises(ParameterError, match="success_on 'mean'"):
        default_config("forward", success_on="noisy")
    with pytest.raises(ParameterError, match="imagine_trials must be a whole number >= 0"):
        default_config("forward", imagine_trials=-1)
    with pytest.raises(ParameterError, match="does not use imagine_trials"):
        default_config("pgpe", imagine_trials=10)


@pytest.mark.parametrize("seed", [101, 102])
def test_imagined_trials_never_reach_simulations_and_real_ones_always_do(
    monkeypatch: pytest.MonkeyPatch, seed: int
) -> None:
    calls = Calls(monkeypatch)
    state, rows = run(Plant(), seed)
    assert calls.imagined > 0 and calls.real > 0
    assert state.simulations == calls.real
    assert state.simulated_seconds == pytest.approx(calls.real_steps * Simulation().dt)
    imagined = state.get("imagined")
    assert imagined[0] == calls.imagined
    assert sum(r.extra[0][1] for r in rows) == calls.imagined  # the history column
    # the real trials: one recorded trial per learning trial, plus the robust checks
    assert calls.real >= len(rows)


def test_the_learned_controller_passes_the_projects_robust_check() -> None:
    result, rows = run(Plant(), 101)
    assert result.success
    assert len(rows) <= 3  # one trial to gather data, then (nearly always) one check
    report = check_robust(Controller(gains=result.W, theta_c=result.theta_c))
    assert report.robust


def test_the_control_repeats_w0_and_never_imagines(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = Calls(monkeypatch)
    config = control_config(default_config("forward", robust=True, max_trials=3))
    result = learn(Plant(), start(101), config, 101)
    assert calls.imagined == 0
    assert tuple(start(101).gains) == result.W
    assert result.trials_done == 3 and not result.success
    assert result.get("imagined") == (0.0, 0.0)


def test_a_plant_outside_the_family_shows_in_the_fit_and_the_real_checks() -> None:
    """Gravity is what the model takes as known (9.8 m/s^2): on a plant with g = 20 the
    fit cannot explain the data, and a controller found in imagination is refused by the
    real trial until one passes there (then it passes the robust check for real)."""
    far = Plant(gravity=20.0)
    sim = Simulation(duration=20.0)
    trajectory = simulate(far, start(102), sim, hardware=ROBUST_HARDWARE)
    fit = fit_structured(Transitions.of([trajectory]))
    near = fit_structured(
        Transitions.of([simulate(Plant(), start(102), sim, hardware=ROBUST_HARDWARE)])
    )
    assert fit.rms.max() > 1e3 * near.rms.max()
    assert abs(fit.plant.length - 1.0) > 0.2  # the length takes the blame for g
    result, rows = run(far, 102, max_trials=8, learn_seed=2)
    # imagination after trial i found a candidate; trial i + 1 ran it on the real plant
    assert any(
        dict(rows[i].extra)["solved_in_imagination"] == 1 and not rows[i + 1].success
        for i in range(len(rows) - 1)
    )
    if result.success:
        report = check_robust(Controller(gains=result.W, theta_c=result.theta_c), plant=far)
        assert report.robust


def test_the_rules_run_is_deterministic() -> None:
    a, _ = run(Plant(), 101)
    b, _ = run(Plant(), 101)
    assert a.W == b.W and a.simulations == b.simulations
    assert np.array_equal(np.array(a.get("data")), np.array(b.get("data")))


def test_a_sweep_row_counts_the_imagined_trials_apart() -> None:
    """runs.csv: imagined_simulations / imagined_seconds hold what the model ran, never in
    simulations; a rule that imagines nothing has 0."""
    import striatal

    result = striatal.sweep("forward", seeds=1, init="random", max_trials=3, eval_draws=0)
    rows = {r["arm"]: r for r in result.rows}
    learner, control = rows["learner"], rows["control"]
    assert learner["imagined_simulations"] > 0 and learner["imagined_seconds"] > 0
    assert control["imagined_simulations"] == 0 and control["imagined_seconds"] == 0.0
    run = striatal.train("forward", seed=learner["seed"], init="random", max_trials=3)
    assert learner["imagined_simulations"] == int(run.history.column("imagined").sum())
    arms = {a["arm"]: a for a in result.summary["arms"]}
    assert arms["learner"]["imagined_simulations_total"] == learner["imagined_simulations"]


def test_generic_imagination_runs_on_the_model_only_and_counts_apart(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """With the generic model, every imagined trial runs on a learned plant (none on the
    physical kernel: imagination never touches the simulator), every physical trial is a
    real one and is counted, and a rerun under the same seed gives the same run."""
    pytest.importorskip("sklearn")
    calls = Calls(monkeypatch)
    learned = {"n": 0}
    run_learned = kernel.run_learned_trial

    def counted_learned(*args: Any) -> Any:
        assert calls.dreaming
        learned["n"] += 1
        return run_learned(*args)

    monkeypatch.setattr(kernel, "run_learned_trial", counted_learned)
    config = default_config(
        "forward", robust=True, max_trials=2, imagine_trials=300, forward_model="generic"
    )
    rows: list[TrialRecord] = []
    result = learn(Plant(), start(101), config, 101, on_trial=lambda s, r: rows.append(r))
    assert calls.imagined == 0  # no physical trial while dreaming
    assert learned["n"] > 0
    assert result.simulations == calls.real
    assert result.simulated_seconds == pytest.approx(calls.real_steps * Simulation().dt)
    assert result.get("imagined")[0] == learned["n"]
    assert sum(dict(r.extra)["imagined"] for r in rows) == learned["n"]
    # the generic model has no pole mass or length to report
    assert all(
        np.isnan(dict(r.extra)["model_pole_mass"]) for r in rows if dict(r.extra)["imagined"]
    )
    again = learn(Plant(), start(101), config, 101)
    assert again.W == result.W and again.simulations == result.simulations


def test_generic_imagination_cannot_rehearse_other_plants_and_the_real_check_says_so() -> None:
    """A generic model fitted on the nominal plant has no pole mass to vary: candidates
    that pass every member and start in imagination pass the nominal real trial (reward
    +10) and are still refused by the real robust check, whose plant corners imagination
    could not rehearse."""
    pytest.importorskip("sklearn")
    # rounds given the whole budget (imagine_round 2000), so no round ends early
    config = default_config(
        "forward", robust=True, max_trials=7, forward_model="generic", imagine_round=2000
    )
    rows: list[TrialRecord] = []
    result = learn(Plant(), start(2), config, 2, on_trial=lambda s, r: rows.append(r))
    assert not result.success
    refused = [
        i
        for i in range(len(rows) - 1)
        if dict(rows[i].extra)["solved_in_imagination"]
        and rows[i + 1].reward == 10.0
        and not rows[i + 1].success
    ]
    assert refused


def test_generic_gains_checks_candidates_on_the_mean_with_the_pole_answering_slower_and_faster(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """--forward-model generic-gains: the world of the generic model plus its mean with
    theta_ddot (and nothing else) times each of RESPONSE_GAINS in the family; the run
    counts its imagination apart like generic's, and its real trials alone."""
    pytest.importorskip("sklearn")
    sim = Simulation(duration=20.0)
    data = Transitions.of(
        [
            simulate(Plant(), c, sim, hardware=ROBUST_HARDWARE)
            for c in (
                Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C),
                Controller(theta_c=CHAPTER_INITIAL_THETA_C),
            )
        ]
    )
    model = forward.fit_generic(data, np.random.default_rng(0))
    plain = forward.generic_world(model, Plant())
    world = forward.generic_world(model, Plant(), forward.RESPONSE_GAINS)
    assert len(plain.family) == 5  # the members
    assert len(world.family) == 7 and not world.rehearse
    states, forces = data.states[::50], data.forces[::50]
    mean = model.accelerations(states, forces).mean(axis=0)
    for plant, g in zip(world.family[-2:], forward.RESPONSE_GAINS, strict=True):
        assert isinstance(plant, LearnedPlant) and plant.believed == Plant()
        assert plant.dynamics is not None
        got = np.array(
            [
                kernel.learned_accelerations(
                    s[1], np.sin(s[2]), np.cos(s[2]), s[3], f, plant.dynamics.args
                )
                for s, f in zip(states, forces, strict=True)
            ]
        )
        assert np.allclose(got[:, 0], mean[:, 0], rtol=1e-12, atol=1e-12)
        assert np.allclose(got[:, 1], g * mean[:, 1], rtol=1e-12, atol=1e-12)
    seen: list[int] = []
    real = forward.generic_world

    def noting(m: Any, believed: Plant, gains: tuple[float, ...] = ()) -> Any:
        seen.append(len(gains))
        return real(m, believed, gains)

    monkeypatch.setattr(forward, "generic_world", noting)
    config = default_config(
        "forward", robust=True, max_trials=2, imagine_trials=60, forward_model="generic-gains"
    )
    result = learn(Plant(), start(101), config, 101)
    assert seen and set(seen) == {2}
    assert result.get("imagined")[0] > 0
    assert result.simulations >= 2


@pytest.mark.parametrize(
    ("model", "readout"),
    [
        ("generic-gains", "ridge"),
        ("sparse-gains", "sparse"),
        ("sparse-affine", "sparse linear 2"),
    ],
)
def test_sparse_gains_is_generic_gains_with_the_sparse_readout(
    monkeypatch: pytest.MonkeyPatch, model: str, readout: str
) -> None:
    """--forward-model sparse-gains fits the sparse readout, sparse-affine the same with
    the force's monomial and 2 terms on narrow data, and both are otherwise
    generic-gains: the two response gains checked, the margin of the robust preset;
    generic-gains keeps the ridge (its runs unchanged)."""
    pytest.importorskip("sklearn")
    seen: list[tuple[str, int, int]] = []
    fit, world = forward.fit_generic, forward.generic_world

    def fitting(*args: Any, **kwargs: Any) -> Any:
        fitted = fit(*args, **kwargs)
        options = [kwargs.get("readout", "ridge"), kwargs.get("force_term")]
        options.append(kwargs.get("narrow_terms"))
        name = " ".join(str(o) for o in options if o is not None)
        seen.append((name, len(fitted.args.powers), -1))
        return fitted

    def gained(m: Any, believed: Plant, gains: tuple[float, ...] = ()) -> Any:
        seen[-1] = (*seen[-1][:2], len(gains))
        return world(m, believed, gains)

    monkeypatch.setattr(forward, "fit_generic", fitting)
    monkeypatch.setattr(forward, "generic_world", gained)
    config = default_config(
        "forward", robust=True, max_trials=2, imagine_trials=60, forward_model=model
    )
    assert config.imagine_margin == 0.1
    result = learn(Plant(), start(101), config, 101)
    assert seen and {(r, g) for r, _, g in seen} == {(readout, 2)}
    if readout != "ridge":  # a few of the 56 monomials
        assert all(n < 56 for _, n, _ in seen)
    assert result.get("imagined")[0] > 0


def test_the_generic_model_without_scikit_learn_is_refused_before_any_trial(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import importlib.util

    find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "sklearn" else find_spec(name, *a),
    )
    for model in ("generic", "generic-gains", "sparse-gains", "sparse-affine", "conditioned"):
        with pytest.raises(
            ParameterError,
            match=rf"^--forward-model {model} needs scikit-learn: pip install 'striatal\[model\]'$",
        ):
            default_config("forward", forward_model=model)
    default_config("forward", forward_model="structured")  # needs no scikit-learn
    with pytest.raises(
        ParameterError,
        match=(
            "forward_model must be 'structured', 'generic', 'generic-gains', 'sparse-gains', "
            "'sparse-affine' or 'conditioned', got 'neural'"
        ),
    ):
        default_config("forward", forward_model="neural")
    with pytest.raises(ParameterError, match="does not use forward_model"):
        default_config("pgpe", forward_model="generic")


def test_the_conditioned_model_learns_from_the_real_checks(monkeypatch: pytest.MonkeyPatch) -> None:
    """--forward-model conditioned: the real robust checks' runs join the data with their
    plant factors, counted in ``simulations`` as always (the chapter's final gains pass
    the nominal trial, so the robustness set runs)."""
    pytest.importorskip("sklearn")
    calls = Calls(monkeypatch)
    config = default_config(
        "forward", robust=True, max_trials=1, forward_model="conditioned", imagine_trials=1
    )
    final = Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C)
    state = learn(Plant(), final, config, 0)
    assert state.simulations > 1 and calls.real == state.simulations and calls.imagined == 0
    data = forward.kept_data(state)
    factors = [tuple(f) for f in data[:, 9:].tolist()]
    corners = {f for f in factors if f != (1.0, 1.0)}
    assert corners and corners <= {(a, b) for a in (0.8, 1.2) for b in (0.8, 1.2)}
    # the plain generic model keeps only its real trial, as before
    plain = learn(Plant(), final, replace(config, forward_model="generic"), 0)
    assert plain.simulations == state.simulations
    assert {tuple(f) for f in forward.kept_data(plain)[:, 9:].tolist()} == {(1.0, 1.0)}


def test_imagination_believes_a_plain_plant_passed_explicitly() -> None:
    """The imagined controller believes the four nominal parameters the real controller
    believes (TrialContext.plant), never the object the loop holds: a learned plant as the
    loop's plant gives a plain Plant of the same parameters, and every plant of the
    generic world believes exactly that."""
    pytest.importorskip("sklearn")
    data = Transitions.of(
        [simulate(Plant(), start(1), Simulation(duration=5.0), hardware=ROBUST_HARDWARE)]
    )
    model = forward.fit_generic(data, np.random.default_rng(0))
    loops_plant = model.plant(Plant(pole_mass=0.11))
    believed = forward.believed_plant(loops_plant)
    assert type(believed) is Plant and believed == Plant(pole_mass=0.11)
    world = forward.generic_world(model, believed)
    assert all(p.believed == believed for p in (world.plant, *world.family))  # type: ignore[attr-defined]
    assert world.family_model == believed


def _generic_world() -> forward.World:
    data = Transitions.of(
        [
            simulate(Plant(), c, Simulation(duration=20.0), hardware=ROBUST_HARDWARE)
            for c in (
                Controller(gains=CHAPTER_FINAL_W, theta_c=CHAPTER_FINAL_THETA_C),
                Controller(theta_c=CHAPTER_INITIAL_THETA_C),
            )
        ]
    )
    model = forward.fit_generic(data, np.random.default_rng(0))
    return forward.generic_world(model, Plant(), forward.RESPONSE_GAINS)


@pytest.mark.parametrize("cap", [None, 15])
def test_a_round_without_a_solution_ends_the_imagination(
    monkeypatch: pytest.MonkeyPatch, cap: int | None
) -> None:
    """--imagine-round N: each round of the inner learner is given at most N trials, and a
    round that finds no solution is the last (the budget left is not spent); the same
    seed gives the same candidate and counts."""
    pytest.importorskip("sklearn")
    world = _generic_world()
    rounds: list[tuple[int, bool]] = []
    learn_steps = forward.learn_steps

    def noting(*args: Any, **kwargs: Any) -> Any:
        result = yield from learn_steps(*args, **kwargs)
        rounds.append((args[2].max_trials, bool(result.success)))
        return result

    monkeypatch.setattr(forward, "learn_steps", noting)
    config = default_config(
        "forward", robust=True, imagine_trials=400, imagine_round=cap, forward_model="generic"
    )
    dream = forward.imagine(world, start(3), config, Simulation(), NO_PROTOCOL, 3)
    assert rounds
    assert all(ok for _, ok in rounds[:-1])  # only the last round may end unsolved
    if cap is not None:
        assert all(m <= cap for m, _ in rounds)
        assert not rounds[-1][1] and not dream.solved  # W(0) of seed 3: no solution in 15
        assert dream.simulations < config.imagine_trials
    first = list(rounds)
    rounds.clear()
    again = forward.imagine(world, start(3), config, Simulation(), NO_PROTOCOL, 3)
    assert again == dream and rounds == first


def test_generic_checks_are_spent_from_the_imagined_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    """The generic worlds charge their family checks to the budget: after a real trial,
    the imagined simulations (inner trials and checks) exceed ``imagine_trials`` by at
    most one family check; the structured world does not charge them (unchanged)."""
    pytest.importorskip("sklearn")
    world = _generic_world()
    structured = forward.structured_world(
        fit_structured(Transitions.of([simulate(Plant(), start(1), Simulation(duration=5.0))]))
    )
    assert world.charge_checks and not structured.charge_checks
    # the generic worlds' own round cap and duration; the structured world has none
    assert (world.round_trials, world.duration) == (forward.GENERIC_ROUND, forward.GENERIC_DURATION)
    assert (structured.round_trials, structured.duration) == (None, None)
    starts = 5  # the robustness set's starts on one family plant
    config = default_config(
        "forward", robust=True, imagine_trials=120, forward_model="generic-gains"
    )
    for seed in (1, 2):
        dream = forward.imagine(world, start(seed), config, Simulation(), NO_PROTOCOL, seed)
        assert dream.simulations <= config.imagine_trials + len(world.family) * starts


def test_a_capped_run_counts_imagination_apart_and_repeats_under_its_seed(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """generic-gains with --imagine-round: no physical trial while dreaming, every real
    trial in ``simulations``, the imagined ones apart; the same seed, the same run."""
    pytest.importorskip("sklearn")
    calls = Calls(monkeypatch)
    config = default_config(
        "forward",
        robust=True,
        max_trials=3,
        imagine_trials=300,
        imagine_round=50,
        forward_model="generic-gains",
    )
    rows: list[TrialRecord] = []
    result = learn(Plant(), start(101), config, 101, on_trial=lambda s, r: rows.append(r))
    assert calls.imagined == 0 and calls.real == result.simulations
    assert result.simulated_seconds == pytest.approx(calls.real_steps * Simulation().dt)
    assert result.get("imagined")[0] == sum(dict(r.extra)["imagined"] for r in rows) > 0
    again = learn(Plant(), start(101), config, 101)
    assert again.W == result.W and again.simulations == result.simulations
    assert again.get("imagined") == result.get("imagined")
    with pytest.raises(ParameterError, match="imagine_round"):
        default_config("forward", imagine_round=0)
    with pytest.raises(ParameterError, match="does not use imagine_round"):
        default_config("pgpe", imagine_round=10)


def test_imagined_trials_last_the_imagine_duration_and_checks_keep_60_s(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """--imagine-duration D: the inner learner's trials run for D seconds (its success test
    judged then), the family checks for the robustness set's 60 s; longer than the real
    trial is cut to it; out of [1, 600] is refused."""
    pytest.importorskip("sklearn")
    world = _generic_world()
    durations: list[float] = []
    checks: list[int] = []
    learn_steps, check_steps = forward.learn_steps, forward.family_check_steps

    def noting(*args: Any, **kwargs: Any) -> Any:
        durations.append(args[4].duration)
        result = yield from learn_steps(*args, **kwargs)
        checks.append(-result.trials_done)
        return result

    def checking(*args: Any, **kwargs: Any) -> Any:
        verdict = yield from check_steps(*args, **kwargs)
        checks.append(verdict.simulations)
        return verdict

    monkeypatch.setattr(forward, "learn_steps", noting)
    monkeypatch.setattr(forward, "family_check_steps", checking)
    config = default_config(
        "forward", robust=True, imagine_trials=200, imagine_duration=20.0, forward_model="generic"
    )
    dream = forward.imagine(world, start(1), config, Simulation(), NO_PROTOCOL, 1)
    assert durations and set(durations) == {20.0}
    inner = -sum(c for c in checks if c < 0)
    checked = sum(c for c in checks if c > 0)
    assert dream.simulations == inner + checked
    assert dream.simulated_seconds <= inner * 20.0 + checked * 60.0 + 1e-9
    durations.clear()
    longer = replace(config, imagine_duration=90.0)
    forward.imagine(world, start(1), longer, Simulation(duration=30.0), NO_PROTOCOL, 1)
    assert set(durations) == {30.0}
    for bad in (0.5, 601.0):
        with pytest.raises(ParameterError, match="imagine_duration"):
            default_config("forward", imagine_duration=bad)
