"""``libero-data import``: LIBERO's HDF5 layout in, our dataset out, checked against the episodes
the files were made from (fixture files written from our own expert episodes: no downloads)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from libero_data.errors import DatasetError
from libero_data.hdf5.reader import DROPPED_AT_START, read_libero_file
from libero_data.runtime.folder import DATASET_WORK
from tests.hdf5.libero_files import Episode, expert_episodes, write_libero_file
from tests.tiny_data import run_cli


def _write_foreign(path: Path) -> Path:
    import h5py

    with h5py.File(path, "w") as f:
        f.create_group("observations").create_dataset("x", data=np.zeros(3))
    return path


def test_a_truncated_foreign_or_non_hdf5_file_is_refused_in_one_sentence(tmp_path: Path) -> None:
    import h5py

    good = tmp_path / "good.hdf5"
    with h5py.File(good, "w") as f:
        f.create_group("data").attrs["problem_info"] = "{}"
    truncated = tmp_path / "truncated.hdf5"
    truncated.write_bytes(good.read_bytes()[:700])
    text = tmp_path / "notes.hdf5"
    text.write_text("not an HDF5 file")
    cases = {
        truncated: "is not a readable HDF5 file",
        text: "is not a readable HDF5 file",
        _write_foreign(
            tmp_path / "foreign.hdf5"
        ): "is not a LIBERO demonstration file: it has no 'data' group",
        good: "is not a LIBERO demonstration file: data has no attribute 'bddl_file_name'",
    }
    for path, words in cases.items():
        with pytest.raises(DatasetError) as caught:
            read_libero_file(path)
        message = str(caught.value)
        assert words in message and str(path) in message and "\n" not in message, message
    # From the command line: the sentence alone, exit code 2, nothing written.
    result = run_cli("import", str(truncated), "--out", str(tmp_path / "out"))
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr[-2000:]
    assert "is not a readable HDF5 file" in result.stderr and not (tmp_path / "out").exists()


def test_a_file_of_a_task_of_its_own_is_imported_as_its_own_suite_and_not_mixed_with_liberos(
    tmp_path: Path,
) -> None:
    """A file whose embedded BDDL is none of LIBERO's tasks (here: one with its instruction
    reworded) becomes a task of a suite folder in the output; mixed with a file of LIBERO's
    tasks it is refused in one sentence."""
    from libero_data.pipeline.importer import plan_import, write_own_suite
    from libero_data.tasks import get_suite, get_task

    task = get_task("libero_goal/7")
    stub = [Episode(0, 0, np.zeros((8, 79)), np.zeros((8, 7)), "<mujoco/>")]
    text = task.bddl_path.read_text()
    own_bddl = tmp_path / "turn_on_the_stove_slowly.bddl"
    own_bddl.write_text(text.replace("(:language", "(:language slowly", 1))
    own = write_libero_file(tmp_path / "own" / "own_demo.hdf5", _Renamed(task, own_bddl), stub)
    out = tmp_path / "out"
    request, by_task = plan_import([own.parent], out)
    assert request.suite == str(out.resolve()) and request.tasks == (0,) and request.imported == (str(own),)
    write_own_suite(out, [by_task[0]])
    mine = get_suite(out).task(0)
    assert mine.name == "turn_on_the_stove_slowly" and mine.problem.goal == task.problem.goal
    theirs = write_libero_file(tmp_path / "mixed" / "b_demo.hdf5", task, stub)
    (tmp_path / "mixed" / "a_demo.hdf5").write_bytes(own.read_bytes())
    with pytest.raises(DatasetError, match="holds a task of its own") as caught:
        plan_import([theirs.parent], tmp_path / "out2")
    assert str(theirs) in str(caught.value) and "libero_goal/7" in str(caught.value)


class _Renamed:
    """A task with another BDDL file (what a LIBERO-format file of one's own task holds)."""

    def __init__(self, task: object, bddl: Path) -> None:
        self.suite, self.bddl_path = "mine", bddl
        from libero_data.bddl import parse_file

        self.problem = parse_file(bddl)


@pytest.mark.sim
@pytest.mark.parametrize(
    ("ref", "inits", "drop_noops", "executor"),
    [
        ("libero_spatial/0", [3], True, "local"),
        # The second suite runs with the slow tests (scripts/test runs them after the default
        # suite): two demonstrations, the import interrupted after checking the first, then
        # resumed on Ray with two workers (whose folders are not the driver's: the checked
        # records travel with the jobs).
        pytest.param("libero_goal/7", [1, 2], False, "ray", marks=pytest.mark.slow),
    ],
)
def test_import_gives_the_source_episodes_states_actions_and_upright_frames(
    ref: str, inits: list[int], drop_noops: bool, executor: str, tmp_path: Path
) -> None:
    """Two suites: the imported dataset validates (re-simulated step by step), loads with
    `datasets` and LeRobot, holds the source's states and actions exactly (after LIBERO's 5
    dropped steps), its frames are the states rendered upright, and each episode knows the stored
    init state it began from (which held-out evaluation then skips). An import interrupted
    part-way and run again (on Ray) gives that too."""
    import datasets
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from libero_bench.data.dataset import DemoDataset
    from libero_data.hdf5.checks import nearest_init, noop_frames
    from libero_data.hdf5.fixtures import fixture_poses, place_fixtures
    from libero_data.pipeline.importer import import_hdf5
    from libero_data.pipeline.validate import validate
    from libero_data.record.features import ACTION, OBS_IMAGE, SIM_STATE, sim_states
    from libero_data.sim import EnvConfig, LiberoEnv
    from libero_data.tasks import get_task

    task = get_task(ref)
    source = expert_episodes(task, inits)
    path = write_libero_file(tmp_path / f"{task.name}_demo.hdf5", task, source)
    out = tmp_path / "imported"
    if len(inits) > 1:
        checked: list[str] = []

        def interrupt(message: str) -> None:
            checked.append(message)
            if len(checked) > 1:
                raise KeyboardInterrupt

        with pytest.raises(KeyboardInterrupt):
            import_hdf5([tmp_path], out, image_size=64, drop_noops=drop_noops, on_step=interrupt)
        assert not (out / "meta" / "info.json").exists()  # nothing published yet
        assert len(list((out / DATASET_WORK / "search").glob("*.npz"))) == 1  # the first one's checks kept
    progress = import_hdf5(
        [tmp_path],
        out,
        image_size=64,
        drop_noops=drop_noops,
        workers=2 if executor == "ray" else 1,
        executor=executor,
    )
    assert progress.done == len(inits) and progress.failed == 0

    report = validate(out, resimulate=len(inits))
    assert not report.issues and report.resimulated_ok == len(inits), report.issues
    frames = datasets.load_dataset(str(out), split="train")
    ds = LeRobotDataset(f"libero-data/{task.suite}-human", root=out)
    rows = [json.loads(line) for line in (out / "meta" / "libero_episodes.jsonl").read_text().splitlines()]
    assert ds.num_episodes == len(inits) == len(rows)
    with LiberoEnv(task, EnvConfig(image_size=64, cameras=("agentview",))) as env:
        for e, (ep, row) in enumerate(zip(source, rows, strict=True)):
            states, actions = ep.states[DROPPED_AT_START:], ep.actions[DROPPED_AT_START:]
            keep = ~noop_frames(actions) if drop_noops else np.ones(len(actions), dtype=bool)
            keep[-1] = True
            mine = frames.filter(lambda r, e=e: r["episode_index"] == e)
            width = states.shape[1]
            assert np.array_equal(sim_states(mine[SIM_STATE])[:, :width], states[keep])
            assert np.array_equal(np.array(mine[ACTION]), actions[keep].astype(np.float32))
            assert row["init_index"] == ep.init_index and row["demonstrator"].startswith("human")
            assert row["source_file"] == path.name and row["noops_dropped"] == int((~keep).sum())
            assert row["replay_worst"] <= 0.01
            # Frames: the stored state rendered upright (within the video encoding's error),
            # not LIBERO's upside-down convention.
            env.reset(seed=0)
            place_fixtures(env, fixture_poses(ep.model_xml, env, "fixture"))
            start = int(ds.meta.episodes["dataset_from_index"][e])
            for k in (0, int(keep.sum()) - 1):
                env.set_state(states[keep][k])
                drawn = env.observe()["agentview"].astype(np.float64) / 255.0
                decoded = ds[start + k][OBS_IMAGE].numpy().transpose(1, 2, 0)
                assert np.abs(decoded - drawn).mean() < 0.03
                assert np.abs(decoded - drawn[::-1, ::-1]).mean() > 3 * np.abs(decoded - drawn).mean()
            # The init state it began from, found by stepping the few nearest before stepping,
            # is the one stepping all 50 finds.
            stored = task.init_states()
            assert nearest_init(env, states[0], stored, DROPPED_AT_START) == nearest_init(
                env, states[0], stored, DROPPED_AT_START, shortlist=len(stored)
            )
    # Held-out evaluation sees the stored init states the demonstrations began from.
    assert DemoDataset(out).starts_of(range(len(inits))) == (set(inits), set())
    card = (out / "README.md").read_text()
    assert "Human demonstrations of the LIBERO suite" in card and path.name in card
    assert ("no-op frames dropped" in card) == drop_noops and "Human demonstrations are not used" not in card
    # Human demonstrations are kept as long as they are: no length bound, those over the limit counted.
    from libero_data.tasks.horizons import standard_limit

    over = sum(int(row["length"]) > standard_limit(task.suite) for row in rows)
    assert "| length bound (steps) | none: episodes are kept however long they are |" in card
    assert "| steps after the goal |" not in card  # kept as recorded, with the recorder's own steps after it
    assert f"Episodes are kept however long they are: {over} of {len(rows)} episode" in card
