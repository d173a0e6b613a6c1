"""The options of a learning run, one flat frozen record that every front end builds.

Each learning rule reads only its own options from it (its small frozen config,
e.g. :class:`striatal.learners.pgpe.PgpeConfig`, picked by :func:`pick`); the
options the chapter leaves open are listed in docs/paper-notes.md, section 7.
"""

from __future__ import annotations

import functools
import math
import numbers
import types
from dataclasses import Field, asdict, dataclass, field, fields
from typing import Any, Literal, TypeVar, get_args, get_origin, get_type_hints

from striatal.errors import ParameterError
from striatal.params import Hardware, as_float, require_finite

__all__ = [
    "MAX_COUNT",
    "STORED_ALWAYS",
    "W1_FLOOR",
    "Eligibility",
    "Eq21Rule",
    "ForwardModel",
    "LearnerConfig",
    "RewardKind",
    "SuccessOn",
    "ThetaCRule",
    "bounds_of",
    "bounds_text",
    "check_field",
    "field_kind",
    "meta",
    "option",
    "pick",
    "require_count",
]

SuccessOn = Literal["noisy", "mean"]
#: The readings of eq 21's theta_c rule (every rule that keeps theta_c out of its update).
Eq21Rule = Literal["swingup", "trial", "clamped", "fixed"]
#: ... and "learned": theta_c perturbed and updated with the gains (a rule whose config
#: field takes it: pgpe).
ThetaCRule = Literal[Eq21Rule, "learned"]
Eligibility = Literal["score", "chapter"]
RewardKind = Literal["sparse", "shaped"]
ForwardModel = Literal[
    "structured", "generic", "generic-gains", "sparse-gains", "sparse-affine", "conditioned"
]

#: The largest value of a count field: 2**31 - 1, what the compiled kernel's int32 holds.
MAX_COUNT = 2**31 - 1

#: Floor that keeps W1 > 0 for sqrt(W1 g) (eq 22): the documented guard.
W1_FLOOR = 1e-3


def require_count(name: str, value: object, low: int = 1) -> None:
    """ParameterError unless ``value`` is a whole number >= ``low`` (text, null or a list
    too)."""
    try:
        whole = not isinstance(value, bool) and int(value) == value  # type: ignore[call-overload]
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole or value < low:  # type: ignore[operator]
        raise ParameterError(f"{name} must be a whole number >= {low}, got {value!r}")


def meta(help: str, *, bounds: str = "", **more: Any) -> dict[str, Any]:
    """The metadata of a :class:`LearnerConfig` field: its option, stated once.

    ``help`` is the field's meaning (the docstring and ``--help`` both read it);
    ``bounds`` its allowed values: ``"[0, 1)"``, ``"(0, 100]"``, ``">= 0"`` or ``"> 0"``
    (a number field is also finite, unless ``finite=False``). The choices of a text
    field are its ``Literal`` type. ``more``: ``finite``, ``metavar``, ``flag`` and
    ``sets`` (a true/false field set by the option ``--flag``, to the value ``sets``),
    ``negatable`` (``--X`` and ``--no-X``), ``cli=False`` (no option).
    """
    return {"help": help, "bounds": bounds, **more}


def option(default: Any, help: str, **more: Any) -> Any:
    """A :class:`LearnerConfig` field: its default and its option's :func:`meta`
    (``help``, ``bounds`` and the rest, stated once)."""
    return field(default=default, metadata=meta(help, **more))


