"""What a researcher reads: one self-contained HTML page per sweep, training run or
comparison of sweeps (``striatal report``).

The page is a Jinja2 template (package data, ``templates/``) filled from the objects
:func:`striatal.experiments.results.load` opens; its figures are the project's own
(:mod:`striatal.viz`), embedded as PNG data, and its maths is typeset in the browser by
a copy of MathJax installed from PyPI (the ``report`` extra), embedded in the page, so
the file opens with no network. Nothing here computes a statistic: every number comes
from :mod:`striatal.experiments`.
"""
