#!/usr/bin/env bash
# The LIBERO paper's five lifelong algorithms on one sequence of libero_object tasks, on record
# (issue 59): the same data, seed, step limit and held-out starts for SeqL, ER, EWC, PackNet and MTL.
#
#   benchmarks/lifelong.sh [WORK_DIR] [PART]    (WORK_DIR default: ../lifelong-work beside the repository)
#
# PART:
#   data   100 demonstrations of each of libero_object 0, 1, 2 with today's expert (64x64, `fast`
#          images, LIBERO's sampler starts with the stored states' arm noise), as benchmarks/quick.sh
#   sweep  the settings the quick preset leaves open, on tasks 0 and 1: EWC's penalty weight
#          (5e2, 5e3, 5e4: the paper's 5e4 was set for a 10x larger policy) and PackNet's pruned share
#          with a post-prune fine-tuning as long as a task's training (prune 0.5 and 0.75, 16 epochs);
#          each sweep run is a run on tasks 0, 1, 2 stopped after two tasks (--stop-after 2)
#   five   the five algorithms on tasks 0, 1, 2, seed 0; EWC and PackNet with the sweep's kept
#          setting (the highest held-out AUC, benchmarks/lifelong_report.py --pick; EWC_RUN and
#          PACKNET_RUN name another sweep run), going on from that run's folder when WORK_DIR holds it
#          instead of learning tasks 0 and 1 again (the report says which)
#   seeds  SeqL, ER, EWC and PackNet again with seeds 1 and 2 (SEEDS="1 2"; issue 78), the kept
#          settings; ~30 h of one-core runs (the seed-0 runs' timings: PackNet 5.5 h, ER 4.1, EWC
#          3.0, SeqL 2.6), ~15 h of the two cores
#   arch   ER and PackNet with ResNet-RNN and ViT-T, seed 0 (ARCH_SEEDS="0"; issue 78), runs
#          er-rnn-s0, er-vit-s0, packnet-rnn-s0, packnet-vit-s0
#   all    every part in turn
#   carry-out  pack WORK's unfinished runs and their dataset (without its MCAP logs) into CARRY
#          (default benchmarks/results/lifelong/carry, to commit): a session's machine may keep only
#          the repository (benchmarks/lifelong_carry.py)
#   carry-in   put them back into WORK, the dataset too where WORK has none (a dataset WORK has must
#          be the same bytes: one made again on another machine was not)
#
# A session on a machine that kept only the repository: scripts/setup, `carry-in`, the part with
# RUNS naming the runs to go on and new ones, and `carry-out` before the session ends, its folder
# committed.
#
# RUNS="seql-s0 mtl-s0" limits a part to the runs it names, started in that order (a session too short for a whole part
# runs some of its runs; the report is made once every run of the five is on record).
#
# seeds and arch learn from the five's data: where WORK_DIR has no object-64, it is taken from the
# commit that carried it (DATA_COMMIT; made on an AMD EPYC, digest DATA_DIGEST), since making it
# again on another machine gives other bytes, and a seed's runs are compared start for start with
# the seed-0 runs.
#
# Runs go two at a time, one torch thread each (benchmarks/quick.sh says why), or alone on two threads
# when a part has one run left; each resumes where it stopped when run again; logs in WORK_DIR/logs/.
# Datasets, checkpoints and rollouts stay in WORK_DIR; each run's config, results and timings are
# copied to benchmarks/results/lifelong/runs/ as soon as it finishes, then the sweep's table
# (sweep.md) and the report with the paper's findings (findings.md, report/).
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(realpath -m "${1:-../lifelong-work}")
part="${2:-all}"
case "$part" in
  data | sweep | five | seeds | arch | all | carry-out | carry-in) ;;
  *) echo "lifelong.sh: PART must be data, sweep, five, seeds, arch, all, carry-out or carry-in, not '$part'" >&2; exit 2 ;;