@dataclass(frozen=True)
class LearnerConfig:
    """Every option of a learning run (the chapter leaves most open: docs/paper-notes.md, 7).

    Build it with :func:`striatal.learners.default_config` (the learner's tuned
    preset, then your changes): ``LearnerConfig(learner="pgpe")`` alone keeps the
    chapter's values of the other fields. Which rule reads which field:
    ``striatal.learners.RULES[name].options``. Each field states its meaning, its
    bounds and its choices once, in its metadata (:func:`option`, :func:`meta`): validation here and
    the options of ``striatal train`` and ``striatal sweep`` read them.
    """

    alpha: float = option(5.0, "learning rate (eqs 1, 4)", bounds=">= 0")
    gamma: float = option(
        0.999,
        "discount per draw of the eligibility trace D(t) = e(t) + gamma D(t-1) (eq 3)",
        bounds="[0, 1)",
    )
    baseline: float = option(
        0.0, "reinforcement baseline b of eq 1 (chapter learner)", flag="reward-baseline"
    )
    action_every: int = option(1, "draw a new action every N control steps and hold it")
    reset_trace: bool = option(
        True, "do not reset the trace D between trials", flag="carry-trace", sets=False
    )
    eligibility: Eligibility = option(
        "score",
        "score: the Gaussian score (docs/paper-notes.md, section 2); chapter: the printed e1",
    )
    success_on: SuccessOn = option(
        "noisy", "judge the success test on the noisy trial (chapter) or a mean-policy rerun"
    )
    theta_c_rule: ThetaCRule = option(
        "swingup",
        "eq 21's min|theta| under the swing-up (a ratchet), over the whole trial (falls "
        "to its floor), over the whole trial but at least 0.6 (clamped), keep theta_c, "
        "or learn it with the gains (pgpe)",
    )
    max_trials: int = option(2000, "stop after this many trials if the success test never holds")
    max_step: float = option(
        1.0, "bound on each gain's update per trial (inf: none)", bounds="> 0", finite=False
    )
    w1_floor: float = option(
        W1_FLOOR,
        "W1 is kept >= this after every update (sqrt(W1 g) of eq 22)",
        bounds="> 0",
        cli=False,
    )
    learner: str = option(
        "chapter", "the learning rule, a key of striatal.learners.RULES", cli=False
    )
    reward: RewardKind = option(
        "sparse", "sparse +10/-5 (eqs 24-25) or a dense score of the trial (shaped_reward)"
    )
    rpe_rate: float = option(
        0.1,
        "rate beta of the expected-reward baseline b += beta (r - b) and of the prediction "
        "error's running mean square (rpe, pgpe: per trial; ac: per step, of delta)",
        bounds="(0, 1]",
    )
    normalise: bool = option(
        False,
        "divide the prediction error r - b (ac: the TD error, for the actor) by its running rms",
        negatable=True,
    )
    explore: float = option(
        0.3,
        "parameter-exploration std of W1..W5 (pgpe); theta_c's is 0.3 times it [rad]",
        bounds="(0, 100]",
    )
    sigma_rate: float = option(
        0.0, "adaptation rate of the exploration's log-std (pgpe; 0: fixed)", bounds=">= 0"
    )
    decay: float = option(
        0.0,
        "synaptic decay lambda: the update adds -rate*lambda*W1..5 (rpe, pgpe; rate: alpha "
        "for pgpe, alpha (1 - gamma) for rpe)",
        bounds=">= 0",
    )
    plant_jitter: float = option(
        0.0,
        "pgpe: each trial's pole mass and length scaled by U[1-J, 1+J], the controller "
        "believing the nominal plant (learning for robustness)",
        bounds="[0, 0.5]",
    )
    symmetric: bool = option(
        False,
        "pgpe: symmetric sampling (Sehnke et al. 2010), trials in pairs p + eps, p - eps on "
        "the same plant, one update per pair from the reward difference (r+ - r-) / 2",
    )
    robust: bool = option(
        False,
        "the robust stop rule (any learner): trials hold the motor force of eq 12 (ac's "
        "online trial still holds u), and a controller that passes the success test must "
        "also pass the robustness set (striatal simulate --robust: 9 mean-policy runs of "
        "60 s) for the run to stop; every run counted (docs/paper-notes.md section 12). It "
        "also applies the learner's robust preset before the options given (pgpe: "
        "--plant-jitter 0.2 --alpha 0.5)",
    )
    stop_margin: float = option(
        0.0,
        "with --robust: a controller that passes the success test must first also pass the "
        "four plant corners at pole mass and length x(1 +- (0.2 + M)), a margin beyond the "
        "robustness set's (mean policy, 60 s, the force held, up to the first failure, "
        "every run counted); the set then decides as before. The learner's stop rule only: "
        "a sweep's baselines keep theirs. 0: none",
        bounds="[0, 0.5]",
    )
    margin_after_success: bool = option(
        False,
        "with --stop-margin M: the run succeeds (trials, simulations, seconds to success "
        "recorded) at the first controller that passes the robust stop rule without the "
        "margin, as without --stop-margin; it then learns on, every trial and check "
        "counted, until a controller also passes the wider corners or the budget ends, and "
        "delivers that one, else the first robust one",
    )
    critic_rate: float = option(
        0.01, "ac: rate beta of the critic's weights, v += beta delta z", bounds="[0, 1]"
    )
    td_discount: float = option(
        0.99,
        "ac: discount gamma_v per control step of the TD error delta = r + gamma_v V(s') - "
        "V(s); 1 - dt / tau for a value horizon tau",
        bounds="[0, 1)",
    )
    critic_decay: float = option(
        0.9, "ac: lambda of the critic's trace z <- gamma_v lambda z + phi(s)", bounds="[0, 1]"
    )
    imagine_trials: int = option(
        2000,
        "forward: imagined trials (on the forward model, not counted as simulations) allowed "
        "after each real trial, the generic models' checks of a candidate included; 0 fits "
        "no model and learns nothing (its control)",
        bounds=">= 0",
    )
    imagine_round: int | None = option(
        None,
        "forward: imagined trials a round of imagination (pgpe from the candidate under one "
        "seed) may spend without a solution; a round that finds none ends the imagination "
        "until the next real trial, whose data refit the model (none: the model's own, "
        "500 for the generic models, the whole --imagine-trials budget for the structured)",
        bounds=">= 1",
        metavar="TRIALS",
    )
    imagine_duration: float | None = option(
        None,
        "forward: duration [s] of the inner learner's imagined trials (at most the real "
        "trial's), its success test judged at their end; a candidate is still checked on "
        "the model's plants for the robustness set's 60 s (none: the real trial's duration)",
        bounds="[1, 600]",
        metavar="SECONDS",
    )
    forward_model: ForwardModel = option(
        "structured",
        "forward: the forward model imagination runs on: 'structured' (the cart-pole's "
        "equations, pole mass, length, cart mass and friction fitted), 'generic' (no "
        "cart-pole equations: a scikit-learn ensemble of polynomial ridge regressions), "
        "'generic-gains' (the same, a candidate also checked on its mean with the pole's "
        "angular acceleration scaled by 1/1.2 and 1/0.8), 'sparse-gains' (generic-gains "
        "with a sparse readout: a few monomials of the raw inputs per output, chosen by "
        "orthogonal matching pursuit, as in SINDy), 'sparse-affine' (sparse-gains with the "
        "force f in each output's terms, and 2 terms an output while the data's angle spans "
        "less than 1 rad) or "
        "'conditioned' (the generic ensemble with the plant's pole mass and length factors "
        "as inputs, learned from the real trials and the real robust checks, rehearsing "
        "the corners it has seen)",
    )
    imagine_margin: float = option(
        0.0,
        "forward, with --robust and the structured, generic-gains or a sparse model: "
        "imagination asks "
        "for the plant corners at pole mass and length x(1 +- (0.2 + M)) instead of the "
        "robustness set's (structured: the inner pgpe's jittered plants and each family "
        "plant's checks; generic-gains and the sparse models: the angular-acceleration gains "
        "1/(1 +- (0.2 + M))); "
        "the real checks are unchanged. 0: the set's box (with --robust, these models: 0.1 "
        "unless given, their robust preset)",
        bounds="[0, 0.5]",
    )
    max_force: float | None = option(
        None,
        "motor limit [N] of every trial and check, the robustness set's included: the force "
        "is clipped to [-F, F] (none: unlimited)",
        bounds="> 0",
        metavar="NEWTONS",
    )
    track: float | None = option(
        None,
        "track half-length [m] of every trial and check: |x| beyond it ends the trial as a "
        "failure (none: endless)",
        bounds="> 0",
        metavar="METRES",
    )

    def __post_init__(self) -> None:
        for f in fields(self):
            value = check_field(f, getattr(self, f.name))
            if value is not getattr(self, f.name):
                object.__setattr__(self, f.name, value)

    @functools.cached_property
    def hardware(self) -> Hardware:
        """The motor and track of every trial and check of the run: the force held with
        ``robust`` (u otherwise, the chapter's idealisation), ``max_force`` and ``track``
        (made once: every trial of a run asks for it)."""
        return Hardware(
            hold="force" if self.robust else "u", max_force=self.max_force, track=self.track
        )

    def to_dict(self) -> dict[str, Any]:
        """The fields as stored in a run's settings (and hashed into its run id): every
        field of :data:`STORED_ALWAYS`, and each later one only when it differs from its
        default, so that adding a field changes no earlier run's settings or id."""
        d = asdict(self)
        for f in fields(self):
            if f.name not in STORED_ALWAYS and d[f.name] == f.default:
                del d[f.name]
        return d


