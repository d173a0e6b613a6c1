"""The learner's options, shared by ``train`` and ``sweep``, read from :class:`LearnerConfig`.

Each field of :class:`~striatal.learners.config.LearnerConfig` states its help, bounds and
choices once (its metadata, :func:`striatal.learners.config.meta`); one loop here turns
them into options. Options left unset take the tuned preset of the chosen ``--learner``
(:func:`striatal.learners.default_config`); "chapter" keeps the chapter's learner exactly.
"""

from __future__ import annotations

import argparse
from dataclasses import Field, fields
from typing import Any

from striatal.cli.helpformat import default_note, default_text
from striatal.learners import RULES, LearnerConfig, default_config
from striatal.learners.config import bounds_text, field_kind


def learner_defaults() -> dict[str, LearnerConfig]:
    """The defaults of each registered learner (its tuned preset: striatal.learners)."""
    return {name: default_config(name) for name in RULES}


def option_fields() -> list[Field[Any]]:
    """The fields of LearnerConfig that are options, in their order."""
    return [f for f in fields(LearnerConfig) if f.metadata.get("cli", True)]


def flag_of(f: Field[Any]) -> str:
    """The option of field ``f`` (``--max-trials`` for max_trials)."""
    return "--" + f.metadata.get("flag", f.name.replace("_", "-"))


#: The word that sets an optional number (``--track``, ``--max-force``) to "no limit".
NONE = "none"


def _optional(kind: Any) -> Any:
    """The option type of an optional number field: a number, or ``none`` (no limit)."""

    def parse(text: str) -> Any:
        return NONE if text.strip().lower() == NONE else kind(text)

    parse.__name__ = getattr(kind, "__name__", "number")
    parse.numeric = True  # type: ignore[attr-defined]
    parse.takes_none = True  # type: ignore[attr-defined]
    return parse


def _defaults_note(f: Field[Any], presets: dict[str, LearnerConfig]) -> str:
    # only the learners that read the option: another's default would be offered in vain
    values = {
        name: getattr(c, f.name)
        for name, c in presets.items()
        if f.name in getattr(RULES[name], "options", (f.name,))
    }
    if not values:
        values = {name: getattr(c, f.name) for name, c in presets.items()}
    if len(set(values.values())) == 1:
        value = next(iter(values.values()))
        return default_note("none" if value is None else default_text(value))
    return default_note(", ".join(f"{k} {default_text(v)}" for k, v in values.items()))


def _help(f: Field[Any], presets: dict[str, LearnerConfig]) -> str:
    text = f.metadata["help"]
    if f.metadata.get("bounds"):
        text += f"; {bounds_text(f)}"
    kind, _, _ = field_kind(f)
    plain_flag = kind is bool and not f.metadata.get("negatable")
    if plain_flag and all(getattr(c, f.name) == f.default for c in presets.values()):
        return text  # a flag whose default is its absence for every learner
    return f"{text} {_defaults_note(f, presets)}"


def add_learner_arguments(parser: argparse.ArgumentParser) -> None:
    """--learner, and every LearnerConfig field that is an option (docs/paper-notes.md, 7)."""
    lg = parser.add_argument_group(
        "learning (the chapter leaves these open: docs/paper-notes.md, section 7)"
    )
    lg.add_argument(
        "--learner",
        choices=tuple(RULES),
        default="chapter",
        help="; ".join(f"{name}: {rule.summary}" for name, rule in RULES.items())
        + " (an option the chosen learner does not read is refused)",
    )
    presets = learner_defaults()
    for f in option_fields():
        kind, choices, optional = field_kind(f)
        flag, help_text = flag_of(f), _help(f, presets).replace("%", "%%")
        if kind is bool and "sets" in f.metadata:
            # a flag that sets the field to the opposite of its default: --carry-trace
            lg.add_argument(flag, action="store_true", help=help_text)
        elif kind is bool and f.metadata.get("negatable"):
            pair = lg.add_mutually_exclusive_group()
            pair.add_argument(flag, dest=f.name, action="store_const", const=True, help=help_text)
            pair.add_argument(
                f"--no-{flag[2:]}",
                dest=f.name,
                action="store_const",
                const=False,
                help=f"the opposite of {flag}",
            )
        elif kind is bool:
            lg.add_argument(flag, dest=f.name, action="store_const", const=True, help=help_text)
        else:
            lg.add_argument(
                flag,
                dest=f.name,
                type=_optional(kind) if optional and kind is float else kind,
                choices=choices or None,
                metavar=f.metadata.get("metavar"),
                help=help_text,
            )


def learner_changes(args: argparse.Namespace) -> dict[str, Any]:
    """The LearnerConfig fields the options set explicitly (the rest: the learner's preset)."""
    changes = {}
    for f in option_fields():
        if "sets" in f.metadata:
            if getattr(args, flag_of(f)[2:].replace("-", "_"), False):
                changes[f.name] = f.metadata["sets"]
        elif getattr(args, f.name, None) == NONE:
            changes[f.name] = None  # --track none: no limit, said explicitly
        elif getattr(args, f.name, None) is not None:
            changes[f.name] = getattr(args, f.name)
    return changes


def learner_config_from(args: argparse.Namespace) -> LearnerConfig:
    """The LearnerConfig the options describe (validated): the learner's preset, overridden."""
    return default_config(getattr(args, "learner", None) or "chapter", **learner_changes(args))
