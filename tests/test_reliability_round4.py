"""Round 4 of the hostile pass: each listed defect, closed by its class, with a test.

The classes (docs/reliability.md): every file read through its schema
(:mod:`striatal.io.schema`), every argument held to one table
(:mod:`striatal.arguments`), work bounded before it starts, nothing written before
every check. ``tests/test_fuzz.py`` tries the classes at large; these are the cases.
"""

from __future__ import annotations

import csv
import importlib.util
import inspect
import io
import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import Ran, cli_in_process

import striatal
from striatal.errors import DataFileError, ParameterError


def one_line(r: Ran, *needles: str) -> None:
    """Exit 2 and one line on stderr holding every needle."""
    assert r.rc == 2, (r.rc, r.err[-2000:])
    lines = r.err.strip().splitlines()
    assert len(lines) == 1, r.err
    for n in needles:
        assert n in lines[0], (n, lines[0])


@pytest.fixture(scope="module")
def swept(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("round4") / "sweep"
    r = cli_in_process(
        *("sweep", "--seeds", "2", "--max-trials", "3", "--duration", "2"),
        *("--eval-draws", "0", "--no-progress", "--out", str(out)),
    )
    assert r.rc == 0, r.err
    return out


@pytest.fixture(scope="module")
def forward_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("round4") / "forward"
    r = cli_in_process(
        *("train", "--learner", "forward", "--max-trials", "3", "--duration", "3"),
        *("--imagine-trials", "20", "--out", str(out)),
    )
    assert r.rc == 0, r.err
    return out


def copy_of(folder: Path, tmp: Path) -> Path:
    dest = tmp / folder.name
    shutil.copytree(folder, dest)
    return dest


def edit_runs(folder: Path, change: Any) -> None:
    """runs.csv of ``folder`` with ``change(rows)`` applied (rows: list of dicts)."""
    path = folder / "runs.csv"
    rows = list(csv.DictReader(io.StringIO(path.read_text())))
    header = list(rows[0])
    rows = change(rows)
    buf = io.StringIO()
    w = csv.DictWriter(buf, header, lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    path.write_text(buf.getvalue())


def edit_json(path: Path, change: Any) -> None:
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


# -- N1, N4, N2, N11: the forward learner's files and options ------------------------


@pytest.mark.skipif(importlib.util.find_spec("sklearn") is None, reason="needs [model]")
def test_n1_the_generic_model_run_writes_its_result_and_resumes(tmp_path: Path) -> None:
    """N1: the generic model's empty model cells are what its history schema allows."""
    out = tmp_path / "G"
    argv = ("train", "--learner", "forward", "--forward-model", "generic", "--duration", "3")
    r = cli_in_process(*argv, "--max-trials", "2", "--imagine-trials", "5", "--out", str(out))
    assert r.rc == 0, r.err
    assert (out / "result.json").exists()
    assert "model_pole_mass" in (out / "history.csv").read_text().splitlines()[0]
    r = cli_in_process(
        *argv, "--max-trials", "3", "--imagine-trials", "5", "--out", str(out), "--resume"
    )
    assert r.rc == 0, r.err
    r = cli_in_process("curves", str(out / "history.csv"), "--out", str(tmp_path / "c.png"))
    assert r.rc == 0, r.err


@pytest.mark.parametrize(
    ("how", "says"),
    [
        ("deleted", "state.memory.data is missing or empty"),
        ("emptied", "state.memory.data is missing or empty"),
        ("text", "field state.memory.data: input should be a valid list"),
        ("huge", "field state.memory.data.5"),
        ("one short", "not a multiple of 11"),
        ("unknown", "state.memory.trace is not kept by the forward learner"),
        ("imagined negative", "state.memory.imagined holds a negative count"),
        ("imagined fraction", "state.memory.imagined.0 is a count, not a whole number"),
    ],
)
def test_n4_the_forward_memory_is_checked_on_resume(
    forward_run: Path, tmp_path: Path, how: str, says: str
) -> None:
    """N4: a deleted, emptied, text, 1e300 or short memory is refused in one line."""
    run = copy_of(forward_run, tmp_path)

    def change(d: dict[str, Any]) -> None:
        mem = d["state"]["memory"]
        if how == "deleted":
            del d["state"]["memory"]
        elif how == "emptied":
            mem["data"] = []
        elif how == "text":
            mem["data"] = "text"
        elif how == "huge":
            mem["data"][5] = 1e300
        elif how == "one short":
            mem["data"] = mem["data"][:-1]
        elif how == "unknown":
            mem["trace"] = [0.0] * 6
        elif how == "imagined fraction":
            mem["imagined"] = [1.5, 0.0]
        else:
            mem["imagined"] = [-1.0, 0.0]

    edit_json(run / "checkpoint.json", change)
    before = {p.name: p.read_bytes() for p in run.iterdir()}
    r = cli_in_process(
        *("train", "--learner", "forward", "--max-trials", "4", "--duration", "3"),
        *("--imagine-trials", "20", "--resume", "--out", str(run)),
    )
    one_line(r, says)
    assert {p.name: p.read_bytes() for p in run.iterdir()} == before


def test_n2_resume_accepts_the_run_s_own_forward_options(forward_run: Path, tmp_path: Path) -> None:
    """N2: --forward-model structured and --imagine-trials as the run has them."""
    run = copy_of(forward_run, tmp_path)
    r = cli_in_process(
        *("train", "--learner", "forward", "--forward-model", "structured"),
        *("--max-trials", "3", "--duration", "3", "--imagine-trials", "20"),
        *("--resume", "--out", str(run)),
    )
    assert r.rc == 0, r.err


def test_n11_one_trial_s_imagination_is_bounded() -> None:
    """N11: --imagine-trials 2**31-1 would imagine for days: refused before the first trial."""
    r = cli_in_process("train", "--learner", "forward", "--imagine-trials", "2147483647")
    one_line(r, "one real trial would imagine up to", "--imagine-trials")


# -- N6, H4, N5, N9: sweep folders -----------------------------------------------------


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (lambda rows: [{**rows[0], "simulations": "-4"}, *rows[1:]], "simulations"),
        (lambda rows: [{**rows[0], "trials": "5", "simulations": "2"}, *rows[1:]], "simulations"),
        (lambda rows: [{**rows[0], "trials": "5", "simulations": "9"}, *rows[1:]], "budget of 3"),
        (lambda rows: [*rows, {**rows[0], "success": "1", "trials": "2"}], "a second row"),
        (lambda rows: [{**rows[0], "pass_rate": "7.5"}, *rows[1:]], "pass_rate"),
    ],
)
def test_n6_a_sweep_rerun_refuses_rows_against_the_schema(
    swept: Path, tmp_path: Path, change: Any, says: str
) -> None:
    """N6: negative counts, fewer simulations than trials, more trials than the budget,
    a conflicting duplicate: one line, nothing rewritten."""
    folder = copy_of(swept, tmp_path)
    edit_runs(folder, change)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    r = cli_in_process(
        *("sweep", "--seeds", "2", "--max-trials", "3", "--duration", "2"),
        *("--eval-draws", "0", "--no-progress", "--out", str(folder)),
    )
    one_line(r, says)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before


