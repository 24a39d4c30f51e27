"""SDG-Net's input features for one grasp (per-example; vmap over grasps, jit at the outer call).

Everything is expressed in the grasp frame, so the features do not change under a rigid transform of
the world (property C1) nor under a different choice of the tool's mesh frame:

  geometry [G^3]   soft occupancy of a G x G x G grid (edge `grid_half_width` x 2, centred on the grasp
                   origin) by a fixed surface sample of the tool: each point adds an isotropic Gaussian
                   of the cell size, normalised by the number of points. The Gaussian is isotropic, so
                   the occupancy of a cell is a field D(x) of the tool alone, evaluated at the cell's
                   centre: D is tabulated once per tool on a voxel grid in the tool frame
                   (`density_field`) and read by trilinear interpolation, 64 reads per grasp instead
                   of a sum over every surface point (measured: 610 ms -> see docs/benchmarks.md for 10,000
                   grasps). `exact_occupancy` is the direct sum, the reference the tests check against.
  loads [12]       peak |component| over time of the force the grasp carries and of the torque about the
                   grasp origin (grasp-frame axes), and both at the step of peak torque (signed).
  contact [9]      primary contact point, primary interaction normal at the step of peak torque, and
                   centre of mass, in the grasp frame.
  physics [4]      log mass, pad friction, restitution, log contact duration.
  wrist [6]        (only with `FeatureSpec.wrist`) the same rigid-body loads as the wrist's force/torque
                   site would read them, FLANGE_TO_GRASP behind the grasp along its approach axis: the
                   peak |component| of that torque per grasp-frame axis, the peak of its norm, the peak
                   the pads pass on (the closure-axis part capped by their torsional friction at
                   WRIST_GRIP_FORCE per pad, as `costs` 'passed'), and the peak grip demand of the
                   loads about the grasp (`grip_demand`, N per pad); each as log1p(x / scale), the
                   network's own target transform (scales WRIST_TORQUE_SCALE, 1 N), so that the
                   analytic ranking is one linear read-out away.
  residual [4]     (only with `FeatureSpec.residual`; after the wrist block when both are on) the rigid-body
                   model's own prediction of the wrench objective's first four targets, in their
                   transform: the wrist torque's three grasp-frame components at the step where the
                   torque the pads pass on peaks (the closure-axis one capped by the pads' torsional
                   friction at WRIST_GRIP_FORCE, so their norm is that passed-on peak), each
                   log1p(|x| / WRIST_TORQUE_SCALE), and the peak grip demand, log1p(x / 1 N). The
                   network takes them as inputs and, for such a spec, learns only what its torque and
                   grip outputs add to them (`model.residual_base`): where it has learnt nothing, its
                   prediction is the physics'.

Sizes and scales live in `FeatureSpec` (static), stored with a checkpoint so a scorer rebuilds the
same features.
"""

from __future__ import annotations

import dataclasses
import math
import weakref

import jax
import jax.numpy as jnp
import numpy as np
import trimesh

from itup_jax import robot
from itup_jax.costs import SQRT_TINY, TINY, passed_torque_sq, torsion_cap
from itup_jax.grasp import Grasps
from itup_jax.grip_demand import grip_demand_sq
from itup_jax.precision import full_precision
from itup_jax.robot import FLANGE_TO_GRASP
from itup_jax.rotations import quat_to_matrix
from itup_jax.shapes import pad_zeros_high, to_device
from itup_jax.tools import Tool, ToolParams
from itup_jax.wrench import Loads


@dataclasses.dataclass(frozen=True)
class FeatureSpec:
    """Static feature settings (SI units). `num_points`: surface sample size; `grid`: cells per axis."""

    num_points: int = 512
    grid: int = 4
    grid_half_width: float = 0.06  # m
    seed: int = 0
    field_spacing: float = 0.004  # m, voxel pitch of the tabulated density (Gaussian sigma / 7.5)
    wrist: bool = False  # append the wrist block (module docstring)
    residual: bool = False  # append the residual block; the network learns the residual on it (docstring)

    @property
    def size(self) -> int:
        return (self.grid**3 + 12 + 9 + 4 + (WRIST_SIZE if self.wrist else 0)
                + (RESIDUAL_SIZE if self.residual else 0))

    def to_dict(self) -> dict:
        """The spec as stored in datasets and checkpoints; `wrist` and `residual` only when set, so a spec
        without the blocks reads and compares as the specs written before the blocks existed."""
        d = dataclasses.asdict(self)
        for block in ("wrist", "residual"):
            if not d[block]:
                d.pop(block)
        return d


