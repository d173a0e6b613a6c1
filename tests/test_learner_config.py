"""LearnerConfig states each option once: its help, bounds and choices are field metadata,
read by validation and by the options of train and sweep; run ids do not move."""

from __future__ import annotations

import argparse
import math
from dataclasses import fields
from typing import Any

import pytest

from striatal.cli import OneLineParser
from striatal.cli.learner_options import add_learner_arguments, flag_of, learner_config_from
from striatal.errors import ParameterError
from striatal.io.rundir import run_id
from striatal.learners import LearnerConfig, default_config
from striatal.learners.config import STORED_ALWAYS, bounds_of, field_kind

#: Run ids of configs as the code before field metadata hashed them ({"config": to_dict()}).
IDS_BEFORE = {
    "chapter": ("ac873adbaeaa2db9", lambda: default_config("chapter")),
    "pgpe": ("7f0845f0af095afc", lambda: default_config("pgpe")),
    "pgpe_robust": ("fc6a6732cb1cc881", lambda: default_config("pgpe", robust=True)),
    "rpe_normalise": ("5143e23f0fdee04d", lambda: default_config("rpe", normalise=True)),
    "ac": ("f57ef5dee156e5f5", lambda: default_config("ac")),
    "symmetric_track": (
        "51629dabca0bb331",
        lambda: default_config("pgpe", symmetric=True, track=2.4, max_force=20),
    ),
    "carry": ("e6bd014937a1c09b", lambda: LearnerConfig(reset_trace=False, alpha=5, max_trials=7)),
}


@pytest.mark.parametrize("name", sorted(IDS_BEFORE))
def test_run_ids_of_existing_configs_are_unchanged(name: str) -> None:
    expected, make = IDS_BEFORE[name]
    assert run_id({"config": make().to_dict()}) == expected


def test_a_field_beyond_schema_2_is_stored_only_when_it_differs_from_its_default() -> None:
    later = {f.name for f in fields(LearnerConfig)} - STORED_ALWAYS
    assert later == {
        "symmetric",
        "robust",
        "max_force",
        "track",
        "imagine_trials",
        "imagine_round",
        "imagine_duration",
        "forward_model",
        "stop_margin",
        "margin_after_success",
        "imagine_margin",
    }
    plain = LearnerConfig().to_dict()
    assert set(plain) == STORED_ALWAYS
    assert LearnerConfig(track=2.4).to_dict()["track"] == 2.4
    assert LearnerConfig(robust=True).to_dict()["robust"] is True


def _parse(*argv: str) -> argparse.Namespace:
    parser = OneLineParser(prog="t")
    add_learner_arguments(parser)
    return parser.parse_args(argv)


def test_every_option_field_has_help_and_an_option() -> None:
    parser = OneLineParser(prog="t")
    add_learner_arguments(parser)
    for f in fields(LearnerConfig):
        assert f.metadata["help"], f.name
        if f.metadata.get("cli", True):
            action = parser._option_string_actions[flag_of(f)]
            assert f.metadata["help"].replace("%", "%%") in action.help


def test_choices_are_the_literal_types_in_validation_and_options() -> None:
    parser = OneLineParser(prog="t")
    add_learner_arguments(parser)
    by_dest = {a.dest: a for a in parser._actions}
    texts = [f for f in fields(LearnerConfig) if field_kind(f)[1]]
    assert {f.name for f in texts} == {
        "eligibility",
        "success_on",
        "theta_c_rule",
        "reward",
        "forward_model",
    }
    for f in texts:
        choices = field_kind(f)[1]
        assert tuple(by_dest[f.name].choices) == choices
        for c in choices:
            LearnerConfig(**{f.name: c})
        with pytest.raises(ParameterError, match=f.name):
            LearnerConfig(**{f.name: "nonsense"})


def _just_outside(low: float, high: float, low_open: bool, high_open: bool) -> list[float]:
    out = [low if low_open else math.nextafter(low, -math.inf)]
    if math.isfinite(high):
        out.append(high if high_open else math.nextafter(high, math.inf))
    return out


@pytest.mark.parametrize(
    "f", [f for f in fields(LearnerConfig) if bounds_of(f)], ids=lambda f: f.name
)
def test_bounds_are_enforced_at_their_edges(f: Any) -> None:
    low, high, low_open, high_open = bounds_of(f)
    for bad in _just_outside(low, high, low_open, high_open):
        with pytest.raises(ParameterError, match=f.name):
            LearnerConfig(**{f.name: bad})
    inside = [v for v in (low, high) if math.isfinite(v)]
    for good in inside:
        edge_open = low_open if good == low else high_open
        if not edge_open:
            LearnerConfig(**{f.name: int(good) if field_kind(f)[0] is int else good})


def test_true_false_fields_refuse_other_values() -> None:
    for name in ("reset_trace", "normalise", "symmetric", "robust"):
        with pytest.raises(ParameterError, match=name):
            LearnerConfig(**{name: 1})


def test_options_reach_the_config() -> None:
    c = learner_config_from(_parse("--learner", "rpe", "--alpha", "0.2", "--carry-trace"))
    assert (c.learner, c.alpha, c.reset_trace) == ("rpe", 0.2, False)
    assert learner_config_from(_parse("--no-normalise", "--learner", "rpe")).normalise is False
    assert learner_config_from(_parse("--track", "2")).track == 2.0
    assert learner_config_from(_parse()) == default_config("chapter")
    assert learner_config_from(_parse("--max-step", "inf")).max_step == math.inf