def test_h4_profile_counts_a_repeated_row_once(swept: Path, tmp_path: Path) -> None:
    folder = copy_of(swept, tmp_path)
    edit_runs(folder, lambda rows: [*rows, rows[0], rows[0]])
    r = cli_in_process("profile", str(folder), "--out", str(tmp_path / "p.png"), "--json")
    assert r.rc == 0, r.err
    runs = {p["arm"]: p["runs"] for p in json.loads(r.out)["profiles"]}
    assert runs == {"control": 2, "learner": 2}
    edit_runs(folder, lambda rows: [*rows, {**rows[0], "success": "1", "trials": "1"}])
    one_line(cli_in_process("profile", str(folder), "--out", str(tmp_path / "q.png")), "second row")


def test_n5_eval_draws_is_refused_by_its_name_before_anything_is_written(tmp_path: Path) -> None:
    out = tmp_path / "s"
    r = cli_in_process("sweep", "--eval-draws", "1000001", "--out", str(out))
    one_line(r, "--eval-draws", "1,000,000")
    assert not out.exists()


def test_n9_a_library_that_does_not_load_is_refused_before_any_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """N9: a broken scikit-learn (found, but its import fails) is refused before writing."""
    import sys

    monkeypatch.setitem(sys.modules, "sklearn.linear_model", None)
    out = tmp_path / "s"
    r = cli_in_process(
        *("sweep", "--learner", "forward", "--forward-model", "generic", "--seeds", "1"),
        *("--max-trials", "1", "--out", str(out)),
    )
    one_line(r, "scikit-learn")
    assert not out.exists() or not any(out.iterdir())


