#!/usr/bin/env bash
# Issue 74's proof by learning: does a policy trained on demonstrations that fit the field's step
# limits finish in time, where one trained on the expert's earlier, longer demonstrations runs out?
#
#   benchmarks/pace.sh [WORK_DIR] [PART]     (WORK_DIR default: ../pace-work beside the repository;
#                                             PART: before, after, tail, deft, eval, report, or all,
#                                             the default)
#
# before  The expert as it was before issue 74 (git commit BEFORE, expert code aba7309349fc), checked
#         out as a worktree in WORK_DIR/before-src and run from there: 100 demonstrations of each of
#         libero_goal/3 and libero_spatial/7 (its episodes kept whatever their length, as then), and
#         the quick recipe trained on each. One fix of issue 74 is applied to that checkout
#         (benchmarks/pace_before_sampler_fix.patch): before it, LIBERO's placement sampler put
#         libero_spatial/7's bowl on the floor (0 of 800 attempts at its data); the expert's own
#         code is as it was.
# after   Today's expert on the same two tasks, each episode within its suite's standard limit
#         (generate's default --max-length), same recipe.
# tail    Today's expert with 10 steps recorded after the goal (`generate --after-goal 10`, as
#         LIBERO's human demonstrations have): the after-runs' policies stopped over the target with
#         the object held, a release being 3 frames of ~150. The same two tasks and the three on
#         which the quick recipe missed 80% in RESULTS ("Quick on the other suites":
#         libero_spatial/8, libero_goal/1, libero_10/0).
# deft    The expert at a deft pace (libero_goal/3 and /5; RESULTS, "Pending: libero_goal/3 and /5 at a
#         deft pace"), 10 steps after the goal, on libero_goal/3: its tail-run's policy ran out of
#         time on demonstrations taking 86% of the limit. While that expert is a pending patch
#         (benchmarks/results/expert_tables_pending/expert.patch), its data is made from a worktree
#         of HEAD with the patch applied (WORK_DIR/deft-src); once landed, from the repository.
# eval    Every run evaluated under the standard protocol (openpi's LIBERO loop, the suite's own
#         limit after the 10 waits: spatial 220, goal 300, libero_10 520) from stored init states
#         0-19 (`libero-bench eval RUN --protocol standard --trials 20`).
# report  The runs' reports, the standard evaluations' table and the paired comparisons of the two
#         tasks before and after, into benchmarks/results/pace/.
# carry-out  pack WORK's unfinished runs with the datasets they learn from, the finished ones (their
#         final checkpoint, 1.8 MB, no dataset) and the standard evaluations made (their JSON and
#         report) into CARRY (default benchmarks/results/pace/carry, to commit;
#         benchmarks/lifelong_carry.py): a session's
#         machine may keep only the repository, and this takes several sessions (~7 h of 2 cores:
#         7 datasets of ~20 min, 7 trainings of 33-113 min two at a time, 7 evaluations of ~10 min).
# carry-in   put them back into WORK; then run the part again.
#
# Data as benchmarks/quick_suites.sh makes it: 64x64, `fast` images, LIBERO's placement sampler with
# the stored states' arm noise (no stored init state: the evaluation's starts are unseen), seed 0.
# The quick preset unchanged but for its evaluation limit, set to openpi's (its own evaluation: 20
# stored and 20 held-out starts). Two runs at a time, one torch thread each; every step resumes.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
work="${1:-../pace-work}"
part="${2:-all}"
case "$part" in
  before | after | tail | deft | eval | report | all | carry-out | carry-in) ;;
  *) echo "pace.sh: PART must be before, after, tail, deft, eval, report, all, carry-out or carry-in, not '$part'" >&2; exit 2 ;;
esac
mkdir -p "$work/logs"
work=$(cd "$work" && pwd)
results=benchmarks/results/pace
export OMP_NUM_THREADS=1 SVT_LOG=1
ld=$repo/.venv/bin/libero-data
lb=$repo/.venv/bin/libero-bench
#: The last commit with the expert before issue 74 (expert code aba7309349fc).
BEFORE=d9e2855

