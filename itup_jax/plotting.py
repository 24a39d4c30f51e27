"""Matplotlib figures (host side, off the jit path): tools, grasp candidates, the grasp frame."""

from __future__ import annotations

import os
from typing import Any

import matplotlib

matplotlib.use("Agg")  # headless: figures are written to files

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

from itup_jax.grasp import Grasps, gripper_boxes  # noqa: E402
from itup_jax.tool import Tool  # noqa: E402

AXIS_COLOURS = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}
_BOX_EDGES = [(0, 1), (0, 2), (0, 4), (1, 3), (1, 5), (2, 3), (2, 6), (3, 7), (4, 5), (4, 6), (5, 7), (6, 7)]


def _box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])


def draw_mesh(ax, mesh, colour: str = "0.75", alpha: float = 0.35) -> None:
    """Triangles of a trimesh on a 3-D axes (metres)."""
    poly = Poly3DCollection(mesh.triangles, facecolor=colour, edgecolor="none", alpha=alpha)
    ax.add_collection3d(poly)


def draw_gripper(ax, R: np.ndarray, p: np.ndarray, opening: float, colour: str = "k", lw: float = 1.0) -> None:
    """Wireframe of the gripper's fingers and palm at pose (R, p) and jaw `opening` (m)."""
    segs = []
    for _, lo, hi in gripper_boxes(opening):
        c = _box_corners(lo, hi) @ R.T + p
        segs += [(c[i], c[j]) for i, j in _BOX_EDGES]
    ax.add_collection3d(Line3DCollection(segs, colors=colour, linewidths=lw))


def draw_frame(ax, R: np.ndarray, p: np.ndarray, length: float, labels: bool = True) -> None:
    """Axes x (red), y = jaw closure (green), z = approach (blue) of a frame."""
    for k, name in enumerate("xyz"):
        d = R[:, k] * length
        ax.quiver(*p, *d, color=AXIS_COLOURS[name], linewidth=2, arrow_length_ratio=0.2)
        if labels:
            text = {"x": "x", "y": "y (closure)", "z": "z (approach)"}[name]
            ax.text(*(p + 1.15 * d), text, color=AXIS_COLOURS[name], fontsize=8)


def _equal_axes(ax, points: np.ndarray) -> None:
    centre = 0.5 * (points.max(0) + points.min(0))
    half = 0.5 * (points.max(0) - points.min(0)).max()
    for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        setter(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")


def plot_frame_convention(ax, width: float = 0.03) -> None:
    """The grasp frame: gripper outline in its own frame, pads at y = -/+ width/2, origin between."""
    draw_gripper(ax, np.eye(3), np.zeros(3), width, colour="0.3")
    pads = np.array([[0, -width / 2, 0], [0, width / 2, 0]])
    ax.scatter(*pads.T, color=AXIS_COLOURS["y"], s=25)
    ax.scatter(0, 0, 0, color="k", s=20)
    draw_frame(ax, np.eye(3), np.zeros(3), 0.04)
    corners = np.concatenate([_box_corners(lo, hi) for _, lo, hi in gripper_boxes(width)])
    _equal_axes(ax, np.concatenate([corners, [[0, 0, 0.05]]]))
    ax.set_title("grasp frame: origin between the pads", fontsize=9)
    ax.view_init(elev=20, azim=-60)


def save_figure(fig, path: str, *, dpi: int = 100, **savefig_kw: Any) -> str:
    """Render `fig` to PNG, close it, and write it to `path` atomically (folders made as needed)."""
    import io

    from itup_jax.atomic import atomic_write

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, **savefig_kw)
    plt.close(fig)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    atomic_write(path, buf.getvalue())
    return path