# -- H17, H25: compare reads summaries through their schema --------------------------


@pytest.mark.parametrize(
    ("field", "value", "says"),
    [
        ("success_rate", 7.5, "success_rate"),
        ("runs", -3, "runs"),
        ("successes", 9, "successes"),
        ("success_rate_ci", [0.9, 0.1], "success_rate"),
        # held-out round-3 case: a field of the wrong type
        ("runs", "2", "field arms.0.runs"),
        ("success_rate", "x", "field arms.0.success_rate"),
        ("trials_median", [1], "field arms.0.trials_median"),
    ],
)
def test_h25_compare_refuses_impossible_rates_and_counts(
    swept: Path, tmp_path: Path, field: str, value: Any, says: str
) -> None:
    folder = copy_of(swept, tmp_path)
    edit_json(folder / "summary.json", lambda d: d["arms"][0].__setitem__(field, value))
    one_line(cli_in_process("compare", str(folder)), says)


def test_h17_compare_refuses_notes_of_the_wrong_type(swept: Path, tmp_path: Path) -> None:
    folder = copy_of(swept, tmp_path)
    edit_json(folder / "summary.json", lambda d: d.__setitem__("notes", 5))
    one_line(cli_in_process("compare", str(folder)), "field notes")


def test_compare_writes_the_format_of_its_suffix(swept: Path, tmp_path: Path) -> None:
    """Issue 39 item 4: --out's format from its suffix."""
    assert cli_in_process("compare", str(swept), "--out", str(tmp_path / "t.md")).rc == 0
    assert (tmp_path / "t.md").read_text().startswith("| arm |")
    assert cli_in_process("compare", str(swept), "--out", str(tmp_path / "t.json")).rc == 0
    assert "arms" in json.loads((tmp_path / "t.json").read_text())
    one_line(cli_in_process("compare", str(swept), "--out", str(tmp_path / "t.txt")), ".json")


# -- H9, H11, H12, H20: work bounded before it starts --------------------------------


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (("ablation", "--seeds", "2147483647"), "--seeds"),
        (("sweep", "--seeds", "100000", "--max-trials", "2000000"), "would simulate up to"),
        (("robustness", "R", "--repeats", "1000000000"), "--repeats"),
        (("sweep", "--connect-timeout", "1e308"), "--connect-timeout"),
        (("switch-figure", "--inhibition", ",".join(["5"] * 13)), "at most 12"),
        # held-out round-3 case: 200 values took over a minute
        (("switch-figure", "--inhibition", ",".join(["5"] * 200)), "at most 12"),
    ],
)
def test_work_past_its_limit_is_refused_at_once(argv: tuple[str, ...], says: str) -> None:
    """H9, H11, H12, H20: one line giving the estimate or the bound, before any work."""
    import time

    t0 = time.monotonic()
    one_line(cli_in_process(*argv), says)
    assert time.monotonic() - t0 < 10


# -- N8, N13, N3: the Python API, TOML and the Gymnasium kwargs -----------------------


def test_sweep_lists_its_parameters_by_name() -> None:
    """Issue 39 item 3: no ``**`` catch-all; every parameter typed, with its default."""
    sig = inspect.signature(striatal.sweep)
    kinds = {p.kind for p in sig.parameters.values()}
    assert inspect.Parameter.VAR_KEYWORD not in kinds
    assert {"seeds", "seed", "init", "max_trials", "baselines", "alpha"} <= set(sig.parameters)
    assert all(p.annotation is not inspect.Parameter.empty for p in sig.parameters.values())


