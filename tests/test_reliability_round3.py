"""Reliability, round 3: options given at their default, outputs over inputs, typed files.

Each scenario tries one thing a user can do and records what happened, with the
machinery of tests/test_reliability.py; this module checks them and the "round3"
table of docs/reliability.md (regenerate with
``STRIATAL_WRITE_RELIABILITY=1 pytest tests/test_reliability_round3.py``).
"""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import cli_in_process
from test_reliability import (
    Scenario,
    check_doc_section,
    library_error,
    outcome,
    params_of,
    snapshot,
    usage_error,
)

from striatal.errors import ParameterError
from striatal.experiments.training import simulate, train
from striatal.sim.robust import check_robust

#: A short training run (2 s of trials) whose folder the scenarios below start from.
SHORT = ("--duration", "5", "--max-trials", "3", "--no-progress")


def _trained(*extra: str) -> Callable[[Path], None]:
    """OUT holds a finished ``striatal train`` run of SHORT with ``extra`` options."""

    def prepare(out: Path) -> None:
        r = cli_in_process("train", *SHORT, *extra, "--out", str(out))
        assert r.rc == 0, r.err

    return prepare


def _edited(prepare: Callable[[Path], None], name: str, change: Callable[[dict[str, Any]], None]):
    """``prepare``, then the JSON file OUT/``name`` loaded, changed and saved."""

    def run(out: Path) -> None:
        prepare(out)
        path = out / name
        data = json.loads(path.read_text())
        change(data)
        path.write_text(json.dumps(data))

    return run


#: A small sweep (2 seeds, 3 trials of 5 s, the learner and its control).
SWEEP = ("sweep", "--seeds", "2", "--max-trials", "3", "--duration", "5", "--eval-draws", "0",
         "--no-progress")  # fmt: skip


def _swept(out: Path) -> None:
    r = cli_in_process(*SWEEP, "--out", str(out))
    assert r.rc == 0, r.err


def _config_fifo(out: Path) -> None:
    out.mkdir(parents=True)
    os.mkfifo(out / "exp.toml")


def _config_huge(out: Path) -> None:
    """A sparse 300 MB experiment file: refused by its size, never read."""
    out.mkdir(parents=True)
    with (out / "exp.toml").open("wb") as fh:
        fh.truncate(300 * 10**6)


