"""Performance profiles: the fraction of seeds solved against the budget, one line per arm.

The profiles come from :func:`striatal.experiments.profiles.sweep_profiles`; the arms
are named for a reader from the sweep's recorded settings (:func:`arm_label`), and the
legend goes where it covers no curve (:func:`legend_overlap`), outside the axes when
no place inside is free.
"""

from __future__ import annotations

import textwrap
from collections import Counter
from collections.abc import Mapping, Sequence
from itertools import pairwise
from typing import TYPE_CHECKING, Any, Literal, Protocol, get_args

import numpy as np

from striatal.errors import ParameterError
from striatal.viz.canvas import new_figure

__all__ = [
    "BASELINE_NAMES",
    "LEGEND_PLACES",
    "ProfileCurve",
    "arm_label",
    "arm_labels",
    "curve_points",
    "legend_overlap",
    "performance_profiles",
    "sweep_title",
    "sweeps_title",
]

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend


class ProfileCurve(Protocol):
    """What a profile line is drawn from (a :class:`striatal.experiments.profiles.Profile`):
    ``budget`` (k,) ascending, ``solved`` (k,) the fraction of ``runs`` seeds solved within
    it, ``low``/``high`` (k,) its band; ``arm`` names it, ``successes`` of ``runs`` solved."""

    @property
    def arm(self) -> str: ...
    @property
    def runs(self) -> int: ...
    @property
    def successes(self) -> int: ...
    @property
    def budget(self) -> np.ndarray: ...
    @property
    def solved(self) -> np.ndarray: ...
    @property
    def low(self) -> np.ndarray: ...
    @property
    def high(self) -> np.ndarray: ...


#: Readable names of the baseline methods of ``striatal sweep --baselines``.
BASELINE_NAMES: Mapping[str, str] = {
    "random": "random search",
    "cmaes": "CMA-ES",
    "lqr": "LQR",
    "hand": "hand-tuned",
}
LegendPlace = Literal[
    "lower right",
    "center right",
    "upper left",
    "upper right",
    "lower left",
    "center left",
    "upper center",
    "lower center",
    "center",
]
#: Places inside the axes tried for the legend, in this order.
LEGEND_PLACES: tuple[LegendPlace, ...] = get_args(LegendPlace)


def arm_label(arm: str, spec: Mapping[str, Any] | None) -> str:
    """A reader's name for the arm ``arm`` of a sweep.

    ``spec`` is the arm's entry in the ``settings.arms`` of the sweep's summary.json
    (``method``, ``role``, ``config.learner``): a learning arm is named by its
    learner, ``pgpe (learner)`` or ``pgpe control (no learning)``; a baseline by its
    method (``random search``, ``CMA-ES``). Without a usable ``spec``: ``arm``.
    """
    if not isinstance(spec, Mapping):
        return arm
    method = spec.get("method")
    if method == "learn":
        config = spec.get("config")
        learner = config.get("learner") if isinstance(config, Mapping) else None
        if not isinstance(learner, str):
            return arm
        role = spec.get("role", "control" if arm == "control" else "learner")
        return f"{learner} control (no learning)" if role == "control" else f"{learner} (learner)"
    if isinstance(method, str) and method in BASELINE_NAMES:
        return BASELINE_NAMES[method]
    return arm


def arm_labels(arms: Sequence[tuple[str, str, Mapping[str, Any] | None]]) -> list[str]:
    """Labels of ``(source, arm, spec)`` triples (:func:`arm_label`); a label that
    occurs more than once gets its source in brackets, ``random search (sweep-a)``, and
    one that still does (the arms of a grid) its arm's name, ``learner, alpha=0.5``."""
    labels = [arm_label(arm, spec) for _, arm, spec in arms]
    counts = Counter(labels)
    labels = [
        f"{label} ({source})" if counts[label] > 1 else label
        for label, (source, _, _) in zip(labels, arms, strict=True)
    ]
    # arms of one sweep that the spec does not tell apart (a grid's alphas): by their name
    counts = Counter(labels)
    return [
        f"{label}, {arm.rpartition('/')[2]}" if counts[label] > 1 else label
        for label, (_, arm, _) in zip(labels, arms, strict=True)
    ]


def curve_points(ax: Axes, profiles: Sequence[ProfileCurve], spacing: float = 2.0) -> np.ndarray:
    """(n, 2) display coordinates [px] along every step line of ``profiles`` drawn on
    ``ax``, risers included, at most ``spacing`` px apart."""
    chunks = []
    for p in profiles:
        x = np.repeat(p.budget, 2)[1:]
        y = np.repeat(p.solved, 2)[:-1]
        xy = ax.transData.transform(np.column_stack([x, y]))
        chunks.append(xy[:1])
        for a, b in pairwise(xy):
            n = max(1, int(np.ceil(np.hypot(*(b - a)) / spacing)))
            chunks.append(a + np.outer(np.arange(1, n + 1) / n, b - a))
    return np.concatenate(chunks) if chunks else np.empty((0, 2))


