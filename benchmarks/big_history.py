"""A big history.csv, and the peak memory of ``striatal curves`` on it (N12).

    python benchmarks/big_history.py SEED_RUN/history.csv OUT_DIR --mb 100
    /usr/bin/time -v .venv/bin/python -m striatal curves OUT_DIR/history.csv --out c.png

Writes OUT_DIR/history.csv: the rows of a real run's history repeated, with trial
numbers renumbered, until the file holds ``--mb`` megabytes (at most 256 MiB, the
largest input striatal reads), and copies the run's result.json beside it (the learner
and reward are read from it). docs/reliability.md ("A big history") used a 300-trial
chapter run (``striatal train --max-trials 300 --duration 5 --out SEED_RUN``) at 100 and
255 MB, and ``PYTHONPATH=SRC`` to time the old and the new code in turn.
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("history", type=Path, help="history.csv of a real run")
    parser.add_argument("out", type=Path, help="folder to write history.csv into")
    parser.add_argument("--mb", type=float, default=100.0, help="size of the file [MB]")
    args = parser.parse_args()
    lines = args.history.read_text().splitlines()
    header, rows = lines[0], [line.split(",", 1)[1] for line in lines[1:]]
    args.out.mkdir(parents=True, exist_ok=True)
    result = args.history.parent / "result.json"
    if result.exists():
        shutil.copy(result, args.out / "result.json")
    n = 0
    with (args.out / "history.csv").open("w") as f:
        f.write(header + "\n")
        while f.tell() < args.mb * 1e6:
            f.write(f"{n + 1},{rows[n % len(rows)]}\n")
            n += 1
    print(f"wrote {args.out / 'history.csv'}: {n} trials")


if __name__ == "__main__":
    main()