#: The fields of the settings schema 2, stored in every run's settings. It never grows:
#: a field added since is stored only when it differs from its default.
STORED_ALWAYS = frozenset(
    {
        "alpha",
        "gamma",
        "baseline",
        "action_every",
        "reset_trace",
        "eligibility",
        "success_on",
        "theta_c_rule",
        "max_trials",
        "max_step",
        "w1_floor",
        "learner",
        "reward",
        "rpe_rate",
        "normalise",
        "explore",
        "sigma_rate",
        "decay",
        "plant_jitter",
        "critic_rate",
        "td_discount",
        "critic_decay",
    }
)


@functools.cache
def field_kind(f: Field[Any]) -> tuple[type, tuple[Any, ...], bool]:
    """A field's value type, its choices (of its ``Literal`` type; () for none) and
    whether it may be None."""
    hint = _hints()[f.name]
    optional = False
    if isinstance(hint, types.UnionType):
        args = [a for a in get_args(hint) if a is not type(None)]
        optional, hint = len(args) < len(get_args(hint)), args[0]
    if get_origin(hint) is Literal:
        return str, get_args(hint), optional
    return hint, (), optional


@functools.cache
def bounds_of(f: Field[Any]) -> tuple[float, float, bool, bool] | None:
    """``(low, high, low_open, high_open)`` of a field's ``bounds`` (None: no bounds)."""
    text = f.metadata.get("bounds", "").replace(" ", "")
    if not text:
        return None
    if text.startswith(">="):
        return float(text[2:]), math.inf, False, False
    if text.startswith(">"):
        return float(text[1:]), math.inf, True, False
    low, high = text[1:-1].split(",")
    return float(low), float(high), text[0] == "(", text[-1] == ")"


