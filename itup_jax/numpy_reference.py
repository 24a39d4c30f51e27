"""The wrench costs in plain vectorised NumPy: the benchmark's reference and an independent oracle.

Written from the formulas in `wrench` and `costs` docstrings, batch axes by hand (no vmap), so that
tests can check the JAX implementation against it and `itup bench costs` can time both on the same
inputs. Not differentiable; not the library path.
"""

from __future__ import annotations

import numpy as np

from itup_jax.grip_demand import MIN_COUPLE_WIDTH
from itup_jax.robot import PAD_TORSION, PAD_WIDTH


def _norm(x: np.ndarray) -> np.ndarray:
    return np.sqrt(np.sum(x * x, axis=-1))


def numpy_wrench_costs(tool: dict, task: dict, grasps: dict, *, w_tau=1.0, w_slip=1.0, w_align=1.0,
                       grip_force=0.0, lever_arm="grasp", torque_projection="perp",
                       include_gravity=False) -> dict[str, np.ndarray]:
    """Peak costs [N] of a batch of grasps.

    Args:
      tool: mass, com [3], inertia [3, 3], restitution, mu, contact_duration (NumPy).
      task: c_tool [K, 3], n_world [K, 3], inv_mass_obj [K], drag_force [K], impact [T, K], drag [T, K],
        gravity_world [3], slip_velocity, and the trajectory p, R [T, 3, 3], v, w, a, alpha [T, 3].
      grasps: p [N, 3] (tool frame), R [N, 3, 3] (R_tool_grasp), width [N] (m).
    Returns:
      dict of tau, slip, align, total, tau_closure, each [N].
    """
    R, v, w, a, alpha = task["R"], task["v"], task["w"], task["a"], task["alpha"]
    m, com, inertia = tool["mass"], tool["com"], tool["inertia"]
    I_w = R @ inertia @ R.transpose(0, 2, 1)  # [T, 3, 3]
    I_inv_w = R @ np.linalg.inv(inertia) @ R.transpose(0, 2, 1)
    com_rel = R @ com  # [T, 3]
    c_rel = np.einsum("tij,kj->tki", R, task["c_tool"])  # [T, K, 3]
    v_c = v[:, None, :] + np.cross(w[:, None, :], c_rel)
    n = task["n_world"][None]  # [1, K, 3]
    r = c_rel - com_rel[:, None, :]
    rxn = np.cross(r, n)
    k_eff = 1.0 / m + task["inv_mass_obj"][None] + np.sum(n * np.cross(np.einsum("tij,tkj->tki", I_inv_w, rxn), r), -1)
    J = (1.0 + tool["restitution"]) * np.maximum(-np.sum(v_c * n, -1), 0.0) / k_eff  # [T, K]
    F_imp = (task["impact"] * J / tool["contact_duration"])[..., None] * n
    speed = np.sqrt(np.sum(v_c * v_c, -1) + task["slip_velocity"] ** 2)
    F_drag = -(task["drag"] * task["drag_force"][None] / speed)[..., None] * v_c
    F_k = F_imp + F_drag
    a_com = a + np.cross(alpha, com_rel) + np.cross(w, np.cross(w, com_rel))
    g = task["gravity_world"] if include_gravity else np.zeros(3)
    F_in = m * (a_com - g)
    M_in = np.cross(com_rel, F_in) + np.einsum("tij,tj->ti", I_w, alpha) + np.cross(w, np.einsum("tij,tj->ti", I_w, w))
    F_world = F_in - F_k.sum(1)
    M_world = M_in - np.cross(c_rel, F_k).sum(1)
    Rt = R.transpose(0, 2, 1)
    F = np.einsum("tij,tj->ti", Rt, F_world)  # [T, 3] tool frame
    M = np.einsum("tij,tj->ti", Rt, M_world)
    n_tool = np.einsum("tij,tj->ti", Rt, task["n_world"][0][None].repeat(len(R), 0))
    active = np.max(np.maximum(task["impact"], task["drag"]), axis=1)  # [T]

    n_f = grasps["R"][:, :, 1]  # [N, 3] closure axes
    pivot = {"grasp": grasps["p"], "com": np.broadcast_to(com, grasps["p"].shape),
             "wrist": grasps["p"] - 0.085 * grasps["R"][:, :, 2]}[lever_arm]  # the flange, 85 mm behind
    tau = M[None] - np.cross(pivot[:, None, :], F[None])  # [N, T, 3]
    tau_n = np.einsum("ntj,nj->nt", tau, n_f)
    tau_perp = tau - tau_n[..., None] * n_f[:, None, :]
    if torque_projection == "grip":
        # the wrench in each grasp's frame (x third, y closure, z approach), then the pads' limit surface
        Fg = np.einsum("tj,nji->nti", F, grasps["R"])
        tg = np.einsum("ntj,nji->nti", tau, grasps["R"])
        mu = tool["mu"]
        arm = mu * np.maximum(grasps["width"], MIN_COUPLE_WIDTH)[:, None]
        need = np.sqrt((Fg[..., 0] ** 2 + Fg[..., 2] ** 2) / (2 * mu) ** 2 + Fg[..., 1] ** 2 / 4
                       + (tg[..., 1] / (2 * PAD_TORSION)) ** 2 + (tg[..., 2] / (arm + PAD_WIDTH)) ** 2
                       + (tg[..., 0] / arm) ** 2)
        c_tau = (2 * PAD_TORSION * need).max(1)
    elif torque_projection == "passed":  # the closure-axis part capped by the pads' torsional friction
        cap = 2 * PAD_TORSION * tool["mu"] * grip_force
        c_tau = np.sqrt(_norm(tau_perp) ** 2 + np.minimum(np.abs(tau_n), cap) ** 2).max(1)
    else:
        c_tau = _norm(tau_perp if torque_projection == "perp" else tau).max(1)
    F_n = np.einsum("tj,nj->nt", F, n_f)
    F_t = _norm(F[None] - F_n[..., None] * n_f[:, None, :])
    c_slip = np.maximum(F_t - tool["mu"] * (np.abs(F_n) + 2.0 * grip_force), 0.0).max(1)
    cross = _norm(np.cross(n_f[:, None, :], n_tool[None]))
    dot = np.abs(np.einsum("nj,tj->nt", n_f, n_tool))
    c_align = np.where(active[None] > 0, np.arctan2(cross, dot), 0.0).max(1)
    total = w_tau * c_tau + w_slip * c_slip + w_align * c_align
    return {"tau": c_tau, "slip": c_slip, "align": c_align, "total": total, "tau_closure": np.abs(tau_n).max(1)}


def to_numpy_inputs(tool_params, task, grasps) -> tuple[dict, dict, dict]:
    """Convert (ToolParams, Task, Grasps) pytrees to the dicts `numpy_wrench_costs` takes."""
    a = np.asarray
    tool = {k: a(getattr(tool_params, k)) for k in ("mass", "com", "inertia", "restitution", "mu", "contact_duration")}
    tr = task.traj
    tk = {k: a(getattr(task, k)) for k in ("c_tool", "n_world", "inv_mass_obj", "drag_force", "impact", "drag",
                                          "gravity_world", "slip_velocity")}
    tk.update(R=a(tr.R_world_tool), v=a(tr.v_world), w=a(tr.w_world), a=a(tr.a_world), alpha=a(tr.alpha_world))
    return tool, tk, {"p": a(grasps.p_tool_grasp), "R": a(grasps.rotation), "width": a(grasps.width)}
