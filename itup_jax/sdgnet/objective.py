"""What SDG-Net learns and what a planner minimises: the named objectives.

An objective names the label columns the network regresses (each as log1p(y / scale)), how its
outputs make the costs the scorer totals, and the analytic cost of the same form (`costs.CostParams`).

  paper   the paper's: C_tau = the peak wrist torque perpendicular to the jaw's closure axis (the
          labels' `peak_torque_projected`), slip, alignment drift. A network trained on it can lower
          C_tau by turning the jaw until the impact torque lies on the closure axis, which the
          projection discards and which the pads hold worst (torsional friction only).
  wrench  the induced wrist torque's three grasp-frame components at its peak (third, closure,
          approach axes: tau = their norm, the full induced peak torque, with no projection), the grip
          demand (the normal force each pad needs to hold the induced wrench by friction,
          `grip_demand.py`: every component weighed by how hard it loads the grip), slip, alignment
          drift. Moving torque onto the closure axis leaves tau unchanged and raises the grip demand.
          Its analytic counterpart is `CostParams.wrench()`.

`costs_of(outputs, objective)` turns a network's outputs [N, K] (SI units) into the scorer's four cost
columns [N, 4] = (tau N m, slip m, align rad, grip N per pad; grip is 0 for the paper's objective,
which does not predict it). The scorer's total is `scoring.ScoreWeights` . those columns plus the
binary heads' penalties.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp

from itup_jax.costs import CostParams
from itup_jax.errors import InputError

#: The scorer's cost columns, in order, for every objective.
COST_COLUMNS = ("tau", "slip", "align", "grip")


@dataclasses.dataclass(frozen=True)
class Objective:
    """A named objective: `targets` (label columns, the network's regression outputs in order), their
    output names `outputs`, their default log1p scales `scales` (SI units; the ones named in
    `torque_outputs` take `TrainConfig.torque_scale` instead), `analytic`, the analytic cost of the
    same form, and `measured_tau`, the label that the scorer's tau predicts (what a verified pick's
    measured total weighs)."""

    name: str
    targets: tuple
    outputs: tuple
    scales: tuple
    torque_outputs: tuple
    analytic: CostParams
    measured_tau: str

    def target_scales(self, torque_scale: float) -> tuple:
        """Each target's log1p scale, the torque targets' at `torque_scale` (N m)."""
        return tuple(torque_scale if o in self.torque_outputs else s for o, s in zip(self.outputs, self.scales))


PAPER = Objective(
    name="paper",
    targets=("label_peak_torque_projected", "label_slip_translation", "label_alignment_drift"),
    outputs=("tau", "slip", "align"),
    scales=(0.02, 1e-3, 0.1),
    torque_outputs=("tau",),
    analytic=CostParams.paper(),
    measured_tau="peak_torque_projected",
)
WRENCH = Objective(
    name="wrench",
    targets=("label_peak_induced_third", "label_peak_induced_closure", "label_peak_induced_approach",
             "label_grip_demand", "label_slip_translation", "label_alignment_drift"),
    outputs=("tau_third", "tau_closure", "tau_approach", "grip", "slip", "align"),
    # N m, N m, N m, N per pad (1 N: about the least demand measured), m, rad
    scales=(0.02, 0.02, 0.02, 1.0, 1e-3, 0.1),
    torque_outputs=("tau_third", "tau_closure", "tau_approach"),
    analytic=CostParams.wrench(),
    measured_tau="peak_torque_induced",
)
OBJECTIVES = {o.name: o for o in (PAPER, WRENCH)}


def get(name: str, *, what: str = "objective") -> Objective:
    """The objective called `name`; InputError naming `what` and the known ones otherwise."""
    if name not in OBJECTIVES:
        raise InputError(f"{what}: unknown objective {name!r}; known: {', '.join(OBJECTIVES)}")
    return OBJECTIVES[name]


def costs_of(outputs, objective: str):
    """[N, K] network outputs (SI units) of `objective` -> [N, 4] cost columns (`COST_COLUMNS`). Pure
    (jnp); `objective` is static."""
    if objective == "paper":
        return jnp.concatenate([outputs, jnp.zeros_like(outputs[:, :1])], axis=1)
    if objective == "wrench":
        tau = jnp.sqrt(jnp.sum(outputs[:, :3] ** 2, axis=1, keepdims=True))
        return jnp.concatenate([tau, outputs[:, 4:6], outputs[:, 3:4]], axis=1)
    raise InputError(f"costs_of: unknown objective {objective!r}; known: {', '.join(OBJECTIVES)}")
