"""Offscreen pictures: where a world point lands in a picture (no OpenGL needed), the rendering itself
where an OpenGL backend works here, and a clear error where none does."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from itup_jax import render

XML = """<mujoco><visual><headlight ambient=".6 .6 .6"/></visual><worldbody><light pos="0 0 2"/>
<geom type="plane" size="2 2 .1" rgba=".2 .2 .2 1"/>
<geom type="sphere" size=".03" pos=".3 .2 .1" rgba="1 0 0 1"/></worldbody></mujoco>"""


@pytest.fixture(scope="module")
def ball():
    m = mujoco.MjModel.from_xml_string(XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return m, d


def test_projection_puts_the_lookat_at_the_centre_and_follows_the_camera_axes(ball):
    m, d = ball
    cam = render.free_camera((0.1, -0.2, 0.05), 1.5, 30.0, -40.0)
    glcam = render.gl_camera(m, d, cam)
    px, depth = render.project(np.array([[0.1, -0.2, 0.05]]), glcam, 320, 200)
    np.testing.assert_allclose(px[0], [160.0, 100.0], atol=1e-3)
    np.testing.assert_allclose(depth[0], 1.5, rtol=1e-5)
    right = np.cross(glcam["forward"], glcam["up"])
    px2, _ = render.project(np.array([[0.1, -0.2, 0.05]]) + 0.1 * right + 0.1 * glcam["up"], glcam, 320, 200)
    assert px2[0, 0] > 160 + 5 and px2[0, 1] < 100 - 5  # right is +column, up is -row
    # the vertical field of view is the model's fovy: a point on the frustum's top edge lands on row 0
    half = np.radians(m.vis.global_.fovy / 2)
    edge = glcam["pos"] + glcam["forward"] + np.tan(half) * glcam["up"]
    np.testing.assert_allclose(render.project(edge, glcam, 320, 200)[0][0], [160.0, 0.0], atol=1e-2)


def test_a_rendered_ball_lands_where_the_projection_says(ball):
    if render.gl_backend() is None:
        pytest.skip("no OpenGL backend on this machine (the fallback is tested below)")
    m, d = ball
    cam = render.free_camera((0.0, 0.0, 0.0), 1.5, 30.0, -40.0)
    with render.Offscreen(m, 320, 200) as off:
        rgb = off.render(d, cam)
    assert rgb.shape == (200, 320, 3) and rgb.dtype == np.uint8
    rows, cols = np.nonzero((rgb[..., 0] > 150) & (rgb[..., 1] < 80))
    assert len(rows) > 20
    px, _ = render.project(np.array([[0.3, 0.2, 0.1]]), render.gl_camera(m, d, cam), 320, 200)
    assert abs(cols.mean() - px[0, 0]) < 2.0 and abs(rows.mean() - px[0, 1]) < 2.0


def test_no_backend_is_a_clear_error_and_the_picture_falls_back(monkeypatch):
    from itup_jax import tabletop
    from itup_jax.errors import InputError

    def refuse(name):
        raise OSError(f"no {name} here")

    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setattr(render.importlib, "import_module", refuse)
    monkeypatch.setattr(render, "_BACKEND", [])
    with pytest.raises(render.RenderUnavailable, match="egl: OSError: no mujoco.egl here; osmesa: OSError"):
        render.Offscreen(mujoco.MjModel.from_xml_string(XML), 32, 32)
    assert render.gl_backend() is None
    assert tabletop.resolve_view("auto") == "top" and tabletop.resolve_view("top") == "top"
    with pytest.raises(render.RenderUnavailable, match="MUJOCO_GL=egl"):
        tabletop.resolve_view("camera")
    with pytest.raises(InputError, match="view 'side' is not one of auto, camera, top"):
        tabletop.resolve_view("side")


def test_run_asks_for_the_camera_view_where_none_works_before_any_work(monkeypatch, tmp_path, capsys):
    from itup_jax.cli import main
    from itup_jax.vlm import VLMError, VLMGrounder

    monkeypatch.setattr(render, "_BACKEND", [None])
    monkeypatch.setattr(render, "_context", lambda w, h: (_ for _ in ()).throw(render.RenderUnavailable("none here")))
    assert main(["run", "drive the nail", "--view", "camera", "--out", str(tmp_path / "r")]) == 2
    assert "--view camera: none here" in capsys.readouterr().err and not (tmp_path / "r").exists()
    with pytest.raises(VLMError, match="view must be one of auto, camera, top, got 'side'"):
        VLMGrounder(url="http://localhost:1/v1", model="m", view="side")
