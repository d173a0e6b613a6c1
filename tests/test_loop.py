"""The loop's success test as named checks (learners.loop.success_checks, CHECKS)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from striatal.errors import ParameterError
from striatal.learners import default_config, initial_state, learn, learning_step
from striatal.learners.loop import CHECKS, nominal_checked, success_checks
from striatal.params import (
    CHAPTER_FINAL_THETA_C,
    CHAPTER_FINAL_W,
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)
from striatal.sim.rollout import Protocol, TrialRequest

SHORT = Simulation(duration=10.0)
DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"
#: The table's rows: learner and the options (as LearnerConfig changes).
ROWS: dict[str, tuple[str, dict[str, Any]]] = {
    "chapter (preset: success_on noisy)": ("chapter", {}),
    "chapter `--success-on mean`": ("chapter", {"success_on": "mean"}),
    "chapter `--robust`": ("chapter", {"robust": True}),
    "chapter `--success-on mean --robust`": ("chapter", {"success_on": "mean", "robust": True}),
    "rpe `--success-on mean`": ("rpe", {"success_on": "mean"}),
    "pgpe (preset: success_on mean)": ("pgpe", {}),
    "pgpe `--plant-jitter 0.2`": ("pgpe", {"plant_jitter": 0.2}),
    "pgpe `--robust` (jitter 0.2)": ("pgpe", {"robust": True}),
    "pgpe `--robust --stop-margin 0.1`": ("pgpe", {"robust": True, "stop_margin": 0.1}),
    "forward (preset)": ("forward", {}),
    "ac (preset)": ("ac", {}),
}


def test_the_documented_table_is_what_the_loop_applies() -> None:
    text = DOC.read_text(encoding="utf-8")
    table = text.split("<!-- success-checks:begin -->")[1].split("<!-- success-checks:end -->")[0]
    found = {}
    for line in table.strip().splitlines()[2:]:
        learner, options, checks = (c.strip() for c in line.strip("|").split("|"))
        found[f"{learner} {options}"] = tuple(c.strip() for c in checks.split(","))
    assert set(found) == set(ROWS)
    for key, (learner, changes) in ROWS.items():
        assert found[key] == success_checks(default_config(learner, **changes)), key
    assert all(c in CHECKS for checks in found.values() for c in checks)


def test_the_nominal_case_of_the_set_is_skipped_only_after_a_nominal_check() -> None:
    assert nominal_checked(default_config("chapter", success_on="mean", robust=True))
    assert not nominal_checked(default_config("chapter", robust=True))  # a noisy trial
    assert nominal_checked(default_config("pgpe"))  # its noise-free nominal candidate
    assert not nominal_checked(default_config("pgpe", robust=True))  # on a jittered plant


class Count:
    """Counts the trials the loop asks for (every check that simulates is one)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.n = 0
        real = TrialRequest.run

        def counted(request: TrialRequest) -> Any:
            self.n += 1
            return real(request)

        monkeypatch.setattr(TrialRequest, "run", counted)


@pytest.mark.parametrize(
    ("learner", "changes", "trials"),
    [
        ("chapter", {"success_on": "mean"}, 2),  # the noisy trial, then the rerun
        ("pgpe", {"reward": "sparse"}, 1),  # the candidate's trial is the check: it fails
        ("pgpe", {"reward": "sparse", "plant_jitter": 0.2}, 2),  # the rerun fails: no corners
    ],
)
def test_a_failing_check_ends_the_test(
    monkeypatch: pytest.MonkeyPatch, learner: str, changes: dict[str, Any], trials: int
) -> None:
    config = default_config(learner, max_trials=5, **changes)
    count = Count(monkeypatch)
    state = initial_state(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C, seed=0)
    new, record = learning_step(state, Plant(), Controller(), SHORT, Protocol(), config)
    assert not record.success
    assert count.n == new.simulations == trials


def test_passing_checks_all_run(monkeypatch: pytest.MonkeyPatch) -> None:
    """The chapter's final gains pass the rerun: the noisy trial plus the rerun, success."""
    config = default_config("chapter", success_on="mean", max_trials=5)
    count = Count(monkeypatch)
    good = initial_state(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C, seed=0)
    new, record = learning_step(good, Plant(), Controller(), Simulation(), Protocol(), config)
    assert record.success and count.n == new.simulations == 2
    # judged on the noisy trial alone, the same gains need one trial
    count.n = 0
    noisy = default_config("chapter", max_trials=5)
    new, _ = learning_step(good, Plant(), Controller(), Simulation(), Protocol(), noisy)
    assert count.n == new.simulations == 1


def test_a_rule_that_judges_its_candidate_must_plan_it_noise_free(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The success checks take such a rule's trial for the noise-free run of what it
    judges; a plan with policy noise would be judged on a noisy trial, so it is refused
    before the trial runs."""
    from striatal.learners import loop
    from striatal.learners.chapter import ChapterRule
    from striatal.learners.rule import Judging

    class Noisy(ChapterRule):
        name = "noisy-candidate"
        judging = Judging("candidate")

    monkeypatch.setitem(loop.RULES, "noisy-candidate", Noisy())
    config = default_config("chapter", max_trials=1, success_on="mean")
    config = type(config)(**{**config.__dict__, "learner": "noisy-candidate"})
    count = Count(monkeypatch)
    state = initial_state(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C, seed=0)
    with pytest.raises(ParameterError, match="must be noise-free"):
        learning_step(state, Plant(), Controller(), SHORT, Protocol(), config)
    assert count.n == 0


@pytest.mark.parametrize("learner", ["chapter", "pgpe"])
def test_a_run_restoring_its_generator_once_equals_steps_that_each_restore_it(
    learner: str,
) -> None:
    """learn_steps sets its generator from the state on its first step only (the steps
    after start where the last one left it): each state and record equals a chain of
    learning_step calls from the same start, each of which restores the generator."""
    config = default_config(learner, max_trials=6)
    template = Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C)
    start = initial_state(template.gains, template.theta_c, 11)
    seen: list[tuple[Any, Any]] = []
    last = learn(
        Plant(),
        template,
        config,
        11,
        sim=SHORT,
        protocol=Protocol(),
        on_trial=lambda s, r: seen.append((s, r)),
    )
    state = start
    for run_state, run_record in seen:
        state, record = learning_step(state, Plant(), template, SHORT, Protocol(), config)
        assert (state, record) == (run_state, run_record)
    assert len(seen) == 6 and state == last
    # the generator moved: the states do not all share one generator state
    assert len({str(s.rng_state) for s, _ in seen}) == 6