# name:suite:task:limit, in the order they start (the longest demonstrations first)
before=(before-goal-3:libero_goal:3:300 before-spatial-7:libero_spatial:7:220)
after=(after-goal-3:libero_goal:3:300 after-spatial-7:libero_spatial:7:220)
tail=(tail-spatial-7:libero_spatial:7:220 tail-goal-3:libero_goal:3:300 tail-long-0:libero_10:0:520
  tail-spatial-8:libero_spatial:8:220 tail-goal-1:libero_goal:1:300)
deft=(deft-goal-3:libero_goal:3:300)
#: The pending expert change the deft runs' data is made with (none once it has landed).
pending=benchmarks/results/expert_tables_pending/expert.patch

finished() {  # run folder: whether it has learned and made its own evaluation (results.json)
  .venv/bin/python -c 'import sys, pathlib; from benchmarks.lifelong_carry import complete
sys.exit(not complete(pathlib.Path(sys.argv[1])))' "$1"
}
portable() {  # source target [old new]...: a copy naming WORK's paths relative to the file's folder,
  # a path in a folder OLD named as the same path in NEW (lifelong_carry.portable_copy)
  .venv/bin/python -c 'import sys; from pathlib import Path; from benchmarks.lifelong_carry import portable_copy
a = [Path(x) for x in sys.argv[1:]]
portable_copy(a[0], a[1], a[2], list(zip(a[3::2], a[4::2])))' "$1" "$2" "$work" "${@:3}"
}
#: what of a standard evaluation the report reads (its rollouts' recordings stay behind), and the
#: summaries pace_report and pace_release keep beside it where they were made
evaluation=(config.json results.json report.json report.md)
summaries=(failures_end.json release.json)

carry=${CARRY:-$results/carry}
if [[ $part == carry-out ]]; then
  also=()
  for entry in "${before[@]}" "${after[@]}" "${tail[@]}" "${deft[@]}"; do  # finished: its checkpoint and results go too
    name=${entry%%:*}
    if [[ -d $work/runs/$name ]] && finished "$work/runs/$name"; then also+=(--also "$name"); fi
  done
  .venv/bin/python -m benchmarks.lifelong_carry out "$work" "$carry" "${also[@]}"
  for entry in "${before[@]}" "${after[@]}" "${tail[@]}" "${deft[@]}"; do
    name=${entry%%:*}
    if [[ -f $work/standard/$name/report.json ]]; then
      mkdir -p "$carry/standard/$name"
      for f in "${evaluation[@]}"; do  # the carry keeps the run at CARRY/<run>
        portable "$work/standard/$name/$f" "$carry/standard/$name/$f" "$work/runs" "$carry"
      done
      for f in "${summaries[@]}"; do
        [[ -f $work/standard/$name/$f ]] && cp "$work/standard/$name/$f" "$carry/standard/$name/"
      done
    fi
  done
  exit
