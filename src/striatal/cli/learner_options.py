"""The learner's options, shared by ``train`` and ``sweep``."""

from __future__ import annotations

import argparse

from striatal.learn import LearnerConfig


def add_learner_arguments(parser: argparse.ArgumentParser) -> None:
    """Every LearnerConfig field as an option (the chapter leaves most open: NOTES section 7)."""
    lg = parser.add_argument_group("learning (the chapter leaves these open: NOTES section 7)")
    d = LearnerConfig()
    lg.add_argument("--max-trials", type=int, default=d.max_trials)
    lg.add_argument("--alpha", type=float, default=d.alpha, help="learning rate (eq 4)")
    lg.add_argument("--gamma", type=float, default=d.gamma, help="trace discount per draw (eq 3)")
    lg.add_argument("--baseline", type=float, default=d.baseline, help="reward baseline b (eq 1)")
    lg.add_argument(
        "--action-every", type=int, default=d.action_every, help="draw a new action every N steps"
    )
    lg.add_argument(
        "--carry-trace", action="store_true", help="do not reset the trace D between trials"
    )
    lg.add_argument("--eligibility", choices=("score", "chapter"), default=d.eligibility)
    lg.add_argument(
        "--success-on",
        choices=("noisy", "mean"),
        default=d.success_on,
        help="judge the success test on the noisy trial (chapter) or a mean-policy rerun",
    )
    lg.add_argument(
        "--theta-c-rule",
        choices=("swingup", "trial", "fixed"),
        default=d.theta_c_rule,
        help="eq 21's min|theta|: under the swing-up, over the whole trial, or keep theta_c",
    )
    lg.add_argument(
        "--max-step", type=float, default=d.max_step, help="bound on each gain's update per trial"
    )


def learner_config_from(args: argparse.Namespace) -> LearnerConfig:
    """The LearnerConfig the options describe (validated)."""
    return LearnerConfig(
        alpha=args.alpha,
        gamma=args.gamma,
        baseline=args.baseline,
        action_every=args.action_every,
        reset_trace=not args.carry_trace,
        eligibility=args.eligibility,
        success_on=args.success_on,
        theta_c_rule=args.theta_c_rule,
        max_trials=args.max_trials,
        max_step=args.max_step,
    )
