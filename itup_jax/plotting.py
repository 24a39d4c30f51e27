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
from itup_jax.tools import Tool  # noqa: E402

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


def view_axes(tool: Tool) -> tuple[int, int]:
    """The tool-frame plane a side view draws: (the axis across the handle that the contact normal leans
    along, z). Hammer and mallet: x-z (the face normal is +x); broom: y-z; L-stick: x-z (its hook)."""
    n = np.asarray(tool.contact_normal, float)
    return (0, 2) if abs(n[0]) >= abs(n[1]) else (1, 2)


def silhouette(ax, tool: Tool, axes: tuple[int, int], colour: str = "0.8", origin=(0.0, 0.0),
                scale: float = 1.0) -> None:
    """The mesh projected on the plane of `axes`: every triangle filled (their union is the outline),
    drawn as scale * (point - origin) (e.g. mm about a zoom's centre)."""
    from matplotlib.collections import PolyCollection

    tri = np.asarray(tool.mesh.vertices, float)[np.asarray(tool.mesh.faces)][:, :, list(axes)]
    ax.add_collection(PolyCollection(scale * (tri - np.asarray(origin, float)), facecolors=colour, edgecolors=colour,
                                     linewidths=0.3))


def _pad_outlines(g: Grasps, axes: tuple[int, int]) -> list[np.ndarray]:
    """The two pads of a grasp (22 x 37.5 mm, at y = -+width/2 in the grasp frame) projected on `axes`:
    [2] arrays [4, 2] of corners in the tool frame."""
    from itup_jax.robot import PAD_LENGTH, PAD_WIDTH

    R = np.asarray(g.rotation, float).reshape(3, 3)
    p = np.asarray(g.p_tool_grasp, float).reshape(3)
    w = float(np.asarray(g.width).reshape(()))
    out = []
    for side in (-1.0, 1.0):
        c = np.array([[sx * PAD_WIDTH / 2, side * w / 2, sz * PAD_LENGTH / 2]
                      for sx, sz in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
        out.append((p + c @ R.T)[:, list(axes)])
    return out


def plot_picks(tool: Tool, grasps: dict, path: str, *, traces: dict | None = None, title: str | None = None,
               motion: np.ndarray | None = None) -> str:
    """Each method's picked grasp on the tool, and (with `traces`) each pick's measured wrist torque over
    the motion.

    Left: a side view of the whole tool (tool frame, the plane of the handle and the contact normal) with
    the contact point, the face's normal and, given `motion` [3] (the contact point's direction of motion
    at contact, tool frame), the direction the tool moves; each pick as the outline of its two pads and
    its approach axis. Middle: the same view zoomed on the picks, in mm, each pick with its own colour and
    line style. Right: the torque traces, {method: (t [S] s, induced [S] N m, raw [S] N m)}: the full
    induced torque (`sim.labels.induced`'s norm, the comparison's headline; solid) and the raw torque
    norm, holding torque included (dotted).
    grasps: {method: Grasps of one}. Writes a PNG (atomically) and returns the path."""
    from matplotlib.ticker import MaxNLocator

    colours = ["tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange", "tab:brown"]
    styles = ["-", "--", "-.", ":", "-", "--"]
    axes = view_axes(tool)
    names = "xyz"
    ncol = 3 if traces else 2
    fig, axs = plt.subplots(1, ncol, figsize=(5.2 * ncol, 5.2), gridspec_kw={"width_ratios": [1, 1, 1.6][:ncol]})
    verts = np.asarray(tool.mesh.vertices, float)[:, list(axes)]
    cp = np.asarray(tool.contact_point, float)[list(axes)]
    n2 = np.asarray(tool.contact_normal, float)[list(axes)]
    span = float(np.ptp(verts, axis=0).max())
    pads = {name: _pad_outlines(g, axes) for name, g in grasps.items()}
    ax = axs[0]
    silhouette(ax, tool, axes)
    for name, c, ls in zip(grasps, colours, styles):
        for pad in pads[name]:
            ax.fill(*pad.T, facecolor=c, alpha=0.35, edgecolor=c, lw=1.2, ls=ls)
    ax.plot(*cp, marker="*", ms=14, color="tab:orange", mec="k", mew=0.5, ls="none", label="contact point")
    if np.linalg.norm(n2) > 1e-6:
        d = 0.18 * span * n2 / np.linalg.norm(n2)
        ax.annotate("", xy=cp + d, xytext=cp, arrowprops=dict(arrowstyle="-|>", color="tab:orange", lw=2))
        ax.text(*(cp + 1.15 * d), "face", color="tab:orange", fontsize=9, ha="center", va="center")
    if motion is not None:
        m2 = np.asarray(motion, float)[list(axes)]
        if np.linalg.norm(m2) > 1e-6:
            d = 0.18 * span * m2 / np.linalg.norm(m2)
            side = 0.08 * span * np.array([d[1], -d[0]]) / np.linalg.norm(d)  # beside the contact, away from the tool
            if side @ (cp - verts.mean(0)) < 0:
                side = -side
            start = cp - 1.2 * d + side
            ax.annotate("", xy=start + d, xytext=start, arrowprops=dict(arrowstyle="-|>", color="k", lw=1.5, ls="--"))
            ax.text(*(start + 0.5 * d + 0.8 * side), "motion", fontsize=9, ha="center", va="center")
    lo, hi = verts.min(0) - 0.2 * span, verts.max(0) + 0.2 * span
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.set_xlabel(f"tool {names[axes[0]]} (m)")
    ax.set_ylabel(f"tool {names[axes[1]]} (m): along the handle")
    ax.xaxis.set_major_locator(MaxNLocator(4))
    ax.yaxis.set_major_locator(MaxNLocator(6))
    ax.set_title(title or f"{tool.name}: picked grasps", fontsize=9)
    ax.legend(fontsize=8, loc="lower right")
    # zoom on the picks, in mm
    ax = axs[1]
    pts = np.concatenate([np.concatenate(v) for v in pads.values()])
    centre = pts.mean(0)
    half = max(float(np.ptp(pts, axis=0).max()) / 2 + 0.015, 0.03)
    silhouette(ax, tool, axes, colour="0.85", origin=centre, scale=1e3)
    for (name, g), c, ls in zip(grasps.items(), colours, styles):
        for k, pad in enumerate(pads[name]):
            ax.fill(*(1e3 * (pad - centre)).T, facecolor="none", edgecolor=c, lw=2, ls=ls,
                    label=name if k == 0 else None)
        R = np.asarray(g.rotation, float).reshape(3, 3)
        o = (np.asarray(g.p_tool_grasp, float).reshape(3))[list(axes)] - centre
        a = R[:, 2][list(axes)]  # the approach axis, from the palm to the fingertips
        if np.linalg.norm(a) > 1e-6:
            a = a / np.linalg.norm(a)
            ax.annotate("", xy=1e3 * o, xytext=1e3 * (o - min(0.6 * half, 0.03) * a),
                        arrowprops=dict(arrowstyle="-|>", color=c, lw=1.2, ls=ls))
        ax.plot(*(1e3 * o), marker="o", ms=4, color=c)
    ax.set_xlim(-1e3 * half, 1e3 * half)
    ax.set_ylim(-1e3 * half, 1e3 * half)
    ax.set_aspect("equal")
    ax.set_xlabel(f"tool {names[axes[0]]} (mm, from the picks' centre)")
    ax.set_ylabel(f"tool {names[axes[1]]} (mm)")
    ax.xaxis.set_major_locator(MaxNLocator(5))
    ax.yaxis.set_major_locator(MaxNLocator(5))
    ax.legend(fontsize=8, loc="upper left", title="pads; arrow: approach", title_fontsize=8)
    ax.set_title("the picks, zoomed", fontsize=9)
    if traces:
        ax2 = axs[2]
        for (name, (t, induced, raw)), c in zip(traces.items(), colours):
            ax2.plot(t, induced, color=c, lw=1.3, label=f"{name}: induced |τ - τ_static|")
            ax2.plot(t, raw, color=c, lw=0.8, ls=":", label=f"{name}: raw |τ| (holding torque included)")
        ax2.set_xlabel("time from the start of the motion (s)")
        ax2.set_ylabel("wrist torque (N m)")
        ax2.legend(fontsize=8)
        ax2.set_title("wrist torque measured in MuJoCo", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)
