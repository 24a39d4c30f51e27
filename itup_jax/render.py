"""Offscreen pictures with MuJoCo's renderer (host side), and where a world point lands in them.

    from itup_jax import render
    render.gl_backend()                          # 'egl', 'osmesa', ... or None where none works
    with render.Offscreen(m, 640, 480) as off:   # an OpenGL context and MuJoCo's render context
        rgb = off.render(d, render.free_camera((0.5, 0, 0), 1.4, 140, -22))   # [480, 640, 3] uint8
    px, depth = render.project(points, render.gl_camera(m, d, cam), 640, 480)  # [N, 2] pixels, [N] m

The OpenGL backend is the one `MUJOCO_GL` names when it is set (MuJoCo reads it when it is imported).
Unset, the first of EGL and OSMesa that makes a context is used: on a CPU-only Linux machine Mesa's
EGL renders in software (llvmpipe), and Debian's `libosmesa6` provides OSMesa. Where none works,
`Offscreen` raises `RenderUnavailable` naming what each backend said, and `gl_backend()` is None: the
callers that have a drawing without OpenGL (`tabletop.picture`) fall back to it.

`project` needs no OpenGL: it takes the camera MuJoCo's abstract scene computes (`gl_camera`,
`mjv_updateScene`) and the renderer's projection (the frustum's half-width from the image's aspect), so
marks drawn at its pixels sit on the rendered points.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Sequence

import mujoco
import numpy as np

from itup_jax.sim.arm import Plan
from itup_jax.sim.physics import Physics, randomized_model
from itup_jax.sim.scene import Scene


class RenderUnavailable(RuntimeError):
    """No OpenGL backend could make an offscreen context on this machine."""


def _context(width: int, height: int):
    """(an OpenGL context made current, the backend's name); RenderUnavailable if none works."""
    chosen = os.environ.get("MUJOCO_GL", "").strip().lower()
    if chosen:  # the user's choice, as MuJoCo set it up when it was imported
        from mujoco import gl_context

        try:
            ctx = gl_context.GLContext(width, height)
            ctx.make_current()
            return ctx, chosen
        except Exception as e:  # noqa: BLE001 - each backend fails in its own way
            raise RenderUnavailable(f"MUJOCO_GL={chosen} made no OpenGL context: {e}") from e
    errors = []
    for name in ("egl", "osmesa"):
        platform = os.environ.get("PYOPENGL_PLATFORM")
        try:
            ctx = importlib.import_module(f"mujoco.{name}").GLContext(width, height)
            ctx.make_current()
            return ctx, name
        except Exception as e:  # noqa: BLE001
            errors.append(f"{name}: {type(e).__name__}: {e}")
            if platform is None:  # mujoco.<name> set it before failing; let the next backend choose
                os.environ.pop("PYOPENGL_PLATFORM", None)
    raise RenderUnavailable("no OpenGL backend made an offscreen context (" + "; ".join(errors) + "); set "
                            "MUJOCO_GL=egl with a GPU or Mesa's libEGL, or MUJOCO_GL=osmesa with libosmesa6")


_BACKEND: list = []  # the probe's answer, once


def _probe() -> str:
    """The backend that makes a (small) context here; RenderUnavailable, saying why, where none does."""
    ctx, name = _context(16, 16)
    ctx.free()
    return name


def gl_backend() -> str | None:
    """The OpenGL backend offscreen pictures use here ('egl', 'osmesa', or what MUJOCO_GL names), or None
    where none makes a context. Probed once per process."""
    if not _BACKEND:
        try:
            _BACKEND.append(_probe())
        except RenderUnavailable:
            _BACKEND.append(None)
    return _BACKEND[0]


def require_gl() -> str:
    """`gl_backend()`, or RenderUnavailable naming what each backend said where none works."""
    return gl_backend() or _probe()


def free_camera(lookat: Sequence[float], distance: float, azimuth: float, elevation: float) -> mujoco.MjvCamera:
    """MuJoCo's free camera: looking at `lookat` (m, world) from `distance` (m); azimuth and elevation in
    degrees (azimuth 0 looks along world +x, elevation < 0 looks down)."""
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = lookat
    cam.distance, cam.azimuth, cam.elevation = distance, azimuth, elevation
    return cam


def _scene(m: mujoco.MjModel, d: mujoco.MjData, cam: mujoco.MjvCamera, maxgeom: int = 10_000) -> mujoco.MjvScene:
    scn = mujoco.MjvScene(m, maxgeom=maxgeom)
    mujoco.mjv_updateScene(m, d, mujoco.MjvOption(), None, cam, mujoco.mjtCatBit.mjCAT_ALL, scn)
    return scn


def gl_camera(m: mujoco.MjModel, d: mujoco.MjData, cam: mujoco.MjvCamera) -> dict:
    """The camera a mono picture is drawn with (no OpenGL needed): pos [3] m, forward [3], up [3] (unit),
    frustum near/top/bottom (m, at the near plane), frustum centre and half-width (0: from the aspect)."""
    scn = _scene(m, d, cam)
    g = mujoco.mjv_averageCamera(scn.camera[0], scn.camera[1])  # the two eyes' mean: what a mono picture uses
    return {"pos": np.array(g.pos, float), "forward": np.array(g.forward, float), "up": np.array(g.up, float),
            "near": float(g.frustum_near), "top": float(g.frustum_top), "bottom": float(g.frustum_bottom),
            "center": float(g.frustum_center), "width": float(g.frustum_width)}


def project(points: np.ndarray, cam: dict, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixels [N, 2] (column, row from the image's top left) of world points [N, 3] (m) in a picture of
    width x height drawn with `cam` (`gl_camera`), and their depth along the view [N] (m; <= 0: behind)."""
    p = np.atleast_2d(np.asarray(points, float)) - cam["pos"]
    fwd, up = cam["forward"], cam["up"]
    right = np.cross(fwd, up)
    z = p @ fwd
    x_near = cam["near"] * (p @ right) / z
    y_near = cam["near"] * (p @ up) / z
    half = cam["width"] if cam["width"] > 0 else 0.5 * (width / height) * (cam["top"] - cam["bottom"])
    left = cam["center"] - half
    col = (x_near - left) / (2 * half) * width
    row = (cam["top"] - y_near) / (cam["top"] - cam["bottom"]) * height
    return np.stack([col, row], axis=-1), z


class Offscreen:
    """An offscreen OpenGL context and MuJoCo's render context for model `m`, pictures of width x height
    pixels; a context manager (frees both). RenderUnavailable where no backend works (module docstring)."""

    def __init__(self, m: mujoco.MjModel, width: int = 640, height: int = 480):
        self.m, self.width, self.height = m, int(width), int(height)
        m.vis.global_.offwidth = max(m.vis.global_.offwidth, self.width)
        m.vis.global_.offheight = max(m.vis.global_.offheight, self.height)
        self._gl, self.backend = _context(self.width, self.height)
        self._con = mujoco.MjrContext(m, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self._con)

    def render(self, d: mujoco.MjData, cam: mujoco.MjvCamera) -> np.ndarray:
        """RGB [H, W, 3] uint8 of the state in `d` (after mj_forward) seen by `cam`."""
        self._gl.make_current()
        scn = _scene(self.m, d, cam)
        viewport = mujoco.MjrRect(0, 0, self.width, self.height)
        mujoco.mjr_render(viewport, scn, self._con)
        rgb = np.empty((self.height, self.width, 3), np.uint8)
        mujoco.mjr_readPixels(rgb, None, viewport, self._con)
        return np.flipud(rgb).copy()  # OpenGL's rows run bottom up

    def close(self) -> None:
        if self._con is not None:
            self._con.free()
            self._gl.free()
            self._con = None

    def __enter__(self) -> Offscreen:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def rollout_frames(scene: Scene, p: Plan, physics: Physics, i: int, steps: list[int], *,
                   width: int = 640, height: int = 480, lookat=(0.45, 0.0, 0.15), distance: float = 1.4,
                   azimuth: float = 140.0, elevation: float = -22.0) -> list[np.ndarray]:
    """RGB images [H, W, 3] of rollout i after each of `steps` (sorted step indices), stepping natively."""
    m = randomized_model(scene, physics, i)
    d = mujoco.MjData(m)
    d.qpos[:] = p.qpos0[i]
    mujoco.mj_forward(m, d)
    cam = free_camera(lookat, distance, azimuth, elevation)
    frames, k = [], 0
    with Offscreen(m, width, height) as off:
        for target in sorted(steps):
            while k < target:
                d.ctrl[:] = p.ctrl[i, k]
                mujoco.mj_step(m, d)
                k += 1
            mujoco.mj_forward(m, d)
            frames.append(off.render(d, cam))
    return frames
