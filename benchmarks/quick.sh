#!/usr/bin/env bash
# The `quick` preset on two CPU cores: does a policy learn from our demonstrations, and does
# sequential fine-tuning forget where experience replay does not?
#
#   benchmarks/quick.sh [WORK_DIR]     (default: ../quick-work beside the repository)
#
# 1. 50 demonstrations of each of the first three libero_object tasks, 64x64, starting from
#    LIBERO's sampler with the stored states' arm noise (no stored init state: the
#    evaluation's stored starts are unseen).
# 2. Each task trained alone (SeqL on a one-task list), quick preset: 20 stored and 20
#    held-out evaluation starts per task, drawn with `--render-quality fast` (simplified
#    meshes: 4.3x cheaper rollouts on CPU, no detectable effect on this policy's success;
#    RESULTS.md "Fast rendering: policy check"). Training images are the dataset's (full).
# 3. The three tasks in sequence with SeqL and with ER (same data, same seed).
# 4. Reports (with 95% intervals) and the paired comparison, into benchmarks/results/quick/.
#
# Every step resumes where it stopped when run again. Datasets, checkpoints and rollouts stay
# in WORK_DIR; the reports and each run's config.json, results.json and timings.jsonl are
# copied into benchmarks/results/quick/ (no checkpoints).
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-../quick-work}"
results=benchmarks/results/quick
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}" SVT_LOG=1
ld=.venv/bin/libero-data
lb=.venv/bin/libero-bench
run=(--policy resnet_t --preset quick --render-quality fast --workers 2 --threads 2)

$ld generate --suite libero_object --tasks 0,1,2 --episodes-per-task 50 --image-size 64 --workers 2 --seed 0 \
  --out "$work/object-64"
for t in 0 1 2; do
  $lb run --data "$work/object-64" --tasks "$t" --algo seql "${run[@]}" --out "$work/runs/single-$t"
done
for algo in seql er; do
  $lb run --data "$work/object-64" --tasks 0,1,2 --algo "$algo" "${run[@]}" --out "$work/runs/$algo"
done

mkdir -p "$results"
$lb report "$work/runs/single-0" "$work/runs/single-1" "$work/runs/single-2" --out "$results/single-task"
$lb report "$work/runs/seql" "$work/runs/er" --out "$results/lifelong"
$lb compare "$work/runs/seql" "$work/runs/er" --out "$results/lifelong"
for name in single-0 single-1 single-2 seql er; do
  mkdir -p "$results/runs/$name"
  cp "$work/runs/$name"/{config.json,results.json,timings.jsonl} "$results/runs/$name/"
done
echo "reports in $results"
