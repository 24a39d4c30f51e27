"""Simulation: MuJoCo scenes of the four tasks, rolled out in batches for ground-truth labels.

    from itup_jax.sim import simulate
    result = simulate(tool, task, grasps)     # result.labels.<name>: arrays [N]

One module per stage: `scene` (the composed MJCF: UR5e, gripper, wrist sensor, tool, task), `physics`
(each rollout's physics draw), `arm` (IK along the task, reachability, the plan of controls), `native`
(native MuJoCo, the CPU default and ground truth), `mjx` (MJX on accelerators), `labels` (what a rollout
measured), `rollout` (`simulate`, the one interface to both backends); `restitution`, `mjx_cholesky` and
`mjx_collision` hold what the scene and MJX need; `arm_inertia` (the arm as the hand feels it: the
operational-space inertia and servo impedance at the wrist sensor, for `itup_jax.transmission`).
"""

from itup_jax.sim.arm import Plan, reachability_in_order, reachable
from itup_jax.sim.config import SimConfig
from itup_jax.sim.labels import LABEL_FIELDS, Labels
from itup_jax.sim.physics import Physics, Randomization, sample_physics
from itup_jax.sim.rollout import SimResult, default_backend, simulate
from itup_jax.sim.scene import Scene, build_scene, task_timestep

__all__ = ["LABEL_FIELDS", "Labels", "Physics", "Plan", "Randomization", "Scene", "SimConfig", "SimResult",
           "build_scene", "default_backend", "reachability_in_order", "reachable", "sample_physics", "simulate",
           "task_timestep"]
