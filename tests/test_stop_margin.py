"""A margin beyond the robustness set: ``stop_margin`` (the robust stop rule of any learner
also asks for the plant corners of a wider box, every run counted) and ``imagine_margin``
(the forward learner's imagination checks the wider corners; the real checks unchanged).

Refused where they do not apply, counted like every simulation, deterministic, and at
their defaults the runs (and run ids) are those without them.
"""

from __future__ import annotations

from typing import Any

import pytest
from conftest import KernelCounter
from test_robust_stop import (  # pgpe's robust controller: passes the corners at +-25 %,
    ROBUST_THETA_C,  # fails the first corner at +-30 % (pole mass x1.3, length x0.7)
    ROBUST_W,
)

import striatal
from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments import baselines
from striatal.experiments.spec import initial_gains
from striatal.learners import default_config, learn
from striatal.learners.forward import rule as forward
from striatal.learners.loop import success_checks
from striatal.params import CHAPTER_INITIAL_THETA_C, Controller, Plant
from striatal.sim.robust import (
    ROBUST_BOX,
    ROBUST_CASES,
    STOP_ORDER,
    corner_cases,
    corners_check,
    robust_cases,
    run_case,
    stop_check,
)

DT = 0.01
FIXED = dict(alpha=0.0, theta_c_rule="fixed", success_on="mean")


def test_the_wider_corners_replace_the_sets_corners_and_keep_its_order() -> None:
    assert robust_cases() is ROBUST_CASES and robust_cases(ROBUST_BOX) is ROBUST_CASES
    wide = robust_cases(0.3)
    assert len(wide) == len(ROBUST_CASES)
    for old, new in zip(ROBUST_CASES, wide, strict=True):
        if old.pole_mass == 1.0:
            assert new is old  # the starts are the set's
        else:
            # the same corner, 0.1 farther out
            assert new.pole_mass == pytest.approx(1.0 + 1.5 * (old.pole_mass - 1.0))
            assert new.length == pytest.approx(1.0 + 1.5 * (old.length - 1.0))
    assert [(c.pole_mass, c.length) for c in corner_cases(0.3)] == [
        (1.3, 0.7),
        (0.7, 0.7),
        (1.3, 1.3),
        (0.7, 1.3),
    ]
    # corner_cases(0.2) are the set's corners in the stop rule's order
    assert corner_cases(ROBUST_BOX) == tuple(
        ROBUST_CASES[i] for i in STOP_ORDER if ROBUST_CASES[i].pole_mass != 1.0
    )
    for bad in (0.0, 1.0, -0.1, 1.5):
        with pytest.raises(ParameterError, match="corner box"):
            robust_cases(bad)


def test_the_corners_check_counts_its_runs_and_agrees_with_each_case(
    counted: KernelCounter,
) -> None:
    c = Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)
    for box, robust, runs in ((0.25, True, 4), (0.3, False, 1)):
        counted.calls = counted.steps = 0
        verdict = corners_check(c, Plant(), DT, box)
        assert verdict.robust is robust and verdict.simulations == runs == counted.calls
        assert verdict.simulated_seconds == pytest.approx(counted.steps * DT)
        cases = corner_cases(box)
        assert all(run_case(c, k).success for k in cases) is robust
    # the wide stop check is the set with the corners moved: the same verdict here
    assert not stop_check(c, Plant(), DT, box=0.3).robust
    assert stop_check(c, Plant(), DT, box=0.25).robust


def test_stop_margin_is_refused_without_robust_and_out_of_its_bounds() -> None:
    with pytest.raises(ParameterError, match="stop_margin widens the robust stop rule"):
        default_config("pgpe", stop_margin=0.1)
    for bad in (-0.1, 0.6, float("nan")):
        with pytest.raises(ParameterError, match="stop_margin"):
            default_config("pgpe", robust=True, stop_margin=bad)
    # any learner's loop reads it
    for learner in ("chapter", "rpe", "pgpe", "ac", "forward"):
        assert default_config(learner, robust=True, stop_margin=0.1).stop_margin == 0.1
    assert success_checks(default_config("pgpe", robust=True, stop_margin=0.1)) == (
        "trial",
        "margin corners",
        "robustness set",
    )
    assert "margin corners" not in success_checks(default_config("pgpe", robust=True))


