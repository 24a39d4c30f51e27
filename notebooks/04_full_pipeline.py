# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # 04 — The whole chain: from an instruction to a tool picked up and the task done
#
# A table with tools lying on it (dropped to rest in MuJoCo), an instruction in plain words, and
# `itup.run`: grounding (which task, which tool, which parts), grasps the arm can pick from where the
# tool lies and carry through the task, SDG-Net's choice, the pick rolled out in MuJoCo (approach,
# close, lift: the grasp it achieved is measured), then the task from that grasp. Then the same table
# with an ablation, and a look at where the pipeline loses trials.
#
# Open with `jupytext --to notebook notebooks/04_full_pipeline.py`, or run it as a script.
# `ITUP_QUICK=1` (set by the test suite) samples fewer grasps.

# %%
import os

import matplotlib

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import numpy as np

import itup_jax as itup
from itup_jax import grounding, tabletop
from itup_jax.tools import parts

QUICK = os.environ.get("ITUP_QUICK") == "1"
OUT = os.environ.get("ITUP_NOTEBOOK_OUT", "notebooks/out")
os.makedirs(OUT, exist_ok=True)
SAMPLES = 256 if QUICK else 2048
METHODS = ("itup", "object_level") if QUICK else ("itup", "copa", "object_level")

# %% [markdown]
# ## The table
# The four built-in tools lie apart; `clutter=N` drops N procedural tools among them. Every tool names
# its parts; the work part holds the contact (Omega's c_tool), the grasp parts overlap the grasp region.

# %%
top = tabletop.make_tabletop(clutter=2, seed=4)
for i, t in enumerate(top.tools):
    print(f"tool {i + 1}: {t.name:18s}", ", ".join(f"{p.name} ({'/'.join(p.roles) or 'body'})" for p in parts.tool_parts(t)))
tabletop.picture(top, f"{OUT}/04_table.png")

# %% [markdown]
# ## Grounding
# The rule grounder reads the task from its verb and target, the tool and its parts from their names.

# %%
for instruction in ("drive the nail", "knock over the tower with the mallet, held by the handle",
                    "pull the block closer with tool 4"):
    g = grounding.ground(instruction, top)
    print(f"{instruction!r}: task {g.task}, tool {g.tool_index + 1} ({g.tool_name}), strike with the "
          f"{g.work_part}, hold the {g.grasp_part}")

# %% [markdown]
# ## The whole chain, and an ablation on the same table
# `method="copa"` scores by geometry within the grounded part; `"no_sdgnet"` by force closure;
# `"object_level"` grounds the tool only (whole tool, default contact). The SDG-Net methods choose as
# `itup plan` does: SDG-Net's 5 best checked in MuJoCo (`r.choice["checked"]`), the lowest measured total
# kept; the baselines take their best-scored grasp.

# %%
for method in METHODS:
    r = itup.run("knock over the tower", tabletop=top, seed=4, method=method, samples=SAMPLES)
    pick = r.pick
    print(f"{method:13s} {r.stage:6s} {r.message}")
    if pick is not None:
        print(f"{'':13s} pick: rose {pick.rise * 1000:.0f} mm, achieved grasp {pick.position_error * 1000:.1f} mm / "
              f"{np.degrees(pick.angle_error):.1f} deg from the planned one; candidates {r.counts}")
    if r.labels is not None:
        print(f"{'':13s} full induced peak wrist torque {r.labels['peak_torque_induced']:.2f} N m, "
              f"task metric {r.labels['task_metric']:.3f}")

# %% [markdown]
# ## When a pick cannot go on
# A pick that does not bring the tool up, or brings it up in a grasp the arm cannot carry through the
# task, puts the tool back down and the table is planned again (away from the grasp tried). Some rest
# poses leave no usable grasp at all: on this table the L-stick lies on its shaft with the hook up,
# where grasps from above hold it only along the hook, and the reach needs the gripper on the other
# side. The run then picks it up, turns it over about its handle and sets it down on its side first.

# %%
hooked = tabletop.make_tabletop(seed=2)
r = itup.run("pull the block closer", tabletop=hooked, seed=2, samples=SAMPLES)
for k, a in enumerate(r.attempts):
    print(f"pick {k + 1} ({a['action']}): {a['why']}")
print(f"pick {len(r.attempts) + 1}: {r.stage}: {r.message}")
