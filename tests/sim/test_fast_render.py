"""``render_quality="fast"``: images close to full quality within the stated bound, physics
untouched, culling that changes no pixel, and a full-quality reference equal to LIBERO's."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.bench_render_fast import fast_renderer_of, render_timed
from libero_data.sim import EnvConfig, LiberoEnv
from libero_data.sim.fast.images import FAST_MEAN_BOUND
from libero_data.tasks import get_task

pytestmark = pytest.mark.sim

CAMERAS = ("agentview", "eye_in_hand")
PUSH = np.array([0.4, -0.3, -0.2, 0.0, 0.0, 0.1, -1.0])
SKYBOX = 4  # mjtRndFlag.mjRND_SKYBOX


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
        renderer = fast_renderer_of(env, "agentview")
        assert renderer.cull
        culled = {c: env.render(c) for c in CAMERAS}
        # The timed render (for benchmarks) draws the same image and counts what it drew.
        timed = render_timed(renderer, env.sim.model._model, env.sim.data._data, env.camera_id("agentview"))
        assert np.array_equal(renderer.image(), culled["agentview"])
        assert all(timed[part] > 0 for part in ("update", "draw", "read"))
        assert 0 < timed["triangles"] < env.render_scene()["faces_after"]  # culled: fewer than all
        renderer.cull = False
        for camera in CAMERAS:
            assert np.array_equal(env.render(camera), culled[camera]), camera


def test_what_a_study_room_leaves_out_changes_no_pixel() -> None:
    # libero_90/75. (1) Culling by bounding box: the room's bookshelf, plant and painting have
    # bounding spheres of 1-1.1 m that reach into the wrist camera's view from beside or behind
    # the robot; their boxes do not (with spheres alone the wrist drew 63.9 k triangles at the
    # first state). (2) Occlusion queries: the pedestal is hidden from the wrist camera and left
    # out; the desk caddy on the table shows, so the frame is drawn again with it. (3) The sky:
    # the room covers agentview's view, and the floor the wrist's, so it is left out of both.
    task = get_task("libero_90/75")
    with LiberoEnv(task, EnvConfig(image_size=96, render_quality="fast")) as env:
        env.reset(task.init_states()[0], seed=0, render=False)
        model, data = env.sim.model._model, env.sim.data._data
        wrist = env.camera_id("eye_in_hand")
        env.render("eye_in_hand")
        renderer = fast_renderer_of(env, "eye_in_hand")
        renderers = {id(r): r for r in (fast_renderer_of(env, c) for c in CAMERAS)}
        hidden = renderer.hidden
        assert hidden is not None and len(hidden.geoms) >= 2
        renderer.hidden = None
        assert render_timed(renderer, model, data, wrist)["triangles"] < 55_000
        renderer.hidden = hidden
        fewer, shown, skyless = 0, 0, 0
        skies = {key: r.sky for key, r in renderers.items()}
        for _ in range(4):
            images = {}
            for camera in CAMERAS:
                images[camera] = env.render(camera)
                skyless += not fast_renderer_of(env, camera).scene.flags[SKYBOX]
            shown += bool(hidden.found_visible)
            left = render_timed(renderer, model, data, wrist)["triangles"]
            for r in renderers.values():
                r.cull, r.hidden, r.sky = False, None, None
                r.scene.flags[SKYBOX] = 1
            for camera in CAMERAS:
                assert np.array_equal(env.render(camera), images[camera]), camera
            for key, r in renderers.items():
                r.cull, r.sky = True, skies[key]
            fewer += left < render_timed(renderer, model, data, wrist)["triangles"]
            renderer.hidden = hidden
            for _ in range(12):
                env.advance(PUSH)
        assert fewer == 4  # the pedestal was left out at every state
        assert skyless == 8  # and the sky, from both cameras
        assert shown > 0  # and a mesh in view was found visible, so drawn


def test_the_wrist_camera_is_drawn_without_the_mirror_pass_and_nearly_the_same() -> None:
    import mujoco

    task = get_task("libero_goal/1")  # the bowl onto the stove, a reflective box
    with LiberoEnv(task, EnvConfig(image_size=128, render_quality="fast")) as env:
        env.reset(task.init_states()[0], seed=0, render=False)
        wrist = env.camera_id("eye_in_hand")
        near, far = (fast_renderer_of(env, c) for c in ("eye_in_hand", "agentview"))
        assert near.unmirrored == far.unmirrored == frozenset({wrist})  # the fixed camera keeps them
        reflection = mujoco.mjtRndFlag.mjRND_REFLECTION
        for _ in range(3):
            for _ in range(8):
                env.advance(PUSH)
            unmirrored = env.render("eye_in_hand")
            assert near.scene.flags[reflection] == 0
            env.render("agentview")
            assert far.scene.flags[reflection] == 1
            near.unmirrored = frozenset()
            mirrored = env.render("eye_in_hand")
            near.unmirrored = frozenset({wrist})
            assert _difference(unmirrored, mirrored) < 0.002


def test_the_fixed_camera_draws_distant_still_meshes_coarser_and_the_wrist_does_not() -> None:
    from libero_data.sim.fast.distant import LEVELS, still_geoms
    from libero_data.sim.fast.meshes import MeshSettings

    task = get_task("libero_90/0")  # a kitchen: its background and the robot's pedestal stand far
    with LiberoEnv(task, EnvConfig(image_size=128, render_quality="fast")) as env:
        env.reset(task.init_states()[0], seed=0, render=False)
        model = env.sim.model._model
        wrist, front = env.camera_id("eye_in_hand"), env.camera_id("agentview")
        assert env.fast_images is not None
        near, far = (env.fast_images.renderer(model, c) for c in (wrist, front))
        near_scene, far_scene = (env.fast_images.fast_scene(model, c) for c in (wrist, front))
        assert near is not far and far_scene.faces_drawn_after < 0.8 * near_scene.faces_drawn_after
        still = still_geoms(model, [front, wrist])
        names = {model.body(int(model.body_rootid[model.geom_bodyid[g]])).name for g in np.flatnonzero(still)}
        assert names <= {"world", "robot0_base"}  # never a fixture LIBERO places anew at each reset
        # Only meshes of still geoms are coarser for the fixed camera; every other mesh is the same.
        meshes = model.geom_type == 7  # mjGEOM_MESH
        only_still = set(model.geom_dataid[meshes & still]) - set(model.geom_dataid[meshes & ~still])
        coarser = set(np.flatnonzero(far.facenum < near.facenum))
        assert coarser and coarser <= only_still
        assert np.all(far.facenum <= near.facenum)
        assert MeshSettings().max_error == LEVELS[0]
        for camera in CAMERAS:
            env.render(camera)
        assert env.render_scene()["settings"]["distant_meshes"].endswith("(fixed cameras)")


def test_objects_near_the_wrist_camera_are_drawn_from_their_detailed_copies() -> None:
    # A free object's shading needs finer normals a few centimetres from the wrist camera
    # (libero_90/23's bowl: 0.0123 -> 0.0060), not from afar: the detailed copy is swapped into
    # the context while the camera is near, and the image is then exactly that of a context
    # built with the detailed copy; moved away again, exactly that of the coarse one.
    from libero_data.sim.fast.images import fast_renderer
    from libero_data.sim.fast.near import NEAR_OBJECT_M, detailed_objects, object_meshes
    from libero_data.sim.fast.simplify import simplified_meshes
    from libero_data.sim.fast.texture_size import TEXTURE_PER_IMAGE

    task = get_task("libero_object/0")
    size = 96
    up, push = np.array([0, 0, 0.5, 0, 0, 0, -1.0]), np.array([0.3, -0.2, -0.25, 0, 0, 0.1, -1.0])
    with LiberoEnv(task, EnvConfig(image_size=size, render_quality="fast")) as env:
        env.reset(task.init_states()[0], seed=0, render=False)
        model, data = env.sim.model._model, env.sim.data._data
        ids = [env.camera_id(c) for c in CAMERAS]
        wrist = env.camera_id("eye_in_hand")
        env.render("eye_in_hand")
        renderer = fast_renderer_of(env, "eye_in_hand")
        near = renderer.detail
        assert near is not None and near.near == NEAR_OBJECT_M
        faces, _ = simplified_meshes(model, ids, progress=False)
        detail, _ = detailed_objects(model, ids, progress=False)
        assert detail.keys() == near.fine.keys() and set(detail) <= object_meshes(model)
        assert all(len(detail[i]) >= len(faces[i]) for i in detail)
        assert sum(map(len, detail.values())) > 2 * sum(len(faces[i]) for i in detail)
        seen = []
        for action, steps in ((up, 10), (push, 35), (up, 10)):
            for _ in range(steps):
                env.advance(action)
            image = env.render("eye_in_hand")
            wanted = near.wanted(model, data)
            assert near.detailed == wanted
            held = {**faces, **{i: detail[i] for i in wanted}}
            reference = fast_renderer(
                model, size, ids, held, TEXTURE_PER_IMAGE["mounted"] * size, env.backend
            )
            try:
                assert np.array_equal(reference.render(model, data, wrist), image)
            finally:
                reference.close()
            seen.append(frozenset(wanted))
        assert seen[0] == seen[2] == frozenset() and seen[1]  # far, near, far again


def test_a_bad_render_quality_is_named() -> None:
    from libero_data.errors import InputError

    with pytest.raises(InputError, match="render quality must be full or fast"):
        EnvConfig(render_quality="medium")


def test_environments_of_one_scene_share_their_fast_renderers_and_draw_the_same() -> None:
    from libero_data.sim.fast import images

    task = get_task("libero_object/0")
    inits = task.init_states()
    config = EnvConfig(image_size=64, render_quality="fast")
    a, b = LiberoEnv(task, config), LiberoEnv(task, config)
    try:
        a.reset(inits[0], seed=0)
        b.reset(inits[1], seed=1)
        assert a.fast_images is not None and b.fast_images is not None
        assert a.fast_images.renderer(a.sim.model._model) is b.fast_images.renderer(b.sim.model._model)
        # The key leaves out what a reset changes, and tells another scene apart.
        assert images.scene_key(a.sim.model._model) == images.scene_key(b.sim.model._model)
        with LiberoEnv(get_task("libero_goal/0"), EnvConfig(cameras=())) as other:
            assert images.scene_key(other.sim.model._model) != images.scene_key(a.sim.model._model)
        for _ in range(3):  # drawn in turns from one context: each its own scene
            seen_a, _ = a.step(PUSH)
            seen_b, _ = b.step(-PUSH)
        a.close()  # the other keeps the renderers
        assert len(images._SHARED) == 1
        again_b = b.render("eye_in_hand")
        assert np.array_equal(again_b, seen_b["eye_in_hand"])
    finally:
        a.close()
        b.close()
    assert images._SHARED == {}  # closed with the last of them
    # Alone, the same start and actions: the same pixels as drawn in turns with another scene.
    with LiberoEnv(task, config) as alone:
        alone.reset(inits[0], seed=0)
        for _ in range(3):
            seen, _ = alone.step(PUSH)
        assert np.array_equal(seen["sim_state"], seen_a["sim_state"])
        for camera in CAMERAS:
            assert np.array_equal(seen[camera], seen_a[camera]), camera
    # Another size is another set of renderers.
    with (
        LiberoEnv(task, config) as one,
        LiberoEnv(task, EnvConfig(image_size=96, render_quality="fast")) as two,
    ):
        one.reset(inits[0], seed=0)
        two.reset(inits[0], seed=0)
        assert len(images._SHARED) == 2
