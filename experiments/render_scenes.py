"""Pictures of the four task scenes for the docs: for each task, the first feasible sampled grasp at
the start of the motion and at the moment of contact (impact, or mid-pull), rendered offscreen; and the
whole chain's table with four clutter tools (seed 3), as `itup run` draws it (tabletop.png).

    python experiments/render_scenes.py [--out docs]

OpenGL as `itup_jax.render` finds it: MUJOCO_GL if set, else EGL (a GPU's, or Mesa's software EGL on a
CPU-only machine), else OSMesa (Debian's libosmesa6).
"""

from __future__ import annotations

import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import itup_jax as itup
from itup_jax.render import rollout_frames
from itup_jax.sim.arm import plan
from itup_jax.sim.physics import sample_physics
from itup_jax.sim.scene import build_scene
from itup_jax.task import DEFAULT_TOOL

VIEWS = {
    "hammer": dict(lookat=(0.45, 0.0, 0.15), azimuth=150.0),
    "sweep": dict(lookat=(0.45, 0.0, 0.1), azimuth=200.0),
    "knock": dict(lookat=(0.45, 0.0, 0.2), azimuth=130.0),
    "reach": dict(lookat=(0.6, 0.0, 0.1), azimuth=120.0, distance=1.6),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="docs")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    for kind in itup.TASK_KINDS:
        tool = itup.load_tool(DEFAULT_TOOL[kind])
        task = itup.make_task(kind, tool)
        grasps = itup.sample_grasps(tool, 32, seed=0)
        scene = build_scene(tool, task)
        physics = sample_physics(tool, len(grasps), spread=None)
        p = plan(scene, task, grasps, physics)
        i = int(np.nonzero(~p.infeasible)[0][0])
        active = np.asarray(np.maximum(task.impact, task.drag).max(1) > 0)
        k_contact = int(np.nonzero(active)[0][len(np.nonzero(active)[0]) // 2 if kind in ("sweep", "reach") else 0])
        step_contact = p.n_settle + int(np.argmin(np.abs(p.sim_t[p.n_settle:] - float(task.traj.t[k_contact]))))
        frames = rollout_frames(scene, p, physics, i, [p.n_settle, step_contact], **VIEWS[kind])
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.9))
        for ax, img, title in zip(axes, frames, ("start of the motion", "contact")):
            ax.imshow(img)
            ax.set_title(f"{kind}: {title}", fontsize=9)
            ax.axis("off")
        fig.tight_layout()
        path = os.path.join(args.out, f"scene_{kind}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        print(f"wrote {path} (grasp #{i})")
    from itup_jax import tabletop

    path = os.path.join(args.out, "tabletop.png")
    fig = tabletop.picture(tabletop.make_tabletop(clutter=4, seed=3), path, view="camera")
    plt.close(fig)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