#: Size of the optional wrist block, its torque scale (N m, SDG-Net's `TrainConfig.torque_scale`) and
#: the squeeze per pad (N, `sim.config.SimConfig.grip_force`) at which the pads' torsional cap is taken.
WRIST_SIZE = 6
WRIST_TORQUE_SCALE = 0.02
WRIST_GRIP_FORCE = robot.GRIP_FORCE
#: Size of the optional residual block and the log1p scales of its entries (N m, N m, N m, N per pad): the
#: wrench objective's scales of its first four targets (`objective.WRENCH`), which a residual network needs.
RESIDUAL_SIZE = 4
RESIDUAL_SCALES = (WRIST_TORQUE_SCALE,) * 3 + (1.0,)


def surface_sample(tool: Tool, spec: FeatureSpec) -> jax.Array:
    """[P, 3] fixed, area-uniform points on the tool's surface (tool frame), deterministic for the seed."""
    pts, _ = trimesh.sample.sample_surface(tool.mesh, spec.num_points, seed=spec.seed)
    return to_device(np.asarray(pts, float))


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class DensityField:
    """The surface density D(x) of a tool tabulated on a voxel grid in the tool frame.

    values [I, J, K] (dimensionless, sum of unit Gaussians / points); origin [3] (m): the position of
    voxel (0, 0, 0); spacing (m, static). Zero outside the grid, which extends `grid_half_width` x sqrt(3)
    + 2 sigma beyond the surface sample, so every cell centre of a grasp on the tool falls inside it.
    """

    values: jax.Array
    origin: jax.Array
    spacing: float = dataclasses.field(metadata=dict(static=True))


#: the density field's voxel counts are padded to buckets of 3 significant bits (shapes.py)
FIELD_BUCKET_BITS = 3


def _cell(spec: FeatureSpec) -> float:
    return 2 * spec.grid_half_width / spec.grid


def _cell_centres(spec: FeatureSpec) -> np.ndarray:
    """[G^3, 3] cell centres in the grasp frame, in the (i, j, k) ravel order of the features."""
    c = (np.arange(spec.grid) + 0.5) * _cell(spec) - spec.grid_half_width
    return np.stack(np.meshgrid(c, c, c, indexing="ij"), -1).reshape(-1, 3)


def density_field(points_tool: np.ndarray | jax.Array, spec: FeatureSpec) -> DensityField:
    """Tabulate D(x) = (1/P) sum_p exp(-|x - x_p|^2 / (2 sigma^2)), sigma = the cell size (host side,
    float64, separable: three 1-D Gaussians per point and one matrix product). Each axis is zero-padded
    at its high end to a size bucket (`shapes.bucket`, 3 significant bits: <= 25 % more voxels)."""
    pts = np.asarray(points_tool, np.float64)
    sigma, h = _cell(spec), spec.field_spacing
    margin = spec.grid_half_width * math.sqrt(3) + 2 * sigma
    lo = pts.min(0) - margin
    shape = np.ceil((pts.max(0) + margin - lo) / h).astype(int) + 1
    g = [np.exp(-0.5 * ((lo[a] + h * np.arange(shape[a]))[None, :] - pts[:, a, None]) ** 2 / sigma**2)
         for a in range(3)]  # [P, n_a]
    xy = (g[0][:, :, None] * g[1][:, None, :]).reshape(len(pts), -1)  # [P, I*J]
    values = (xy.T @ g[2]).reshape(*shape) / len(pts)
    # zeros beyond the grid's high ends up to a size bucket: the same reads (map_coordinates' cval is 0),
    # one compile of the features for every tool in the bucket instead of one per tool (shapes.py)
    values = pad_zeros_high(values, FIELD_BUCKET_BITS)
    return DensityField(values=to_device(values), origin=to_device(lo), spacing=float(h))


