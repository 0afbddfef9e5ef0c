"""Robustness perturbations: levels, records that travel in BDDL files, and what each kind does
to the simulated scene (camera, lighting, texture, robot start, noise)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from libero_data.bddl import parse, write
from libero_data.perturb.kinds.language import reword
from libero_data.perturb.levels import ENV_KINDS, KINDS, MAGNITUDES, level_table, magnitude
from libero_data.perturb.spec import Perturbation, sample
from libero_data.procedural.variants import make_variant
from libero_data.seeding import variant_level_rng
from libero_data.tasks import get_task


def test_every_kind_has_five_levels_of_growing_magnitude() -> None:
    assert list(MAGNITUDES) == list(KINDS)  # every registered kind
    for kind, params in MAGNITUDES.items():
        for name, values in params.items():
            assert len(values) == 5, (kind, name)
            if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values) and (
                kind,
                name,
            ) not in (("noise", "jpeg_quality"), ("texture", "tint")):
                assert list(values) == sorted(values), (kind, name)
    assert "| camera | azimuth_deg | 5.0 | 10.0 | 15.0 | 22.5 | 30.0 |" in level_table()
    with pytest.raises(Exception, match=r"level must be 1\.\.5"):
        magnitude("camera", 6)


def test_a_perturbation_travels_in_the_bddl_file_and_libero_ignores_it() -> None:
    from bddl.parsing import scan_tokens

    task = get_task("libero_object/0")
    p = sample("camera", 3, seed=11)
    assert p == sample("camera", 3, seed=11) and p != sample("camera", 3, seed=12)
    problem = dataclasses.replace(task.problem, perturbation=p.to_json())
    text = write(problem)
    assert parse(text) == problem and Perturbation.from_json(parse(text).perturbation) == p
    # LIBERO's own parser reads the same problem as without the record.
    assert scan_tokens(string=text) == scan_tokens(string=write(task.problem))
    with pytest.raises(Exception, match="not valid JSON"):
        parse("; libero-data perturbation: {oops\n" + write(task.problem))


def test_variants_of_every_kind_and_level() -> None:
    task = get_task("libero_goal/0")
    for j, kind in enumerate(KINDS):
        for level in (1, 3, 5):
            try:
                v = make_variant(
                    task.problem, task.id, kind, variant_level_rng(0, task.index, j, level), level=level
                )
            except Exception as exc:  # a scene kind may not fit every task; it says why
                assert "no " in str(exc) or "fit" in str(exc), (kind, level, exc)
                continue
            if kind in ENV_KINDS:
                p = Perturbation.from_json(v.perturbation)
                assert p is not None and (p.kind, p.level) == (kind, level)
                assert dataclasses.replace(v, perturbation="") == dataclasses.replace(
                    task.problem, language=v.language
                )
            else:
                assert v.perturbation == ""


def test_language_levels_add_to_each_other() -> None:
    rng = np.random.default_rng(0)
    base = "put the bowl on the plate"
    one, three, five = (reword(base, level, np.random.default_rng(1)) for level in (1, 3, 5))
    assert one == "set the bowl down on the plate"
    assert three.endswith(one) and len(three) > len(one)
    assert "dish" in five and "bowl" not in five
    assert reword(base, 2, rng) != one


# -- in the simulator ------------------------------------------------------------------------------
def _env(problem: Any, tmp_path: Path, name: str, size: int = 96) -> Any:
    from libero_data.sim import EnvConfig, LiberoEnv

    path = tmp_path / f"{name}.bddl"
    path.write_text(write(problem))
    return LiberoEnv(path, EnvConfig(image_size=size))


def _variant(task: Any, kind: str, level: int) -> Any:
    return dataclasses.replace(task.problem, perturbation=sample(kind, level, seed=5).to_json())


def _project(env: Any, point: np.ndarray) -> np.ndarray:
    """Pixel (u, v) of a world point in the agentview image (upright, as LiberoEnv returns it)."""
    import mujoco

    model, data = env.sim.model._model, env.sim.data._data
    cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "agentview")
    local = data.cam_xmat[cam].reshape(3, 3).T @ (point - data.cam_xpos[cam])
    f = 0.5 * env.config.image_size / np.tan(np.deg2rad(model.cam_fovy[cam]) / 2)
    return np.array([f * local[0] / -local[2], f * local[1] / -local[2]])


@pytest.mark.sim
def test_scene_kinds_change_what_the_cameras_see_and_nothing_else(tmp_path: Path) -> None:
    from libero_data.perturb.kinds.camera import surface_height

    task = get_task("libero_goal/0")
    init = task.init_states()[0]
    push = np.array([0.3, -0.2, -0.2, 0.0, 0.0, 0.0, -1.0])
    with _env(task.problem, tmp_path, "source") as source:
        clean = source.reset(init, seed=0)
        model, data = source.sim.model._model, source.sim.data._data
        table_point = np.array([0.0, 0.0, surface_height(model, data)])
        where = _project(source, table_point)
        clean_steps = [source.step(push)[0] for _ in range(3)]
    for kind in ("camera", "lighting", "texture", "noise"):
        with _env(_variant(task, kind, 4), tmp_path, kind) as env:
            obs = env.reset(init, seed=0)
            steps = [env.step(push)[0] for _ in range(3)]
            # Physics untouched: the same states, action for action.
            assert all(
                np.array_equal(a["sim_state"], b["sim_state"])
                for a, b in zip(steps, clean_steps, strict=True)
            )
            assert np.array_equal(obs["sim_state"], clean["sim_state"])
            difference = np.abs(obs["agentview"].astype(int) - clean["agentview"]).mean()
            assert difference > 2.0, (kind, difference)
            if kind == "camera":  # the table's centre is drawn elsewhere
                assert np.linalg.norm(_project(env, table_point) - where) > 3.0
                assert np.array_equal(obs["eye_in_hand"], clean["eye_in_hand"])  # the wrist camera stays
            if kind == "lighting":
                brighter = env.perturbation.params["intensity"] > 1
                change = obs["agentview"].mean() - clean["agentview"].mean()
                assert (change > 3) if brighter else (change < -3), change
            if kind == "noise":  # images and proprioception noisy, the same noise for the same state
                assert not np.array_equal(obs["state"], clean["state"])
                again = env.observe()
                assert np.array_equal(again["agentview"], steps[-1]["agentview"])


@pytest.mark.sim
def test_robot_init_moves_the_arm_within_its_level(tmp_path: Path) -> None:
    task = get_task("libero_goal/0")
    init = task.init_states()[0]
    with _env(task.problem, tmp_path, "source") as source:
        clean = source.reset(init, seed=3)["joint_pos"]
    limit = magnitude("robot_init", 3)["joint_offset_rad"]
    with _env(_variant(task, "robot_init", 3), tmp_path, "robot") as env:
        moved = env.reset(init, seed=3)["joint_pos"]
        again = env.reset(init, seed=3)["joint_pos"]
        other = env.reset(init, seed=4)["joint_pos"]
    offset = np.abs(moved - clean)
    assert offset.max() > 0.01 and offset.max() <= limit + 1e-6
    assert np.array_equal(moved, again) and not np.array_equal(moved, other)


@pytest.mark.sim
def test_generate_variants_of_the_new_kinds_writes_a_dataset_that_replays(tmp_path: Path) -> None:
    import json

    from libero_data.pipeline.validate import validate
    from tests.pipeline.conftest import run_cli

    # One kind per hook the simulator calls: the built scene (camera; lighting and texture change
    # it the same way), the arm's start (robot_init), the observations (noise).
    kinds = ("camera", "robot_init", "noise")
    out = tmp_path / "variants"
    args = ["--variants-of", "libero_object/0", "--kinds", ",".join(kinds), "--level", "3"]
    args += ["--episodes-per-task", "1", "--image-size", "64", "--render-quality", "fast"]
    args += ["--workers", "1", "--out", str(out)]
    result = run_cli("generate", *args)
    assert result.returncode == 0, result.stderr[-3000:]
    tasks = json.loads((out / "suite.json").read_text())["tasks"]
    assert [t["template"] for t in tasks] == [f"variant:{k}:3" for k in kinds]
    report = validate(out, resimulate=3)
    assert not report.issues and report.resimulated_ok == 3
    card = (out / "README.md").read_text()
    for kind in kinds:
        assert f"{kind} level 3 (" in card, kind
    # Each task's BDDL in the dataset carries the record that reproduces it.
    bddl = next((out / "meta" / "bddl").glob("*__camera_l3.bddl")).read_text()
    assert bddl.startswith("; libero-data perturbation: {")


def test_contact_sheet_of_a_kind_names_what_is_wrong(tmp_path: Path) -> None:
    from tests.pipeline.conftest import run_cli

    result = run_cli("contact-sheet", "libero_object", "--kind", "fog", "--out", str(tmp_path / "x.png"))
    assert result.returncode != 0
    assert "unknown kind(s) fog" in result.stderr and "Traceback" not in result.stderr
    result = run_cli(
        "contact-sheet", "libero_object", "--kind", "camera", "--task", "99", "-o", str(tmp_path)
    )
    assert result.returncode != 0 and "--task 99" in result.stderr
    result = run_cli(
        "contact-sheet", "libero_object", "--kind", "camera", "--format", "gif", "-o", str(tmp_path)
    )
    assert result.returncode != 0 and "--format must be png or jpg" in result.stderr
    assert "Traceback" not in result.stderr
    assert not list(tmp_path.iterdir())


@pytest.mark.sim
def test_contact_sheet_of_a_kind_shows_six_levels(tmp_path: Path) -> None:
    from PIL import Image

    from tests.pipeline.conftest import run_cli

    # Into a folder, as cards/robustness/ is made: <kind>.jpg.
    result = run_cli(
        "contact-sheet",
        "libero_object",
        "--kind",
        "lighting",
        "--size",
        "48",
        "--format",
        "jpg",
        "--out",
        str(tmp_path),
    )
    assert result.returncode == 0, result.stderr[-2000:]
    with Image.open(tmp_path / "lighting.jpg") as img:
        assert img.format == "JPEG"
        assert img.width > 2 * img.height  # six columns (the source and levels 1-5) over two rows


@pytest.mark.sim
def test_only_the_kinds_the_sweep_widens_for_change_the_simulator_state_width(tmp_path: Path) -> None:
    from libero_bench.robustness.run_policy import WIDER_KINDS
    from libero_data.pipeline.request import state_width

    task = get_task("libero_object/0")
    source = state_width(task)
    from libero_data.scenes.sampler import SamplingError

    for kind in KINDS:
        rng = variant_level_rng(0, task.index, 0, 1)
        try:
            problem = make_variant(task.problem, task.id, kind, rng, language=task.language, level=1)
        except SamplingError:  # no variant of this kind for this task (e.g. nothing to swap in)
            continue
        path = tmp_path / f"{kind}.bddl"
        path.write_text(write(problem))
        width = state_width(path)
        if kind in WIDER_KINDS:
            assert width >= source, kind
        else:
            assert width == source, kind
    assert state_width(tmp_path / "distractors.bddl") > source  # the sweep would have cut these states


def test_variants_of_a_task_and_tasks_together_is_refused_before_any_work(tmp_path: Path) -> None:
    from tests.pipeline.conftest import run_cli

    out = tmp_path / "v"
    result = run_cli(
        "generate", "--variants-of", "libero_object/0", "--tasks", "1", "--kinds", "camera", "--out", str(out)
    )
    assert result.returncode == 2 and "names a task already" in result.stderr
    assert not out.exists()
