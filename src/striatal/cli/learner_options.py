"""The learner's options, shared by ``train`` and ``sweep``.

Options left unset take the tuned preset of the chosen ``--learner``
(:func:`striatal.learners.default_config`); "chapter" keeps the chapter's learner exactly.
"""

from __future__ import annotations

import argparse
from typing import Any

from striatal.learners import LEARNERS, RULES, LearnerConfig, default_config

#: Defaults of each learner (the tuned presets live with each rule: striatal.learners).
LEARNER_DEFAULTS: dict[str, LearnerConfig] = {name: default_config(name) for name in LEARNERS}

# Option name -> LearnerConfig field, for the options whose default depends on --learner.
_FIELDS = {
    "max_trials": "max_trials",
    "alpha": "alpha",
    "gamma": "gamma",
    "baseline": "baseline",
    "action_every": "action_every",
    "eligibility": "eligibility",
    "success_on": "success_on",
    "theta_c_rule": "theta_c_rule",
    "max_step": "max_step",
    "reward": "reward",
    "rpe_rate": "rpe_rate",
    "explore": "explore",
    "sigma_rate": "sigma_rate",
    "normalise": "normalise",
    "decay": "decay",
    "plant_jitter": "plant_jitter",
    "robust": "robust",
    "symmetric": "symmetric",
    "critic_rate": "critic_rate",
    "td_discount": "td_discount",
    "critic_decay": "critic_decay",
    "max_force": "max_force",
    "track": "track",
}


def _default_text(name: str) -> str:
    values = {k: getattr(c, name) for k, c in LEARNER_DEFAULTS.items()}
    if len(set(values.values())) == 1:
        return f"default {values['chapter']}"
    return "default " + ", ".join(f"{v} ({k})" for k, v in values.items())


