"""Conventions every command shares (issue 17): help, lists, defaults, --json, progress,
experiment files (--config, --print-config, --from-summary)."""

from __future__ import annotations

import argparse
import json
import math
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import cli_in_process

from striatal.cli import build_parser, config, main, progress
from striatal.cli.ablation import variant_line
from striatal.cli.helpformat import DefaultsHelpFormatter
from striatal.experiments import sweeps
from striatal.learners import default_config

TINY_SWEEP = ["--seeds", "2", "--max-trials", "3", "--duration", "2", "--eval-draws", "0"]


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


COMMANDS = _commands()


def _helps(p: argparse.ArgumentParser) -> list[tuple[argparse.Action, str]]:
    """Each shown action with its help as the formatter prints it."""
    fmt = p._get_formatter()
    return [
        (a, fmt._expand_help(a))
        for a in p._actions
        if not isinstance(a, argparse._HelpAction) and a.help != argparse.SUPPRESS
    ]


# ---- item 1 and 2: help


def test_every_command_is_checked() -> None:
    assert len(COMMANDS) >= 15 and {"sweep", "ablation", "bench", "train"} <= set(COMMANDS)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_help_states_each_default_once_and_never_none(name: str) -> None:
    p = COMMANDS[name]
    text = p.format_help()
    assert "(default: None)" not in text
    assert "NOTES" not in text and "NOTES" not in (p.description or "")
    for action, help_text in _helps(p):
        assert help_text.strip(), f"{name} {action.option_strings or action.dest} has no help"
        said = re.findall(r"\bdefault", help_text, re.IGNORECASE)
        assert len(said) <= 1, f"{name} {action.option_strings}: {help_text!r}"
        assert "(default: False)" not in help_text and "(default: None)" not in help_text


def test_defaults_are_still_stated() -> None:
    """The formatter drops only what says nothing: a real default is printed once."""
    helps = {a.dest: h for a, h in _helps(COMMANDS["sweep"])}
    assert helps["duration"].endswith("(default: 60.0)")
    assert helps["init"].endswith("(default: chapter)")
    assert helps["max_trials"].count("default") == 1 and "2000" in helps["max_trials"]
    bench = {a.dest: h for a, h in _helps(COMMANDS["bench"])}
    assert bench["batch_size"].endswith("(default: 256; --quick: 32)")
    sw = {a.dest: h for a, h in _helps(COMMANDS["switch-figure"])}
    assert sw["inhibition"].endswith("(default: 2.0,5.0,20.0,50.0)")


def test_formatter_rules() -> None:
    p = argparse.ArgumentParser(formatter_class=DefaultsHelpFormatter)
    p.add_argument("--a", default=None, help="unset")
    p.add_argument("--b", default=3, help="three")
    p.add_argument("--c", default=3, help="default 3 already")
    p.add_argument("--d", action="store_true", help="a flag")
    p.add_argument("--e", default="50%", help="percent")
    text = " ".join(p.format_help().split())
    assert "unset --b" in text and "three (default: 3)" in text
    assert "default 3 already --d" in text and "a flag --e" in text
    assert "percent (default: 50%)" in text


def test_the_options_the_issue_names_have_help() -> None:
    for name, dest in (("train", "init_gains"), ("train", "eligibility"), ("sweep", "init")):
        helps = {a.dest: h for a, h in _helps(COMMANDS[name])}
        assert len(helps[dest]) > 20
    helps = {a.dest: h for a, h in _helps(COMMANDS["ablation"])}
    assert "budget" in helps["max_trials"] and "(default: 300)" in helps["max_trials"]


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_default_is_written_one_way(name: str) -> None:
    """Every stated default reads "(default: X)", whoever states it."""
    for action, help_text in _helps(COMMANDS[name]):
        for m in re.finditer(r"\bdefault\b", help_text, re.IGNORECASE):
            assert help_text[m.start() - 1 : m.end() + 1] == "(default:", (
                f"{name} {action.option_strings}: {help_text!r}"
            )


# ---- item 3: one list syntax