def test_sweep_parameters_are_the_table_s_and_the_learner_config_s() -> None:
    """The sweep's parameters, the option table and LearnerConfig's fields agree, and the
    command line has an option for each (its own spelling)."""
    from dataclasses import fields

    from striatal.arguments import ARGS
    from striatal.cli import build_parser
    from striatal.experiments.sweeps import LEARNER_OPTIONS
    from striatal.learners import LearnerConfig

    params = set(inspect.signature(striatal.sweep).parameters)
    assert set(LEARNER_OPTIONS) == {f.name for f in fields(LearnerConfig)} - {"learner"}
    python_only = {"plant", "sim", "on_run"}  # objects and a callback: no option text
    own = params - set(LEARNER_OPTIONS) - {"learner", "out"} - python_only
    assert own <= set(ARGS), own - set(ARGS)
    parser = build_parser(only="sweep")
    sub = next(a for a in parser._actions if hasattr(a, "choices") and a.choices)
    dests = {a.dest for a in sub.choices["sweep"]._actions}  # type: ignore[index]
    cli_name = {"control": "no_control", "progress": "no_progress", "reset_trace": "carry_trace"}
    api_only = {f.name for f in fields(LearnerConfig) if not f.metadata.get("cli", True)}
    api_only -= {"learner"}  # --learner: its own option, outside the table of fields
    missing = {p for p in params - python_only if cli_name.get(p, p) not in dests}
    assert missing == api_only


@pytest.mark.parametrize(
    ("kwargs", "says"),
    [
        ({"control": "no"}, "control must be true or false"),
        ({"out": ""}, "out must be a folder's path"),
        ({"seeds": 2.0}, "seeds must be a whole number"),
        ({"alpha_grid": [0.5] * 1001}, "at most 1,000"),
        ({"alpha_grid": []}, "alpha_grid needs at least 1"),
    ],
)
def test_n8_the_sweep_api_refuses_in_one_line(
    tmp_path: Path, kwargs: dict[str, Any], says: str
) -> None:
    out = tmp_path / "s"
    with pytest.raises(ParameterError, match=says):
        striatal.sweep(**{"out": out, **kwargs})
    assert not out.exists()


def test_n8_numpy_integers_are_whole_numbers() -> None:
    run = striatal.train(max_trials=np.int64(2), sim=striatal.Simulation(duration=2.0))
    assert run.trials == 2 and json.dumps(run.to_dict()["settings"])


def test_n13_text_is_not_a_number_in_a_config_file(tmp_path: Path) -> None:
    toml = tmp_path / "c.toml"
    toml.write_text('seeds = "2"\n')
    one_line(cli_in_process("sweep", "--config", str(toml)), "seeds must be a number")


def test_n13_text_is_not_a_number_in_gymnasium_kwargs() -> None:
    gym = pytest.importorskip("gymnasium")
    with pytest.raises(ParameterError, match="track must be a number"):
        gym.make("striatal/CartPoleSwingUp-v0", track="1.8")


def test_n3_none_is_no_limit_as_the_help_says() -> None:
    r = cli_in_process("train", "--track", "none", "--max-force", "none", "--max-trials", "1")
    assert r.rc == 0, r.err


def test_n10_train_help_offers_a_default_only_for_the_learners_that_read_it() -> None:
    r = cli_in_process("train", "--help")
    text = " ".join(r.out.split())
    alpha = text.split("--alpha ALPHA", 1)[1].split("--gamma", 1)[0]
    assert "forward" not in alpha


def test_n7_grid_arms_get_distinct_labels() -> None:
    from striatal.viz.profiles import arm_labels

    spec = {"method": "learn", "config": {"learner": "chapter"}}
    labels = arm_labels([("s", "alpha=0.5", spec), ("s", "alpha=2", spec)])
    assert len(set(labels)) == 2


def test_old_spelling_of_interpret_s_file_names_the_new_one() -> None:
    one_line(cli_in_process("interpret", "R/result.json"), "--result R/result.json")


def test_a_result_file_of_the_wrong_type_is_one_line(tmp_path: Path) -> None:
    from striatal.io.rundir import read_result

    p = tmp_path / "result.json"
    p.write_text(json.dumps({"W": [1.0] * 6, "theta_c": 0.6, "trials": -1}))
    with pytest.raises(DataFileError, match="field trials"):
        read_result(p)


def test_a_plant_the_lqr_baseline_cannot_fit_is_one_line(tmp_path: Path) -> None:
    """Found by tests/test_fuzz.py: --gravity 1.3e30 ended in scipy's LinAlgError."""
    out = tmp_path / "s"
    r = cli_in_process("sweep", "--gravity", "1.3327198662459107e+30", "--out", str(out))
    one_line(r, "the LQR baseline cannot be fitted to this plant")
    assert not out.exists()