def tool_field(tool: Tool, spec: FeatureSpec) -> DensityField:
    """`density_field` of the tool's fixed surface sample."""
    return density_field(surface_sample(tool, spec), spec)


def occupancy(field: DensityField, p: jax.Array, R: jax.Array, spec: FeatureSpec) -> jax.Array:
    """[G^3] occupancy of the grasp's cells: D at p + R c for every cell centre c (trilinear)."""
    x = p + jnp.asarray(_cell_centres(spec), field.values.dtype) @ R.T  # [G^3, 3] tool frame
    idx = (x - field.origin) / field.spacing
    return jax.scipy.ndimage.map_coordinates(field.values, list(idx.T), order=1, mode="constant", cval=0.0)


def exact_occupancy(points_tool: jax.Array, p: jax.Array, R: jax.Array, spec: FeatureSpec) -> jax.Array:
    """[G^3] the same occupancy as a direct sum over the surface points (the reference; O(P G) per grasp)."""
    local = (points_tool - p) @ R  # [P, 3] grasp frame
    cell = _cell(spec)
    centres = (jnp.arange(spec.grid) + 0.5) * cell - spec.grid_half_width  # [G]
    w = jnp.exp(-0.5 * ((local[:, :, None] - centres[None, None, :]) / cell) ** 2)  # [P, 3, G]
    return jnp.einsum("pi,pj,pk->ijk", w[:, 0], w[:, 1], w[:, 2]).ravel() / points_tool.shape[0]


def grasp_features(field: DensityField, loads: Loads, tool: ToolParams, grasp: Grasps,
                   spec: FeatureSpec) -> jax.Array:
    """[spec.size] features of ONE grasp. Pure; vmap over grasps, jit outside."""
    R = quat_to_matrix(grasp.q_tool_grasp)
    p = grasp.p_tool_grasp

    def to_grasp(v):
        """Rows v -> R^T v, as broadcast products: a [T,3] @ [3,3] per grasp would vmap into tiny batched
        matmuls, measured 2.5x slower for 10,000 grasps (docs/benchmarks.md)."""
        return v[..., 0:1] * R[0] + v[..., 1:2] * R[1] + v[..., 2:3] * R[2]

    def to_grasp_t(vt):
        """Columns vt [3, T] -> R^T vt [3, T]: `to_grasp` transposed, the same products summed in the same
        order (the same bits), with the time axis minor: vmapped over grasps it vectorises along T
        instead of along a minor axis of 3."""
        return R[0][:, None] * vt[0:1] + R[1][:, None] * vt[1:2] + R[2][:, None] * vt[2:3]

    occ = occupancy(field, p, R, spec)
    # loads about the grasp origin, grasp-frame axes, [3, T]
    ft = loads.force_tool.T
    F = to_grasp_t(ft)
    tau = to_grasp_t(loads.moment_tool.T - jnp.cross(p, ft, axisb=0, axisc=0))
    k = jnp.argmax(tau[0] * tau[0] + tau[1] * tau[1] + tau[2] * tau[2])
    load_feats = jnp.concatenate([jnp.abs(F).max(1), jnp.abs(tau).max(1), F[:, k], tau[:, k]])
    # contact geometry
    contact = jnp.concatenate([to_grasp(loads.contact_point_tool - p), to_grasp(loads.normal_tool[k]),
                               to_grasp(tool.com - p)])
    physics = jnp.stack([jnp.log(tool.mass), tool.mu, tool.restitution, jnp.log(tool.contact_duration)])
    blocks = [occ, load_feats, contact, physics]
    if spec.wrist:
        blocks.append(wrist_block(F, tau, tool.mu, grasp.width))
    if spec.residual:
        blocks.append(residual_block(F, tau, tool.mu, grasp.width))
    return jnp.concatenate(blocks)


def _wrist_torque(F: jax.Array, tau: jax.Array) -> jax.Array:
    """[3, T] N m: the torque about the wrist site (-FLANGE_TO_GRASP e_z) of loads F [3, T] (N) and tau
    [3, T] (N m, about the grasp origin), grasp-frame axes: tau + FLANGE_TO_GRASP e_z x F."""
    d = FLANGE_TO_GRASP
    return jnp.stack([tau[0] - d * F[1], tau[1] + d * F[0], tau[2]])