def _parse(argv: list[str]) -> argparse.Namespace:
    return build_parser().parse_args(argv)


def test_lists_are_comma_separated(capsys: pytest.CaptureFixture[str]) -> None:
    new = _parse(["sweep", "--init", "chapter,random"])
    assert capsys.readouterr().err == ""
    assert new.init == ("chapter", "random")
    assert _parse(["switch-figure", "--inhibition", "2,5"]).inhibition == (2.0, 5.0)
    a = _parse(["sweep", "--alpha-grid", "0.5,1", "--baselines", "lqr,hand"])
    assert a.alpha_grid == (0.5, 1.0) and a.baselines == ("lqr", "hand")
    assert _parse(["sweep", "--alpha-grid", "-1,2"]).alpha_grid == (-1.0, 2.0)
    assert _parse(["robustness", "f.json", "--variants", "chapter,pgpe"]).variants == (
        "chapter",
        "pgpe",
    )
    assert _parse(["robustness", "f.json"]).variants == ()


@pytest.mark.parametrize(
    "argv",
    [
        ["sweep", "--init", "chapter", "random"],
        ["switch-figure", "--inhibition", "2", "5"],
    ],
)
def test_space_separated_and_repeated_lists_are_refused(
    argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as e:
        _parse(argv)
    err = capsys.readouterr().err.splitlines()
    assert e.value.code == 2 and len(err) == 1 and "unrecognized arguments" in err[0], err


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["sweep", "--init", "chapter,nope"], "invalid choice 'nope'"),
        (["sweep", "--alpha-grid", "1,x"], "'x'"),
        (["sweep", "--alpha-grid", ","], "names nothing"),
        (["switch-figure", "--inhibition", "a"], "'a'"),
    ],
)
def test_bad_lists_are_one_line(
    argv: list[str], says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as e:
        _parse(argv)
    err = capsys.readouterr().err.splitlines()
    assert e.value.code == 2 and len(err) == 1 and says in err[0], err


def test_usage_shows_the_comma_form() -> None:
    usage = COMMANDS["sweep"].format_usage()
    assert "--init {chapter,random}[,...]" in usage and "[INIT ...]" not in usage


# ---- item 4: one default per option


def test_shared_options_have_one_default() -> None:
    for dest in ("seeds", "workers", "backend", "connect_timeout", "address"):
        found = {
            n: a.default
            for n, p in COMMANDS.items()
            for a in p._actions
            # neural without --seeds is one run of --seed: its --seeds has no number
            if a.dest == dest and a.option_strings and (n, dest) != ("neural", "seeds")
        }
        assert len(found) >= 2 and len(set(found.values())) == 1, (dest, found)
    assert sweeps.SEEDS == 100 and config.WORKERS == 1


@pytest.mark.parametrize(
    ("given", "says"),
    [
        (["--backend", "brian2"], "the network's simulator is --simulator brian2"),
        (["--backend=nengo"], "the network's simulator is --simulator nengo"),
        (["--backend", "ray"], "--backend needs --learn --seeds N"),
        (["--backend"], "expected one argument"),
    ],
)
def test_neural_backend_is_the_cluster_backend(tmp_path: Path, given: list[str], says: str) -> None:
    """--backend is the cluster backend (local, ray) of sweep, ablation and neural --learn
    --seeds; a simulator's name gets one line naming --simulator; every refusal is one
    line from the parser or the command, exit 2, no folder made."""
    out_dir = tmp_path / "o"
    code, out, err = cli_in_process("neural", *given, "--chapter-final", "--out", str(out_dir))
    assert code == 2 and out == "" and not out_dir.exists()
    assert err.endswith("\n") and err.count("\n") == 1, err
    assert err.startswith("striatal neural: error: ") and says in err, err
    parser = build_parser(only="neural")
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    shown = sub.choices["neural"].format_help()
    assert "--backend {local,ray}" in shown and "--simulator {nengo,brian2}" in shown


# ---- item 5: --json and progress


def _tiny_sweep(out: Path, *extra: str) -> dict[str, Any]:
    assert main(["sweep", *TINY_SWEEP, "--no-progress", "--out", str(out), *extra]) == 0
    return dict(json.loads((out / "summary.json").read_text())["settings"])


def test_compare_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _tiny_sweep(tmp_path / "s")
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "s"), "--json", "--out", str(tmp_path / "c.json")]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads((tmp_path / "c.json").read_text())
    assert {a["arm"] for a in printed["arms"]} == {"learner", "control"}
    assert all(a["runs"] == 2 for a in printed["arms"])