@pytest.mark.parametrize(
    "options",
    [
        ("--learner", "chapter"),
        ("--learner", "rpe"),
        ("--learner", "pgpe"),
        ("--learner", "pgpe", "--symmetric"),
        ("--learner", "ac"),
        ("--learner", "forward", "--imagine-trials", "5"),
    ],
)
def test_what_each_learner_writes_is_what_its_schema_reads(
    tmp_path: Path, options: tuple[str, ...]
) -> None:
    """The writers and the schema agree: every learner's checkpoint (its memory too) and
    result, and the history they wrote, read back through their schema."""
    from striatal.io import schema
    from striatal.io.rundir import RunDir, read_history

    out = tmp_path / "run"
    r = cli_in_process("train", *options, "--max-trials", "3", "--duration", "3", "--out", str(out))
    assert r.rc == 0, r.err
    data = json.loads((out / "checkpoint.json").read_text())
    model = schema.validated(schema.CheckpointModel, data, "checkpoint")
    schema.check_memory(data["settings"]["learner"], model.state, "checkpoint")
    RunDir(out).read_checkpoint()
    RunDir(out).read_result()
    assert len(read_history(out / "history.csv")) == 3


def test_what_a_sweep_and_an_ablation_write_is_what_their_schemas_read(
    swept: Path, tmp_path: Path
) -> None:
    from striatal.experiments.profiles import read_sweep_runs
    from striatal.experiments.runs_csv import read_runs
    from striatal.io import schema

    schema.read_summary(swept)
    schema.read_sweep_settings(swept / "sweep.json")
    rows, _ = read_runs(swept / "runs.csv", max_trials=3)
    assert len(rows) == len(read_sweep_runs(swept)) == 4
    out = tmp_path / "a"
    r = cli_in_process(
        *("ablation", "--seeds", "2", "--max-trials", "1", "--variants", "chapter,pgpe"),
        *("--no-progress", "--out", str(out)),
    )
    assert r.rc == 0, r.err
    schema.AblationModel.of(json.loads((out / "ablation.json").read_text()), "ablation")
    schema.read_summary(out)


# -- N12: a big history is read into arrays, and drawn with bounded points -------------


def _history_file(path: Path, n: int, every_empty: int = 3) -> Path:
    """A chapter history.csv of ``n`` trials (random gains, some empty cells)."""
    from striatal.learners import RULES
    from striatal.learners.state import history_columns

    columns = history_columns(RULES["chapter"].history_columns)
    x = np.random.default_rng(0).normal(size=(n, 8))
    with path.open("w") as fh:
        fh.write(",".join(columns) + "\n")
        for i in range(n):
            empty = "" if i % every_empty else "0.5"
            gains, sigma = map(repr, x[i, :6].tolist()), repr(abs(float(x[i, 7])))
            cells = [str(i + 1), "-5.0", *gains, "0.6", sigma, empty, "5.0", "0", "0", "0"]
            fh.write(",".join(cells) + "\n")
    return path


