"""Figures and animations only; no physics: the public face of :mod:`striatal.viz`.

Every figure function returns a :class:`matplotlib.figure.Figure` built on the Agg
backend (no display needed) so tests can inspect its artists; :func:`save_figure`
and :func:`save_animation` write files atomically
(:func:`striatal.io.files.atomic_write_file`). Trajectories come from
:func:`striatal.sim.rollout.simulate`. The figures live by what they show:

- :mod:`striatal.viz.trajectory`: Figure 5 of one run (snapshots, tip path, x, theta);
- :mod:`striatal.viz.curves`: learning curves and the rule panels;
- :mod:`striatal.viz.switch`: the cerebellar soft switch;
- :mod:`striatal.viz.animation`: frames, GIF and MP4;
- :mod:`striatal.viz.profiles`: performance profiles of sweeps;
- :mod:`striatal.viz.canvas`: the Agg canvas, output checks and the save.
"""

from __future__ import annotations

from striatal.io.rundir import read_history as read_history
from striatal.viz.animation import (
    MAX_FRAMES,
    MAX_TRACK,
    animation_frames,
    check_animation,
    ffmpeg_path,
    frame_times,
    save_animation,
)
from striatal.viz.canvas import check_image_path, save_figure
from striatal.viz.curves import RULE_PANELS, learning_curves, running_mean
from striatal.viz.profiles import arm_label, arm_labels, performance_profiles
from striatal.viz.switch import switch_figure
from striatal.viz.trajectory import (
    BALANCING_COLOUR,
    MAX_SNAPSHOTS,
    POSE_GAP,
    ROW_HEIGHT,
    ROW_SECONDS,
    SETTLED_BAND,
    SNAPSHOT_EVERY,
    SWINGUP_COLOUR,
    VIEW_LIMIT,
    Figure5Parts,
    display_theta,
    drawn_snapshots,
    figure5,
    figure5_caption,
    final_upright,
    gains_title,
    pole_tip,
    settled_from,
    snapshot_indices,
    snapshot_layout,
)

__all__ = [
    "BALANCING_COLOUR",
    "MAX_FRAMES",
    "MAX_SNAPSHOTS",
    "MAX_TRACK",
    "POSE_GAP",
    "ROW_HEIGHT",
    "ROW_SECONDS",
    "RULE_PANELS",
    "SETTLED_BAND",
    "SNAPSHOT_EVERY",
    "SWINGUP_COLOUR",
    "VIEW_LIMIT",
    "Figure5Parts",
    "animation_frames",
    "arm_label",
    "arm_labels",
    "check_animation",
    "check_image_path",
    "display_theta",
    "drawn_snapshots",
    "ffmpeg_path",
    "figure5",
    "figure5_caption",
    "final_upright",
    "frame_times",
    "gains_title",
    "learning_curves",
    "performance_profiles",
    "pole_tip",
    "read_history",
    "running_mean",
    "save_animation",
    "save_figure",
    "settled_from",
    "snapshot_indices",
    "snapshot_layout",
    "switch_figure",
]
