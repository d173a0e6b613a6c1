"""Track and force limits of a learning run (issue 15): ``LearnerConfig.max_force`` and
``track``, ``train``/``sweep --max-force/--track``.

Every simulation of the run (its trials, the success checks, the robust stop rule,
the re-checks after it, the searches of a sweep) gets the run's hardware (checked by
monkeypatching ``plant_args``, through which every kernel call passes); a 0.5-m
track ends trials by the track; resume keeps the limits; a run without them keeps its
run id of before; bad values are one line and exit 2.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from test_robust_stop import ROBUST_THETA_C, ROBUST_W  # a controller pgpe learned: robust

import striatal
from striatal.cli import main
from striatal.errors import ParameterError
from striatal.experiments import baselines
from striatal.learners import LearnerConfig, default_config, learn
from striatal.params import Controller, Hardware, Plant, Simulation
from striatal.sim import rollout

#: Run ids of ``striatal.train(learner="pgpe", init="random", seed=0, max_trials=1)``
#: and of the same with ``robust=True``, computed on main before the limits existed.
ID_BEFORE = "78e12ac8c85974e4"
ID_BEFORE_ROBUST = "1d2dfd8188bf4ccc"


@pytest.fixture
def hardwares(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[Hardware]]:
    """The hardware of every kernel call (all go through ``plant_args``)."""
    seen: list[Hardware] = []
    real = rollout.plant_args

    def noting(*args: Any, **kwargs: Any) -> Any:
        seen.append(args[3] if len(args) > 3 else kwargs["hardware"])
        return real(*args, **kwargs)

    monkeypatch.setattr(rollout, "plant_args", noting)
    yield seen


def test_the_config_gives_the_runs_hardware() -> None:
    assert LearnerConfig().hardware == Hardware()
    assert LearnerConfig(robust=True).hardware == Hardware(hold="force")
    c = LearnerConfig(robust=True, max_force=20, track=2.4)
    assert c.hardware == Hardware(hold="force", max_force=20.0, track=2.4)
    assert LearnerConfig(track=1).hardware == Hardware(hold="u", track=1.0)
    assert isinstance(LearnerConfig(max_force=20).max_force, float)


@pytest.mark.parametrize("name", ["max_force", "track"])
@pytest.mark.parametrize("bad", [0, -1.0, float("inf"), float("nan"), "x"])
def test_bad_limits_are_refused(name: str, bad: object) -> None:
    with pytest.raises(ParameterError, match=name):
        LearnerConfig(**{name: bad})  # type: ignore[arg-type]


def test_a_run_without_limits_keeps_its_run_id_and_settings() -> None:
    plain = striatal.train(learner="pgpe", init="random", seed=0, max_trials=1)
    robust = striatal.train(learner="pgpe", init="random", seed=0, max_trials=1, robust=True)
    assert (plain.run_id, robust.run_id) == (ID_BEFORE, ID_BEFORE_ROBUST)
    assert "track" not in plain.settings["config"]
    assert "max_force" not in robust.settings["config"]
    tracked = striatal.train(learner="pgpe", init="random", seed=0, max_trials=1, track=2.4)
    assert tracked.settings["config"]["track"] == 2.4
    assert tracked.run_id != plain.run_id


def test_every_kernel_call_of_a_robust_run_gets_its_hardware(hardwares: list[Hardware]) -> None:
    """Limits too wide to bind: the robust controller passes its trial, the stop rule's
    eight other cases, the re-simulation and the nine-case re-check, 20 runs in all."""
    run = striatal.train(
        learner="chapter",
        init_gains=ROBUST_W,
        theta_c0=ROBUST_THETA_C,
        alpha=0.0,
        theta_c_rule="fixed",
        success_on="mean",
        robust=True,
        max_force=1e4,
        track=100.0,
        max_trials=2,
    )
    assert run.success and run.trials == 1
    assert run.robust_report is not None and run.robust_report["robust"]
    assert run.robust_report["hardware"] == {"hold": "force", "max_force": 1e4, "track": 100.0}
    assert len(hardwares) == run.state.simulations + 1 + 9 == 20
    assert set(hardwares) == {Hardware(hold="force", max_force=1e4, track=100.0)}


def test_a_force_limit_that_binds_changes_the_verdict() -> None:
    """The robust controller's swing-up needs more than 5 N: under that limit the
    same run does not stop (the limit reaches the trial and the checks)."""
    changes = dict(alpha=0.0, theta_c_rule="fixed", success_on="mean", max_trials=2)
    template = Controller(gains=ROBUST_W, theta_c=ROBUST_THETA_C)
    free = learn(Plant(), template, default_config("chapter", robust=True, **changes), 1)
    weak = default_config("chapter", robust=True, max_force=5.0, **changes)
    limited = learn(Plant(), template, weak, 1)
    assert free.success and not limited.success


def test_the_ac_online_trial_holds_u_under_the_runs_limits(hardwares: list[Hardware]) -> None:
    config = default_config("ac", max_trials=2, track=1.5, max_force=30.0)
    learn(Plant(), Controller(), config, seed=0)
    assert hardwares and set(hardwares) == {Hardware(hold="u", max_force=30.0, track=1.5)}


def test_a_half_metre_track_ends_trials_by_the_track(monkeypatch: pytest.MonkeyPatch) -> None:
    outcomes: list[Any] = []
    real = rollout.TrialRequest.run

    def noting(request: rollout.TrialRequest) -> Any:
        o = real(request)
        outcomes.append(o)
        return o

    monkeypatch.setattr(rollout.TrialRequest, "run", noting)
    config = default_config("chapter", max_trials=4, track=0.5)
    result = learn(Plant(), Controller(), config, seed=0)
    ends = [o.end_reason for o in outcomes]
    assert ends.count("track") >= 3, ends
    for o in outcomes:
        if o.end_reason == "track":
            assert o.max_abs_x > 0.5 and o.ended_at < 60.0
    assert not result.success
    # without the track the same chapter trials run the cart further than 0.5 m
    outcomes.clear()
    learn(Plant(), Controller(), default_config("chapter", max_trials=1), seed=0)
    assert outcomes[0].end_reason != "track" and outcomes[0].max_abs_x > 0.5


def test_train_track_writes_trials_that_end_early(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    options = "--track 0.5 --max-trials 3 --json --no-progress"
    code = main(["train", *options.split(), "--out", str(tmp_path)])
    assert code == 0
    result = json.loads(capsys.readouterr().out)
    assert result["settings"]["config"]["track"] == 0.5
    rows = (tmp_path / "history.csv").read_text().splitlines()
    header = rows[0].split(",")
    ended = [float(r.split(",")[header.index("ended_at")]) for r in rows[1:]]
    assert len(ended) == 3 and all(t < 60.0 for t in ended)


def test_resume_keeps_the_limits(tmp_path: Path) -> None:
    kw: dict[str, Any] = dict(learner="pgpe", init="random", seed=5, robust=True, track=2.4)
    whole = striatal.train(max_trials=8, **kw)
    striatal.train(out=tmp_path, max_trials=4, checkpoint_every=2, **kw)
    with pytest.raises(ParameterError, match="--track"):
        striatal.train(out=tmp_path, resume=True, track=1.0)
    with pytest.raises(ParameterError, match="--max-force"):
        striatal.train(out=tmp_path, resume=True, max_force=20.0)
    resumed = striatal.train(out=tmp_path, resume=True, max_trials=8)
    assert resumed.settings["config"]["track"] == 2.4
    assert resumed.state == whole.state
    assert resumed.history == whole.history


def test_the_searches_run_under_the_given_hardware(hardwares: list[Hardware]) -> None:
    hw = Hardware(hold="force", max_force=20.0, track=2.4)
    template = Controller(gains=(0.6, -0.4, -0.9, 0.9, 0.1, -1.2), theta_c=0.6)
    budget = baselines.Budget(5, "mean", robust=True, hardware=hw)
    baselines.random_search(Plant(), template, Simulation(), 7, budget)
    baselines.cmaes(Plant(), template, Simulation(), template.gains, 0.6, 7, budget)
    assert len(hardwares) >= 10 and set(hardwares) == {hw}


def test_sweep_track_runs_every_arm_on_the_track(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], hardwares: list[Hardware]
) -> None:
    out = tmp_path / "sweep"
    options = "--init random --seeds 1 --learner pgpe --robust --max-trials 3 --track 2.4"
    options += " --max-force 20 --baselines random,cmaes --eval-draws 0 --json --no-progress"
    assert main(["sweep", *options.split(), "--out", str(out), "--workers", "1"]) == 0
    capsys.readouterr()
    settings = json.loads((out / "sweep.json").read_text())
    for arm in settings["arms"].values():
        assert arm["config"]["track"] == 2.4 and arm["config"]["max_force"] == 20.0
    assert len(hardwares) >= 4 * 3
    assert set(hardwares) == {Hardware(hold="force", max_force=20.0, track=2.4)}


@pytest.mark.parametrize("command", ["train", "sweep"])
@pytest.mark.parametrize(
    ("option", "value"), [("--track", "0"), ("--track", "nan"), ("--max-force", "-20")]
)
def test_bad_limit_options_are_one_line_and_exit_2(
    command: str,
    option: str,
    value: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main([command, option, value, "--out", str(tmp_path / "x")])
    assert code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert option.lstrip("-").replace("-", "_") in err
    assert not (tmp_path / "x").exists()
