"""``striatal report``: one self-contained HTML page per sweep, training run or comparison.

:func:`render` fills the template ``templates/report.html.j2`` from what
:func:`striatal.experiments.results.load` opens: for a sweep its settings, every arm's
success rate with its Wilson 95 % interval, the paired tests of each learner against its
control and the baselines, the performance profiles and the commands that made it; for a
training run its outcome, learning curves and command. Several sweeps get one profile
figure over all their arms first. :func:`write_report` writes the page atomically.
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from striatal.errors import ParameterError, StriatalError
from striatal.experiments.profiles import X_LABELS, Profile
from striatal.experiments.results import Sweep, load
from striatal.experiments.training import Run
from striatal.io.files import atomic_write_text
from striatal.learners import LearnerConfig, default_config
from striatal.reports.assets import REPORT_EXTRA, mathjax_script, png_data_uri

__all__ = ["Source", "render", "sweep_command", "train_command", "write_report"]


@dataclass(frozen=True)
class Source:
    """One folder of the page: ``name`` (its folder's), ``path`` as given, what it holds."""

    name: str
    path: str
    item: Sweep | Run


def _pct(v: Any) -> str:
    return f"{100 * v:.0f} %" if isinstance(v, int | float) and math.isfinite(v) else "–"


def _num(v: Any, fmt: str = ".4g") -> str:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        return "–"
    return format(v, fmt)


def _interval(ci: Any, scale: float = 1.0, fmt: str = ".4g") -> str:
    if not isinstance(ci, list | tuple) or len(ci) != 2:
        return ""
    return f" [{_num(ci[0] * scale, fmt)}, {_num(ci[1] * scale, fmt)}]"


def _p(v: Any) -> str:
    return _num(v, ".3g")


def _option_words(name: str, value: Any) -> list[str]:
    """``--name value`` as a command line writes it ([] for an option left off)."""
    if value is None or value is False or value == []:
        return []
    if value is True:
        return [f"--{name}"]
    if isinstance(value, list):
        return [f"--{name}", ",".join(str(v) for v in value)]
    return [f"--{name}", str(value)]


def sweep_command(settings: Mapping[str, Any]) -> str | None:
    """The ``striatal sweep`` command with every option the sweep recorded
    (``settings.options``), None when it recorded none (a sweep from the Python API)."""
    recorded = settings.get("options")
    if not isinstance(recorded, Mapping) or not recorded:
        return None
    words = ["striatal", "sweep"]
    for name, value in recorded.items():
        words += _option_words(str(name), value)
    return " ".join(words)


def _config_words(config: LearnerConfig, base: LearnerConfig) -> list[str]:
    """The learner options by which ``config`` differs from ``base`` (its preset)."""
    words: list[str] = []
    for f in fields(LearnerConfig):
        value, default = getattr(config, f.name), getattr(base, f.name)
        if f.name == "learner" or value == default or f.metadata.get("cli") is False:
            continue
        flag = f.metadata.get("flag", f.name.replace("_", "-"))
        if isinstance(value, bool):
            if "sets" in f.metadata:
                words += [f"--{flag}"] if value == f.metadata["sets"] else []
            else:
                words += [f"--{flag}" if value else f"--no-{flag}"]
        elif isinstance(value, tuple | list):
            words += [f"--{flag}", ",".join(str(v) for v in value)]
        else:
            words += [f"--{flag}", str(value)]
    return words


def train_command(run: Run) -> str:
    """The ``striatal train`` command that reruns ``run`` (its learner, init, seed and
    every learner option that differs from the learner's preset)."""
    s = run.settings
    words = ["striatal", "train", "--learner", run.learner]
    if s.get("init") == "gains":
        words += ["--init-gains", ",".join(f"{w:g}" for w in s["W0"])]
    else:
        words += ["--init", str(s.get("init", "chapter"))]
    words += ["--seed", str(run.seed)]
    if s.get("theta_c0") not in (None, 0.6):
        words += ["--theta-c0", str(s["theta_c0"])]
    config = s.get("config")
    if isinstance(config, Mapping):
        values = dict(config)
        if values.get("max_step") is None:
            values["max_step"] = math.inf
        try:
            mine = LearnerConfig(**values)
            base = default_config(run.learner, robust=mine.robust)
            words += _config_words(mine, base)
        except (TypeError, ValueError):
            pass  # settings of another version: the learner, init and seed alone
    if run.out is not None:
        words += ["--out", str(run.out)]
    return " ".join(words)


def _arm_rows(sweep: Sweep) -> list[dict[str, str]]:
    from striatal.viz.profiles import arm_label

    specs = sweep.settings.get("arms", {})
    rows = []
    for a in sweep.arms:
        s = a.stats
        rows.append(
            {
                "arm": a.name,
                "label": arm_label(a.name, specs.get(a.name) if isinstance(specs, dict) else None),
                "role": a.role,
                "init": a.init,
                "solved": f"{a.successes}/{a.runs}",
                "rate": _pct(a.success_rate) + _interval(a.interval, 100, ".0f"),
                "median": _num(s.get("simulations_median"))
                + _interval(s.get("simulations_median_ci")),
                "iqm": _num(s.get("simulations_iqm")) + _interval(s.get("simulations_iqm_ci")),
                "simulations": _num(s.get("simulations_total"), ",d")
                if isinstance(s.get("simulations_total"), int)
                else "–",
                "mean_seconds": _num(s.get("simulated_seconds_restricted_mean"), ".0f")
                + _interval(s.get("simulated_seconds_restricted_mean_ci"), 1, ".0f"),
            }
        )
    return rows


def _pair_rows(pairs: Sequence[Mapping[str, Any]], other: str) -> list[dict[str, str]]:
    rows = []
    for c in pairs:
        mc = c.get("mcnemar") or {}
        fisher = c.get("fisher") or {}
        rows.append(
            {
                "arm": str(c["arm"]),
                "other": str(c[other]),
                "init": str(c["init"]),
                "rate": _pct(c.get("success_rate"))
                + _interval(c.get("success_rate_ci"), 100, ".0f"),
                "other_rate": _pct(c.get(f"{other}_success_rate"))
                + _interval(c.get(f"{other}_success_rate_ci"), 100, ".0f"),
                "fisher": _p(fisher.get("p_value")),
                "mcnemar": _p(mc.get("p_value")),
                "only": f"{mc.get('only_a', '–')} / {mc.get('only_b', '–')}",
            }
        )
    return rows


def _settings_rows(settings: Mapping[str, Any]) -> list[tuple[str, str]]:
    """The settings a reader checks first, as (name, value) text."""
    arms = settings.get("arms", {})
    learners = sorted(
        {
            str(a["config"].get("learner"))
            for a in (arms.values() if isinstance(arms, Mapping) else ())
            if isinstance(a, Mapping)
            and a.get("method") == "learn"
            and isinstance(a.get("config"), Mapping)
        }
    )
    plant = settings.get("plant", {})
    trial = settings.get("trial", {})
    rows = [
        ("learner", ", ".join(learners) or "–"),
        ("arms", ", ".join(arms) if isinstance(arms, Mapping) else "–"),
        ("seeds per arm and init", str(settings.get("seeds", "–"))),
        ("root seed", f"{settings.get('root_seed', '–')} ({settings.get('seed_rule', '')})"),
        ("initial gains W(0)", ", ".join(settings.get("inits", [])) or "–"),
        ("θ_c(0) [rad]", str(settings.get("theta_c0", "–"))),
        ("trials per run, at most", str(settings.get("max_trials", "–"))),
        ("success judged on", str(settings.get("success_on", "–"))),
        ("pass-probability draws per estimate", str(settings.get("eval_draws", "–"))),
        (
            "plant",
            ", ".join(f"{k} {v}" for k, v in plant.items()) if isinstance(plant, Mapping) else "–",
        ),
        (
            "trial",
            ", ".join(f"{k} {v}" for k, v in trial.items()) if isinstance(trial, Mapping) else "–",
        ),
    ]
    if settings.get("tuning_root") is not None:
        rows.append(("preset tuned on root", str(settings["tuning_root"])))
    for key in ("control_reading", "budget", "robust", "trial_kernel"):
        if settings.get(key):
            rows.append((key.replace("_", " "), str(settings[key])))
    return rows


def _sweep_figure(sweep: Sweep) -> tuple[str, str]:
    """(PNG data URI, caption) of the sweep's performance profiles."""
    from striatal.viz.profiles import sweep_title

    _, column, note = sweep.profiles()
    fig = sweep.plot()
    caption = (
        f"Performance profiles of {sweep_title(sweep.settings) or 'the sweep'}: for each arm, "
        f"the fraction of its seeds solved within a budget of {X_LABELS[column]}, with the "
        "pointwise Wilson 95 % band; unsolved seeds stay in the denominator."
    )
    return png_data_uri(fig), caption + (f" Note: {note}" if note else "")


def _sweep_section(source: Source, sweep: Sweep) -> dict[str, Any]:
    from striatal.viz.profiles import sweep_title

    figure, caption = _sweep_figure(sweep)
    settings = sweep.settings
    commands = []
    made = sweep_command(settings)
    if made:
        commands.append(("the sweep", made + f" --out {source.path}"))
        commands.append(
            (
                "the same sweep again, from its recorded options",
                f"striatal sweep --from-summary {source.path}/summary.json --out OTHER_DIR",
            )
        )
    commands.append(("one of its runs alone", str(settings.get("reproduce", ""))))
    return {
        "kind": "sweep",
        "name": source.name,
        "path": source.path,
        "title": sweep_title(settings) or source.name,
        "settings": _settings_rows(settings),
        "arms": _arm_rows(sweep),
        "vs_control": _pair_rows(sweep.learner_vs_control, "control"),
        "vs_baselines": _pair_rows(sweep.learner_vs_baselines, "baseline"),
        "figure": figure,
        "caption": caption,
        "notes": list(sweep.summary.get("notes", [])),
        "commands": commands,
        "runs": len(sweep.runs),
    }


def _run_section(source: Source, run: Run) -> dict[str, Any]:
    from striatal.viz.curves import learning_curves

    curves = None
    if len(run.history):
        curves = png_data_uri(learning_curves(run.history))
    verdict = "interrupted" if run.interrupted else ("solved" if run.success else "not solved")
    outcome = [
        ("outcome", f"{verdict} after {run.trials} trials"),
        ("simulations (every simulated trial)", str(run.state.simulations)),
        ("simulated time [s]", _num(run.state.simulated_seconds, ".6g")),
        ("learned W1..W6", ", ".join(f"{w:.4f}" for w in run.W)),
        ("learned θ_c [rad]", f"{run.theta_c:.4f}"),
        ("mean policy passes the success test", "yes" if run.mean_policy_success else "no"),
        ("wall time [s]", _num(run.wall_seconds, ".3g")),
        ("run id", run.run_id),
    ]
    s = run.settings
    settings = [
        ("learner", run.learner),
        ("seed", str(run.seed)),
        (
            "initial gains W(0)",
            f"{s.get('init')}: " + ", ".join(f"{w:.4g}" for w in s.get("W0", [])),
        ),
        ("θ_c(0) [rad]", str(s.get("theta_c0"))),
        ("trials, at most", str(s.get("config", {}).get("max_trials", "–"))),
        ("success judged on", str(s.get("config", {}).get("success_on", "–"))),
        ("integrator", str(s.get("integrator", "–"))),
        ("reward timing", str(s.get("reward_timing", "–"))),
    ]
    return {
        "kind": "run",
        "name": source.name,
        "path": source.path,
        "title": f"{run.learner} learner, seed {run.seed}",
        "outcome": outcome,
        "settings": settings,
        "curves": curves,
        "commands": [("the run", train_command(run))],
    }


def _comparison_figure(sources: Sequence[Source]) -> str | None:
    """One profile figure over the arms of every sweep (None with fewer than two)."""
    sweeps = [(s, s.item) for s in sources if isinstance(s.item, Sweep)]
    if len(sweeps) < 2:
        return None
    from striatal.experiments.profiles import choose_x
    from striatal.viz.profiles import arm_labels, performance_profiles, sweeps_title

    columns = [c for c in X_LABELS if all(c in sw.runs[0] for _, sw in sweeps)]
    column, _ = choose_x(columns, None)
    profiles: list[Profile] = []
    triples = []
    for src, sw in sweeps:
        specs = sw.settings.get("arms", {})
        for p in sw.profiles(column)[0]:
            profiles.append(p)
            triples.append((src.name, p.arm, specs.get(p.arm)))
    labels = [
        f"{n}, {p.init} init" if p.init else n
        for n, p in zip(arm_labels(triples), profiles, strict=True)
    ]
    title = sweeps_title([sw.settings for _, sw in sweeps]) or None
    fig = performance_profiles(profiles, xlabel=X_LABELS[column], labels=labels, title=title)
    return png_data_uri(fig)


def render(paths: Sequence[str | Path], *, command: str = "") -> str:
    """The HTML page of the sweep or run folders ``paths`` (one or more)."""
    if not paths:
        raise ParameterError("give at least one sweep or run folder")
    try:
        import jinja2
    except ModuleNotFoundError:
        raise StriatalError(f"striatal report needs Jinja2: {REPORT_EXTRA}") from None
    from striatal import __version__

    sources = [Source(Path(p).resolve().name, str(p), load(p)) for p in paths]
    names = [s.name for s in sources]
    sections = [
        _sweep_section(s, s.item) if isinstance(s.item, Sweep) else _run_section(s, s.item)
        for s in sources
    ]
    kinds = {s["kind"] for s in sections}
    if len(sources) > 1:
        what = "Sweeps" if kinds == {"sweep"} else "Results"
        heading = f"{what} {', '.join(names)}"
    else:
        heading = f"{'Sweep' if kinds == {'sweep'} else 'Training run'} {names[0]}"
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("striatal.reports", "templates"),
        autoescape=jinja2.select_autoescape(("html", "j2")),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    template = env.get_template("report.html.j2")
    return template.render(
        heading=heading,
        sections=sections,
        has_sweep="sweep" in kinds,
        has_chapter_rule=any(
            isinstance(s.item, Run) and s.item.learner in ("chapter", "rpe") for s in sources
        ),
        comparison=_comparison_figure(sources),
        command=command or "striatal report " + " ".join(str(p) for p in paths),
        version=__version__,
        made=dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        mathjax=mathjax_script(),
    )


def write_report(paths: Sequence[str | Path], out: str | Path, *, command: str = "") -> Path:
    """Write :func:`render` of ``paths`` to ``out`` (atomically) and return its path."""
    target = Path(out)
    if target.suffix.lower() not in (".html", ".htm"):
        raise ParameterError(f"--out {out}: the report is an HTML page (.html)")
    page = render(paths, command=command)
    atomic_write_text(target, page)
    return target
