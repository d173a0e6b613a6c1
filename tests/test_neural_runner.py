"""``striatal neural --learn --seeds N``: the network's learning runs on the experiment runner.

Tiny networks (300 neurons) and 0.6-s trials on nengo: the runner's bookkeeping is what
is tested here (seeds, resume, refusals); the trials themselves are tested in
test_neural.py and test_neural_brian2.py.
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import cli_in_process

pytest.importorskip("nengo")

from striatal import arguments
from striatal.cli import build_parser
from striatal.experiments.network import read_trials
from striatal.experiments.spec import spawn_seeds
from striatal.neural.driver import learn_with_rule
from striatal.neural.network import NetworkConfig
from striatal.params import (
    CHAPTER_INITIAL_THETA_C,
    CHAPTER_INITIAL_W,
    Controller,
    Plant,
    Simulation,
)

TINY = ["--chapter-initial", "--learn", "--neurons", "300", "--duration", "0.6", "--no-progress"]


def rows(folder: Path) -> list[dict[str, str]]:
    with (folder / "runs.csv").open(newline="") as fh:
        return sorted(csv.DictReader(fh), key=lambda r: (r["arm"], r["seed"]))


def without_time(rs: list[dict[str, str]]) -> list[dict[str, str]]:
    return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rs]


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished sweep: the chapter's rule and its control, one seed of root 4, 2 trials."""
    out = tmp_path_factory.mktemp("runner") / "full"
    ran = cli_in_process("neural", *TINY, "--seeds", "1", "--seed", "4", "--trials", "2",
                         "--out", str(out))  # fmt: skip
    assert ran.rc == 0, ran.err
    assert "ran 2 runs, 0 already in --out" in ran.out
    return out


def test_rows_are_the_spawned_seeds_and_equal_a_learning_run(finished: Path) -> None:
    """Each arm runs the seeds SeedSequence(--seed).spawn(--seeds); the learner's row is
    learn_with_rule's run of its seed (W and theta_c to the last digit written), its
    control's W stays W(0), and every trial is counted."""
    rs = rows(finished)
    (seed,) = spawn_seeds(4, 1)
    assert [(r["arm"], int(r["seed"])) for r in rs] == [("control", seed), ("learner", seed)]
    rewards: list[float] = []
    state = learn_with_rule(
        "chapter",
        Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
        Plant(),
        Simulation(duration=0.6),
        NetworkConfig(neurons=300),
        seed,
        trials=2,
        simulator="nengo",
        on_trial=lambda _state, rec: rewards.append(rec.reward),
    )
    # trials.csv: each run's learning trials, the learner's equal to the run's rewards
    trials = read_trials(finished / "trials.csv")
    assert sorted(trials) == [("control", "chapter", seed), ("learner", "chapter", seed)]
    assert trials[("learner", "chapter", seed)] == rewards
    assert all(len(v) == 2 and set(v) <= {10.0, -5.0} for v in trials.values())
    learner = next(r for r in rs if r["arm"] == "learner")
    control = next(r for r in rs if r["arm"] == "control")
    assert [float(learner[f"W{i}"]) for i in range(1, 7)] == pytest.approx(state.W, rel=1e-12)
    assert float(learner["theta_c"]) == pytest.approx(state.theta_c, rel=1e-12)
    assert state.W != CHAPTER_INITIAL_W
    assert [float(control[f"W{i}"]) for i in range(1, 7)] == list(CHAPTER_INITIAL_W)
    for r in rs:
        assert int(r["trials"]) == 2 and int(r["simulations"]) == 2
        assert int(r["eval_simulations"]) == 1  # the mean-policy rerun of the final gains
        assert np.isclose(float(r["simulated_seconds"]), 1.2)


def test_an_interrupted_sweep_resumes_bit_for_bit(finished: Path, tmp_path: Path) -> None:
    """A folder left with one finished row and a half-written line (a kill) reruns only
    the missing run, and its rows equal the uninterrupted sweep's, every column but
    the wall time."""
    cut = tmp_path / "cut"
    shutil.copytree(finished, cut)
    lines = (cut / "runs.csv").read_text().splitlines(keepends=True)
    (cut / "runs.csv").write_text("".join(lines[:2]) + lines[2][:25])
    ran = cli_in_process("neural", *TINY, "--seeds", "1", "--seed", "4", "--trials", "2",
                         "--out", str(cut))  # fmt: skip
    assert ran.rc == 0, ran.err
    assert "ran 1 runs, 1 already in --out" in ran.out
    assert without_time(rows(cut)) == without_time(rows(finished))
    assert (cut / "summary.json").exists()
    assert read_trials(cut / "trials.csv") == read_trials(finished / "trials.csv")


