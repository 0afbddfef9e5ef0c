#!/usr/bin/env bash
# Our committed libero_object/0 policies (benchmarks/results/robustness_data/runs/) under LIBERO-PRO
# (the standard protocol on libero_object/0 and its four LIBERO-PRO families, 10 episodes each) and
# under our default protocol from the same stored init states; then the report
# (benchmarks/libero_pro_report.py) into benchmarks/results/libero_pro/, which also names each
# policy in the copied reports from where they are committed.
#
#   benchmarks/libero_pro.sh [WORK_DIR]     (default WORK_DIR: ../libero-pro-work)
#
# ~20-25 minutes per policy on 2 cores (full rendering at 256 px, every step drawn: these policies
# act every step). Resumable: run it again after an interruption.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(realpath -m "${1:-../libero-pro-work}")
results=benchmarks/results/libero_pro
export OMP_NUM_THREADS=1 SVT_LOG=1
for policy in single-object-0 single-aug-object-0 mixed-more-object-0; do
  run=benchmarks/results/robustness_data/runs/$policy
  .venv/bin/libero-bench eval "$run" --benchmark libero-pro --tasks libero_object/0 --trials 10 \
    --workers 2 --out "$work/$policy"
  .venv/bin/libero-bench eval "$run" --tasks libero_object/0 --stored 10 --heldout 0 \
    --workers 1 --out "$work/$policy/default"
  # What the report reads: the tables and, per suite, the report and every rollout's outcome.
  mkdir -p "$results/$policy"
  cp "$work/$policy"/libero_pro.{json,md,png} "$results/$policy/"
  for folder in "$work/$policy"/*/; do
    name=$(basename "$folder")
    mkdir -p "$results/$policy/$name"
    cp "$folder"/{results.json,report.json,report.md} "$results/$policy/$name/"
  done
done
.venv/bin/python -m benchmarks.libero_pro_report --results "$results"