def test_imagine_margin_is_refused_where_imagination_has_no_corners() -> None:
    assert default_config("forward", robust=True, imagine_margin=0.1).imagine_margin == 0.1
    ok = default_config("forward", robust=True, forward_model="generic-gains", imagine_margin=0.1)
    assert ok.imagine_margin == 0.1
    for changes in (
        dict(imagine_margin=0.1),  # no robust
        dict(robust=True, forward_model="generic", imagine_margin=0.1),
        dict(robust=True, forward_model="conditioned", imagine_margin=0.1),
    ):
        with pytest.raises(ParameterError, match="imagine_margin widens"):
            default_config("forward", **changes)
    with pytest.raises(ParameterError, match="does not use imagine_margin"):
        default_config("pgpe", robust=True, imagine_margin=0.1)


def test_the_cli_refuses_stop_margin_without_robust_in_one_line(
    tmp_path: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    code = main(["train", "--learner", "pgpe", "--stop-margin", "0.1", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--robust" in err
    assert not out.exists()


def test_the_margin_corners_run_before_the_set_and_every_run_is_counted(
    counted: KernelCounter,
) -> None:
    """A fixed robust controller (alpha 0): with the corners at +-25 % it stops at trial 1
    after its trial, the mean-policy rerun, 4 corners and the set's other 8 cases; at
    +-30 % its first corner fails every trial, so the run goes on to max_trials."""
    template = Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)
    config = default_config("chapter", robust=True, stop_margin=0.05, max_trials=3, **FIXED)
    r = learn(Plant(), template, config, seed=1)
    assert r.success and r.trials_done == 1
    assert r.simulations == counted.calls == 1 + 1 + 4 + 8
    assert r.simulated_seconds == pytest.approx(counted.steps * DT)
    counted.calls = counted.steps = 0
    config = default_config("chapter", robust=True, stop_margin=0.1, max_trials=3, **FIXED)
    r = learn(Plant(), template, config, seed=1)
    assert not r.success and r.trials_done == 3
    assert r.simulations == counted.calls == 3 * (1 + 1 + 1)
    assert r.simulated_seconds == pytest.approx(counted.steps * DT)


def test_pgpe_with_a_margin_counts_every_run_and_its_controller_holds_the_wider_box(
    counted: KernelCounter,
) -> None:
    """Root-0 seed #5 of ``sweep --init random --seed 0`` (robust in 12 trials)."""
    seed = 4118645239
    template = Controller(gains=initial_gains("random", seed), theta_c=CHAPTER_INITIAL_THETA_C)
    config = default_config("pgpe", robust=True, stop_margin=0.1, max_trials=30)
    state = learn(Plant(), template, config, seed)
    assert state.success and state.simulations == counted.calls > state.trials_done
    assert state.simulated_seconds == pytest.approx(counted.steps * DT)
    assert learn(Plant(), template, config, seed) == state  # deterministic under its seed
    found = Controller(gains=state.W, theta_c=state.theta_c)
    assert corners_check(found, Plant(), DT, 0.3).robust
    assert stop_check(found, Plant(), DT).robust


def test_the_defaults_change_no_run_and_no_run_id() -> None:
    config = default_config("pgpe", robust=True)
    assert config.stop_margin == 0.0 and "stop_margin" not in config.to_dict()
    forward_config = default_config("forward", robust=True, imagine_margin=0.0)
    assert forward_config.imagine_margin == 0.0
    assert "imagine_margin" not in forward_config.to_dict()
    assert forward.response_gains() == forward.RESPONSE_GAINS
    kw = dict(learner="pgpe", init="random", seed=0, max_trials=2, robust=True)
    plain = striatal.train(**kw)  # type: ignore[arg-type]
    margin = striatal.train(stop_margin=0.1, **kw)  # type: ignore[arg-type]
    assert margin.settings["config"]["stop_margin"] == 0.1
    assert margin.run_id != plain.run_id


@pytest.mark.parametrize(
    "model", [None, "structured", "generic-gains", "sparse-gains", "sparse-affine"]
)
def test_the_margin_models_robust_preset_carries_the_margin_and_an_explicit_option_overrides_it(
    model: str | None,
) -> None:
    """The structured (the default model) and generic-gains models with --robust ask
    imagination for the +-30 % corners by default (stored in their settings, so their
    runs have new ids); an explicit 0 is kept, the other models and a run without
    --robust are unchanged, and the preset names its root."""
    named = {} if model is None else {"forward_model": model}
    preset = default_config("forward", robust=True, **named)
    assert preset.imagine_margin == forward.MARGIN_ROBUST["imagine_margin"] == 0.1
    assert preset.to_dict()["imagine_margin"] == 0.1
    off = default_config("forward", robust=True, imagine_margin=0.0, **named)
    assert off.imagine_margin == 0.0 and "imagine_margin" not in off.to_dict()
    for other in ("generic", "conditioned"):
        assert default_config("forward", robust=True, forward_model=other).imagine_margin == 0.0
    assert default_config("forward", **named).imagine_margin == 0.0
    assert forward.FORWARD.tuning_root_of(preset) == 0
    assert forward.FORWARD.tuning_root_of(default_config("forward")) is None


def test_a_sweeps_baselines_keep_the_plain_stop_rule() -> None:
    config = default_config("pgpe", robust=True, stop_margin=0.1)
    assert "margin corners" not in baselines.Budget.of(config).checks


def test_imagine_margin_widens_what_imagination_checks(
    monkeypatch: pytest.MonkeyPatch, counted: KernelCounter
) -> None:
    """Structured: the inner pgpe's jitter and each family plant's corners at +-30 %
    (generic-gains: the angular-acceleration gains 1/1.3 and 1/0.7). The run is the same
    under its seed twice, and its imagined trials stay out of ``simulations``."""
    boxes: list[float] = []
    jitters: list[float] = []
    dreamt = KernelCounter()
    real_check, real_learn, real_imagine = (
        forward.family_check_steps,
        forward.learn_steps,
        forward.imagine_steps,
    )

    def noting(*args: Any, **kwargs: Any) -> Any:
        boxes.append(kwargs["box"])
        return (yield from real_check(*args, **kwargs))

    def learning(plant: Plant, template: Controller, config: Any, *a: Any, **k: Any) -> Any:
        jitters.append(config.plant_jitter)
        return (yield from real_learn(plant, template, config, *a, **k))

    def dreaming(*args: Any, **kwargs: Any) -> Any:
        before = counted.calls
        try:
            return (yield from real_imagine(*args, **kwargs))
        finally:
            dreamt.calls += counted.calls - before

    monkeypatch.setattr(forward, "family_check_steps", noting)
    monkeypatch.setattr(forward, "learn_steps", learning)
    monkeypatch.setattr(forward, "imagine_steps", dreaming)
    config = default_config("forward", robust=True, max_trials=4, imagine_margin=0.1)
    template = Controller(gains=(0.6, -0.4, -0.9, 0.9, 0.1, -1.2), theta_c=0.6)
    result = learn(Plant(), template, config, seed=101)
    assert jitters and all(j == pytest.approx(0.3) for j in jitters)
    assert boxes and all(b == pytest.approx(0.3) for b in boxes)
    assert dreamt.calls == result.get("imagined")[0] > 0
    assert result.simulations == counted.calls - dreamt.calls
    assert learn(Plant(), template, config, seed=101) == result
    assert forward.response_gains(0.3) == (1.0 / 1.3, 1.0 / 0.7)


def test_generic_gains_imagines_the_pole_answering_as_the_wider_corners_would(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("sklearn")
    seen: list[tuple[float, ...]] = []
    real = forward.generic_world

    def noting(m: Any, believed: Plant, gains: tuple[float, ...] = ()) -> Any:
        seen.append(gains)
        return real(m, believed, gains)

    monkeypatch.setattr(forward, "generic_world", noting)
    changes = dict(robust=True, max_trials=2, imagine_trials=60, forward_model="generic-gains")
    template = Controller(gains=(0.6, -0.4, -0.9, 0.9, 0.1, -1.2), theta_c=0.6)
    learn(Plant(), template, default_config("forward", imagine_margin=0.1, **changes), 101)
    assert seen and set(seen) == {forward.response_gains(0.3)}
    seen.clear()
    learn(Plant(), template, default_config("forward", imagine_margin=0.0, **changes), 101)
    assert seen and set(seen) == {forward.RESPONSE_GAINS}
    seen.clear()  # generic-gains' robust preset carries the margin 0.1
    learn(Plant(), template, default_config("forward", **changes), 101)
    assert seen and set(seen) == {forward.response_gains(0.3)}


def test_a_sweep_takes_the_margins_and_random_search_keeps_its_rule() -> None:
    kw: dict[str, Any] = dict(
        seeds=2, init="random", max_trials=3, eval_draws=0, control=False, baselines=("random",)
    )
    plain = striatal.sweep("pgpe", robust=True, **kw)
    margin = striatal.sweep("pgpe", robust=True, stop_margin=0.1, **kw)
    rows = {(r["arm"], r["seed"]): r for r in margin.runs}
    for r in plain.runs:
        if r["arm"] == "random":  # the same search, run for run
            assert rows[("random", r["seed"])]["simulations"] == r["simulations"]
    with pytest.raises(ParameterError, match="imagine_margin widens"):
        striatal.sweep("forward", imagine_margin=0.1, **kw)