def test_other_options_are_not_resumed_into_the_folder(finished: Path, tmp_path: Path) -> None:
    other = tmp_path / "other"
    shutil.copytree(finished, other)
    before = (other / "runs.csv").read_text()
    ran = cli_in_process("neural", *TINY, "--seeds", "1", "--seed", "4", "--trials", "2",
                         "--neurons", "400", "--out", str(other))  # fmt: skip
    assert ran.rc == 2 and ran.err.count("\n") == 1 and "other settings" in ran.err
    assert (other / "runs.csv").read_text() == before


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--seeds", "0"], "--seeds"),
        (["--seeds", "2.5"], "--seeds"),
        (["--trials", "0", "--seeds", "2"], "--trials"),
        (["--seeds", "2", "--duration", "31"], "at most 30 s"),
        (["--seeds", "2", "--learner", "ac"], "--learner"),
        (["--seeds", "2", "--backend", "ray"], "--address"),
        (["--seeds", "2", "--workers", "0"], "--workers"),
        (["--seeds", "2", "--init", "bottom"], "--init"),
        (["--workers", "2"], "--workers needs --learn --seeds N"),
        (["--learner", "pgpe"], "--learner needs --learn --seeds N"),
        (["--seeds", "2", "--backend", "brian2"], "--simulator brian2"),
        (["--seeds", "100", "--trials", "100000"], "the network would simulate"),
    ],
)
def test_bad_sweep_options_get_one_line_and_exit_2(
    tmp_path: Path, argv: list[str], says: str
) -> None:
    out = tmp_path / "o"
    ran = cli_in_process("neural", *TINY, *argv, "--out", str(out))
    assert ran.rc == 2 and ran.out == "", ran
    assert ran.err.count("\n") == 1 and says in ran.err, ran.err
    assert not out.exists()


def test_seeds_need_learn_and_the_chapters_start(tmp_path: Path) -> None:
    for argv, says in (
        (["--chapter-initial", "--seeds", "2"], "--seeds needs --learn"),
        (["--chapter-final", "--learn", "--seeds", "2"], "--chapter-initial"),
    ):
        ran = cli_in_process("neural", *argv, "--out", str(tmp_path / "o"))
        assert ran.rc == 2 and ran.err.count("\n") == 1 and says in ran.err, ran.err
        assert not (tmp_path / "o").exists()


def test_the_sweep_options_come_from_the_option_table() -> None:
    """--seeds, --trials, --workers and --connect-timeout are read and bounded by
    striatal.arguments (the same words as sweep's), --init and --backend take the table's
    choices."""
    parser = build_parser(only="neural")
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    acts = {a.dest: a for a in sub.choices["neural"]._actions}
    for dest, name in (
        ("seeds", "seeds"),
        ("trials", "max_trials"),
        ("workers", "workers"),
        ("connect_timeout", "connect_timeout"),
    ):
        assert acts[dest].type.__name__ == arguments.cli_type(name).__name__, dest
    assert set(acts["backend"].choices) == set(arguments.ARGS["backend"].choices)
    assert set(acts["init"].names) == set(arguments.ARGS["init"].choices)


def test_worker_processes_give_the_same_rows(finished: Path, tmp_path: Path) -> None:
    """The specs travel pickled to other processes (a local pool here, Ray's workers the
    same way) and give the rows and trials of the sweep run in this process."""
    out = tmp_path / "pool"
    ran = cli_in_process("neural", *TINY, "--seeds", "1", "--seed", "4", "--trials", "2",
                         "--workers", "2", "--out", str(out))  # fmt: skip
    assert ran.rc == 0, ran.err
    assert without_time(rows(out)) == without_time(rows(finished))
    assert read_trials(out / "trials.csv") == read_trials(finished / "trials.csv")


def test_the_command_offers_the_rules_the_network_runs() -> None:
    from striatal.cli.neural import NETWORK_LEARNERS
    from striatal.errors import ParameterError
    from striatal.neural.driver import NETWORK_RULES

    assert NETWORK_LEARNERS == NETWORK_RULES
    for learner in ("ac", "forward"):
        with pytest.raises(ParameterError, match="cannot learn on the network"):
            learn_with_rule(
                learner,
                Controller(CHAPTER_INITIAL_W, CHAPTER_INITIAL_THETA_C),
                Plant(),
                Simulation(duration=0.6),
                NetworkConfig(neurons=300),
                0,
                trials=1,
            )
