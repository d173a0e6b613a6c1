"""One table of the arguments that every front takes: the command line, an experiment
file (TOML), the Python API and the Gymnasium kwargs.

Each :class:`Arg` states its type, its range and its unit once. :func:`check` holds a
value to it, whichever front it came through, and names the value as the user spelled
it (``--max-trials``, ``max-trials`` in a TOML file, ``max_trials=`` in Python): a
number is never a bool or text, a whole number is never 2.0, and a NumPy integer
is a whole number. The learner's own options are the fields of
:class:`striatal.learners.LearnerConfig`, whose metadata is their table
(:func:`striatal.learners.config.check_field`); this module holds the rest.

:func:`check_work` bounds the work a command may start: each command estimates it
(runs x trials x steps, draws x steps, repeats x steps, values x their cost) before
anything runs or is written, and refuses past :data:`MAX_STEPS` with one line giving
the estimate.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from striatal.errors import ParameterError

__all__ = [
    "ARGS",
    "MAX_ITEMS",
    "MAX_STEPS",
    "MAX_STEPS_ENV",
    "Arg",
    "check",
    "check_all",
    "check_learning_work",
    "check_work",
    "max_steps",
    "plain",
    "spelling",
]

#: The most values a list argument takes (a grid of 1 000 alphas is already 1 000 arms).
MAX_ITEMS = 1_000
#: The most simulated control steps (of dt each) one command may start, counted at its
#: worst case (every run to its budget). 10**12 steps are about 5 days of this machine's
#: kernel; every documented experiment is far below (a 100-seed sweep of six arms over
#: two inits at 2 000 trials of 60 s is 1.4 * 10**10). The environment variable
#: ``STRIATAL_MAX_STEPS`` sets a lower limit (the fuzzer's: work it can wait for).
MAX_STEPS = 10**12
MAX_STEPS_ENV = "STRIATAL_MAX_STEPS"


def max_steps() -> int:
    """:data:`MAX_STEPS`, or the lower limit that ``STRIATAL_MAX_STEPS`` sets."""
    text = os.environ.get(MAX_STEPS_ENV, "")
    try:
        return min(MAX_STEPS, max(1, int(text))) if text else MAX_STEPS
    except ValueError:
        raise ParameterError(
            f"{MAX_STEPS_ENV} must be a whole number of steps, got {text!r:.40}"
        ) from None


Kind = Literal["count", "whole", "real", "choice", "flag", "reals", "names", "text"]


@dataclass(frozen=True)
class Arg:
    """One argument: its ``kind``, range [``low``, ``high``] (``low_open``: low itself
    excluded), ``choices``, ``unit`` and meaning (``help``)."""

    name: str
    kind: Kind
    help: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    choices: tuple[str, ...] = ()
    unit: str = ""
    max_items: int = MAX_ITEMS
    min_items: int = 0
    optional: bool = False

    def range_text(self) -> str:
        if self.low is None and self.high is None:
            return ""
        low = "-inf" if self.low is None else _bound(self.low)
        high = "inf" if self.high is None else _bound(self.high)
        return f"{'(' if self.low_open else '['}{low}, {high}]"


def _bound(v: float) -> str:
    return f"{int(v):,}" if float(v).is_integer() and abs(v) < 1e15 else f"{v:g}"


def spelling(name: str, front: str) -> str:
    """``name`` as the user writes it on ``front``: "cli" (``--max-trials``), "toml"
    (``max-trials``), "api" or "gym" (``max_trials``)."""
    if front == "cli":
        return "--" + name.replace("_", "-")
    if front == "toml":
        return name.replace("_", "-")
    return name


def plain(value: Any) -> Any:
    """A NumPy scalar as the Python number it holds (``np.int64(2)`` is 2); else ``value``."""
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if type(value).__module__ == "numpy" and hasattr(value, "item"):
        item = value.item()
        if isinstance(item, bool | int | float):
            return item
    return value


def _what(arg: Arg) -> str:
    text = {
        "count": "a whole number",
        "whole": "a whole number",
        "real": "a finite number",
        "flag": "true or false",
        "reals": "a list of finite numbers",
        "names": "a list of names" + (f" from {', '.join(arg.choices)}" if arg.choices else ""),
        "text": "text",
        "choice": "one of " + ", ".join(repr(c) for c in arg.choices),
    }[arg.kind]
    rng = arg.range_text()
    return f"{text} in {rng}" if rng and arg.kind in ("count", "whole", "real", "reals") else text


def _in_range(arg: Arg, v: float) -> bool:
    if arg.low is not None and (v <= arg.low if arg.low_open else v < arg.low):
        return False
    return not (arg.high is not None and v > arg.high)


def _number(arg: Arg, value: Any) -> int | float | None:
    """``value`` as the number ``arg`` takes, or None if it is not one."""
    value = plain(value)
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    if arg.kind in ("count", "whole"):
        if not isinstance(value, numbers.Integral):
            return None
        value = int(value)
    else:
        value = float(value)
        if not math.isfinite(value):
            return None
    return value if _in_range(arg, value) else None


def check(arg: Arg, value: Any, front: str = "api") -> Any:
    """``value`` held to ``arg`` (a NumPy number as a Python one, a list as a tuple), or
    ParameterError naming the argument as it is spelled on ``front``."""
    name = spelling(arg.name, front)

    def refuse() -> ParameterError:
        shown = repr(value)
        if len(shown) > 60:
            shown = shown[:57] + "..."
        return ParameterError(f"{name} must be {_what(arg)}, got {shown}")

    if value is None and arg.optional:
        return None
    if arg.kind in ("count", "whole", "real"):
        number = _number(arg, value)
        if number is None:
            raise refuse()
        return number
    if arg.kind == "flag":
        value = plain(value)
        if not isinstance(value, bool):
            raise refuse()
        return value
    if arg.kind == "choice":
        if not isinstance(value, str) or value not in arg.choices:
            raise refuse()
        return value
    if arg.kind == "text":
        if not isinstance(value, str):
            raise refuse()
        return value
    # a list: one value alone is a list of one
    items = (value,) if isinstance(value, str | numbers.Real) else value
    if not isinstance(items, Sequence) or isinstance(items, bytes | bytearray):
        raise refuse()
    if len(items) > arg.max_items:
        raise ParameterError(f"{name} takes at most {arg.max_items:,} values, got {len(items):,}")
    if len(items) < arg.min_items:
        raise ParameterError(f"{name} needs at least {arg.min_items} value(s), got none")
    if arg.kind == "reals":
        numbers_ = [_number(arg, v) for v in items]
        if any(v is None for v in numbers_):
            raise refuse()
        return tuple(numbers_)
    if not all(isinstance(v, str) and (not arg.choices or v in arg.choices) for v in items):
        raise refuse()
    return tuple(items)


def check_all(
    values: Mapping[str, Any], table: Mapping[str, Arg] | None = None, front: str = "api"
) -> dict[str, Any]:
    """Every value of ``values`` held to its :class:`Arg` of ``table`` (:data:`ARGS`)."""
    table = ARGS if table is None else table
    return {k: check(table[k], v, front) if k in table else v for k, v in values.items()}


def check_work(steps: float, what: str, how: str) -> None:
    """ParameterError if ``steps`` (a command's worst-case simulated steps) exceed
    :data:`MAX_STEPS`; the line gives the estimate and how it was made."""
    limit = max_steps()
    if not steps <= limit:
        raise ParameterError(
            f"{what} would simulate up to {steps:.3g} steps ({how}), more than the "
            f"limit of {limit:.0e}; ask for fewer"
        )


#: The most imagined control steps one real trial may start (the forward learner's
#: ``imagine_trials`` x steps per trial): 10**9, about an hour; its default is 1.2 * 10**7.
MAX_IMAGINED_STEPS = 10**9


def check_learning_work(
    runs: int, max_trials: int, imagine_trials: int, steps: int, draws: int, what: str
) -> None:
    """:func:`check_work` of ``runs`` learning runs of ``max_trials`` trials of ``steps``
    steps (and ``draws`` noisy checks of W(0) and W each), and the bound of one real
    trial's imagination (:data:`MAX_IMAGINED_STEPS`), before anything runs."""
    check_work(
        runs * steps * (max_trials + 2 * draws),
        what,
        f"{runs:,} runs x ({max_trials:,} trials + 2 x {draws:,} draws) x {steps:,} steps",
    )
    if imagine_trials * steps > MAX_IMAGINED_STEPS:
        raise ParameterError(
            f"{what}: one real trial would imagine up to {imagine_trials * steps:.3g} steps "
            f"({imagine_trials:,} imagined trials x {steps:,} steps), more than the limit "
            f"of {MAX_IMAGINED_STEPS:.0e}; lower --imagine-trials (imagine_trials= in Python)"
        )


def _args(*args: Arg) -> dict[str, Arg]:
    return {a.name: a for a in args}


#: The arguments of the sweep (``striatal sweep``, :func:`striatal.sweep`) and the
#: options that several commands share, by their Python name.
#: Seconds to wait for a Ray cluster's address to accept a connection (the default of
#: ``connect_timeout``).
CONNECT_TIMEOUT = 30.0

ARGS: dict[str, Arg] = _args(
    Arg("seeds", "count", "seeds per arm and init", low=1, high=100_000),
    # a seed as a sweep spawns one for each run (runs.csv's seeds): 32 bits
    Arg("seed", "count", "a seed (of a run, or a sweep's root)", low=0, high=2**32 - 1),
    Arg("max_trials", "count", "learning-trial budget of a run", low=1, high=2**31 - 1),
    Arg("init", "names", "initial gains: chapter, random or both", choices=("chapter", "random"),
        min_items=1),
    Arg(
        "theta_c0",
        "real",
        "initial switching threshold theta_c(0)",
        low=0,
        high=math.pi,
        low_open=True,
        unit="rad",
    ),
    Arg("alpha_grid", "reals", "learning rates of a grid of arms", low=0, high=1e6,
        min_items=1, optional=True),
    Arg("gamma_grid", "reals", "trace discounts of a grid of arms", low=0, high=1,
        min_items=1, optional=True),
    Arg("control", "flag", "run the learner's no-learning control arm"),
    Arg("eval_draws", "count", "noisy draws judging W(0) and the final W", low=0, high=1_000_000),
    Arg("baselines", "names", "baseline arms", choices=("lqr", "hand", "random", "cmaes")),
    Arg("balance_sign", "choice", "sign of eq 20's theta terms", choices=("corrected", "chapter"),
        optional=True),
    Arg("switch", "choice", "hard or soft (cerebellar) switch", choices=("hard", "soft"),
        optional=True),
    Arg(
        "inhibition", "real", "lateral inhibition of the soft switch", low=0, high=1e6,
        low_open=True, unit="1/rad", optional=True,
    ),
    Arg("engine", "choice", "how runs execute", choices=("processes", "batch", "simd")),
    Arg("workers", "count", "local worker processes", low=1, high=4096),
    Arg("backend", "choice", "local processes or a Ray cluster", choices=("local", "ray")),
    Arg("address", "text", "Ray cluster address HOST:PORT", optional=True),
    Arg(
        "connect_timeout", "real", "seconds to wait for a Ray address", low=0, high=600,
        low_open=True, unit="s",
    ),
    Arg("progress", "flag", "show a progress bar"),
    Arg("repeats", "count", "noisy repeats per case", low=1, high=100_000),
    Arg("track", "real", "track half-length", low=0, high=1e6, low_open=True, unit="m",
        optional=True),
    Arg("max_force", "real", "motor limit", low=0, high=1e9, low_open=True, unit="N",
        optional=True),
)  # fmt: skip


def cli_type(name: str) -> Any:
    """The argparse ``type=`` of the option of :data:`ARGS` ``name``: the word read as
    the option's kind, then held to its range (:func:`check`), named ``--name``."""
    import argparse

    arg = ARGS[name]

    def parse(text: str) -> Any:
        try:
            value: Any = int(text) if arg.kind in ("count", "whole") else float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {_what(arg)}, got {text!r:.40}") from None
        try:
            return check(arg, value, "cli")
        except ParameterError:
            raise argparse.ArgumentTypeError(f"must be {_what(arg)}, got {text:.40}") from None

    parse.__name__ = _what(arg).split(" in ")[0]
    parse.numeric = True  # type: ignore[attr-defined]
    return parse