esac
preset=${PRESET:-quick}          # PRESET=smoke tries the script end to end in minutes
episodes=${EPISODES:-100}
export OMP_NUM_THREADS=1 SVT_LOG=1
ld=.venv/bin/libero-data
lb=.venv/bin/libero-bench
results=benchmarks/results/lifelong
[[ $preset == smoke ]] && results=$work/results  # a try of the script commits nothing
mkdir -p "$work/logs"
carry=${CARRY:-$results/carry}
if [[ $part == carry-out ]]; then
  .venv/bin/python -m benchmarks.lifelong_carry out "$work" "$carry"
  exit
fi
if [[ $part == carry-in ]]; then
  .venv/bin/python -m benchmarks.lifelong_carry in "$carry" "$work"
  exit
fi

start_run() {  # name tasks algo seed threads [run options...]; on success its files go to $results
  local name=$1 tasks=$2 algo=$3 seed=$4 threads=$5 policy=resnet_t
  shift 5
  [[ $name == *-rnn-s* ]] && policy=resnet_rnn
  [[ $name == *-vit-s* ]] && policy=vit_t
  echo "$(date +%H:%M) start $name (log: $work/logs/$name.log)"
  $lb run --data "$work/object-64" --tasks "$tasks" --algo "$algo" --policy "$policy" --preset "$preset" \
    --seed "$seed" --workers 2 --threads "$threads" --out "$work/runs/$name" "$@" >"$work/logs/$name.log" 2>&1
  mkdir -p "$results/runs/$name"  # what the report reads, committed; checkpoints stay in WORK_DIR
  cp "$work/runs/$name"/{config.json,results.json,timings.jsonl} "$results/runs/$name/"
  echo "$(date +%H:%M) done $name"
}

chosen() {  # name -> is it among $RUNS (every run when RUNS is unset)
  [[ -z ${RUNS:-} ]] || [[ " $RUNS " == *" $1 "* ]]
}

run_all() {  # entries "name|tasks|algo|seed|options", two at a time (the last one alone on two threads)
  local pids=() failed=0 entry name tasks algo seed options threads picked=() wanted
  if [[ -z ${RUNS:-} ]]; then
    picked=("$@")
  else  # in the order RUNS names them (the longest first shortens a session's queue)
    for wanted in $RUNS; do
      for entry in "$@"; do [[ ${entry%%|*} == "$wanted" ]] && picked+=("$entry"); done
    done
  fi
  local left=${#picked[@]}
  for entry in "${picked[@]}"; do
    while (($(jobs -rp | wc -l) >= 2)); do wait -n || true; done
    IFS='|' read -r name tasks algo seed options <<<"$entry"
    threads=1
    ((left == 1 && $(jobs -rp | wc -l) == 0)) && threads=2
    left=$((left - 1))
    # shellcheck disable=SC2086  # the options are words
    start_run "$name" "$tasks" "$algo" "$seed" "$threads" $options &
    pids+=($!)
  done
  for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
  ((failed == 0)) || { echo "a run failed; its log in $work/logs says why" >&2; exit 1; }
}

post_prune=16
[[ $preset == smoke ]] && post_prune=1
setting() {  # a sweep run's name -> its algorithm settings
  case $1 in
    sweep-ewc-*) echo "--algo-set penalty_weight=${1#sweep-ewc-}" ;;
    sweep-packnet-*) echo "--algo-set prune_fraction=0.${1#sweep-packnet-0} --algo-set post_prune_epochs=$post_prune" ;;
    *) echo "lifelong.sh: $1 is not a sweep run" >&2; exit 2 ;;
  esac
}
continue_from() {  # sweep-run run: the kept sweep run's folder becomes the run's, which goes on from it;
  # without it (a new WORK_DIR: the sweep's checkpoints are not committed) the run learns tasks 0 and 1
  # itself, with the same data, seed and settings
  chosen "$2" || return 0
  [[ -e $work/runs/$2 ]] && return 0
  if [[ -d $work/runs/$1 ]]; then
    cp -a "$work/runs/$1" "$work/runs/$2"
  else
    echo "$work/runs/$1 is not here: $2 learns tasks 0 and 1 itself"
  fi
}
#: The commit whose carry folder holds the five's data, and that data's digest (benchmarks/lifelong_carry.py).
DATA_COMMIT=68ed961^
DATA_DIGEST=825acfe7ccd1a9022e4746c781756a3a7a435014d8058f60e30d1acafd031b14
if [[ $part == seeds || $part == arch ]] && [[ ! -d $work/object-64 ]] && [[ $preset != smoke ]]; then
  echo "taking the five's data from $DATA_COMMIT"
  git archive "$DATA_COMMIT" benchmarks/results/lifelong/carry/datasets/object-64 | tar -x -C "$work" --strip-components=5
  digest=$(.venv/bin/python -c "import sys; from pathlib import Path; from benchmarks.lifelong_carry import data_digest; print(data_digest(Path(sys.argv[1])))" "$work/object-64")
  [[ $digest == "$DATA_DIGEST" ]] || { echo "$work/object-64 is not the five's data (digest $digest)" >&2; exit 1; }
