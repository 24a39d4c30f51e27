"""The tool frame of each built-in category, drawn for the README's "Your own tool": every tool's side
view in its tool frame (the handle along z; x or y across it), the frame's axes at the origin, the
contact point and the direction its face pushes, and the grasp region.

    python experiments/plot_tool_frames.py --out docs/tool_frames.png
"""

from __future__ import annotations

import argparse

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

import itup_jax as itup
from itup_jax.plotting import AXIS_COLOURS, save_figure, silhouette, view_axes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="docs/tool_frames.png")
    args = ap.parse_args()
    names = [itup.tasks.get(k).default_tool for k in itup.TASK_KINDS]
    fig, axs = plt.subplots(1, len(names), figsize=(3.2 * len(names), 5.0))
    for ax, name in zip(axs, names):
        tool = itup.load_tool(name)
        axes = view_axes(tool)
        letters = "xyz"
        silhouette(ax, tool, axes)
        lo, hi = tool.grasp_region.lo[list(axes)], tool.grasp_region.hi[list(axes)]
        ax.add_patch(Rectangle(lo, *(hi - lo), fill=False, ls="--", ec="0.35", lw=1.0, label="grasp region"))
        L = 0.08
        for i, a in enumerate(axes):
            d = np.zeros(2)
            d[i] = L
            ax.annotate("", xy=d, xytext=(0, 0), arrowprops=dict(arrowstyle="-|>", color=AXIS_COLOURS[letters[a]], lw=2))
            ax.text(*(1.25 * d), f"+{letters[a]}", color=AXIS_COLOURS[letters[a]], fontsize=10, ha="center", va="center")
        cp = tool.contact_point[list(axes)]
        n = tool.contact_normal[list(axes)]
        ax.plot(*cp, marker="*", ms=14, color="tab:orange", mec="k", mew=0.5, ls="none", label="contact point")
        if np.linalg.norm(n) > 1e-6:
            d = 0.07 * n / np.linalg.norm(n)
            ax.annotate("", xy=cp + d, xytext=cp, arrowprops=dict(arrowstyle="-|>", color="tab:orange", lw=2))
        off = [letters[a] for a in range(3) if a not in axes][0]
        normal = "".join(f"{'+' if v > 0 else '-'}{letters[i]}" for i, v in enumerate(tool.contact_normal) if abs(v) > 0.5)
        ax.set_title(f"{tool.category}: normal {normal}\n(view along {off})", fontsize=9)
        v = np.asarray(tool.mesh.vertices, float)[:, list(axes)]
        span = np.ptp(v, axis=0).max()
        ax.set_xlim(v[:, 0].min() - 0.12, v[:, 0].max() + 0.12)
        ax.set_ylim(v[:, 1].min() - 0.05, v[:, 1].min() + span + 0.08)
        ax.set_aspect("equal")
        ax.set_xlabel(f"{letters[axes[0]]} (m)")
        ax.set_ylabel(f"{letters[axes[1]]} (m)")
    axs[0].legend(fontsize=7, loc="upper left")
    fig.suptitle("The tool frame of each category: the handle along +z; the contact face's normal (orange)", fontsize=10)
    fig.tight_layout()
    print(save_figure(fig, args.out, dpi=100))


if __name__ == "__main__":
    main()
