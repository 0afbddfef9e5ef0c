#!/usr/bin/env bash
# The `quick` preset on two CPU cores: does a policy learn from our demonstrations, and does
# sequential fine-tuning forget where experience replay does not?
#
#   benchmarks/quick.sh [WORK_DIR] [PART]   (WORK_DIR default: ../quick-work beside the repository;
#                                            PART: single, lifelong or all, the default)
#
# 1. 100 demonstrations of each of the first three libero_object tasks, 64x64, `fast` images
#    (simplified meshes; 2.2x the episodes per minute), starting from LIBERO's sampler with the
#    stored states' arm noise (no stored init state: the evaluation's stored starts are unseen).
# 2. Each task trained alone (SeqL on a one-task list), quick preset: ResNet-T at the quick
#    size on 5-frame windows, 16 epochs, batch 32; 20 stored and 20 held-out evaluation starts
#    per task of at most the suite's step limit (libero_object: 280), `fast` images (4.3x cheaper rollouts on CPU, no detectable effect on success;
#    RESULTS.md "Fast rendering: policy check").
# 3. The three tasks in sequence with SeqL and with ER (same data, same seed).
# 4. Reports (with 95% intervals) and the paired comparison, into benchmarks/results/quick/.
#
# PART picks the runs: `single` makes the data and the three single-task runs (~2 h), `lifelong`
# the SeqL/ER pair (~4 h), `all` both. The five runs go two at a time, one torch thread each: on two cores that trains 1.16x more
# samples per second than one run on two threads (RESULTS.md "Learning on CPU"). Each run's
# output is in WORK_DIR/logs/. Every step resumes where it stopped when run again. Datasets,
# checkpoints and rollouts stay in WORK_DIR; the reports and each run's config.json,
# results.json and timings.jsonl are copied into benchmarks/results/quick/ (no checkpoints).
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-../quick-work}"
part="${2:-all}"
case "$part" in single | lifelong | all) ;; *) echo "quick.sh: PART must be single, lifelong or all, not '$part'" >&2; exit 2 ;; esac
results=benchmarks/results/quick
export OMP_NUM_THREADS=1 SVT_LOG=1
ld=.venv/bin/libero-data
lb=.venv/bin/libero-bench

# --after-goal 0: the committed runs were trained on data made before the expert recorded steps after the goal
$ld generate --suite libero_object --tasks 0,1,2 --episodes-per-task 100 --image-size 64 \
  --render-quality fast --workers 2 --seed 0 --after-goal 0 --out "$work/object-64"

# name:tasks:algorithm, in the order they start
singles=(single-1:1:seql single-2:2:seql single-0:0:seql)
pair=(er:0,1,2:er seql:0,1,2:seql)
case "$part" in single) runs=("${singles[@]}") ;; lifelong) runs=("${pair[@]}") ;; all) runs=("${singles[@]}" "${pair[@]}") ;; esac
mkdir -p "$work/logs"
start_run() {
  local name=${1%%:*} rest=${1#*:}
  local tasks=${rest%%:*} algo=${rest#*:}
  echo "$(date +%H:%M) start $name (log: $work/logs/$name.log)"
  $lb run --data "$work/object-64" --tasks "$tasks" --algo "$algo" --policy resnet_t --preset quick \
    --workers 2 --threads 1 --out "$work/runs/$name" >"$work/logs/$name.log" 2>&1
}
pids=()
for entry in "${runs[@]}"; do
  while (($(jobs -rp | wc -l) >= 2)); do wait -n || true; done
  start_run "$entry" &
  pids+=($!)
done
failed=0
for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
((failed == 0)) || { echo "a run failed; its log in $work/logs says why" >&2; exit 1; }

mkdir -p "$results"
if [[ $part != lifelong ]]; then
  $lb report "$work/runs/single-0" "$work/runs/single-1" "$work/runs/single-2" --out "$results/single-task"
fi
if [[ $part != single ]]; then
  $lb report "$work/runs/seql" "$work/runs/er" --out "$results/lifelong"
  $lb compare "$work/runs/seql" "$work/runs/er" --out "$results/lifelong"
fi
for entry in "${runs[@]}"; do
  name=${entry%%:*}
  mkdir -p "$results/runs/$name"
  cp "$work/runs/$name"/{config.json,results.json,timings.jsonl} "$results/runs/$name/"
done
echo "reports in $results"
