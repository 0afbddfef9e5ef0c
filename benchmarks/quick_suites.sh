#!/usr/bin/env bash
# The `quick` single-task recipe on one task of each of libero_spatial, libero_goal and
# libero_10, none of which any recipe was tuned on (the recipes were found on libero_object/0
# and /1). The tasks were drawn before any training, with numpy.random.default_rng(2026)
# .integers(10) once per suite in that order: libero_spatial/8, libero_goal/1, libero_10/0.
#
#   benchmarks/quick_suites.sh [WORK_DIR]     (default: ../quick-work beside the repository)
#
# 1. 100 demonstrations of each task at 64x64 with `fast` images, from LIBERO's placement
#    sampler with the stored states' arm noise (no stored init state: the evaluation's stored
#    starts are unseen), as benchmarks/quick.sh makes libero_object's.
# 2. Each task trained alone with the quick preset, evaluated from 20 stored and 20 held-out
#    starts with each suite's step limit (libero_data.tasks.horizons: spatial 280, goal 300,
#    libero_10 520).
# 3. The report (95% intervals) into benchmarks/results/quick/suites/, each run's config.json,
#    results.json and timings.jsonl into benchmarks/results/quick/runs/.
#
# Each task's run starts once its data is written, two runs at a time, one torch thread each (as
# quick.sh). Every step resumes when run again.
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-../quick-work}"
results=benchmarks/results/quick
export OMP_NUM_THREADS=1 SVT_LOG=1
ld=.venv/bin/libero-data
lb=.venv/bin/libero-bench

# name:suite:task
# libero_10/0 first: its demonstrations are 2.4x longer (mean 308 steps against ~126), so its
# training is the long pole and starts as soon as its data is written.
tasks=(long-0:libero_10:0 spatial-8:libero_spatial:8 goal-1:libero_goal:1)
mkdir -p "$work/logs"
start_run() {
  local name=$1 index=$2
  echo "$(date +%H:%M) start single-$name (log: $work/logs/single-$name.log)"
  $lb run --data "$work/$name-64" --tasks "$index" --algo seql --policy resnet_t --preset quick \
    --workers 2 --threads 1 --out "$work/runs/single-$name" \
    >"$work/logs/single-$name.log" 2>&1
}
pids=()
for entry in "${tasks[@]}"; do
  IFS=: read -r name suite index <<<"$entry"
  # --max-length none: the committed runs were trained on data made before generate bounded episode
  # lengths (libero_spatial/8's expert episodes reach 208 of its 220-step standard limit), and
  # --after-goal 0 before it recorded steps after the goal
  $ld generate --suite "$suite" --tasks "$index" --episodes-per-task 100 --image-size 64 \
    --render-quality fast --workers 2 --seed 0 --max-length none --after-goal 0 --out "$work/$name-64"
  while (($(jobs -rp | wc -l) >= 2)); do wait -n || true; done
  start_run "$name" "$index" &
  pids+=($!)
done
failed=0
for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
((failed == 0)) || { echo "a run failed; its log in $work/logs says why" >&2; exit 1; }

runs=()
for entry in "${tasks[@]}"; do
  name=${entry%%:*}
  runs+=("$work/runs/single-$name")
  mkdir -p "$results/runs/single-$name"
  cp "$work/runs/single-$name"/{config.json,results.json,timings.jsonl} "$results/runs/single-$name/"
done
$lb report "${runs[@]}" --out "$results/suites"
echo "report in $results/suites"
