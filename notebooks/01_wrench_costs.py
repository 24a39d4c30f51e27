# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
# ---

# %% [markdown]
# # 01 — Wrench costs along the handle
#
# Slide one grasp along the hammer's handle and watch the analytic costs change: the torque cost C_tau
# grows with the lever arm between the grasp and the hammer's face, and the jaw-closure axis decides
# how the impact torque splits: C_tau is the part perpendicular to the closure axis (the seed's
# choice), `tau_closure` the part about it, which only torsional friction of the pads resists. With
# the closure axis along the swing axis the whole impact torque is about the closure axis, so C_tau is
# ~0 while `tau_closure` carries it; with the closure axis along the face normal it is the other way
# round. Which of the two predicts measured wrist torque is for the MuJoCo experiments to decide.
#
# Open with `jupytext --to notebook notebooks/01_wrench_costs.py`, or run it as a script.
# `ITUP_QUICK=1` (set by the test suite) uses fewer samples.

# %%
import dataclasses
import os

import jax
import matplotlib

matplotlib.use(os.environ.get("MPLBACKEND", "Agg"))
import matplotlib.pyplot as plt
import numpy as np

import itup_jax as itup
from itup_jax.costs import CostParams, grasp_cost_trace
from itup_jax.grasp import make_grasps
from itup_jax.wrench import task_loads

QUICK = os.environ.get("ITUP_QUICK") == "1"
OUT = os.environ.get("ITUP_NOTEBOOK_OUT", "notebooks/out")
os.makedirs(OUT, exist_ok=True)

# %% [markdown]
# ## The tool and the task

# %%
tool = itup.load_tool("hammer")
task = itup.make_task("hammer", tool)
print(f"{tool.name}: {tool.mass:.3f} kg, com {np.round(np.asarray(tool.params.com), 3)} m, "
      f"regime {itup.classify_regime(tool, task).name}")
print("Omega:", {k: np.round(np.asarray(v), 3).tolist() for k, v in task.omega.items()})

# %% [markdown]
# ## One grasp orientation, many heights
# The closure axis is tool +y (perpendicular to the swing plane) or tool +x (along the face normal).

# %%
heights = np.linspace(0.01, 0.25, 12 if QUICK else 60)
R_closure_y = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])  # x, y, z columns
R_closure_x = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
fig, axes = plt.subplots(1, 2, figsize=(11, 4))
for R, name in ((R_closure_y, "closure along y (swing axis)"), (R_closure_x, "closure along x (face normal)")):
    g = make_grasps(np.c_[np.zeros_like(heights), np.zeros_like(heights), heights], np.repeat(R[None], len(heights), 0),
                    np.full(len(heights), 0.029))
    c = itup.wrench_costs(tool, task, g)
    axes[0].plot(heights, np.asarray(c.tau), label=f"C_tau, {name}")
    axes[0].plot(heights, np.asarray(c.tau_closure), "o", ms=3, label=f"tau about closure, {name}")
    axes[1].plot(heights, np.asarray(c.slip), label=name)
axes[0].set_xlabel("grasp height on the handle (m)")
axes[0].set_ylabel("peak torque (N m)")
axes[0].legend(fontsize=7)
axes[1].set_xlabel("grasp height on the handle (m)")
axes[1].set_ylabel("C_s (N)")
axes[1].legend(fontsize=7)
fig.tight_layout()
fig.savefig(f"{OUT}/01_costs_along_handle.png", dpi=90)

# %% [markdown]
# ## The wrench over time for one grasp

# %%
loads = task_loads(tool.params, task)
g = make_grasps([[0.0, 0.0, 0.12]], R_closure_x[None], [0.029])[0]
trace = grasp_cost_trace(loads, g, tool.params, CostParams())
t = np.asarray(task.traj.t)
fig, ax = plt.subplots(figsize=(7, 3))
ax.semilogy(t, np.asarray(trace.tau) + 1e-6, label="C_tau(t) (N m)")
ax.semilogy(t, np.asarray(trace.slip) + 1e-6, label="C_s(t) (N)")
ax.axvline(t[int(np.argmax(np.asarray(task.impact[:, 0])))], color="k", ls=":", label="impact")
ax.set_xlabel("t (s)")
ax.legend()
fig.tight_layout()
fig.savefig(f"{OUT}/01_trace.png", dpi=90)

# %% [markdown]
# ## Gradient: which way should the grasp move?
# The costs are differentiable in the grasp pose; the gradient of C_tau with respect to the grasp
# position points away from the contact (down the handle).

# %%
grad_p = jax.grad(lambda p: itup.grasp_costs(loads, dataclasses.replace(g, p_tool_grasp=p), tool.params,
                                             CostParams()).tau)(g.p_tool_grasp)
print("dC_tau/dp (N m per m):", np.round(np.asarray(grad_p), 2))
assert float(grad_p[2]) < 0  # moving up the handle, towards the head, lowers the torque