fi
if [[ $part == data || $part == all ]]; then
  # --after-goal 0: the five's data was made before the expert recorded steps after the goal
  $ld generate --suite libero_object --tasks 0,1,2 --episodes-per-task "$episodes" --image-size 64 \
    --render-quality fast --workers 2 --seed 0 --after-goal 0 --out "$work/object-64"
fi
if [[ $part == sweep || $part == all ]]; then
  run_all \
    "sweep-ewc-500|0,1,2|ewc|0|$(setting sweep-ewc-500) --stop-after 2" \
    "sweep-ewc-5000|0,1,2|ewc|0|$(setting sweep-ewc-5000) --stop-after 2" \
    "sweep-ewc-50000|0,1,2|ewc|0|$(setting sweep-ewc-50000) --stop-after 2" \
    "sweep-packnet-050|0,1,2|packnet|0|$(setting sweep-packnet-050) --stop-after 2" \
    "sweep-packnet-075|0,1,2|packnet|0|$(setting sweep-packnet-075) --stop-after 2"
  .venv/bin/python -m benchmarks.lifelong_report --runs "$results/runs" --sweep --out "$results"
fi
if [[ $part == five || $part == seeds || $part == arch || $part == all ]]; then
  ewc_run=${EWC_RUN:-$(.venv/bin/python -m benchmarks.lifelong_report --runs "$results/runs" --pick ewc)}
  packnet_run=${PACKNET_RUN:-$(.venv/bin/python -m benchmarks.lifelong_report --runs "$results/runs" --pick packnet)}
  setting "$ewc_run" >/dev/null && setting "$packnet_run" >/dev/null  # a name that is no sweep run stops here
  echo "kept: $ewc_run ($(setting "$ewc_run")), $packnet_run ($(setting "$packnet_run"))"
fi
if [[ $part == five || $part == all ]]; then
  continue_from "$ewc_run" ewc-s0
  continue_from "$packnet_run" packnet-s0
  run_all \
    "seql-s0|0,1,2|seql|0|" \
    "er-s0|0,1,2|er|0|" \
    "ewc-s0|0,1,2|ewc|0|$(setting "$ewc_run")" \
    "packnet-s0|0,1,2|packnet|0|$(setting "$packnet_run")" \
    "mtl-s0|0,1,2|mtl|0|"
fi
if [[ $part == seeds || $part == all ]]; then
  entries=()
  for seed in ${SEEDS:-1 2}; do  # the longest first
    entries+=("packnet-s$seed|0,1,2|packnet|$seed|$(setting "$packnet_run")" "er-s$seed|0,1,2|er|$seed|"
      "ewc-s$seed|0,1,2|ewc|$seed|$(setting "$ewc_run")" "seql-s$seed|0,1,2|seql|$seed|")
  done
  run_all "${entries[@]}"
fi
if [[ $part == arch || $part == all ]]; then
  entries=()
  for seed in ${ARCH_SEEDS:-0}; do
    for policy in vit rnn; do
      entries+=("packnet-$policy-s$seed|0,1,2|packnet|$seed|$(setting "$packnet_run")" "er-$policy-s$seed|0,1,2|er|$seed|")
    done
  done
  run_all "${entries[@]}"
fi
if [[ $part == five || $part == seeds || $part == arch || $part == all ]] && [[ -z ${RUNS:-} ]]; then
  .venv/bin/python -m benchmarks.lifelong_report --runs "$results/runs" --out "$results"
fi
