"""What a page embeds: figures as PNG data URIs, and MathJax from its PyPI package."""

from __future__ import annotations

import base64
import io
from functools import cache
from importlib import resources
from typing import TYPE_CHECKING

from striatal.errors import StriatalError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["MATHJAX_COMPONENT", "REPORT_EXTRA", "mathjax_script", "png_data_uri"]

#: The extra that installs Jinja2 and MathJax.
REPORT_EXTRA = "pip install 'striatal[report]' (from a clone: pip install -e '.[report]')"
#: The MathJax 3 component the page embeds: TeX input, SVG output, every TeX extension
#: inside (nothing is loaded later, so nothing is fetched), no font files needed.
MATHJAX_COMPONENT = "es5/tex-svg-full.js"


def png_data_uri(fig: Figure, *, dpi: int = 110) -> str:
    """``fig`` as a ``data:image/png;base64,...`` URI (the figure is closed after)."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return "data:image/png;base64," + base64.b64encode(buffer.getvalue()).decode("ascii")


@cache
def mathjax_script() -> str:
    """The source of :data:`MATHJAX_COMPONENT` from the ``mathjax`` package
    (django-static-mathjax), safe to place inside a ``<script>`` element."""
    try:
        root = resources.files("mathjax") / "static" / "mathjax"
        text = (root / MATHJAX_COMPONENT).read_text(encoding="utf-8")
    except (ModuleNotFoundError, FileNotFoundError):
        raise StriatalError(f"the report typesets its maths with MathJax: {REPORT_EXTRA}") from None
    # a "</script" inside the source would end the element early
    return text.replace("</script", "<\\/script")