def add_learner_arguments(parser: argparse.ArgumentParser) -> None:
    """Every LearnerConfig field as an option (docs/paper-notes.md, section 7)."""
    lg = parser.add_argument_group(
        "learning (the chapter leaves these open: docs/paper-notes.md, section 7)"
    )
    lg.add_argument(
        "--learner",
        choices=LEARNERS,
        default="chapter",
        help="; ".join(f"{name}: {rule.summary}" for name, rule in RULES.items())
        + " (an option the chosen learner does not read is refused)",
    )
    lg.add_argument("--max-trials", type=int, default=None, help=_default_text("max_trials"))
    lg.add_argument(
        "--alpha", type=float, default=None, help="learning rate (eq 4); " + _default_text("alpha")
    )
    lg.add_argument(
        "--gamma",
        type=float,
        default=None,
        help="trace discount per draw (eq 3); " + _default_text("gamma"),
    )
    lg.add_argument(
        "--baseline",
        type=float,
        default=None,
        help="reward baseline b (eq 1; chapter learner); " + _default_text("baseline"),
    )
    lg.add_argument(
        "--action-every",
        type=int,
        default=None,
        help="draw a new action every N steps; " + _default_text("action_every"),
    )
    lg.add_argument(
        "--carry-trace", action="store_true", help="do not reset the trace D between trials"
    )
    lg.add_argument(
        "--eligibility",
        choices=("score", "chapter"),
        default=None,
        help="score: the Gaussian score (docs/paper-notes.md, section 2); chapter: the "
        "printed e1; " + _default_text("eligibility"),
    )
    lg.add_argument(
        "--success-on",
        choices=("noisy", "mean"),
        default=None,
        help="judge the success test on the noisy trial (chapter) or a mean-policy rerun; "
        + _default_text("success_on"),
    )
    lg.add_argument(
        "--theta-c-rule",
        choices=("swingup", "trial", "clamped", "fixed", "learned"),
        default=None,
        help="eq 21's min|theta| under the swing-up, over the whole trial, over the whole "
        "trial but at least 0.6 (clamped), keep theta_c, or "
        "learn it with the gains (pgpe); " + _default_text("theta_c_rule"),
    )
    lg.add_argument(
        "--max-step",
        type=float,
        default=None,
        help="bound on each gain's update per trial; " + _default_text("max_step"),
    )
    lg.add_argument(
        "--reward",
        choices=("sparse", "shaped"),
        default=None,
        help="sparse +10/-5 (eqs 24-25) or a dense score of the trial; " + _default_text("reward"),
    )
    lg.add_argument(
        "--rpe-rate",
        type=float,
        default=None,
        help="rate of the expected-reward baseline (rpe, pgpe); " + _default_text("rpe_rate"),
    )
    norm = lg.add_mutually_exclusive_group()
    norm.add_argument(
        "--normalise",
        dest="normalise",
        action="store_const",
        const=True,
        default=None,
        help="divide the prediction error by its running rms; " + _default_text("normalise"),
    )
    norm.add_argument(
        "--no-normalise",
        dest="normalise",
        action="store_const",
        const=False,
        help="use the raw prediction error (the opposite of --normalise)",
    )
    lg.add_argument(
        "--explore",
        type=float,
        default=None,
        help="parameter-exploration std of W1..W5 (pgpe); " + _default_text("explore"),
    )
    lg.add_argument(
        "--sigma-rate",
        type=float,
        default=None,
        help="adaptation rate of the exploration std (pgpe); " + _default_text("sigma_rate"),
    )
    lg.add_argument(
        "--decay",
        type=float,
        default=None,
        help="synaptic decay: the update adds -rate*decay*W1..5 (rpe, pgpe); "
        + _default_text("decay"),
    )
    lg.add_argument(
        "--plant-jitter",
        type=float,
        default=None,
        help="pgpe: each trial's pole mass and length scaled by U[1-J, 1+J], the controller "
        "believing the nominal plant (learning for robustness); " + _default_text("plant_jitter"),
    )
    lg.add_argument(
        "--symmetric",
        action="store_const",
        const=True,
        default=None,
        help="pgpe: symmetric sampling, trials in pairs p + eps, p - eps on the same plant, "
        "one update per pair from the reward difference; " + _default_text("symmetric"),
    )
    lg.add_argument(
        "--robust",
        action="store_const",
        const=True,
        default=None,
        help="the robust stop rule (issue 15): trials hold the motor force of eq 12, and a "
        "controller that passes the success test must also pass the robustness set "
        "(striatal simulate --robust: 9 mean-policy runs of 60 s) for the run to stop; "
        "every run counted (docs/paper-notes.md section 12). It also applies the learner's "
        "robust preset before the options given (pgpe: --plant-jitter 0.2 --alpha 0.5)",
    )
    lg.add_argument(
        "--critic-rate",
        type=float,
        default=None,
        help="ac: rate beta of the critic, v += beta delta z; " + _default_text("critic_rate"),
    )
    lg.add_argument(
        "--td-discount",
        type=float,
        default=None,
        help="ac: discount gamma_v per step of the TD error delta = r + gamma_v V(s') - V(s); "
        + _default_text("td_discount"),
    )
    lg.add_argument(
        "--critic-decay",
        type=float,
        default=None,
        help="ac: lambda of the critic's trace; " + _default_text("critic_decay"),
    )
    lg.add_argument(
        "--max-force",
        type=float,
        default=None,
        metavar="NEWTONS",
        help="motor limit [N] of every trial and check, the robustness set's included: the "
        "force is clipped to [-F, F] (default: none)",
    )
    lg.add_argument(
        "--track",
        type=float,
        default=None,
        metavar="METRES",
        help="track half-length [m] of every trial and check: |x| beyond it ends the trial "
        "as a failure (default: none)",
    )


def learner_changes(args: argparse.Namespace) -> dict[str, Any]:
    """The LearnerConfig fields the options set explicitly (the rest: the learner's preset)."""
    changes = {
        field: getattr(args, option)
        for option, field in _FIELDS.items()
        if getattr(args, option, None) is not None
    }
    if getattr(args, "carry_trace", False):
        changes["reset_trace"] = False
    return changes


def learner_config_from(args: argparse.Namespace) -> LearnerConfig:
    """The LearnerConfig the options describe (validated): the learner's preset, overridden."""
    return default_config(getattr(args, "learner", None) or "chapter", **learner_changes(args))
