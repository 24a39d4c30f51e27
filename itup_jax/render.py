"""Offscreen pictures of a rollout (host side). Needs an OpenGL backend: MUJOCO_GL=egl on a GPU
machine, MUJOCO_GL=osmesa with Debian's libosmesa6 on a CPU-only one."""

from __future__ import annotations

import mujoco
import numpy as np

from itup_jax.scene import Scene
from itup_jax.simulate import Physics, Plan, randomized_model


def rollout_frames(scene: Scene, p: Plan, physics: Physics, i: int, steps: list[int], *,
                   width: int = 640, height: int = 480, lookat=(0.45, 0.0, 0.15), distance: float = 1.4,
                   azimuth: float = 140.0, elevation: float = -22.0) -> list[np.ndarray]:
    """RGB images [H, W, 3] of rollout i after each of `steps` (sorted step indices), stepping natively."""
    m = randomized_model(scene, physics, i)
    d = mujoco.MjData(m)
    d.qpos[:] = p.qpos0[i]
    mujoco.mj_forward(m, d)
    cam = mujoco.MjvCamera()
    cam.lookat[:], cam.distance, cam.azimuth, cam.elevation = lookat, distance, azimuth, elevation
    renderer = mujoco.Renderer(m, height, width)
    frames, k = [], 0
    try:
        for target in sorted(steps):
            while k < target:
                d.ctrl[:] = p.ctrl[i, k]
                mujoco.mj_step(m, d)
                k += 1
            renderer.update_scene(d, cam)
            frames.append(renderer.render().copy())
    finally:
        renderer.close()
    return frames