def _magnitude(x: jax.Array) -> jax.Array:
    """|x| with a finite gradient at 0 (as `costs`)."""
    return jnp.sqrt(x * x + TINY) - SQRT_TINY


def wrist_block(F: jax.Array, tau: jax.Array, mu: jax.Array, width: jax.Array) -> jax.Array:
    """[WRIST_SIZE] the wrist block of one grasp from its loads about the grasp origin, force F [3, T] (N)
    and torque tau [3, T] (N m) in grasp-frame axes (x third, y closure, z approach), pad friction mu []
    and jaw opening width [] (m). The wrist sits at -FLANGE_TO_GRASP e_z, so its torque is
    tau + FLANGE_TO_GRASP e_z x F."""
    tw = _wrist_torque(F, tau)  # [3, T] about the wrist site
    full_sq = tw[0] ** 2 + tw[1] ** 2 + tw[2] ** 2
    # `costs`' 'passed' form: the part off the closure axis (y) from its two components, the part about it
    # capped by the pads' torsional friction at WRIST_GRIP_FORCE
    passed_sq = passed_torque_sq(tw[0] ** 2 + tw[2] ** 2, tw[1], mu, WRIST_GRIP_FORCE)
    grip_sq = grip_demand_sq(F.T, tau.T, mu, width, xp=jnp)
    peaks = jnp.stack([full_sq.max(), passed_sq.max(), grip_sq.max()])
    peaks = jnp.sqrt(peaks + TINY) - SQRT_TINY  # a finite gradient where a load is zero (as `costs`)
    s = WRIST_TORQUE_SCALE
    return jnp.concatenate([jnp.log1p(jnp.abs(tw).max(1) / s), jnp.log1p(peaks[:2] / s), jnp.log1p(peaks[2:])])


def residual_block(F: jax.Array, tau: jax.Array, mu: jax.Array, width: jax.Array) -> jax.Array:
    """[RESIDUAL_SIZE] the residual block of one grasp (arguments as `wrist_block`): the rigid-body
    prediction of the wrench objective's targets tau_third, tau_closure, tau_approach (the wrist torque's
    components at the step of its largest passed-on torque, the closure one capped by the pads'
    torsional friction at WRIST_GRIP_FORCE) and grip (the peak grip demand, N per pad), each
    log1p(x / RESIDUAL_SCALES)."""
    tw = _wrist_torque(F, tau)
    cap = torsion_cap(mu, WRIST_GRIP_FORCE)
    k = jnp.argmax(passed_torque_sq(tw[0] ** 2 + tw[2] ** 2, tw[1], mu, WRIST_GRIP_FORCE))
    comps = jnp.stack([_magnitude(tw[0, k]), jnp.minimum(_magnitude(tw[1, k]), cap), _magnitude(tw[2, k])])
    grip = jnp.sqrt(grip_demand_sq(F.T, tau.T, mu, width, xp=jnp).max() + TINY) - SQRT_TINY
    return jnp.log1p(jnp.concatenate([comps, grip[None]]) / jnp.asarray(RESIDUAL_SCALES))


def batched(field, loads, tool, grasps, spec):
    return jax.vmap(lambda g: grasp_features(field, loads, tool, g, spec))(grasps)


#: The outer call for a batch of grasps: one jit, `spec` static (recompiles only for new shapes/specs).
batched_features = jax.jit(full_precision(batched), static_argnames=("spec",))


_FIELDS: "weakref.WeakKeyDictionary[Tool, dict]" = weakref.WeakKeyDictionary()  # tool -> {spec: DensityField}


def cached_tool_field(tool: Tool, spec, dt) -> DensityField:
    """The tool's density field for a feature spec in dtype `dt`, cached per tool and spec (no
    conversion per call)."""
    per_tool = _FIELDS.setdefault(tool, {})
    if spec not in per_tool:
        f = tool_field(tool, spec)
        per_tool[spec] = DensityField(to_device(f.values, dt), to_device(f.origin, dt), f.spacing)
    return per_tool[spec]
