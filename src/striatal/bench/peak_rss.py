"""Run a command as a child process; print its wall time and peak resident set as JSON.

    python -P path/to/striatal/bench/peak_rss.py COMMAND [ARGS...]

``maxrss_kib`` is ``ru_maxrss`` of the children (Linux: KiB): with several worker
processes, the largest single one. Standard library only, so this process adds
nothing to what it measures.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import time


def main(argv: list[str]) -> None:
    t0 = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    print(
        json.dumps(
            {
                "returncode": proc.returncode,
                "stderr": proc.stderr[-300:],
                "wall": wall,
                "maxrss_kib": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss,
            }
        )
    )


if __name__ == "__main__":
    main(sys.argv[1:])
