"""The canvas every figure is drawn on, and the checks and atomic save of image files."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from striatal.errors import DataFileError, ParameterError

__all__ = ["check_image_path", "new_figure", "save_figure"]

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def new_figure(
    width: float, height: float, *, layout: Literal["constrained"] | None = "constrained"
) -> Figure:
    """A Figure of ``width`` x ``height`` inches on the Agg canvas (never pyplot: no
    global state, no display)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), layout=layout)
    FigureCanvasAgg(fig)
    return fig


def check_image_path(path: Path, allowed: Sequence[str]) -> Path:
    """``path`` if its extension is one of ``allowed`` and its folder can be written."""
    p = Path(path)
    if p.suffix.lower() not in allowed:
        raise ParameterError(
            f"output {p} must end in one of {', '.join(allowed)} (got {p.suffix or 'none'})"
        )
    if p.is_dir():
        raise DataFileError(f"output {p} is a folder")
    from striatal.io.files import check_out_dir

    check_out_dir(p.parent if str(p.parent) else Path("."))
    return p


def save_figure(fig: Figure, path: Path, *, dpi: int = 120) -> None:
    """Write ``fig`` to ``path`` (format from the extension) atomically."""
    from striatal.io.files import atomic_write_file

    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    atomic_write_file(Path(path), lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))