def _config_entry(name: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def change(d: dict[str, Any]) -> None:
        d["settings"]["config"][name] = value

    return change


def _checkpoint_with(name: str, value: Any) -> Callable[[Path], None]:
    """A checkpointed run in OUT whose settings.config[name] is ``value``."""
    return _edited(_trained(), "checkpoint.json", _config_entry(name, value))


def _settings_entry(name: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def change(d: dict[str, Any]) -> None:
        if value is None:
            del d["settings"][name]
        else:
            d["settings"][name] = value

    return change


def bom_history(tmp: Path) -> tuple[bool, str]:
    """history.csv with a UTF-8 byte-order mark first (as some editors save it) reads."""
    out = tmp / "OUT"
    _trained()(out)
    history = out / "history.csv"
    history.write_bytes(b"\xef\xbb\xbf" + history.read_bytes())
    r = cli_in_process("curves", str(history), "--out", str(out / "c.png"))
    line = r.out.strip().replace(str(out), "OUT") or r.err.strip()
    return r.rc == 0 and (out / "c.png").exists(), f"exit {r.rc}: `{line}`"


def full_disk(*argv: str, names: str) -> Callable[[Path], tuple[bool, str]]:
    """``striatal ARGV`` with every fsync failing as on a full disk (ENOSPC)."""

    def run(tmp: Path) -> tuple[bool, str]:
        out = tmp / "OUT"

        def no_space(fd: int) -> None:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        words = [a.replace("OUT", str(out)) for a in argv]
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(os, "fsync", no_space)
            r = cli_in_process(*words)
        lines = r.err.strip().splitlines()
        line = (lines[-1] if lines else "").replace(str(out), "OUT")
        hidden = [p.name for p in out.rglob(".*.tmp")] if out.exists() else []
        ok = r.rc == 2 and len(lines) == 1 and names in line and not hidden
        return ok, f"exit {r.rc}, {len(lines)} line: `{line}`; temporary files left: {len(hidden)}"

    return run


def _swept_then_removed(*names: str) -> Callable[[Path], None]:
    """OUT holds the sweep of SWEEP, less the files ``names``."""

    def prepare(out: Path) -> None:
        _swept(out)
        for name in names:
            (out / name).unlink()

    return prepare


def enospc_second_file(tmp: Path) -> tuple[bool, str]:
    """``simulate --out OUT`` over an earlier one, the second file's fsync failing (ENOSPC)."""
    out = tmp / "OUT"
    assert cli_in_process("simulate", "--duration", "5", "--out", str(out)).rc == 0
    before = snapshot(out)
    real_fsync, calls = os.fsync, []

    def second_fails(fd: int) -> None:
        calls.append(fd)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(os, "fsync", second_fails)
        r = cli_in_process("simulate", "--duration", "6", "--out", str(out))
    after = snapshot(out)
    lines = r.err.strip().splitlines()
    line = (lines[-1] if lines else "").replace(str(out), "OUT")
    new = [n for n in before if after.get(n) != before[n]]
    state = "both old" if after == before else f"new {', '.join(new) or 'files'} beside old"
    ok = r.rc == 2 and len(lines) == 1 and after == before
    return ok, f"exit {r.rc}, {len(lines)} line: `{line}`; the pair: {state}"


def sigterm_during_write(tmp: Path) -> tuple[bool, str]:
    """SIGTERM while ``simulate --duration 20000 --out OUT`` writes its 2,000,000 rows."""
    out = tmp / "OUT"
    proc = subprocess.Popen(
        [sys.executable, "-m", "striatal", "simulate", "--duration", "20000", "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while not list(out.glob(".*.tmp")) and time.monotonic() < deadline:
            time.sleep(0.05)
        writing = bool(list(out.glob(".*.tmp")))
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=60)
    finally:
        proc.kill()
        proc.wait()
    left = list(out.glob(".*.tmp"))
    ok = writing and rc == -signal.SIGTERM and not left
    ended = "by SIGTERM" if rc == -signal.SIGTERM else f"with {rc}"
    during = "yes" if writing else "no"
    return ok, f"ended {ended} while writing: {during}; temporary files left: {len(left)}"


def stale_temps(tmp: Path) -> tuple[bool, str]:
    """OUT holds what killed writers left: an unlocked ``.striatal-*.tmp`` and an older
    striatal's ``.trajectory.csv.XXXXXXXX.tmp`` of two hours ago; then ``simulate --out OUT``."""
    out = tmp / "OUT"
    out.mkdir(parents=True)
    (out / ".striatal-ab12cd34.tmp").write_text("half a file")
    old = out / ".trajectory.csv.k2j4h5g6.tmp"
    old.write_text("half a file")
    two_hours_ago = time.time() - 7200
    os.utime(old, (two_hours_ago, two_hours_ago))
    r = cli_in_process("simulate", "--duration", "5", "--out", str(out))
    left = sorted(p.name for p in out.glob(".*.tmp"))
    return r.rc == 0 and not left, f"exit {r.rc}; temporary files left: {left or 'none'}"


#: A file name of 254 bytes (the most is 255): with the temporary prefix and suffix
#: around it, the old temporary name was longer than that.
LONG_NAME = "c" * 250 + ".png"


def long_file_name(tmp: Path) -> tuple[bool, str]:
    out = tmp / "OUT"
    _trained()(out)
    r = cli_in_process("curves", str(out / "history.csv"), "--out", str(out / LONG_NAME))
    line = (r.err.strip().splitlines() or [""])[-1].replace(str(out), "OUT")
    line = line.replace(LONG_NAME, "c...c.png")
    written = (out / LONG_NAME).exists()
    said = f", `{line}`" if line else ""
    return r.rc == 0 and written, f"exit {r.rc}{said}; written: {'yes' if written else 'no'}"


def small_address_space(tmp: Path) -> tuple[bool, str]:
    """``prlimit --as=300000000 striatal train ...``: Numba's LLVM library cannot map.
    Which library runs out first (a MemoryError in Python, or libllvmlite's segment)
    varies with the machine's state, so the line is shown with the library's name as
    LIBRARY."""
    import shutil
    import subprocess
    import sys

    if shutil.which("prlimit") is None:
        return True, "prlimit not installed: not tried"
    out = tmp / "OUT"
    argv = [sys.executable, "-m", "striatal", "train", "--max-trials", "2", "--duration", "5"]
    r = subprocess.run(
        ["prlimit", "--as=300000000", *argv, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    lines = r.stderr.strip().splitlines()
    ok = r.returncode == 2 and len(lines) == 1 and "out of memory" in r.stderr
    ok = ok and "Traceback" not in r.stderr and not out.exists()
    last = re.sub(r"while loading [^:]+:", "while loading LIBRARY:", lines[-1] if lines else "")
    return ok, f"exit {r.returncode}, {len(lines)} line(s): `{last}`"


def _env(**kw: Any) -> Any:
    """A scalar swing-up env, reset with seed 0."""
    from striatal.envs import CartPoleSwingUpEnv

    env = CartPoleSwingUpEnv(**kw)
    env.reset(seed=0)
    return env


def env_error(make: Callable[[Any], object]) -> Callable[[Path], tuple[bool, str]]:
    """ParameterError naming the action space, from ``make(env)``; addresses blanked."""
    check = library_error(lambda _: make(_env()), ParameterError)

    def run(tmp: Path) -> tuple[bool, str]:
        ok, observed = check(tmp)
        return ok and "action space Box(" in observed, re.sub(r" at 0x[0-9a-f]+", "", observed)

    return run


def numpy_seed(tmp: Path) -> tuple[bool, str]:
    """The vector env's reset(seed=np.int64(3)) seeds as seed=3 (and a list of numpy ints)."""
    from striatal.envs import CartPoleSwingUpVectorEnv

    vec = CartPoleSwingUpVectorEnv(num_envs=3, perturbation=0.05)
    want, _ = vec.reset(seed=3)
    try:
        got, _ = vec.reset(seed=np.int64(3))
        listed, _ = vec.reset(seed=[np.int64(3), np.int32(4), 5])
    except Exception as exc:
        return False, f"`{type(exc).__name__}: {exc}`"
    same = np.array_equal(got, want) and np.array_equal(listed, want)
    return same, "the same start states as seed=3" if same else "other start states"


def step_after_end(tmp: Path) -> tuple[bool, str]:
    """Steps after truncation: one warning, then the terminal step again with reward 0."""
    env = _env(duration=0.05)
    done = False
    while not done:
        obs, _, terminated, truncated, _ = env.step(np.zeros(1))
        done = terminated or truncated
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        again = [env.step(np.zeros(1)) for _ in range(3)]
    rewards = [float(a[1]) for a in again]
    same = all(np.array_equal(a[0], obs) and a[3] for a in again)
    ok = len(caught) == 1 and rewards == [0.0] * 3 and same
    said = str(caught[0].message).split("WARN: ")[-1].split(";")[0] if caught else ""
    return ok, (
        f"{len(caught)} warning (`{said}`); rewards {rewards}, truncated, "
        f"{'the same observation' if same else 'observations differ'}"
    )


def profile_inits(tmp: Path) -> tuple[bool, str]:
    out = tmp / "P"
    r = cli_in_process(*SWEEP, "--init", "chapter,random", "--out", str(out))
    assert r.rc == 0, r.err
    r = cli_in_process("profile", str(out), "--json", "--out", str(out / "p.png"))
    if r.rc != 0:
        return False, f"exit {r.rc}: `{r.err.strip()}`"
    curves = json.loads(r.out)["profiles"]
    seen = [f"{p['label']} ({p['runs']} runs)" for p in curves]
    return len(curves) == 4 and all(p["runs"] == 2 for p in curves), "; ".join(seen)


S = Scenario
ROUND3: tuple[Scenario, ...] = (
    S("resume-at-default", "runs", "`striatal train --seed 4 --duration 5 --max-trials 3 --out "
      "DIR`, then `--resume --out DIR --seed 0 --duration 60 --max-trials 4` (options given at "
      "their default value)", "exit 2, one line naming --seed and --duration; files untouched",
      usage_error(("train", "--resume", "--out", "OUT", "--seed", "0", "--duration", "60",
                   "--max-trials", "4", "--no-progress"), prepare=_trained("--seed", "4"),
                  says="--seed (the run has 4), --duration (the run has 5.0)")),
    S("out-over-input", "bad file", "`striatal robustness R/result.json --repeats 1 --out "
      "R/result.json`", "exit 2, one line; result.json untouched (it was replaced by the table)",
      usage_error(("robustness", "OUT/result.json", "--repeats", "1", "--out", "OUT/result.json"),
                  prepare=_trained(), says="would overwrite the input")),
    S("out-over-run-file", "bad file", "`striatal compare W --out W/summary.json`, W a sweep "
      "folder (the same for result.json, checkpoint.json, history.csv, sweep.json, runs.csv)",
      "exit 2, one line; the sweep untouched",
      usage_error(("compare", "OUT", "--out", "OUT/summary.json"), prepare=_swept,
                  says="would replace the summary.json of a run or sweep")),
    S("out-folder-over-sweep", "bad file", "`striatal simulate --duration 5 --out W`, W a sweep "
      "folder (simulate writes a summary.json too)", "exit 2, one line; the sweep untouched",
      usage_error(("simulate", "--duration", "5", "--out", "OUT"), prepare=_swept,
                  says="holds a sweep: its summary.json would be replaced")),
    S("config-fifo", "bad file", "`striatal sweep --config FIFO` (no writer: a read would wait "
      "for ever)", "exit 2, one line, no hang",
      usage_error(("sweep", "--config", "OUT/exp.toml", "--out", "OUT/w"), process=True,
                  prepare=_config_fifo, says="not a regular file")),
    S("config-dev-zero", "bad file", "`striatal ablation --config /dev/zero`",
      "exit 2, one line, nothing read",
      usage_error(("ablation", "--config", "/dev/zero", "--out", "OUT"),
                  says="not a regular file")),
    S("config-huge", "bad file", "`striatal sweep --config FILE`, FILE 300 MB",
      "exit 2, one line, nothing read",
      usage_error(("sweep", "--config", "OUT/exp.toml", "--out", "OUT/w"), prepare=_config_huge,
                  says="larger than 1 MiB")),
    S("result-w-text", "bad file", "`striatal simulate --result result.json` whose `\"W\"` is "
      "`\"123456\"` (was read as the gains 1..6)", "exit 2, one line naming W",
      usage_error(("simulate", "--result", "OUT/result.json", "--duration", "5"),
                  prepare=_edited(_trained(), "result.json", lambda d: d.update(W="123456")),
                  says="field W: input should be a valid list")),
    S("result-w-text-figure", "bad file", "`striatal figure --result result.json`, W as above",
      "exit 2, one line naming W",
      usage_error(("figure", "--result", "OUT/result.json", "--out", "OUT/f.png"),
                  prepare=_edited(_trained(), "result.json", lambda d: d.update(W="123456")),
                  says="field W: input should be a valid list")),
    S("result-theta-c-text", "bad file", "`striatal evaluate --result result.json` whose "
      "`\"theta_c\"` is `\"0.6\"`", "exit 2, one line naming theta_c",
      usage_error(("evaluate", "--result", "OUT/result.json"),
                  prepare=_edited(_trained(), "result.json", lambda d: d.update(theta_c="0.6")),
                  says="field theta_c: input should be a valid number")),
    S("result-w-bool", "bad file", "`striatal interpret --result result.json` whose `\"W\"` holds "
      "`true`", "exit 2, one line naming W",
      usage_error(("interpret", "--result", "OUT/result.json"),
                  prepare=_edited(_trained(), "result.json",
                                  lambda d: d["W"].__setitem__(0, True)),
                  says="field W.0: input should be a valid number")),
    S("resume-gamma-text", "bad file", "`striatal train --resume`, checkpoint `\"gamma\": "
      "\"0.9\"` (was an 82-line Numba TypingError)", "exit 2, one line naming gamma",
      usage_error(("train", "--resume", "--out", "OUT", "--no-progress"),
                  prepare=_checkpoint_with("gamma", "0.9"), says="gamma must be a number")),
    S("resume-alpha-text", "bad file", "`striatal train --resume`, checkpoint `\"alpha\": "
      "\"5\"`", "exit 2, one line naming alpha",
      usage_error(("train", "--resume", "--out", "OUT", "--no-progress"),
                  prepare=_checkpoint_with("alpha", "5"), says="alpha must be a number")),
    S("resume-max-step-text", "bad file", "`striatal train --resume`, checkpoint "
      "`\"max_step\": \"1\"`", "exit 2, one line naming max_step",
      usage_error(("train", "--resume", "--out", "OUT", "--no-progress"),
                  prepare=_checkpoint_with("max_step", "1"), says="max_step must be a number")),
    S("resume-count-float", "bad file", "`striatal train --resume`, checkpoint "
      "`\"action_every\": 1.0`", "exit 2, one line naming action_every",
      usage_error(("train", "--resume", "--out", "OUT", "--no-progress"),
                  prepare=_checkpoint_with("action_every", 1.0), says="action_every must be")),
    S("resume-rate-bool", "bad file", "`striatal train --resume`, checkpoint "
      "`\"alpha\": true`", "exit 2, one line naming alpha",
      usage_error(("train", "--resume", "--out", "OUT", "--no-progress"),
                  prepare=_checkpoint_with("alpha", True), says="alpha must be a number")),
    S("api-gamma-text", "bad input", "`striatal.train(gamma=\"0.9\")`",
      "ParameterError naming gamma",
      library_error(lambda _: train(gamma="0.9", max_trials=1), ParameterError)),
    S("api-explore-text", "bad input", "`striatal.train(learner=\"pgpe\", explore=\"1\")`",
      "ParameterError naming explore",
      library_error(lambda _: train(learner="pgpe", explore="1", max_trials=1), ParameterError)),
    S("resume-plant-text", "bad file", "`striatal train --resume --length 2`, checkpoint "
      "`\"plant\": \"x\"`", "exit 2, one line naming the plant",
      usage_error(("train", "--resume", "--out", "OUT", "--length", "2", "--no-progress"),
                  prepare=_edited(_trained(), "checkpoint.json", _settings_entry("plant", "x")),
                  says="settings.plant is not an object")),
    S("resume-plant-gone", "bad file", "`striatal train --resume --length 2`, checkpoint "
      "without `\"plant\"`", "exit 2, one line naming the plant",
      usage_error(("train", "--resume", "--out", "OUT", "--length", "2", "--no-progress"),
                  prepare=_edited(_trained(), "checkpoint.json", _settings_entry("plant", None)),
                  says="lack 'plant'")),
    S("resume-trial-list", "bad file", "`striatal train --resume --duration 5`, checkpoint "
      "`\"trial\": [1, 2]`", "exit 2, one line naming the trial",
      usage_error(("train", "--resume", "--out", "OUT", "--duration", "5", "--no-progress"),
                  prepare=_edited(_trained(), "checkpoint.json", _settings_entry("trial", [1, 2])),
                  says="settings.trial is not an object")),
    S("int-huge", "bad input", "`striatal train --max-trials 2 --duration 5 --action-every "
      "100000000000000000000` (was Numba's \"Int value is too large\")",
      "exit 2, one line naming --action-every",
      usage_error(("train", "--max-trials", "2", "--duration", "5", "--action-every",
                   "100000000000000000000", "--out", "OUT"), says="argument --action-every")),
    S("int-huge-any", "bad input", "`striatal curves history.csv --window 2147483648` (every "
      "whole-number option of every command)", "exit 2, one line naming --window",
      usage_error(("curves", "OUT/history.csv", "--window", "2147483648", "--out", "OUT/c.png"),
                  prepare=_trained(), says="argument --window")),
    S("api-int-huge", "bad input", "`striatal.train(action_every=10**20)`",
      "ParameterError naming action_every",
      library_error(lambda _: train(action_every=10**20, max_trials=1), ParameterError)),
    S("seeds-billion", "bad input", "`striatal sweep --seeds 1000000000` (memory grew while the "
      "seed sequences were spawned)", "exit 2, one line naming --seeds, at once",
      usage_error(("sweep", "--seeds", "1000000000", "--out", "OUT"),
                  says="--seeds: must be a whole number in [1, 100,000]")),
    S("seeds-overflow", "bad input", "`striatal ablation --seeds 10**30` (was an OverflowError)",
      "exit 2, one line naming --seeds",
      usage_error(("ablation", "--seeds", str(10**30), "--out", "OUT"), says="argument --seeds")),
    S("workers-many", "bad input", "`striatal sweep --seeds 2 --workers 1000` (forked 1000 "
      "workers for 4 runs)", "exit 2, one line naming --workers",
      usage_error(("sweep", "--seeds", "2", "--workers", "1000", "--out", "OUT"),
                  says="--workers must be")),
    S("learner-dict-curves", "bad file", "`striatal curves R/history.csv --out c.png`, R's "
      "result.json with `settings.learner = {\"a\": 1}` (was TypeError: unhashable dict)",
      "exit 2, one line naming the learner",
      usage_error(("curves", "OUT/history.csv", "--out", "OUT/c.png"),
                  prepare=_edited(_trained(), "result.json",
                                  _settings_entry("learner", {"a": 1})),
                  says="its settings: field learner: input should be a valid string")),
    S("learner-dict-interpret", "bad file", "`striatal interpret --result R/result.json`, the same",
      "exit 2, one line naming the learner",
      usage_error(("interpret", "--result", "OUT/result.json"),
                  prepare=_edited(_trained(), "result.json",
                                  _settings_entry("learner", {"a": 1})),
                  says="field settings.learner: input should be a valid string")),
    S("api-action-every-0", "bad input", "`striatal.simulate(action_every=0)` (was "
      "ZeroDivisionError)", "ParameterError naming action_every",
      library_error(lambda _: simulate(action_every=0), ParameterError)),
    S("api-simulate-plant", "bad input", "`striatal.simulate(plant=\"x\")`",
      "ParameterError naming plant", library_error(lambda _: simulate(plant="x"), ParameterError)),
    S("api-train-plant", "bad input", "`striatal.train(plant=\"heavy\")` (was TypeError from "
      "asdict)", "ParameterError naming plant",
      library_error(lambda _: train(plant="heavy", max_trials=1), ParameterError)),
    S("api-train-sim", "bad input", "`striatal.train(sim={})` (was taken for the default)",
      "ParameterError naming sim",
      library_error(lambda _: train(sim={}, max_trials=1), ParameterError)),
    S("api-train-learner", "bad input", "`striatal.train(learner=5)` (was AttributeError)",
      "ParameterError naming learner",
      library_error(lambda _: train(learner=5, max_trials=1), ParameterError)),
    S("api-train-out", "bad input", "`striatal.train(out=5)` (was TypeError)",
      "ParameterError naming out",
      library_error(lambda _: train(out=5, max_trials=1), ParameterError)),
    S("api-normalise-text", "bad input", "`striatal.train(learner=\"rpe\", normalise=\"false\")`",
      "ParameterError naming normalise",
      library_error(lambda _: train(learner="rpe", normalise="false", max_trials=1),
                    ParameterError)),
    S("api-max-trials-bool", "bad input", "`striatal.train(max_trials=True)` (was one trial)",
      "ParameterError naming max_trials",
      library_error(lambda _: train(max_trials=True), ParameterError)),
    S("api-check-robust", "bad input", "`striatal.check_robust(\"x\")` (was AttributeError)",
      "ParameterError naming the controller",
      library_error(lambda _: check_robust("x"), ParameterError)),
    S("connect-timeout-inf", "bad input", "`striatal sweep --backend ray --address "
      "127.0.0.1:1 --connect-timeout inf`", "exit 2, one line saying finite",
      usage_error(("sweep", "--backend", "ray", "--address", "127.0.0.1:1", "--connect-timeout",
                   "inf", "--seeds", "1", "--out", "OUT"),
                  says="--connect-timeout: must be a finite number")),
    S("history-bom", "bad file", "`striatal curves history.csv`, the file starting with a UTF-8 "
      "byte-order mark", "read as without it", bom_history),
    S("enospc-simulate", "bad file", "`striatal simulate --duration 5 --out DIR` on a full disk "
      "(every fsync fails with ENOSPC)", "exit 2, one line naming the file",
      full_disk("simulate", "--duration", "5", "--out", "OUT", names="OUT/trajectory.csv")),
    S("enospc-train", "bad file", "`striatal train --max-trials 2 --duration 5 --out DIR` on "
      "the same full disk", "exit 2, one line naming the file",
      full_disk("train", "--max-trials", "2", "--duration", "5", "--out", "OUT",
                names="OUT/history.csv")),
    S("sweep-rows-other-settings", "runs", "`striatal sweep --seeds 2 --max-trials 3 "
      "--duration 5 --eval-draws 0 --out W`, `rm W/sweep.json W/summary.json`, then the same "
      "with `--alpha 3` (was \"ran 0 runs, 4 already in --out\": the rows of alpha 5)",
      "exit 2, one line: W holds rows of other settings; nothing written",
      usage_error((*SWEEP, "--alpha", "3", "--out", "OUT"),
                  prepare=_swept_then_removed("sweep.json", "summary.json"),
                  says="holds rows of other settings")),
    S("sweep-eval-draws-changed", "runs", "the sweep W above, then the same with "
      "`--eval-draws 5` (the refusal named no option)", "exit 2, one line naming eval_draws",
      usage_error((*SWEEP, "--eval-draws", "5", "--out", "OUT"), prepare=_swept,
                  says="other settings (eval_draws)")),
    S("enospc-file-pair", "bad file", "`striatal simulate --duration 6 --out D` over an "
      "earlier run in D, the disk full at the second file (summary.json's fsync fails)",
      "exit 2, one line; D keeps both old files (was a new trajectory.csv beside the old "
      "summary.json)", enospc_second_file),
    S("sigterm-temp-file", "runs", "SIGTERM while `striatal simulate --duration 20000 --out D` "
      "writes trajectory.csv (left D/.trajectory.csv.XXXXXXXX.tmp for ever)",
      "the process ends by SIGTERM, no temporary file left", sigterm_during_write),
    S("stale-temp-files", "runs", "`striatal simulate --duration 5 --out D`, D holding the "
      "temporary files of killed writers (an unlocked `.striatal-XXXXXXXX.tmp`, an older "
      "striatal's `.trajectory.csv.XXXXXXXX.tmp` two hours old)", "both removed",
      stale_temps),
    S("file-name-254", "runs", "`striatal curves R/history.csv --out R/c...c.png`, a legal "
      "254-character name (failed after the figure was drawn: the temporary name was too "
      "long)", "exit 0, the figure written", long_file_name),
    S("address-space", "resource", "`prlimit --as=300000000 striatal train --max-trials 2 "
      "--duration 5 --out OUT` (was an 86-line double traceback from llvmlite)",
      "exit 2, one line saying memory ran out; nothing written", small_address_space),
    S("ray-refused-writes-nothing", "bad input", "`striatal sweep --backend ray --address "
      "127.0.0.1:1 --connect-timeout 1 --out OUT` (sweep.json and runs.csv were written "
      "before the refusal)", "exit 2, one line; nothing written",
      usage_error(("sweep", "--seeds", "1", "--max-trials", "1", "--duration", "5",
                   "--backend", "ray", "--address", "127.0.0.1:1", "--connect-timeout", "1",
                   "--out", "OUT"), says="no Ray cluster answers")),
    S("list-too-long", "bad input", "`striatal sweep --alpha-grid 1,1,...` with 1 001 values "
      "(a list option took any length)", "exit 2, one line naming --alpha-grid; nothing "
      "written", usage_error(("sweep", "--seeds", "1", "--alpha-grid", ",".join(["1"] * 1001),
                              "--out", "OUT"), says="at most 1,000 comma-separated values")),
    S("sweep-runs-bounded", "bad input", "`striatal sweep --seeds 100000 --alpha-grid "
      "1,...,11` (1.2 million run specs built before the first ran)", "exit 2, one line "
      "naming the number of runs; nothing written",
      usage_error(("sweep", "--seeds", "100000", "--alpha-grid", "1,2,3,4,5,6,7,8,9,10,11",
                   "--out", "OUT"), says="at most 1000000")),
    S("print-config-not-utf8", "bad input", "`striatal sweep --print-config --out "
      "$'/tmp/x\\xffy'` (printed a TOML file that --config could not read back)",
      "exit 2, one line naming --out; nothing printed",
      usage_error(("sweep", "--print-config", "--out", "OUT" + "\udcff"), says="--out")),
    S("gym-action-text", "bad input", "`env.step(\"abc\")` on the Gymnasium env (was "
      "numpy's \"could not convert string to float\")",
      "ParameterError (a ValueError) naming the action and the action space",
      env_error(lambda env: env.step("abc"))),
    S("gym-action-object", "bad input", "`env.step(object())` (was a TypeError from float())",
      "ParameterError naming the action and the action space",
      env_error(lambda env: env.step(object()))),
    S("gym-action-complex", "bad input", "`env.step(np.array([1+2j]))` (the imaginary part "
      "was dropped with a ComplexWarning)", "ParameterError: a real number",
      env_error(lambda env: env.step(np.array([1 + 2j])))),
    S("gym-vec-numpy-seed", "bad input", "`CartPoleSwingUpVectorEnv(num_envs=3).reset(seed="
      "np.int64(3))` and `seed=[np.int64(3), np.int32(4), 5]` (was \"not iterable\")",
      "accepted, as seed=3", numpy_seed),
    S("gym-step-after-end", "bad input", "`env.step(a)` three times after the episode "
      "returned truncated = True, without reset (was reward -5 each step, no warning)",
      "one gymnasium warning; the terminal step again, reward 0", step_after_end),
    S("gym-num-envs-huge", "bad input", "`gymnasium.make_vec(\"striatal/CartPoleSwingUp-v0\", "
      "num_envs=10**8, vectorization_mode=\"vector_entry_point\")` (was MemoryError)",
      "ParameterError naming num_envs, nothing allocated",
      library_error(lambda _: __import__("gymnasium").make_vec(
          "striatal/CartPoleSwingUp-v0", num_envs=10**8,
          vectorization_mode="vector_entry_point"), ParameterError)),
    S("profile-inits", "runs", "`striatal sweep --seeds 2 --max-trials 3 --duration 5 "
      "--eval-draws 0 --init chapter,random --out P`, then `striatal profile P --json` (the "
      "two inits were pooled in one curve per arm)", "one curve per (arm, init), 2 runs each",
      profile_inits),
)  # fmt: skip


@pytest.fixture(scope="module")
def round3_tmp(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("round3")


@pytest.mark.parametrize("scenario", params_of(ROUND3))
def test_round3(scenario: Scenario, round3_tmp: Path) -> None:
    ok, observed = outcome(scenario, round3_tmp)
    assert ok, observed


def test_doc_matches_round3(round3_tmp: Path) -> None:
    check_doc_section("round3", ROUND3, round3_tmp, "test_reliability_round3.py")


@pytest.mark.parametrize("gains", ["123456", ("1", "2", "3", "4", "5", "6"), [True] * 6])
def test_gains_given_as_text_or_flags_are_refused_everywhere(gains: object) -> None:
    """check_gains is the one gate: a result, an ablation.json and the API all use it."""
    from striatal.errors import ParameterError
    from striatal.experiments.robustness import controller_groups
    from striatal.params import Controller

    with pytest.raises(ParameterError, match="six numbers"):
        Controller(gains=gains, theta_c=0.6)  # type: ignore[arg-type]
    ablation = {"v": {"runs": [{"success": True, "W": gains, "theta_c": 0.6}]}}
    with pytest.raises(ParameterError, match="six numbers"):
        controller_groups(ablation)


def test_a_long_run_with_files_holds_no_history_in_memory(tmp_path: Path) -> None:
    """With out=, the history rows live in history.csv: Python's allocations do not grow
    with the trials (they grew by about 0.7 kB a trial), and Run.history is read back."""
    import tracemalloc

    from striatal.params import Simulation

    sim = Simulation(duration=0.5, dt=0.1)
    seen: dict[int, int] = {}

    def on(state: Any, _record: Any) -> None:
        if state.trials_done in (1_000, 4_000):
            seen[state.trials_done] = tracemalloc.get_traced_memory()[0]

    tracemalloc.start()
    try:
        run = train(max_trials=4_000, sim=sim, out=tmp_path / "r", on_trial=on)
    finally:
        tracemalloc.stop()
    assert seen[4_000] - seen[1_000] < 600_000, seen  # 3 000 trials: ~2 MB before
    assert len(run.history) == run.trials == 4_000
    in_memory = train(max_trials=50, sim=sim)
    np.testing.assert_array_equal(run.history.data[:50], in_memory.history.data)


def test_rows_without_a_settings_id_need_their_sweep_json(tmp_path: Path) -> None:
    """A runs.csv from before settings_id: its rows are reused when sweep.json is there and
    matches, refused when it is gone (nothing then proves their settings)."""
    from striatal.experiments import runs_csv, sweeps
    from striatal.io.files import csv_text

    the_plan = sweeps.plan(seeds=2, max_trials=3, eval_draws=0, sim=_sim5())
    out = tmp_path / "W"
    full = sweeps.run_sweep(the_plan.specs, the_plan.settings, out=out, max_trials=3)
    assert {r["settings_id"] for r in full.rows} == {sweeps.settings_id(s) for s in the_plan.specs}
    old_columns = runs_csv.COLUMNS_BEFORE_SETTINGS_ID
    cells = [[int(r[c]) if r[c] is True or r[c] is False else r[c] for c in old_columns]
             for r in full.rows]  # fmt: skip
    runs = out / "runs.csv"
    runs.write_text(csv_text(old_columns, cells[:2]), encoding="utf-8")
    again = sweeps.run_sweep(the_plan.specs, the_plan.settings, out=out, max_trials=3)
    assert (again.skipped, again.ran) == (2, 2)
    runs.write_text(csv_text(old_columns, cells[:2]), encoding="utf-8")
    (out / "sweep.json").unlink()
    before = runs.read_bytes()
    with pytest.raises(ParameterError, match=r"rows without a settings id and no sweep\.json"):
        sweeps.run_sweep(the_plan.specs, the_plan.settings, out=out, max_trials=3)
    assert runs.read_bytes() == before and not (out / "sweep.json").exists()


def _sim5() -> Any:
    from striatal.params import Simulation

    return Simulation(duration=5.0)


def test_settings_differences_name_the_keys() -> None:
    from striatal.experiments.sweeps import settings_differences

    arm = {"method": "learn", "role": "learner", "config": {"alpha": 5.0, "gamma": 0.9}}
    old = {"seeds": 2, "eval_draws": 0, "arms": {"learner": arm, "control": arm}}
    new = {
        "seeds": 2,
        "eval_draws": 5,
        "arms": {"learner": {**arm, "config": {"alpha": 3.0, "gamma": 0.9}}, "cmaes": arm},
        "robust": "x",
    }
    assert settings_differences(old, new) == [
        "eval_draws",
        "arms.learner.config.alpha",
        "arms.cmaes",
        "arms.control",
        "robust",
    ]
    assert settings_differences(old, old) == []
    assert settings_differences([1], new) == ["sweep.json is not an object"]