def legend_overlap(legend: Legend, points: np.ndarray, pad: float = 2.0) -> int:
    """How many of ``points`` (display coordinates) lie in ``legend``'s box grown by ``pad`` px."""
    box = legend.get_window_extent().padded(pad)
    x, y = points[:, 0], points[:, 1]
    return int(np.count_nonzero((x >= box.x0) & (x <= box.x1) & (y >= box.y0) & (y <= box.y1)))


def sweep_title(settings: Mapping[str, Any]) -> str:
    """The setting of a sweep in a few words, from its sweep.json ``settings``: learner,
    W(0), seeds and root, budget and success test (``pgpe learner from random W(0): 100 seeds
    (root 0), at most 300 trials, success on the mean policy``); "" without settings."""
    arms = settings.get("arms")
    learners = sorted(
        {
            a["config"]["learner"]
            for a in arms.values()
            if isinstance(a, Mapping)
            and a.get("method") == "learn"
            and isinstance(a.get("config"), Mapping)
            and isinstance(a["config"].get("learner"), str)
        }
        if isinstance(arms, Mapping)
        else ()
    )
    if not learners or "seeds" not in settings:
        return ""
    inits = settings.get("inits") or ["chapter"]
    start = " and ".join("the chapter's W(0)" if i == "chapter" else "random W(0)" for i in inits)
    root = settings.get("root_seed", 0)
    who = f"{' and '.join(learners)} learner{'s' if len(learners) > 1 else ''}"
    parts = [f"{who} from {start}: {settings['seeds']} seeds (root {root})"]
    if "max_trials" in settings:
        parts.append(f"at most {settings['max_trials']} trials")
    on = settings.get("success_on")
    if on == "mean":
        parts.append("success on the mean policy")
    elif on == "noisy":
        parts.append("success on the noisy trial")
    if settings.get("robust"):
        parts.append("robust stop rule")
    return ", ".join(parts)


def sweeps_title(settings: Sequence[Mapping[str, Any]]) -> str:
    """The settings of several sweeps in one title: ``pgpe and chapter learners from
    random W(0): ...`` when they differ only in the learner, else one line each
    (:func:`sweep_title`; a line that repeats is given once)."""
    titles = list(dict.fromkeys(t for t in (sweep_title(s) for s in settings) if t))
    heads = [t.partition(" learner from ")[0] for t in titles]
    rests = {t.partition(" learner from ")[2] for t in titles}
    if len(titles) > 1 and len(rests) == 1 and all(" learner from " in t for t in titles):
        return f"{' and '.join(heads)} learners from {rests.pop()}"
    return "\n".join(titles)


def performance_profiles(
    profiles: Sequence[ProfileCurve],
    *,
    xlabel: str,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> Figure:
    """Fraction of seeds solved against budget, one step line per arm with its 95 % band.

    ``profiles`` from :func:`striatal.experiments.profiles.sweep_profiles`; the band is the
    pointwise Wilson interval. ``labels`` name the arms in the legend (default: each
    profile's ``arm``; :func:`arm_labels` makes readable ones). The legend takes the
    first place of :data:`LEGEND_PLACES` where it covers no point of any line, else
    it goes outside the axes, on the right. The figure holds no other text: a note
    on the data (e.g. the trials fallback) belongs to the caption.
    """
    names = [p.arm for p in profiles] if labels is None else list(labels)
    if len(names) != len(profiles):
        raise ParameterError(f"{len(names)} labels for {len(profiles)} profiles")
    fig = new_figure(8.0, 5.0)
    ax = fig.subplots()
    for i, (p, name) in enumerate(zip(profiles, names, strict=True)):
        colour = f"C{i % 10}"
        ax.fill_between(p.budget, p.low, p.high, step="post", color=colour, alpha=0.2, lw=0)
        ax.step(
            p.budget,
            p.solved,
            where="post",
            color=colour,
            lw=1.6,
            label=f"{name}: {p.successes}/{p.runs} solved",
        )
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlim(left=0.0)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("fraction of seeds solved within budget")
    ax.grid(True, color="0.9", lw=0.5)
    text = title or "Performance profiles (bands: pointwise Wilson 95 %)"
    lines = [w for line in text.splitlines() for w in textwrap.wrap(line, 95) or [""]]
    ax.set_title("\n".join(lines), fontsize=10)
    legend = ax.legend(loc=LEGEND_PLACES[0], fontsize=9, framealpha=0.9)
    fig.canvas.draw()
    points = curve_points(ax, profiles)
    for place in LEGEND_PLACES:
        legend.set_loc(place)
        if legend_overlap(legend, points) == 0:
            return fig
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9, frameon=False)
    return fig
