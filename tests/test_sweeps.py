"""striatal.sweep, the Python API of ``striatal sweep``: the same runs for the same options."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

import striatal
from striatal.errors import ParameterError
from striatal.experiments import sweeps


def _without_wall(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows]


def test_the_api_runs_what_the_command_runs(tmp_path: Path, cli: Any) -> None:
    api = striatal.sweep(seeds=4, init="random", learner="pgpe", success_on="mean", max_trials=50)
    argv = ["sweep", "--seeds", "4", "--init", "random", "--learner", "pgpe"]
    argv += ["--success-on", "mean", "--max-trials", "50", "--no-progress"]
    assert cli(*argv, "--out", tmp_path / "cli")[0] == 0
    cli = json.loads((tmp_path / "cli" / "summary.json").read_text())

    def arms(summary: dict) -> list[tuple]:
        return [(a["arm"], a["init"], a["successes"], a["simulations_total"]) for a in summary]

    assert arms(api.summary["arms"]) == arms(cli["arms"])
    assert {a["arm"] for a in cli["arms"]} == {"learner", "control"}
    from striatal.experiments.runs_csv import read_runs

    rows, _ = read_runs(tmp_path / "cli" / "runs.csv")
    assert _without_wall(api.rows) == _without_wall(sweeps.sort_rows(rows))
    # the settings agree too (the command adds the options it was given)
    settings = dict(cli["settings"])
    settings.pop("options")
    assert sweeps.json_roundtrip(api.summary["settings"]) == settings


def test_a_folder_the_api_wrote_resumes_from_the_command(tmp_path: Path, cli: Any) -> None:
    out = tmp_path / "s"
    first = striatal.sweep(
        seeds=2, max_trials=3, eval_draws=0, sim=striatal.Simulation(duration=5), out=out
    )
    assert first.ran == 4 and first.skipped == 0
    argv = ["sweep", "--seeds", "2", "--max-trials", "3", "--eval-draws", "0"]
    code, printed, _ = cli(*argv, "--duration", "5", "--no-progress", "--out", out)
    assert code == 0 and "ran 0 runs, 4 already in --out" in printed


@pytest.mark.parametrize("engine", ["processes", "batch"])
def test_on_run_sees_every_new_row_once_as_written(tmp_path: Path, engine: str) -> None:
    """``sweep(on_run=f)`` gets each row as it is written to runs.csv, whatever the
    engine; a resume does not replay the rows already in the folder."""
    seen: list[dict[str, Any]] = []
    out = tmp_path / "s"
    kw: dict[str, Any] = {"seeds": 2, "max_trials": 3, "eval_draws": 0, "engine": engine}
    kw["sim"] = striatal.Simulation(duration=5)
    first = striatal.sweep(out=out, on_run=seen.append, **kw)
    assert len(seen) == first.ran == 4
    assert sorted((r["arm"], r["seed"]) for r in seen) == sorted(
        (r["arm"], r["seed"]) for r in first.rows
    )
    from striatal.experiments.runs_csv import read_runs

    written, _ = read_runs(out / "runs.csv")
    assert _without_wall(sweeps.sort_rows(seen)) == _without_wall(sweeps.sort_rows(written))
    again = striatal.sweep(out=out, on_run=seen.append, **kw)
    assert again.ran == 0 and len(seen) == 4


def test_on_run_must_be_callable() -> None:
    with pytest.raises(ParameterError, match="on_run must be a function of one row"):
        striatal.sweep(seeds=1, max_trials=1, on_run=5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"seeds": 0}, "seeds must be a whole number in [1, 100,000], got 0"),
        ({"seeds": 2.5}, "seeds must be a whole number"),
        ({"seeds": 10**30}, f"seeds must be a whole number in [1, {sweeps.MAX_SEEDS:,}]"),
        ({"seed": -1}, "seed must be a whole number in [0, "),
        ({"init": 5}, "init must be"),
        ({"init": "sideways"}, "sideways"),
        ({"eval_draws": -1}, "eval_draws must be a whole number in [0, "),
        ({"plant": "heavy"}, "plant must be a striatal.Plant"),
        ({"baselines": ["nope"]}, "baselines must be a list of names from lqr, hand"),
        ({"engine": "batch", "workers": 2}, "--engine batch runs in this process"),
        ({"connect_timeout": float("inf")}, "finite"),
        ({"backend": "ray"}, "--backend ray needs --address"),
        ({"workers": 10**6}, "workers must be a whole number in [1, 4,096]"),
        ({"learner": {"a": 1}}, "learner must be one of"),
        ({"learner": 5}, "learner must be one of"),
        ({"out": 5}, "out must be a folder's path"),
        ({"alpha_grid": "1,2"}, "alpha_grid must be a list of finite numbers"),
        ({"gamma_grid": [0.9, "1"]}, "gamma_grid must be a list of finite numbers"),
        ({"baselines": [3]}, "baselines must be a list of names"),
    ],
)
def test_bad_arguments_are_refused_before_any_run(
    tmp_path: Path, kwargs: dict, message: str
) -> None:
    out = tmp_path / "s"
    with pytest.raises(ParameterError, match=re.escape(message)):
        striatal.sweep(**{"max_trials": 1, "eval_draws": 0, "out": out, **kwargs})
    assert not out.exists() or not any(out.iterdir())


def test_an_unknown_argument_is_a_type_error_naming_it() -> None:
    """The sweep's parameters are explicit: an unknown one is Python's TypeError."""
    with pytest.raises(TypeError, match="no_such_option"):
        striatal.sweep(no_such_option=1)  # type: ignore[call-arg]


def test_plan_records_the_tuning_root_and_warns_in_sample() -> None:
    plan = sweeps.plan("pgpe", seeds=1, robust=True)
    assert plan.settings["tuning_root"] == 0
    assert "tuned on root seed 0" in (sweeps.in_sample_note(plan.settings) or "")
    held_out = sweeps.plan("pgpe", seeds=1, seed=1, robust=True)
    assert sweeps.in_sample_note(held_out.settings) is None


def test_one_name_is_a_list_of_one_as_on_the_command_line() -> None:
    """``init="random"`` and ``baselines="random"`` are one value each, as
    ``--init random`` and ``--baselines random`` are, not a string to iterate."""
    plan = sweeps.plan(seeds=1, init="random", baselines="random", max_trials=1)
    assert set(plan.settings["arms"]) == {"learner", "control", "random"}
    assert plan.settings["inits"] == ["random"]
