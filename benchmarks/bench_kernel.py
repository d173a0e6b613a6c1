"""Kernel speed against Gymnasium's CartPole: a thin wrapper of ``striatal bench``.

    python benchmarks/bench_kernel.py [--quick] [--json] [--batch-size B] [--seconds S]

Same options and output as ``striatal bench``; the measurements live in
the package striatal.bench and the figures in docs/performance.md.
"""

from __future__ import annotations

import sys

from striatal.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))