def test_n12_reading_a_history_holds_its_numbers_not_its_text(tmp_path: Path) -> None:
    """N12: read_history's peak is its numbers plus a chunk, never the file's text (the
    old reader held the text, then a tuple per row: several times the file)."""
    import tracemalloc

    from striatal.io.rundir import read_history

    path = _history_file(tmp_path / "history.csv", 40_000)
    read_history(path)  # imports and schemas built once, outside the measurement
    tracemalloc.start()
    try:
        history = read_history(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    size = path.stat().st_size
    assert history.data.shape == (40_000, 15)
    assert np.isnan(history.column("min_abs_theta_swingup")[1])
    assert history.data.nbytes <= peak < history.data.nbytes + size / 4, (peak, size)


def test_a_small_file_is_read_into_a_buffer_of_its_size(tmp_path: Path) -> None:
    """Found while measuring N12: read_text asked for a 256 MiB buffer for every file."""
    import tracemalloc

    from striatal.io.files import read_json

    path = tmp_path / "small.json"
    path.write_text(json.dumps({"a": [1.0] * 100}))
    read_json(path)
    tracemalloc.start()
    try:
        read_json(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 2**20, peak


def test_n12_a_bad_cell_names_its_line_and_crlf_lines_are_read(tmp_path: Path) -> None:
    """The rows are allocated from the line ends counted first (CR LF counted once); a bad
    cell in a later chunk still names its line."""
    from striatal.io.rundir import read_history

    path = _history_file(tmp_path / "history.csv", 3000)
    lines = path.read_text().splitlines(keepends=True)
    lines[2500] = lines[2500].replace("-5.0", "abc", 1)
    path.write_text("".join(lines))
    with pytest.raises(DataFileError, match="line 2501: column reward is not a number"):
        read_history(path)
    lines[2500] = lines[2500].replace("abc", "-5.0", 1)
    path.write_text("".join(lines).replace("\n", "\r\n"))
    assert len(read_history(path)) == 3000


def test_n12_curves_draw_a_bounded_number_of_points_with_the_same_extent() -> None:
    """N12: a curve of a million trials is drawn as at most 2 x DRAWN_COLUMNS points, each
    pixel column keeping its lowest and highest value."""
    from striatal.viz.curves import DRAWN_COLUMNS, drawn

    x = np.arange(1.0, 1_000_001.0)
    y = np.sin(x / 5000.0) + np.random.default_rng(1).normal(0, 0.1, x.size)
    dx, dy = drawn(x, y)
    assert len(dx) <= 2 * DRAWN_COLUMNS
    assert dy.min() == y.min() and dy.max() == y.max()
    cut = x <= 500_000
    assert dy[dx <= 500_000].max() == y[cut].max()
    small = np.arange(10.0)
    assert len(drawn(small, small)[0]) == 10


# -- found by this round's own hostile pass --------------------------------------------


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ("learner_vs_control", "success_rate"),
        ("learner_vs_control", "control_success_rate"),
        ("learner_vs_control", "fisher"),
    ],
)
def test_compare_refuses_a_comparison_without_its_rates(
    swept: Path, tmp_path: Path, table: str, field: str
) -> None:
    """A learner-against-control entry of summary.json lacking a rate ended in a
    KeyError traceback: the pairs are held to their schema too."""
    folder = copy_of(swept, tmp_path)
    edit_json(folder / "summary.json", lambda d: d[table][0].pop(field))
    one_line(cli_in_process("compare", str(folder)), f"field {table}.0.{field}")


def test_compare_names_the_summary_of_each_row(swept: Path, tmp_path: Path) -> None:
    """H25: with several summaries, each row of the table names the one it came from."""
    other = copy_of(swept, tmp_path)
    r = cli_in_process("compare", str(swept), str(other))
    assert r.rc == 0, r.err
    header, _, *rows = r.out.split("\n\n")[0].splitlines()
    assert header.startswith("| source | arm |")
    assert {row.split(" | ")[0].removeprefix("| ") for row in rows} == {str(swept), str(other)}
    single = cli_in_process("compare", str(swept))
    assert single.out.startswith("| arm |")


@pytest.mark.skipif(importlib.util.find_spec("ray") is None, reason="needs [cluster]")
@pytest.mark.parametrize("address", ["nonsense:::", "localhost"])
def test_a_ray_address_that_is_refused_writes_nothing(tmp_path: Path, address: str) -> None:
    """H20: an address Ray refuses (not HOST:PORT) wrote sweep.json and runs.csv first."""
    out = tmp_path / "s"
    r = cli_in_process(
        *("sweep", "--backend", "ray", "--address", address, "--connect-timeout", "20"),
        *("--seeds", "1", "--max-trials", "1", "--out", str(out)),
    )
    one_line(r, "cannot connect to the Ray cluster")
    assert not out.exists()


def test_the_network_s_work_is_bounded_before_it_starts() -> None:
    """neural --learn --trials 2147483647 ran without bound: the network's work (trials x
    steps x neurons) is held to the same limit as every command's."""
    from striatal.neural.network import NetworkConfig

    with pytest.raises(ParameterError, match="2,147,483,647 trials x 30,000 steps"):
        NetworkConfig().check_work(30.0, 0.001, 2**31 - 1)
    NetworkConfig().check_work(30.0, 0.001, 20)
    pytest.importorskip("nengo")
    one_line(cli_in_process("neural", "--learn", "--trials", "2147483647"), "would simulate")