fi
if [[ $part == carry-in ]]; then
  .venv/bin/python -m benchmarks.lifelong_carry in "$carry" "$work"
  for folder in "$carry"/standard/*/; do
    [[ -d $folder ]] || continue
    name=$(basename "$folder")
    if [[ -e $work/standard/$name ]]; then
      echo "$work/standard/$name is here already: left as it is"
    else
      mkdir -p "$work/standard/$name"
      for f in "${evaluation[@]}"; do
        portable "$folder/$f" "$work/standard/$name/$f" "$carry/$name" "$work/runs/$name"
      done
      for f in "${summaries[@]}"; do
        [[ -f $folder/$f ]] && cp "$folder/$f" "$work/standard/$name/"
      done
    fi
  done
  exit
fi

checkout() {  # dir rev patch: a detached worktree of REV with PATCH applied (made once)
  [[ -d $1 ]] && return
  git worktree add --detach "$1" "$2" >/dev/null
  git -C "$1" apply "$3"
}
generate() {  # name suite task: the dataset WORK/<name>-64, made by the code in SRC (on the path first)
  local name=$1 suite=$2 index=$3 src=$repo after=0
  local common=(--suite "$suite" --tasks "$index" --episodes-per-task 100 --image-size 64
    --render-quality fast --workers 2 --seed 0 --out "$work/$name-64")
  if [[ $name == before-* ]]; then
    checkout "$work/before-src" "$BEFORE" "$repo/benchmarks/pace_before_sampler_fix.patch"
    # The old code; its generate kept every successful episode and had no --after-goal.
    (cd "$work/before-src" && PYTHONPATH="$work/before-src" $ld generate "${common[@]}")
    return
  fi
  [[ $name == tail-* || $name == deft-* ]] && after=10
  if [[ $name == deft-* && -f $pending ]]; then
    checkout "$work/deft-src" HEAD "$repo/$pending"
    src=$work/deft-src
  fi
  (cd "$src" && PYTHONPATH="$src" $ld generate "${common[@]}" --after-goal "$after")
}
train() {  # name task limit
  local name=$1 index=$2 limit=$3
  echo "$(date +%H:%M) start $name (log: $work/logs/$name.log)"
  $lb run --data "$work/$name-64" --tasks "$index" --algo seql --policy resnet_t --preset quick \
    --set eval_max_steps="$limit" --workers 2 --threads 1 --out "$work/runs/$name" >"$work/logs/$name.log" 2>&1
}
learn() {  # entries...: each task's data, then its run (two at a time)
  local pids=() entry name suite index limit failed=0
  for entry in "$@"; do
    IFS=: read -r name suite index limit <<<"$entry"
    if finished "$work/runs/$name"; then
      echo "$name: finished (its data is not made again)"  # e.g. carried in without its dataset
      continue
    fi
    generate "$name" "$suite" "$index"
    while (($(jobs -rp | wc -l) >= 2)); do wait -n || true; done
    train "$name" "$index" "$limit" &
    pids+=($!)
  done
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  ((failed == 0)) || { echo "a run failed; its log in $work/logs says why" >&2; exit 1; }
}
standard() {  # entries...: each run under the standard protocol
  local entry name suite index limit
  for entry in "$@"; do
    IFS=: read -r name suite index limit <<<"$entry"
    if [[ -f $work/standard/$name/report.json ]]; then
      echo "$name: evaluated already ($work/standard/$name)"
      continue
    fi
    if [[ ! -d $work/runs/$name ]] || ! finished "$work/runs/$name"; then
      echo "$name: not learned yet, not evaluated"
      continue
    fi
    $lb eval "$work/runs/$name" --protocol standard --trials 20 --tasks "$suite/$index" --workers 2 \
      --out "$work/standard/$name"
  done
}

case "$part" in
  before) learn "${before[@]}" ;;
  after) learn "${after[@]}" ;;
  tail) learn "${tail[@]}" ;;
  deft) learn "${deft[@]}" ;;
  eval) standard "${before[@]}" "${after[@]}" "${tail[@]}" "${deft[@]}" ;;
  all) learn "${before[@]}" && learn "${after[@]}" && learn "${tail[@]}" && learn "${deft[@]}" &&
    standard "${before[@]}" "${after[@]}" "${tail[@]}" "${deft[@]}" ;;
esac
if [[ $part == report || $part == all ]]; then
  mkdir -p "$results"
  runs=()
  for entry in "${before[@]}" "${after[@]}" "${tail[@]}" "${deft[@]}"; do
    name=${entry%%:*}
    if [[ ! -f $work/standard/$name/report.json ]]; then
      echo "$name: not evaluated yet, left out of the report"
      continue
    fi
    runs+=("$results/runs/$name")  # the committed copies: what the report names resolves on a clone
    if [[ ! -f $work/standard/$name/release.json && -d $work/$name-64 ]]; then  # needs the dataset
      .venv/bin/python -m benchmarks.pace_release "$work/runs/$name" "$work/$name-64" \
        --out "$work/standard/$name/release.json"
    fi
    mkdir -p "$results/runs/$name" "$results/standard/$name"
    cp "$work/runs/$name"/{config.json,results.json,timings.jsonl} "$results/runs/$name/"
    for f in "${evaluation[@]}"; do portable "$work/standard/$name/$f" "$results/standard/$name/$f"; done
  done
  $lb report "${runs[@]}" --out "$results/report"
  pairs=$(.venv/bin/python -c 'from benchmarks.pace_report import PAIRS; print(*(f"{a}:{b}" for a, b in PAIRS))')
  for pair in $pairs; do  # the runs pace_report pairs start for start
    a=${pair%%:*} b=${pair##*:}
    if [[ -f $work/standard/$a/report.json && -f $work/standard/$b/report.json ]]; then
      $lb compare "$results/runs/$a" "$results/runs/$b" --out "$results/compare-${b}"
    fi
  done
  .venv/bin/python -m benchmarks.pace_report "$work" --out "$results"
  echo "reports in $results"
fi
