"""mkdocs hook: MathJax for the site, copied at build time from its PyPI package.

The maths of the pages (``pymdownx.arithmatex``, generic mode) is typeset in the browser
by MathJax 3's ``tex-svg-full.js`` component (every TeX extension inside, SVG output: no
font files and nothing loaded later). The file comes from the ``mathjax`` package
(django-static-mathjax, the ``report`` extra) into the built site as
``assets/mathjax/tex-svg-full.js``; it is not kept in the repository, and no page asks
a CDN for it.
"""

from __future__ import annotations

from importlib import resources

from mkdocs.config.defaults import MkDocsConfig
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

TARGET = "assets/mathjax/tex-svg-full.js"


def on_files(files: Files, config: MkDocsConfig) -> Files:
    try:
        source = resources.files("mathjax") / "static" / "mathjax" / "es5" / "tex-svg-full.js"
        path = str(source)
    except ModuleNotFoundError:
        raise PluginError(
            "the docs typeset maths with MathJax from PyPI: pip install -e '.[report]'"
        ) from None
    files.append(File.generated(config, TARGET, abs_src_path=path))
    return files
