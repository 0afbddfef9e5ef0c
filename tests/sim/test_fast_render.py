"""``render_quality="fast"``: images close to full quality within the stated bound, physics
untouched, culling that changes no pixel, and a full-quality reference equal to LIBERO's."""

from __future__ import annotations

import numpy as np
import pytest

from libero_data.sim import EnvConfig, LiberoEnv
from libero_data.sim.render import FAST_MEAN_BOUND
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

CAMERAS = ("agentview", "eye_in_hand")
PUSH = np.array([0.4, -0.3, -0.2, 0.0, 0.0, 0.1, -1.0])


def _difference(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a.astype(np.int16) - b.astype(np.int16)).mean() / 255.0)


@pytest.mark.parametrize("ref", ["libero_goal/0", "libero_10/3"])
def test_fast_images_are_close_to_full_and_physics_is_untouched(ref: str) -> None:
    task = get_task(ref)
    init = task.init_states()[0]
    with (
        LiberoEnv(task, EnvConfig(image_size=128)) as full,
        LiberoEnv(task, EnvConfig(image_size=128, render_quality="fast")) as fast,
    ):
        a = full.reset(init, seed=0, render=True)
        b = fast.reset(init, seed=0, render=True)
        for _ in range(6):  # the arm moves: images of another state
            a, _ = full.step(PUSH)
            b, _ = fast.step(PUSH)
        assert np.array_equal(a["sim_state"], b["sim_state"])  # what is drawn never touches physics
        for camera in CAMERAS:
            difference = _difference(a[camera], b[camera])
            assert 0.0 < difference <= FAST_MEAN_BOUND, (camera, difference)
            # The reference renderer of a fast environment draws LIBERO's pixels exactly.
            assert np.array_equal(fast.render_full(camera), full.render(camera)), camera
        scene = fast.render_scene()
        assert scene["quality"] == "fast" and scene["faces_after"] < scene["faces_before"] / 2
        assert full.render_scene() == {"quality": "full"}


def test_leaving_out_geoms_outside_the_view_changes_no_pixel() -> None:
    task = get_task("libero_goal/0")
    with LiberoEnv(task, EnvConfig(image_size=96, render_quality="fast")) as env:
        env.reset(task.init_states()[0], seed=0, render=False)
        env.render("agentview")
        renderer = env._fast._fast[0]
        assert renderer.cull
        culled = {c: env.render(c) for c in CAMERAS}
        # The timed render (for benchmarks) draws the same image and counts what it drew.
        timed = renderer.render_timed(env.sim.model._model, env.sim.data._data, env._camera_id("agentview"))
        assert np.array_equal(renderer._pixels[::-1, ::-1], culled["agentview"])
        assert all(timed[part] > 0 for part in ("update", "draw", "read"))
        assert 0 < timed["triangles"] < env.render_scene()["faces_after"]  # culled: fewer than all
        renderer.cull = False
        for camera in CAMERAS:
            assert np.array_equal(env.render(camera), culled[camera]), camera


def test_the_wrist_camera_is_drawn_without_the_mirror_pass_and_nearly_the_same() -> None:
    import mujoco

    task = get_task("libero_goal/1")  # the bowl onto the stove, a reflective box
    with LiberoEnv(task, EnvConfig(image_size=128, render_quality="fast")) as env:
        env.reset(task.init_states()[0], seed=0, render=False)
        env.render("agentview")
        renderer = env._fast._fast[0]
        wrist, front = env._camera_id("eye_in_hand"), env._camera_id("agentview")
        assert renderer.unmirrored == frozenset({wrist})  # the fixed camera keeps its reflections
        reflection = mujoco.mjtRndFlag.mjRND_REFLECTION
        for _ in range(3):
            for _ in range(8):
                env.advance(PUSH)
            unmirrored = env.render("eye_in_hand")
            assert renderer._scene.flags[reflection] == 0
            env.render("agentview")
            assert renderer._scene.flags[reflection] == 1
            renderer.unmirrored = frozenset()
            mirrored = env.render("eye_in_hand")
            renderer.unmirrored = frozenset({wrist})
            assert _difference(unmirrored, mirrored) < 0.002
        assert front not in renderer.unmirrored


def test_a_bad_render_quality_is_named() -> None:
    from libero_data.errors import InputError

    with pytest.raises(InputError, match="render quality must be full or fast"):
        EnvConfig(render_quality="medium")
