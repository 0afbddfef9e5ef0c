"""``fast`` leaves the skybox out only where it is proved to show in no sample (libero_data.sim.fast.sky):
on a small scene whose cameras see the sky from some poses and not from others, every image is
the one drawn with the sky, and the sky is left out where a camera looks only at the floor or
a table top. And culling, which bounds a view by its vertical angle, is off for a camera whose
view is not set by it (an orthographic one)."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.sim

# A small floor (it covers no view here), a large table, a fixed camera high above the table
# looking down, a fixed camera looking out at the horizon, and a camera on a free body.
SCENE = """
<mujoco>
  <visual><quality offsamples="4"/></visual>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.3 0.5 0.8" rgb2="0.9 0.9 1" width="32" height="192"/>
  </asset>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" castshadow="false"/>
    <geom name="floor" group="1" type="plane" size="0.2 0.2 0.05" rgba="0.5 0.5 0.5 1"/>
    <geom name="table" group="1" type="box" pos="0 0 0.4" size="1 1 0.4" rgba="0.6 0.4 0.3 1"/>
    <geom name="cup" group="1" type="box" pos="0.1 0 0.82" size="0.02 0.02 0.02" rgba="0.9 0.1 0.1 1"/>
    <camera name="above" pos="0 0 2" xyaxes="1 0 0 0 1 0" fovy="45"/>
    <camera name="horizon" pos="0 0 1.2" xyaxes="0 -1 0 0 0 1" fovy="45"/>
    <body name="hand" pos="0 0 1.2">
      <freejoint/>
      <geom group="1" type="sphere" size="0.02" pos="0 0 0.1" rgba="0.2 0.8 0.2 1"/>
      <camera name="wrist" pos="0 0 0" xyaxes="1 0 0 0 1 0" fovy="60"/>
      <camera name="flat" pos="0 0 0" xyaxes="1 0 0 0 1 0" projection="orthographic" fovy="0.3"/>
    </body>
  </worldbody>
</mujoco>
"""
SKYBOX = 4  # mjtRndFlag.mjRND_SKYBOX


@pytest.fixture()
def scene():
    import mujoco

    from libero_data.sim.fast.renderer import OffscreenRenderer
    from libero_data.sim.fast.sky import SkyCover
    from libero_data.sim.gl import select_backend

    backend = select_backend()
    model = mujoco.MjModel.from_xml_string(SCENE)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    fast = OffscreenRenderer(model, 64, backend, sky=SkyCover(model))
    full = OffscreenRenderer(model, 64, backend)
    yield model, data, fast, full
    fast.close()
    full.close()


def _draw(model, data, fast, full, camera: str) -> tuple[bool, np.ndarray, np.ndarray]:
    """(whether fast drew the sky, fast's image, the image with the sky)."""
    import mujoco

    camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
    image = fast.render(model, data, camera_id)
    return bool(fast.scene.flags[SKYBOX]), image, full.render(model, data, camera_id)


def test_the_sky_is_left_out_only_where_it_cannot_show(scene) -> None:
    import mujoco

    model, data, fast, full = scene
    # A fixed camera whose view the table fills: proved once by drawing what does not move.
    drawn, image, reference = _draw(model, data, fast, full, "above")
    assert not drawn and np.array_equal(image, reference)
    # A fixed camera looking out over the table's edge: the sky shows, so it is drawn.
    drawn, image, reference = _draw(model, data, fast, full, "horizon")
    assert drawn and np.array_equal(image, reference)
    no_sky = reference.copy()
    full.scene.flags[SKYBOX] = 0
    camera_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "horizon")
    assert not np.array_equal(full.render(model, data, camera_id), no_sky)  # the sky does show
    full.scene.flags[SKYBOX] = 1
    # A camera on a moving body, looking down at the table top from 0.4 m: the box's top face
    # meets every corner ray (the small floor would not).
    drawn, image, reference = _draw(model, data, fast, full, "wrist")
    assert not drawn and np.array_equal(image, reference)
    # An orthographic camera there: its rays are not the ones the proof draws, so the sky is drawn.
    drawn, image, reference = _draw(model, data, fast, full, "flat")
    assert drawn and np.array_equal(image, reference)
    # The same camera turned to look out sideways: the sky shows.
    data.qpos[3:7] = [np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0]  # 90 degrees about x
    mujoco.mj_forward(model, data)
    drawn, image, reference = _draw(model, data, fast, full, "wrist")
    assert drawn and np.array_equal(image, reference)
    # Lifted high above the table, looking down again: past the table's edge lies nothing the
    # camera could prove opaque (the floor is small), so the sky is drawn.
    data.qpos[:7] = [0.0, 0.0, 6.0, 1.0, 0.0, 0.0, 0.0]
    mujoco.mj_forward(model, data)
    drawn, image, reference = _draw(model, data, fast, full, "wrist")
    assert drawn and np.array_equal(image, reference)


def test_a_fixed_camera_moved_is_proved_again(scene) -> None:
    import mujoco

    model, data, fast, full = scene
    assert not _draw(model, data, fast, full, "above")[0]
    above = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "above")
    model.cam_quat[above] = [np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0, 0.0]  # now looking sideways
    mujoco.mj_forward(model, data)
    drawn, image, reference = _draw(model, data, fast, full, "above")
    assert drawn and np.array_equal(image, reference)


def test_culling_is_off_where_a_view_is_not_set_by_its_vertical_angle(scene) -> None:
    # The culling bounds a perspective view by its vertical angle; the orthographic camera's 0.3 is
    # a width in metres, and the cup 0.1 m off its axis would be culled as outside a 0.3-degree view.
    import mujoco

    from libero_data.sim.fast.renderer import OffscreenRenderer
    from libero_data.sim.gl import select_backend

    model, data, _, full = scene
    culled = OffscreenRenderer(model, 64, select_backend(), cull=True)
    try:
        assert not culled.cull
        flat = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, "flat")
        assert np.array_equal(culled.render(model, data, flat), full.render(model, data, flat))
    finally:
        culled.close()
