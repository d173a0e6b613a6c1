"""--out of every command: never one of its inputs, never a run's or sweep's file."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from striatal.cli import COMMANDS, command_module, main
from striatal.cli.outputs import RUN_FOLDER_FILES, check_out, same_file
from striatal.errors import ParameterError


def test_same_file_sees_through_links_and_dots(tmp_path: Path) -> None:
    (tmp_path / "a").mkdir()
    f = tmp_path / "a" / "result.json"
    f.write_text("{}")
    (tmp_path / "link.json").symlink_to(f)
    assert same_file(tmp_path / "link.json", f)
    assert same_file(tmp_path / "a" / ".." / "a" / "result.json", f)
    assert not same_file(tmp_path / "a" / "other.json", f)


@pytest.mark.parametrize("name", RUN_FOLDER_FILES)
def test_a_file_out_never_replaces_a_run_file(name: str, tmp_path: Path) -> None:
    (tmp_path / name).write_text("kept\n")
    args = argparse.Namespace(out=tmp_path / name, files=[])
    with pytest.raises(ParameterError, match=f"replace the {name}"):
        check_out(args, None)
    check_out(argparse.Namespace(out=tmp_path / "new" / name), None)  # not there: allowed
    assert (tmp_path / name).read_text() == "kept\n"


def test_a_folder_out_is_checked_by_the_files_written_there(tmp_path: Path) -> None:
    result = tmp_path / "summary.json"
    result.write_text("{}")
    args = argparse.Namespace(out=tmp_path, result=result)
    with pytest.raises(ParameterError, match="overwrite the input"):
        check_out(args, ("trajectory.csv", "summary.json"))
    check_out(args, ("trajectory.csv",))  # writes beside the input: allowed


def test_every_folder_command_names_its_files() -> None:
    """A command whose --out is a folder states OUT_FILES (else --out is taken as a file)."""
    folders = {"simulate", "train", "sweep", "ablation", "neural"}
    for name in COMMANDS:
        mod = command_module(name)
        assert (getattr(mod, "OUT_FILES", None) is not None) == (name in folders), name


def test_robustness_out_over_its_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    run = tmp_path / "R"
    assert main(["train", "--max-trials", "2", "--duration", "5", "--out", str(run)]) == 0
    before = (run / "result.json").read_bytes()
    link = tmp_path / "r.json"
    link.symlink_to(run / "result.json")
    capsys.readouterr()
    argv = ["robustness", str(link), "--repeats", "1", "--out", str(run / "result.json")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "overwrite the input" in err
    assert (run / "result.json").read_bytes() == before


def test_a_folder_out_never_replaces_another_kind_of_run(tmp_path: Path) -> None:
    """simulate into a sweep's folder would replace its summary.json: refused; into a
    training run's folder (nothing of it replaced), or again into its own, allowed."""
    sweep, run = tmp_path / "W", tmp_path / "R"
    for name in ("sweep.json", "runs.csv", "summary.json"):
        (sweep / name).parent.mkdir(exist_ok=True)
        (sweep / name).write_text("{}")
    for name in ("checkpoint.json", "result.json", "history.csv", "summary.json"):
        (run / name).parent.mkdir(exist_ok=True)
        (run / name).write_text("{}")
    simulate = ("trajectory.csv", "summary.json")
    with pytest.raises(ParameterError, match=r"holds a sweep: its summary\.json"):
        check_out(argparse.Namespace(out=sweep), simulate)
    check_out(argparse.Namespace(out=run), simulate)
    check_out(argparse.Namespace(out=sweep), ("sweep.json", "runs.csv", "summary.json"))
    check_out(argparse.Namespace(out=run), ("checkpoint.json", "result.json", "history.csv"))
