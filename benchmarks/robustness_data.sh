#!/usr/bin/env bash
# Does training on our variant demonstrations make a policy robust? (issue 36)
#
#   benchmarks/robustness_data.sh [WORK_DIR]     (default: ../quick-work beside the repository)
#
# Two tasks of two suites, libero_object/0 and libero_spatial/8, each trained twice with the
# quick preset at the same budget (same epochs, same gradient steps per epoch):
#   (a) on its 100 unperturbed demonstrations (the quick single-task runs of benchmarks/quick.sh
#       and benchmarks/quick_suites.sh: the same commands, so an existing run is reused);
#   (b) on the same demonstrations mixed with variant demonstrations of levels 1-3 of camera,
#       lighting, texture, noise and robot_init (20 per variant, 300 per task), half of each
#       epoch's windows drawn from them (libero-bench run --mix, --mix-weight 0.5).
# Both are swept over all nine kinds at levels 1, 3 and 5 from the same 10 held-out placements
# per cell (the sweep draws its own variants: the same levels, other values than the training
# variants), then compared start for start per task and pooled over both
# (benchmarks/robustness_data_report.py).
#
# Runs go two at a time, one torch thread each. Every step resumes when run again. Datasets,
# checkpoints and rollouts stay in WORK_DIR; reports, comparisons, plots and each run's
# config.json / results.json go to benchmarks/results/robustness_data/.
set -euo pipefail
cd "$(dirname "$0")/.."
work="${1:-../quick-work}"
results=benchmarks/results/robustness_data
export OMP_NUM_THREADS=1 SVT_LOG=1
ld=.venv/bin/libero-data
lb=.venv/bin/libero-bench
kinds=camera,lighting,texture,noise,robot_init
common=(--image-size 64 --render-quality fast --workers 2 --seed 0)

# name:suite:task:dataset-folder:dataset-tasks
tasks=(object-0:libero_object:0:object-64:0,1,2 spatial-8:libero_spatial:8:spatial-8-64:8)
for entry in "${tasks[@]}"; do
  IFS=: read -r name suite index data data_tasks <<<"$entry"
  $ld generate --suite "$suite" --tasks "$data_tasks" --episodes-per-task 100 "${common[@]}" --out "$work/$data"
  $ld generate --variants-of "$suite" --tasks "$index" --kinds "$kinds" --level 1,2,3 \
    --episodes-per-task 20 "${common[@]}" --out "$work/$name-variants"
done

mkdir -p "$work/logs"
train() {  # name data task [mix]
  local name=$1 data=$2 index=$3 mix=${4:-}
  local extra=()
  [[ -n "$mix" ]] && extra=(--mix "$mix" --mix-weight 0.5)
  echo "$(date +%H:%M) start $name (log: $work/logs/$name.log)"
  $lb run --data "$data" --tasks "$index" --algo seql --policy resnet_t --preset quick \
    --workers 2 --threads 1 "${extra[@]}" --out "$work/runs/$name" \
    >"$work/logs/$name.log" 2>&1
}
jobs_list=()
for entry in "${tasks[@]}"; do
  IFS=: read -r name _suite index data _ <<<"$entry"
  single=single-$name
  [[ $name == object-0 ]] && single=single-0  # benchmarks/quick.sh's name for it
  jobs_list+=("$single:$work/$data:$index:" "mixed-$name:$work/$data:$index:$work/$name-variants")
done
pids=()
for job in "${jobs_list[@]}"; do
  IFS=: read -r name data index mix <<<"$job"
  while (($(jobs -rp | wc -l) >= 2)); do wait -n || true; done
  train "$name" "$data" "$index" "$mix" &
  pids+=($!)
done
failed=0
for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
((failed == 0)) || { echo "a run failed; its log in $work/logs says why" >&2; exit 1; }

for job in "${jobs_list[@]}"; do
  IFS=: read -r name _ _ _ <<<"$job"
  suite_task=$(.venv/bin/python -c "import json,sys; c=json.load(open(sys.argv[1])); print(c['dataset']['suite'] + '/' + str(c['tasks'][0]['suite_index']))" "$work/runs/$name/config.json")
  echo "$(date +%H:%M) sweep $name ($suite_task)"
  $lb robustness "$work/runs/$name" --tasks "$suite_task" --levels 1,3,5 --rollouts 10 \
    --render-quality fast --workers 2 --out "$work/sweeps/$name" >"$work/logs/sweep-$name.log" 2>&1
  mkdir -p "$results/sweeps/$name" "$results/runs/$name"
  cp "$work/sweeps/$name"/robustness.{json,md,png} "$results/sweeps/$name/"
  cp "$work/runs/$name"/{config.json,results.json,timings.jsonl} "$results/runs/$name/"
done
.venv/bin/python -m benchmarks.robustness_data_report "$results"
echo "report in $results"
