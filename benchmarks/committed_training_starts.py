"""The training-data record (``training_data.json``) of the committed robustness-data runs, whose
datasets are not committed (``benchmarks/results/robustness_data/runs/``).

A run made today records where its demonstrations started when it is made. These runs predate
that, and their datasets are gone, so this script derives the record from the commands that
made their data (``benchmarks/robustness_data.sh``: ``generate --episodes-per-task 100 --seed 0``
for a task's dataset, ``generate --variants-of SUITE/TASK --kinds ... --level 1,2,3
--episodes-per-task 20`` with seed 0, and seeds 1 and 2 for ``mixed-more``). An episode's reset
seed is a function of the seed, the task and the episode's number and attempt
(``libero_data.seeding.episode_seeds``), and ``generate`` tries at most 8 attempts: the record
holds every reset seed those commands could have drawn, a superset of the starts the kept
episodes began from, whichever attempts succeeded on the machine that made them. Held-out
starts skip them all (none of the committed sweeps' held-out starts changes: checked below and
in ``tests/bench/test_committed_training_starts.py``). No stored init state was used (the
commands sample every start).

    python -m benchmarks.committed_training_starts [--check]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from libero_bench.runs.training_data import TRAINING_DATA, TrainingData
from libero_data.seeding import demo_key, episode_seeds

RESULTS = Path(__file__).resolve().parent / "results" / "robustness_data"
#: robustness_data.sh's settings: episodes per task (the task's data, each variant), attempts
#: per episode (generate's default), the variant kinds and levels.
EPISODES, VARIANT_EPISODES, ATTEMPTS = 100, 20, 8
KINDS = ("camera", "lighting", "texture", "noise", "robot_init")
LEVELS = (1, 2, 3)
#: The variant draws each dataset folder holds (its suite is named after its folder).
VARIANT_SEEDS = {"variants": 0, "variants-s1": 1, "variants-s2": 2}
NOTE = (
    "derived by benchmarks/committed_training_starts.py from the commands that made the data "
    "(benchmarks/robustness_data.sh): every reset seed they could have drawn, a superset of the starts kept"
)


def _seeds(suite: str, task: str, episodes: int, seed: int) -> set[int]:
    return {
        episode_seeds(seed, demo_key(suite, task, k), attempt)[0]
        for k in range(episodes)
        for attempt in range(ATTEMPTS)
    }


def record(run: Path) -> TrainingData:
    """The record of one committed run, from its ``config.json`` and the commands above."""
    from libero_data.pipeline.request import state_width
    from libero_data.tasks import get_suite

    config = json.loads((run / "config.json").read_text())
    suite = config["dataset"]["suite"]
    (task,) = config["tasks"]
    name = task["name"]
    seeds = _seeds(suite, name, EPISODES, 0)
    datasets = [config["data"]]
    for entry in config.get("mix", {}).get("datasets", []):
        folder = Path(entry["data"]).name  # e.g. object-0-variants-s1: its suite's name
        draw = VARIANT_SEEDS[folder.split("-", 2)[-1]]
        for kind in KINDS:
            for level in LEVELS:
                variant = f"{name}__{kind}" + ("" if level == 1 else f"_l{level}")
                seeds |= _seeds(folder, variant, VARIANT_EPISODES, draw)
        datasets.append(entry["data"])
    width = state_width(get_suite(suite).task(name))
    return TrainingData(tuple(datasets), width, {name: (frozenset(), frozenset(seeds))}, NOTE)


def runs() -> list[Path]:
    return sorted(p.parent for p in (RESULTS / "runs").glob("*/config.json"))


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--check", action="store_true", help="compare with the committed records only")
    args = parser.parse_args()
    stale = []
    for run in runs():
        text = json.dumps(record(run).to_dict(), indent=1) + "\n"
        path = run / TRAINING_DATA
        if args.check:
            if not path.is_file() or path.read_text() != text:
                stale.append(str(path))
            continue
        path.write_text(text)
        print(f"wrote {path.relative_to(RESULTS.parent.parent.parent)}")
    if stale:
        sys.exit("not what the script makes: " + ", ".join(stale))


if __name__ == "__main__":
    main()
