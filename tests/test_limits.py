"""Sizes checked before allocation, argparse guards, input-file guards, streamed CSV."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

import numpy as np
import pytest

from striatal.cli import OneLineParser
from striatal.cli.guards import bounded_float, bounded_int
from striatal.errors import DataFileError, ParameterError
from striatal.io.files import (
    MAX_INPUT_BYTES,
    array_rows,
    check_out_dir,
    csv_text,
    read_csv,
    read_json,
    read_text,
    write_csv,
    write_json,
)
from striatal.limits import count_of_steps


@pytest.mark.parametrize(
    ("span", "step"), [(60.0, 0.2), (60.0, 0.25), (10.0, 3.0), (0.0, 1.0), (1.0, 0.1), (7.3, 0.01)]
)
def test_count_is_the_length_of_the_grid(span: float, step: float) -> None:
    """The count equals the length of the array it stands for (0, step, ... <= span)."""
    n = count_of_steps(span, step, cap=10**6, what="points", fix="")
    grid = np.arange(n) * step
    assert grid[-1] <= span + 1e-9 * step
    assert (n * step) > span + 1e-9 * step  # one more point would pass the end


def test_count_at_the_cap_passes_and_above_is_refused() -> None:
    assert count_of_steps(99.0, 1.0, cap=100, what="points", fix="") == 100
    with pytest.raises(ParameterError, match="101 points is more than 100: do less"):
        count_of_steps(100.0, 1.0, cap=100, what="points", fix="do less")


@pytest.mark.parametrize("step", [1e-300, 5e-324, 1e-7])
def test_tiny_steps_are_refused_without_allocating(step: float) -> None:
    with pytest.raises(ParameterError, match="more than 5,000"):
        count_of_steps(60.0, step, cap=5000, what="frames", fix="")


@pytest.mark.parametrize(
    ("span", "step"), [(1.0, 0.0), (1.0, -1.0), (1.0, math.nan), (math.inf, 1.0)]
)
def test_bad_spans_and_steps_are_refused(span: float, step: float) -> None:
    with pytest.raises(ParameterError):
        count_of_steps(span, step, cap=10, what="frames", fix="")


def parser_with_guards() -> argparse.ArgumentParser:
    p = OneLineParser(prog="t")
    p.add_argument("--n", type=bounded_int(1, 4096))
    p.add_argument("--s", type=bounded_float(0.0, 3600.0))
    p.add_argument("--x", type=float)
    return p


@pytest.mark.parametrize(
    "argv",
    [["--n", "0"], ["--n", "100000000"], ["--n", "1.5"], ["--s", "0"], ["--s", "1e308"],
     ["--s", "nan"], ["--s", "inf"], ["--s", "-1"]],
)  # fmt: skip
def test_guards_refuse_at_parsing(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        parser_with_guards().parse_args(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and argv[0] in err


def test_guards_accept_the_range_ends() -> None:
    a = parser_with_guards().parse_args(["--n", "4096", "--s", "3600"])
    assert (a.n, a.s) == (4096, 3600.0)


@pytest.mark.parametrize(
    ("text", "value"), [("-2e-1", -0.2), ("-inf", -math.inf), ("-.5", -0.5), ("-1E+3", -1000.0)]
)
def test_negative_values_parse_as_values(text: str, value: float) -> None:
    assert parser_with_guards().parse_args(["--x", text]).x == value


def test_negative_nan_parses_as_a_value() -> None:
    assert math.isnan(parser_with_guards().parse_args(["--x", "-nan"]).x)


def test_an_unknown_dash_word_is_still_an_option(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        parser_with_guards().parse_args(["--x", "-infinite"])
    assert "expected one argument" in capsys.readouterr().err


# ---- input files


@pytest.mark.parametrize("reader", [read_json, read_csv, read_text])
def test_dev_zero_is_refused_before_reading(reader: object) -> None:
    with pytest.raises(DataFileError, match="not a regular file"):
        reader("/dev/zero")  # type: ignore[operator]


def test_fifo_is_refused_without_waiting(tmp_path: Path) -> None:
    fifo = tmp_path / "result.json"
    os.mkfifo(fifo)
    with pytest.raises(DataFileError, match="not a regular file"):
        read_json(fifo)


def test_folder_and_oversize_are_refused(tmp_path: Path) -> None:
    with pytest.raises(DataFileError, match="is a folder"):
        read_csv(tmp_path)
    big = tmp_path / "big.csv"
    with big.open("wb") as fh:
        fh.truncate(MAX_INPUT_BYTES + 1)
    with pytest.raises(DataFileError, match="larger than 256 MiB"):
        read_csv(big)


def test_a_file_at_the_limit_is_read(tmp_path: Path) -> None:
    p = tmp_path / "a.json"
    p.write_text("[1, 2.5]")
    assert read_json(p) == [1, 2.5]


# ---- outputs


def test_dangling_link_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "missing" / "x")
    for target in (link, link / "sub"):
        with pytest.raises(DataFileError, match="symbolic link"):
            check_out_dir(target)
    with pytest.raises(DataFileError, match="symbolic link"):
        write_json(link / "a.json", {})


def test_writing_onto_a_folder_names_the_target(tmp_path: Path) -> None:
    (tmp_path / "result.json").mkdir()
    with pytest.raises(DataFileError, match=r"cannot write .*result\.json: it is a folder"):
        write_json(tmp_path / "result.json", {})
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]  # no temp file left


def test_streamed_csv_is_the_same_bytes(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    data = rng.standard_normal((10_001, 3))
    data[5, 1] = math.nan
    write_csv(tmp_path / "a.csv", ("a", "b", "c"), array_rows(data, chunk=977))
    text = (tmp_path / "a.csv").read_text()
    assert text == csv_text(("a", "b", "c"), data.tolist())
    assert [float(v) for v in text.splitlines()[1].split(",")] == data[0].tolist()


# ---- start-up


def test_import_striatal_is_light_and_still_registers_the_env() -> None:
    """``import striatal`` loads neither NumPy nor Numba (so Ctrl-C at start-up lands in
    ``main``'s guard), yet Gymnasium imported after it knows the env id, and the
    package's names still resolve."""
    import subprocess
    import sys

    code = (
        "import sys, striatal, striatal.cli; "
        "heavy = sorted(m for m in ('numpy', 'numba', 'gymnasium', 'matplotlib') "
        "if m in sys.modules); "
        "import gymnasium; "
        "print(heavy, 'striatal/CartPoleSwingUp-v0' in gymnasium.envs.registry, "
        "striatal.Plant().length, striatal.sim.kernel.__name__)"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.split() == ["[]", "True", "1.0", "striatal.sim.kernel"]


def test_every_int_option_is_bounded(capsys: pytest.CaptureFixture[str]) -> None:
    """``type=int`` of every parser is cli.guards.whole_number: at most 2**31 - 1."""
    from striatal.cli import build_parser
    from striatal.cli.guards import MAX_WHOLE

    parser = build_parser(only="profile")
    ok = parser.parse_args(["profile", "d", "--dpi", str(MAX_WHOLE)])
    assert ok.dpi == MAX_WHOLE
    for bad, says in ((str(MAX_WHOLE + 1), "at most 2,147,483,647"), ("1.5", "invalid int")):
        with pytest.raises(SystemExit) as exc:
            parser.parse_args(["profile", "d", "--dpi", bad])
        assert exc.value.code == 2
        assert says in capsys.readouterr().err


def test_a_full_disk_names_history_csv(tmp_path: Path) -> None:
    """ENOSPC while history.csv is appended to (buffered writes) names the file."""
    import errno
    from types import SimpleNamespace

    from striatal.io.rundir import RunDir

    def no_space(*_: object) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    full_disk = SimpleNamespace(write=no_space, flush=no_space, close=no_space)
    record = SimpleNamespace(columns=("trial", "reward"), row=lambda: (1, 10.0))
    rundir = RunDir(tmp_path / "run")
    rundir.start_history(["trial", "reward"])
    rundir.close_history()
    says = r"cannot write .*history\.csv: No space left on device"
    rundir._history = full_disk
    with pytest.raises(DataFileError, match=says):
        rundir.append(record)  # type: ignore[arg-type]
    with pytest.raises(DataFileError, match=says):
        rundir.close_history()
    assert rundir._history is None


def test_a_byte_order_mark_is_not_part_of_the_text(tmp_path: Path) -> None:
    from striatal.io.files import read_csv, read_json

    (tmp_path / "a.json").write_bytes(b'\xef\xbb\xbf{"a": 1}')
    (tmp_path / "a.csv").write_bytes(b"\xef\xbb\xbftrial,reward\n1,10\n")
    assert read_json(tmp_path / "a.json") == {"a": 1}
    assert read_csv(tmp_path / "a.csv") == [{"trial": "1", "reward": "10"}]


def _simulate(*argv: str) -> int:
    from striatal.cli import main

    try:
        return main(["simulate", *argv])
    except SystemExit as exc:
        return int(exc.code or 0)


def test_a_full_disk_on_the_second_file_keeps_the_old_pair(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """simulate --out replaces trajectory.csv and summary.json as one set: ENOSPC on the
    second leaves both old files (not a new trajectory beside an old summary)."""
    import errno

    out = tmp_path / "D"
    assert _simulate("--duration", "5", "--out", str(out)) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    real_fsync, calls = os.fsync, []

    def second_fails(fd: int) -> None:
        calls.append(fd)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", second_fails)
    capsys.readouterr()
    assert _simulate("--duration", "6", "--out", str(out)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "summary.json: No space left on device" in err[0], err
    assert len(calls) == 2
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no temp file either
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert _simulate("--duration", "6", "--out", str(out)) == 0
    assert (out / "trajectory.csv").read_bytes() != before["trajectory.csv"]
    assert '"duration": 6.0' in (out / "summary.json").read_text()


def test_stale_temporary_files_are_removed_at_the_next_write(tmp_path: Path) -> None:
    """A temp file whose writer is gone (unlocked) goes at the next write into its folder;
    one of an older striatal's names goes once an hour old; other files stay."""
    import time

    from striatal.io.files import STALE_SECONDS, path_lock

    dead = tmp_path / ".striatal-ab12cd34.tmp"
    dead.write_text("half")
    busy = tmp_path / ".striatal-zz99yy88.tmp"
    busy.write_text("being written")
    old_name = tmp_path / ".trajectory.csv.k2j4h5g6.tmp"
    old_name.write_text("old")
    young_old_name = tmp_path / ".summary.json.a1b2c3d4.tmp"
    young_old_name.write_text("young")
    mine = tmp_path / "notes.tmp"
    mine.write_text("the user's")
    hour_ago = time.time() - STALE_SECONDS - 10
    for p in (old_name, mine):
        os.utime(p, (hour_ago, hour_ago))
    with path_lock(busy):  # its writer's lock, held as a live writer holds it
        write_json(tmp_path / "a.json", {"a": 1})
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted(["a.json", busy.name, young_old_name.name, mine.name])


def test_a_254_character_file_name_is_written(tmp_path: Path) -> None:
    """The temporary name is short: any name the file system takes can be written."""
    name = "r" * 249 + ".json"
    write_json(tmp_path / name, {"a": 1})
    assert read_json(tmp_path / name) == {"a": 1}
    assert [p.name for p in tmp_path.iterdir()] == [name]