def test_a_history_theta_c_outside_its_range_is_one_line(tmp_path: Path) -> None:
    """theta_c = 1e308 in history.csv ended in matplotlib's OverflowError traceback in
    curves: the history schema holds theta_c to (0, pi], as every learner keeps it."""
    path = _history_file(tmp_path / "history.csv", 5)
    lines = path.read_text().splitlines(keepends=True)
    cells = lines[3].split(",")
    cells[8] = "1e308"
    lines[3] = ",".join(cells)
    path.write_text("".join(lines))
    r = cli_in_process("curves", str(path), "--out", str(tmp_path / "c.png"))
    one_line(r, "line 4: column theta_c must be in (0, pi]")
    assert not (tmp_path / "c.png").exists()


def test_curves_draw_gains_too_large_for_an_axis(tmp_path: Path) -> None:
    """W1 alternating +-1e308 (a run without a step bound can reach such gains) ended in
    a LinAlgError traceback; it is drawn at +-1e100, and the figure says so."""
    from striatal.io.rundir import read_history
    from striatal.viz.curves import learning_curves

    path = _history_file(tmp_path / "history.csv", 6)
    lines = path.read_text().splitlines(keepends=True)
    for i in range(1, 7):
        cells = lines[i].split(",")
        cells[2] = "1e308" if i % 2 else "-1e308"
        lines[i] = ",".join(cells)
    path.write_text("".join(lines))
    r = cli_in_process("curves", str(path), "--out", str(tmp_path / "c.png"))
    assert r.rc == 0, r.err
    fig = learning_curves(read_history(path))
    assert "values beyond +-1e+100 drawn at +-1e+100" in fig.texts[0].get_text()


def test_an_animation_s_frames_are_bounded_in_bytes_before_the_run() -> None:
    """animate --width 4096 --height 4096 at 4 801 frames asked for 225 GiB (a process
    without a memory limit would have been killed); refused before the simulation."""
    r = cli_in_process(
        *("animate", "--width", "4096", "--height", "4096", "--fps", "100"),
        *("--speed", "0.125", "--duration", "6", "--out", "x.gif"),
    )
    one_line(r, "4,801 frames of 4096 x 4096 px", "more than 2 GiB")


def test_the_bench_s_work_is_bounded_before_it_times_anything(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The sweeps the bench times (--sweep-seeds up to 10 000: 4.8 * 10**11 steps) are held
    to the work limit before the first timing, like every command's, with the estimate."""
    from striatal.bench.timing import BenchConfig

    monkeypatch.setenv("STRIATAL_MAX_STEPS", str(10**9))
    with pytest.raises(ParameterError, match="sweeps 80,000,000"):
        BenchConfig(sweep_seeds=10_000).check_work()
    BenchConfig(train_max_trials=20).check_work()
    one_line(cli_in_process("bench", "--sweep-seeds", "10000"), "the bench would simulate")


@pytest.mark.parametrize("x0", ["16", "-16", "1e300"])
def test_figure_of_a_run_that_starts_beyond_the_view(tmp_path: Path, x0: str) -> None:
    """Found by tests/test_fuzz.py: `figure --x0 16` (a start beyond the 15-m view, so no
    point inside it) ended in numpy's zero-size-array ValueError traceback."""
    out = tmp_path / "f.png"
    r = cli_in_process("figure", "--duration", "2", "--x0", x0, "--out", str(out))
    assert r.rc == 0 and not r.err.strip(), r.err
    assert out.exists()


@pytest.mark.parametrize("inits", [1, True, [], ["x"], "chapter"])
def test_profile_refuses_summary_settings_of_the_wrong_type(
    swept: Path, tmp_path: Path, inits: Any
) -> None:
    """Found by benchmarks/hostile_files.py: summary.json's settings were any object, and
    `inits: 1` ended in a TypeError traceback in profile's title; they are held to the
    sweep settings' schema (SweepModel)."""
    folder = copy_of(swept, tmp_path)
    edit_json(folder / "summary.json", lambda d: d["settings"].__setitem__("inits", inits))
    r = cli_in_process("profile", str(folder), "--out", str(tmp_path / "p.png"))
    one_line(r, "field settings.inits")
