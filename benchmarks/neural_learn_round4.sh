#!/bin/bash
# Round 4 of the spiking network's learning (docs/neural.md, "Learning at scale, round 4"):
# from the three network runs' files, the trimmed tables in docs/data, the rate learner
# beside each with the same trials and reward, the tables and the learning curves.
#
#   benchmarks/neural_learn_round4.sh CHAPTER.jsonl PGPE.jsonl RANDOM.jsonl
#
# CHAPTER: the chapter's rule and its control from W(0) (--side network --lockstep --alpha 5 0);
# PGPE: pgpe and its control from W(0) (--side loop --learner pgpe --lockstep --alpha 0.3 0);
# RANDOM: the chapter's rule and its control from random gains (--init random, --alpha 5 0).
# Each is compared over the trials every one of its runs has (--done); the rate runs take
# seconds. Writes docs/data/neural_learn_*_r4.csv, docs/data/neural_learn_r4_tables.txt and
# docs/img/neural_learn_r4_*.png.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
B=benchmarks/neural_learn.py
D=docs/data
export OPENBLAS_NUM_THREADS=1
[ $# -eq 3 ] || { echo "usage: $0 CHAPTER.jsonl PGPE.jsonl RANDOM.jsonl" >&2; exit 2; }
n_chapter=$($PY $B --done "$1")
n_pgpe=$($PY $B --done "$2")
n_random=$($PY $B --done "$3")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# the rate learner beside each network run: same rule, W(0), seeds, 30-s trials, reward;
# and the rate control with eq 21 off (theta_c fixed at 0.6)
$PY $B --side rate --seeds 0-19 --trials "$n_chapter" --duration 30 --alpha 5 0 \
    --out "$tmp/rate.jsonl"
$PY $B --side rate --seeds 0-19 --trials "$n_chapter" --duration 30 --alpha 0 \
    --theta-c-rule fixed --out "$tmp/rate.jsonl"
$PY $B --side rate --learner pgpe --seeds 0-19 --trials "$n_pgpe" --duration 30 \
    --alpha 0.3 0 --out "$tmp/rate_pgpe.jsonl"
$PY $B --side rate --init random --seeds 0-19 --trials "$n_random" --duration 30 \
    --alpha 5 0 --out "$tmp/rate_random.jsonl"
$PY $B --trim "$1" $D/neural_learn_brian2_r4.csv
$PY $B --trim "$2" $D/neural_learn_brian2_pgpe_r4.csv
$PY $B --trim "$3" $D/neural_learn_brian2_random_r4.csv
$PY $B --trim "$tmp/rate.jsonl" $D/neural_learn_rate_r4.csv
$PY $B --trim "$tmp/rate_pgpe.jsonl" $D/neural_learn_rate_pgpe_r4.csv
$PY $B --trim "$tmp/rate_random.jsonl" $D/neural_learn_rate_random_r4.csv
{
    echo "# from W(0), the chapter's rule: $n_chapter trials"
    $PY $B --compare $D/neural_learn_rate_r4.csv $D/neural_learn_brian2_r4.csv \
        --trials "$n_chapter" --block 10 --figure docs/img/neural_learn_r4_chapter.png \
        --title "the chapter's rule from the chapter's W(0), 30-s trials, seeds 0-19"
    $PY $B --compare $D/neural_learn_rate_r4.csv $D/neural_learn_brian2_r4.csv \
        --trials "$n_chapter" --block 10 --figure docs/img/neural_learn_r4_chapter_ran.png \
        --ran-only --title "the same, of the trials run (none filled in after a success)" \
        > /dev/null
    echo "# from W(0), pgpe: $n_pgpe trials"
    $PY $B --compare $D/neural_learn_rate_pgpe_r4.csv $D/neural_learn_brian2_pgpe_r4.csv \
        --trials "$n_pgpe" --block 5 --figure docs/img/neural_learn_r4_pgpe.png \
        --title "pgpe from the chapter's W(0), 30-s trials, seeds 0-19"
    echo "# from random gains, the chapter's rule: $n_random trials"
    $PY $B --compare $D/neural_learn_rate_random_r4.csv $D/neural_learn_brian2_random_r4.csv \
        --trials "$n_random" --block 5 --figure docs/img/neural_learn_r4_random.png \
        --title "the chapter's rule from random gains, 30-s trials, seeds 0-19"
    echo "# the learning arms' steps in W"
    $PY $B --drift $D/neural_learn_rate_r4.csv $D/neural_learn_brian2_r4.csv --trials "$n_chapter"
    $PY $B --drift $D/neural_learn_rate_random_r4.csv $D/neural_learn_brian2_random_r4.csv \
        --trials "$n_random"
    echo "# eq 21's ratchet in the no-learning controls"
    $PY benchmarks/eq21_ratchet.py --files $D/neural_learn_rate_r4.csv:rate \
        $D/neural_learn_brian2_r4.csv:network
} | tee $D/neural_learn_r4_tables.txt