def _is_a(value: object, kind: type) -> bool:
    """Whether ``value`` is a ``kind`` (numbers.Real, numbers.Integral) and not a bool."""
    return isinstance(value, kind) and not isinstance(value, bool)


def check_field(f: Field[Any], value: Any) -> Any:
    """``value`` if it is allowed for field ``f`` (a limit as float), else ParameterError."""
    kind, choices, optional = field_kind(f)
    name = f.name
    if optional and value is None:
        return None
    if choices:
        if value not in choices:
            allowed = ", ".join(repr(c) for c in choices[:-1]) + f" or {choices[-1]!r}"
            raise ParameterError(f"{name} must be {allowed}, got {value!r}")
    elif kind is bool:
        if not isinstance(value, bool):
            raise ParameterError(f"{name} must be true or false, got {value!r}")
    elif kind is int:
        least = 0 if f.metadata.get("bounds") == ">= 0" else 1
        if not _is_a(value, numbers.Integral):
            # 5.0 or "5" is not a count: a hand-edited file would otherwise pass it on
            raise ParameterError(f"{name} must be a whole number >= {least}, got {value!r}")
        require_count(name, value, least)
        if value > MAX_COUNT:
            raise ParameterError(f"{name} must be at most {MAX_COUNT:,}, got {value:,}")
    elif kind is str:
        if not isinstance(value, str):
            raise ParameterError(f"{name} must be a name, got {value!r}")
    elif kind is float:
        if not _is_a(value, numbers.Real):
            # "0.9" would reach the compiled kernel as text, true as 1
            raise ParameterError(f"{name} must be a number, got {value!r}")
        number = (
            require_finite(name, value) if f.metadata.get("finite", True) else as_float(name, value)
        )
        bounds = bounds_of(f)
        if bounds is not None:
            low, high, low_open, high_open = bounds
            above = number > low if low_open else number >= low
            below = number < high if high_open else number <= high
            if not (above and below):
                finite = f.metadata.get("finite", True)
                unbounded = "" if finite or high_open else " (inf for no bound)"
                raise ParameterError(f"{name} must be {bounds_text(f)}{unbounded}, got {value!r}")
        if optional:
            return number
    return value


def bounds_text(f: Field[Any]) -> str:
    """A field's bounds as a sentence says them: ">= 0", "in [0, 1)"."""
    text = f.metadata.get("bounds", "")
    return text if text[:1] in ("<", ">") else f"in {text}"


@functools.cache
def _hints() -> dict[str, Any]:
    return get_type_hints(LearnerConfig)


C = TypeVar("C")


@functools.lru_cache(maxsize=256)
def pick(cls: type[C], config: LearnerConfig) -> C:
    """The rule config ``cls`` (a dataclass) with the same-named fields of ``config``
    (remembered: a rule reads it every trial of a run)."""
    return cls(**{f.name: getattr(config, f.name) for f in fields(cls)})  # type: ignore[arg-type]
