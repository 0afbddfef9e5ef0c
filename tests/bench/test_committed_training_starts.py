"""The committed robustness-data runs carry the record of where their demonstrations started
(their datasets are not committed): a clone sweeps them again from the same held-out starts."""

from __future__ import annotations

import json
from pathlib import Path

from benchmarks.committed_training_starts import RESULTS, record, runs
from libero_bench.runs.training_data import read_training_data


def test_each_committed_run_records_its_training_starts_as_the_script_derives_them() -> None:
    assert len(runs()) == 12
    for run in runs():
        assert read_training_data(run) == record(run), run.name


def test_the_committed_sweeps_held_out_starts_skip_every_recorded_start() -> None:
    from libero_bench.robustness.cells import SweepRequest, heldout_seeds
    from libero_bench.rollouts.policy_kinds import policy_source

    for sweep in sorted((RESULTS / "sweeps").glob("*/robustness.json")):
        committed = json.loads(sweep.read_text())
        run = (sweep.parent / committed["policy"]).resolve()
        _, starts = policy_source(str(run)).training_starts()  # from the record: no dataset here
        request = SweepRequest(
            tasks=tuple(committed["request"]["tasks"]),
            kinds=tuple(committed["request"]["kinds"]),
            rollouts=committed["request"]["rollouts"],
        )
        seeds = heldout_seeds(request, {name: found[1] for name, found in starts.items()})
        assert {n: list(s) for n, s in seeds.items()} == committed["heldout_seeds"], sweep.parent.name
        for name, found in starts.items():
            assert not set(seeds[name]) & found[1]


def test_a_committed_run_is_swept_from_a_clone(tmp_path: Path) -> None:
    # What a new user tried (`libero-bench robustness <committed run> --tasks libero_object/0
    # --kinds camera --levels 3`), one short rollout per cell: it runs without the run's datasets.
    from libero_bench.robustness.sweep import SweepRequest, sweep

    run = RESULTS / "runs" / "single-object-0"
    request = SweepRequest(
        tasks=("libero_object/0",),
        kinds=("camera",),
        levels=(3,),
        rollouts=1,
        max_steps=3,
        render_quality="fast",
    )
    summary = sweep(run, request, tmp_path / "sweep")
    assert summary["table"]["grid"]["camera"]["3"]["n"] == 1
    assert (
        summary["heldout_seeds"]["pick_up_the_alphabet_soup_and_place_it_in_the_basket"]
        == json.loads((RESULTS / "sweeps" / "single-object-0" / "robustness.json").read_text())[
            "heldout_seeds"
        ]["pick_up_the_alphabet_soup_and_place_it_in_the_basket"][:1]
    )
    assert not Path(summary["policy"]).is_absolute()