def test_figure_commands_print_a_json_record(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    fig = tmp_path / "f.png"
    assert main(["figure", "--duration", "3", "--out", str(fig), "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["wrote"] == str(fig) and fig.stat().st_size > 0
    assert rec["snapshots"] == 16 and rec["duration"] == 3.0 and "Figure 5" in rec["caption"]
    sw = tmp_path / "s.png"
    assert main(["switch-figure", "--inhibition", "3,7", "--out", str(sw), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["inhibition"] == [3.0, 7.0]
    gif = tmp_path / "a.gif"
    argv = ["animate", "--duration", "2", "--fps", "5", "--speed", "1", "--width", "64"]
    assert main([*argv, "--height", "32", "--out", str(gif), "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec["wrote"] == str(gif) and rec["frames"] == 11 and gif.stat().st_size > 0
    run = tmp_path / "run"
    assert main(["train", "--max-trials", "2", "--duration", "2", "--out", str(run), "--json"]) == 0
    capsys.readouterr()
    png = tmp_path / "c.png"
    assert main(["curves", str(run / "history.csv"), "--out", str(png), "--json"]) == 0
    rec = json.loads(capsys.readouterr().out)
    assert rec == {
        "wrote": str(png),
        "history": str(run / "history.csv"),
        "trials": 2,
        "window": 50,
    }


def test_ablation_json_and_lines(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["ablation", "--seeds", "2", "--max-trials", "2", "--variants", "chapter,pgpe"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    cap = capsys.readouterr()
    assert cap.out.startswith("| variant |")
    lines = cap.err.splitlines()[-2:]
    assert main([*argv, "--json", "--out", str(tmp_path / "a")]) == 0  # resumed: nothing run
    cap = capsys.readouterr()
    data = json.loads(cap.out)
    assert data == json.loads((tmp_path / "a" / "ablation.json").read_text())
    for line, name in zip(lines, ("chapter", "pgpe"), strict=True):
        won = sum(r["success"] for r in data[name]["runs"])
        assert line.startswith(f"{name}: {won} of 2 runs succeeded")
        assert line.endswith("succeeded") == (won == 0), line  # medians only when solved
    assert list(data) == ["chapter", "pgpe"] and len(data["chapter"]["runs"]) == 2
    assert "{" not in cap.err and "nan" not in cap.err


def test_variant_line_has_no_nan_or_dict() -> None:
    s = {"runs": 10, "successes": 3, "median_trials": 40.0, "p90_trials": 120.5}
    assert variant_line("rpe", s) == (
        "rpe: 3 of 10 runs succeeded; trials to success: median 40, 90th percentile 120.5"
    )
    none = {"runs": 4, "successes": 0, "median_trials": math.nan, "p90_trials": math.nan}
    assert variant_line("chapter", none) == "chapter: 0 of 4 runs succeeded"


def test_progress_shown_only_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    args = argparse.Namespace(no_progress=False, json=False)
    monkeypatch.setattr("sys.stderr.isatty", lambda: True, raising=False)
    assert progress.shown(args)
    assert not progress.shown(argparse.Namespace(no_progress=True, json=False))
    assert not progress.shown(argparse.Namespace(no_progress=False, json=True))
    monkeypatch.setattr("sys.stderr.isatty", lambda: False, raising=False)
    assert not progress.shown(args)
    for name in ("sweep", "ablation", "train", "evaluate", "neural"):
        assert any("--no-progress" in a.option_strings for a in COMMANDS[name]._actions), name


def test_evaluate_progress_does_not_touch_the_draws() -> None:
    from striatal.experiments.evaluate import pass_probability
    from striatal.params import (
        CHAPTER_FINAL_THETA_C,
        CHAPTER_FINAL_W,
        Controller,
        Plant,
        Simulation,
    )
    from striatal.sim.rollout import Protocol

    ctrl = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    seen: list[int] = []
    sim = Simulation(duration=20.0)
    a = pass_probability(Plant(), ctrl, sim, Protocol(), 6, 3, on_draw=seen.append)
    b = pass_probability(Plant(), ctrl, sim, Protocol(), 6, 3)
    assert seen == [1, 2, 3, 4, 5, 6]
    assert a == b


def test_neural_progress_counts_simulated_seconds() -> None:
    pytest.importorskip("nengo")
    from striatal.neural.network import NetworkConfig
    from striatal.neural.run import run_network
    from striatal.params import (
        CHAPTER_FINAL_THETA_C,
        CHAPTER_FINAL_W,
        Controller,
        Plant,
        Simulation,
    )

    ctrl = Controller(CHAPTER_FINAL_W, CHAPTER_FINAL_THETA_C)
    sim = Simulation(duration=2.5)
    cfg = NetworkConfig(neurons=300)
    seen: list[float] = []
    a = run_network(ctrl, Plant(), sim, cfg, 1, record_rates=False, on_progress=seen.append)
    b = run_network(ctrl, Plant(), sim, cfg, 1, record_rates=False)
    assert seen == pytest.approx([1.0, 2.0, 2.5])
    # two unchunked runs of one seed already differ in the last bit (nengo's sums), so the
    # chunked run is compared to that precision, far below any change a step would make
    np.testing.assert_allclose(a.data, b.data, rtol=0, atol=1e-12)
    assert a.success == b.success


# ---- item 6: experiment files


def test_print_config_round_trip(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """print-config -> file -> --config gives the settings of the original command, and so
    does the file printed from the finished sweep's summary.json."""
    extra = ["--init", "chapter,random", "--alpha", "2.5", "--no-normalise", "--learner", "rpe"]
    original = _tiny_sweep(tmp_path / "a", *extra)
    assert original["options"]["init"] == ["chapter", "random"]
    assert original["options"]["normalise"] is False and "out" not in original["options"]
    capsys.readouterr()
    assert main(["sweep", *TINY_SWEEP, *extra, "--print-config"]) == 0
    text = capsys.readouterr().out
    assert not (tmp_path / "b").exists()  # printed, not run
    parsed = tomllib.loads(text)
    assert parsed["seeds"] == 2 and parsed["max-trials"] == 3 and parsed["normalise"] is False
    (tmp_path / "exp.toml").write_text(text)
    assert _tiny_sweep(tmp_path / "b", "--config", str(tmp_path / "exp.toml")) == original
    capsys.readouterr()
    assert main(["sweep", "--print-config", "--from-summary", str(tmp_path / "a")]) == 0
    (tmp_path / "rec.toml").write_text(capsys.readouterr().out)
    assert _tiny_sweep(tmp_path / "c", "--config", str(tmp_path / "rec.toml")) == original
    # and --from-summary alone reruns it
    assert _tiny_sweep(tmp_path / "d", "--from-summary", str(tmp_path / "a")) == original


def test_command_line_wins_over_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "exp.toml"
    f.write_text('seeds = 7\nmax_trials = 11\ninit = ["random"]\nalpha-grid = [0.5, -1]\n')
    assert main(["sweep", "--config", str(f), "--seeds", "3", "--print-config"]) == 0
    got = tomllib.loads(capsys.readouterr().out)
    assert got["seeds"] == 3 and got["max-trials"] == 11
    assert got["init"] == ["random"] and got["alpha-grid"] == [0.5, -1.0]


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("seeds = 2\nfoo = 1\n", "unknown option 'foo'"),
        ("print-config = true\n", "unknown option 'print-config'"),
        ("[plant]\nlength = 2\n", "[plant] is a table"),
        ('seeds = "many"\n', "seeds must be a number, not the text 'many'"),
        ("no-control = 1\n", "no-control must be true or false"),
        ("seeds = true\n", "seeds takes a value"),
        ("seeds = [1, 2]\n", "seeds takes one value"),
        ('init = ["nope"]\n', "invalid choice 'nope'"),
        ("seeds = = 2\n", "is not TOML"),
    ],
)
def test_bad_experiment_files_are_one_line(
    tmp_path: Path, text: str, says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "exp.toml"
    f.write_text(text)
    assert main(["sweep", "--config", str(f), "--out", str(tmp_path / "o")]) == 2
    cap = capsys.readouterr()
    err = cap.err.splitlines()
    assert cap.out == "" and len(err) == 1 and says in err[0], err
    assert err[0].startswith(f"striatal sweep: error: --config {f}")
    assert not (tmp_path / "o").exists()


def test_missing_file_and_wrong_summary(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sweep", "--config", str(tmp_path / "none.toml")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["ablation", "--seeds", "1", "--max-trials", "1", "--variants", "chapter",
                 "--no-progress", "--out", str(tmp_path / "ab")]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["sweep", "--print-config", "--from-summary", str(tmp_path / "ab")]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "'striatal ablation', not striatal sweep" in err[0]
    assert main(["ablation", "--print-config", "--from-summary", str(tmp_path / "ab")]) == 0
    got = tomllib.loads(capsys.readouterr().out)
    assert got["variants"] == ["chapter"] and got["seeds"] == 1 and "out" not in got


def test_toml_writer_reads_back() -> None:
    odd = 'quote " back \\ tab \t new\nline é \x7f ☃'
    args = argparse.Namespace(
        command="sweep", a=odd, b=[1.5, -2.0, math.inf], c=True, d=None, e=Path("x/y"), f=3
    )
    got = tomllib.loads(config.toml_text("sweep", args))
    assert got == {"a": odd, "b": [1.5, -2.0, math.inf], "c": True, "e": "x/y", "f": 3}


def test_resume_compares_what_is_computed_not_how_it_was_asked(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s"
    _tiny_sweep(out)
    spath = out / "sweep.json"
    old = json.loads(spath.read_text())
    del old["options"]
    spath.write_text(json.dumps(old))
    capsys.readouterr()
    assert _tiny_sweep(out)["options"]["seeds"] == 2
    assert "ran 0 runs, 4 already in --out" in capsys.readouterr().out
    # an option given at its default computes the same sweep: it resumes too
    alpha = str(default_config("chapter").alpha)
    assert _tiny_sweep(out, "--alpha", alpha)["options"]["alpha"] == float(alpha)
    assert "ran 0 runs, 4 already in --out" in capsys.readouterr().out
    # other options are still refused
    assert main(["sweep", *TINY_SWEEP, "--seed", "9", "--no-progress", "--out", str(out)]) == 2
    assert "other settings" in capsys.readouterr().err


def test_every_command_has_json() -> None:
    missing = [n for n, p in COMMANDS.items() if "--json" not in p._option_string_actions]
    assert missing == []


def test_no_docstring_or_help_points_at_a_notes_file() -> None:
    """Users have docs/paper-notes.md, not the NOTES file of the sources."""
    src = Path(__file__).resolve().parents[1] / "src" / "striatal"
    said = [str(p) for p in src.rglob("*.py") if "NOTES" in p.read_text(encoding="utf-8")]
    assert said == []


def test_the_sweep_offers_one_baseline_option() -> None:
    """--baselines are the comparison arms; the reward baseline b of eq 1 is
    --reward-baseline, so no command has both --baseline and --baselines."""
    for name, parser in _commands().items():
        flags = {o for a in parser._actions for o in a.option_strings}
        assert "--baseline" not in flags, name
    sweep = _commands()["sweep"]
    flags = {o for a in sweep._actions for o in a.option_strings}
    assert {"--baselines", "--reward-baseline"} <= flags
