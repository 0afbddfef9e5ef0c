#!/usr/bin/env bash
# Does a refactoring change any output? Makes the same small artifacts with two commits and
# compares them file by file, byte for byte:
#
#   benchmarks/same_outputs.sh BEFORE AFTER [WORK_DIR]   (default WORK_DIR: ../same-outputs)
#
# The artifacts: a dataset (two libero_goal tasks, one episode each, 64 px), a dataset of
# robustness variants (camera and noise, level 3), a procedural suite with its dataset (two
# tasks), a smoke run on the first dataset, and a robustness sweep of that run (two kinds,
# level 1, two rollouts per cell). Each commit runs from its own git worktree with this
# checkout's virtual environment. Files that record how long something took, or when, are
# listed as such and compared without those fields (timings.jsonl, run.log, *.rrd and MCAP logs
# hold wall-clock times; results' phases are seconds); a card's snapshot line is a hash of its
# content, output path included, and is left out of the comparison.
set -euo pipefail
cd "$(dirname "$0")/.."
before=${1:?the commit before}
after=${2:?the commit after}
work=$(realpath -m "${3:-../same-outputs}")
repo=$(pwd)
export OMP_NUM_THREADS=1 SVT_LOG=1

make_outputs() {  # commit, folder
  local commit=$1 out=$2 tree="$work/tree-$1"
  [[ -d "$tree" ]] || git worktree add --detach "$tree" "$commit" >/dev/null
  ln -sfn "$repo/.venv" "$tree/.venv"
  mkdir -p "$out"
  (
    cd "$tree"
    export PYTHONPATH="$tree"
    ld=.venv/bin/libero-data
    lb=.venv/bin/libero-bench
    $ld generate --suite libero_goal --tasks 0,7 --episodes-per-task 1 --image-size 64 --seed 0 \
      --workers 1 --out "$out/data"
    $ld generate --variants-of libero_goal/7 --kinds camera,noise --level 3 --episodes-per-task 1 \
      --image-size 64 --seed 0 --workers 1 --out "$out/variants"
    $ld generate --procedural 2 --seed 0 --episodes-per-task 1 --image-size 64 --workers 1 \
      --out "$out/procedural"
    $lb run --data "$out/data" --algo er --policy resnet_t --preset smoke --set epochs=1 \
      --set eval_max_steps=6 --set language_encoder=task_id --workers 1 --out "$out/run"
    $lb robustness "$out/run" --tasks libero_goal/7 --kinds camera,noise --levels 1 --rollouts 2 \
      --max-steps 6 --workers 1 --out "$out/sweep"
  ) >"$work/log-$commit.txt" 2>&1
}

mkdir -p "$work"
for commit in "$before" "$after"; do
  [[ -f "$work/$commit/done" ]] && continue
  rm -rf "${work:?}/$commit"
  echo "$(date +%H:%M) making the outputs of $commit"
  make_outputs "$commit" "$work/$commit"
  touch "$work/$commit/done"
done
.venv/bin/python - "$work/$before" "$work/$after" <<'EOF'
import json, re, sys
from pathlib import Path

a, b = Path(sys.argv[1]), Path(sys.argv[2])
TIMED = {"timings.jsonl", "run.log", "done"}
TIMED_SUFFIXES = (".rrd", ".mcap")
# keys whose values are wall-clock times, dates or the machine's paths
VOLATILE = {"seconds", "created", "date", "wall_s", "started", "finished", "elapsed", "duration_s", "phases"}
# a card's last line names its snapshot by a hash of its content, which holds the output folder's path
SNAPSHOT = re.compile(r"<!-- libero-data snapshot [0-9a-f-]+ -->")


def strip(value):
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [strip(v) for v in value]
    if isinstance(value, str):
        return value.replace(str(a), "<out>").replace(str(b), "<out>")
    return value


def same(x: Path, y: Path) -> bool:
    if x.read_bytes() == y.read_bytes():
        return True
    if x.suffix == ".json":
        return strip(json.loads(x.read_text())) == strip(json.loads(y.read_text()))
    if x.suffix == ".jsonl":
        lines_x = [strip(json.loads(line)) for line in x.read_text().splitlines() if line.strip()]
        lines_y = [strip(json.loads(line)) for line in y.read_text().splitlines() if line.strip()]
        return lines_x == lines_y
    if x.suffix == ".safetensors":  # the header's key order was the hash map's before it was sorted
        from libero_bench.runs.state_files import canonical_header

        return canonical_header(x.read_bytes()) == canonical_header(y.read_bytes())
    if x.suffix == ".md":
        def text(path, root):
            return SNAPSHOT.sub("<snapshot>", path.read_text().replace(str(root), "<out>"))

        return text(x, a) == text(y, b)
    return False


files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
only = sorted(files_a ^ files_b)
timed, equal, differ = [], [], []
for rel in sorted(files_a & files_b):
    if rel.name in TIMED or rel.suffix in TIMED_SUFFIXES:
        timed.append(rel)
    elif same(a / rel, b / rel):
        equal.append(rel)
    else:
        differ.append(rel)
print(
    f"{len(equal)} files the same (byte for byte; JSON equal once times and the output folder's "
    "path are left out; safetensors equal once their header's keys are sorted)"
)
print(f"{len(timed)} files of times (not compared): " + ", ".join(sorted({r.name for r in timed})))
for rel in only:
    print(f"only in {'before' if rel in files_a else 'after'}: {rel}")
for rel in differ:
    print(f"DIFFERENT: {rel}")
sys.exit(1 if differ or only else 0)
EOF