def plot_grasp_candidates(tool: Tool, grasps: Grasps, values: Any, path: str, *, label: str = "C_tau (N m)",
                          title: str | None = None, best: int | None = None) -> str:
    """Three panels: the tool with grasp origins coloured by `values` [N] and the best grasp's gripper;
    `values` against the grasp's height along the tool's z axis; the grasp-frame convention.

    Writes a PNG to `path` (folders created) and returns the path.
    """
    values = np.asarray(values, dtype=float)
    p = np.asarray(grasps.p_tool_grasp, dtype=float)
    R = np.asarray(grasps.rotation, dtype=float)
    w = np.asarray(grasps.width, dtype=float)
    best = int(np.argmin(values)) if best is None else best
    fig = plt.figure(figsize=(15, 5.0))
    ax = fig.add_subplot(1, 3, 1, projection="3d")
    draw_mesh(ax, tool.mesh)
    sc = ax.scatter(*p.T, c=values, cmap="viridis", s=10, depthshade=False)
    draw_gripper(ax, R[best], p[best], w[best] + 0.01, colour="tab:red", lw=1.2)
    draw_frame(ax, R[best], p[best], 0.03, labels=False)
    cp = tool.contact_point
    ax.quiver(*cp, *(0.05 * tool.contact_normal), color="tab:orange", linewidth=2)
    ax.text(*(cp + 0.06 * tool.contact_normal), "contact", color="tab:orange", fontsize=8)
    _equal_axes(ax, np.asarray(tool.mesh.vertices))
    ax.view_init(elev=15, azim=-50)
    fig.colorbar(sc, ax=ax, shrink=0.6, pad=0.12, label=label)
    ax.set_title(title or f"{tool.name}: {len(p)} candidates, best in red", fontsize=9)

    ax2 = fig.add_subplot(1, 3, 2)
    closure_along_face = np.abs(R[:, :, 1] @ tool.contact_normal)
    sc2 = ax2.scatter(p[:, 2], values, c=closure_along_face, cmap="coolwarm", s=8, vmin=0, vmax=1)
    ax2.scatter(p[best, 2], values[best], marker="*", s=160, color="tab:red", label="best C")
    ax2.axvline(cp[2], color="tab:orange", ls="--", lw=1, label="contact height")
    ax2.set_xlabel("grasp origin height along the tool z axis (m)")
    ax2.set_ylabel(label)
    ax2.legend(fontsize=8, loc="upper right")
    fig.colorbar(sc2, ax=ax2, label="|closure axis . contact normal|")
    ax2.set_title("shorter lever arm to the contact, lower torque", fontsize=9)
    plot_frame_convention(fig.add_subplot(1, 3, 3, projection="3d"))
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)


def plot_picks(tool: Tool, grasps: dict, path: str, *, traces: dict | None = None, title: str | None = None) -> str:
    """The tool with each method's picked grasp (gripper wireframe), and (with `traces`) each pick's
    measured wrist torque over the motion. grasps: {method: Grasps of one}; traces: {method: (t [S] s,
    projected [S] N m, raw [S] N m)}: the projected induced torque (`simulate.induced`'s (x, z) norm, the
    labels' and C_tau's quantity; solid) and the raw torque norm, holding torque included (dotted).
    Writes a PNG (atomically) and returns the path."""
    colours = ["tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown"]
    ncol = 2 if traces else 1
    fig = plt.figure(figsize=(6.5 * ncol, 5.0))
    ax = fig.add_subplot(1, ncol, 1, projection="3d")
    draw_mesh(ax, tool.mesh)
    for (name, g), c in zip(grasps.items(), colours):
        R = np.asarray(g.rotation, float).reshape(3, 3)
        p = np.asarray(g.p_tool_grasp, float).reshape(3)
        draw_gripper(ax, R, p, float(np.asarray(g.width).reshape(())) + 0.01, colour=c, lw=1.4)
        ax.text(*(p + np.array([0.0, 0.0, 0.015])), name, color=c, fontsize=8)
    _equal_axes(ax, np.asarray(tool.mesh.vertices))
    ax.view_init(elev=15, azim=-50)
    ax.set_title(title or f"{tool.name}: picked grasps", fontsize=9)
    if traces:
        ax2 = fig.add_subplot(1, 2, 2)
        for (name, (t, projected, raw)), c in zip(traces.items(), colours):
            ax2.plot(t, projected, color=c, lw=1.2, label=f"{name}: projected induced")
            ax2.plot(t, raw, color=c, lw=0.8, ls=":", label=f"{name}: raw |τ|, holding torque included")
        ax2.set_xlabel("time from the start of the motion (s)")
        ax2.set_ylabel("wrist torque (N m)")
        ax2.legend(fontsize=8)
        ax2.set_title("measured in MuJoCo", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)
