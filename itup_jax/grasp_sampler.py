"""Antipodal grasp sampling for a Robotiq-2F-85-class parallel gripper on a tool mesh.

Stage 4 of iTuP (grasp candidates G). Host-side NumPy + trimesh (ray casts); deterministic
for a given PRNG key or integer seed. For each candidate:

1. a point p1 on the mesh surface, area-uniform, with outward normal n1;
2. a closure direction u inside the friction cone around -n1 (half-angle atan(mu), mu the tool's pad
   friction), uniform on that spherical cap;
3. a ray from p1 along u through the tool: its exit point p2 with outward normal n2;
4. accepted when antipodal (angle(u, n2) <= atan(mu) and angle(-u, n1) <= atan(mu)), the width
   |p2 - p1| lies in [min_width, 0.085 m - 2 clearance], p1, p2 and their midpoint lie in the grasp
   region, and the gripper (two fingers opened to width + 2 clearance, and the palm; see
   `grasp.gripper_boxes`) holds no point of the tool's dense surface sample;
5. the approach axis is drawn uniformly around the closure axis.

That is the sampler for point contacts (`SamplerConfig(contact="point")`, every dataset up to code 0.5.0
and the default until then).
The simulated gripper has flat pads (22 x 37.5 mm), and flat pads on a handle whose closure axis is
tilted off its cross-section touch it at their ends: at step 0 they start a median 2.3-2.7 mm inside
the tool, and the tool turns 4-9 degrees in the first 50 ms until it lies flat between them
(`experiments/initial_grip.py`). With `contact="flat"` (the default since code 0.6.0) the
grasp is the one the pads settle into:

2'. the closure direction is the inward normal, u = -n1 (no cone);
3'. p2 is accepted when its normal is antiparallel to u within `flat_angle`;
4'. the tool's surface points inside the pads' footprint (|x| <= PAD_WIDTH/2, |z| <= PAD_LENGTH/2 in the
   grasp frame) may stand at most `flat_excess` proud of the contact planes through p1 and p2 (so no
   other part of the tool props a pad open), the jaw opening is the tool's extent along y across that
   footprint, and the grasp origin sits midway in it.
"""

from __future__ import annotations

import dataclasses
import math
import weakref
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import trimesh

from itup_jax import robot
from itup_jax.errors import InputError, check_seed
from itup_jax.grasp import Grasps, gripper_boxes, make_grasps
from itup_jax.kernel_cache import kept
from itup_jax.shapes import pad_rows_repeating, to_device
from itup_jax.tools import Tool


@dataclasses.dataclass(frozen=True)
class SamplerConfig:
    """Sampler settings (SI units).

    cone_half_angle: rad; None -> atan(tool mu) (the friction cone).
    clearance: m, extra opening per side when the open fingers approach the tool.
    min_width: m, thinnest feature the gripper may pinch.
    surface_spacing: m, spacing of the tool surface sample used for the collision check.
    collision_margin: m, the gripper boxes grow by this much in the check, so that a shallow cut of the
      tool surface between two surface samples is still caught.
    batch: candidates drawn per round.  max_rounds: rounds before giving up.
    contact: "flat" (the pads lie flat on the tool; module docstring) or "point" (antipodal point
      contacts within the friction cone, the jaw opening the chord; the default up to code 0.5.0).
    flat_angle: rad, contact="flat": largest angle between the exit normal and the closure axis.
    flat_excess: m, contact="flat": how far any tool point in the pads' footprint may stand proud of the
      contact planes.
    """

    cone_half_angle: float | None = None
    clearance: float = 0.005
    min_width: float = 0.004
    surface_spacing: float = 0.0025
    collision_margin: float = 0.001
    batch: int = 4096
    max_rounds: int = 100
    contact: str = "flat"
    flat_angle: float = math.radians(2.0)
    flat_excess: float = 0.0005


#: The sampler's contact models (`SamplerConfig.contact`).
CONTACT_MODELS = ("point", "flat")


class SamplingError(RuntimeError):
    """The sampler could not find enough valid grasps (the grasp region may be wrong)."""


def _rng_from(seed: Any) -> np.random.Generator:
    """NumPy generator from an int seed or a JAX PRNG key (typed or raw uint32)."""
    if isinstance(seed, (int, np.integer)):
        return np.random.default_rng(check_seed(seed, "sample_grasps"))
    try:
        data = jax.random.key_data(seed) if jax.dtypes.issubdtype(seed.dtype, jax.dtypes.prng_key) else seed
        words = np.asarray(data, dtype=np.uint32).ravel()
    except (AttributeError, TypeError, ValueError):
        raise InputError(f"sample_grasps: seed must be an int or a JAX PRNG key, got {seed!r}") from None
    return np.random.default_rng(words.tolist())


_SURFACE_CACHE: "weakref.WeakKeyDictionary[Tool, tuple[float, np.ndarray]]" = weakref.WeakKeyDictionary()


def collision_points(tool: Tool, spacing: float) -> np.ndarray:
    """[S, 3] dense surface sample of the tool (vertices + area-uniform points), cached per tool."""
    cached = _SURFACE_CACHE.get(tool)
    if cached is not None and cached[0] == spacing:
        return cached[1]
    count = int(math.ceil(tool.mesh.area / spacing**2))
    pts, _ = trimesh.sample.sample_surface(tool.mesh, count, seed=0)
    pts = np.concatenate([np.asarray(tool.mesh.vertices, float), np.asarray(pts, float)])
    _SURFACE_CACHE[tool] = (spacing, pts)
    return pts


def _cone_directions(rng: np.random.Generator, axis: np.ndarray, half_angle: float) -> np.ndarray:
    """[M, 3] unit vectors uniform on the spherical caps of `half_angle` around each `axis` [M, 3]."""
    m = axis.shape[0]
    cos_t = 1.0 - rng.random(m) * (1.0 - math.cos(half_angle))
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
    phi = rng.random(m) * 2 * math.pi
    e1, e2 = _perpendicular_basis(axis)
    return cos_t[:, None] * axis + sin_t[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors [M, 3] completing each unit `axis` [M, 3] to an orthonormal basis."""
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(axis, e1)


#: Triangle x ray pairs tested at once by `ray_hits` (its temporaries: ~100 bytes a pair at most).
RAY_PAIRS_PER_CHUNK = 1_000_000


def ray_hits(mesh: trimesh.Trimesh, origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every crossing of the rays origins [M, 3], dirs [M, 3] (m, unit) with the mesh's triangles:
    (location [H, 3], ray index [H], triangle index [H]), one row per distinct location of a ray.

    The same hits as trimesh's `mesh.ray.intersects_location(..., multiple_hits=True)`, from the same
    narrow phase (trimesh's plane crossing, barycentric test and tolerances) on the same candidate pairs;
    only the broad phase differs: the rays' bounding boxes (`ray_bounds`) against every triangle's box at
    once, in NumPy, instead of one R-tree query per ray from Python (2-3x faster on the built-in tools'
    few hundred triangles; the sampler casts thousands of rays a round). Rays are taken in chunks of at
    most RAY_PAIRS_PER_CHUNK pairs, so memory stays bounded on a mesh of many triangles."""
    from trimesh import grouping, intersections, util
    from trimesh import triangles as triangles_mod
    from trimesh.constants import tol
    from trimesh.ray.ray_triangle import ray_bounds

    origins, dirs = np.asarray(origins, np.float64), np.asarray(dirs, np.float64)
    tris = np.asarray(mesh.triangles, np.float64)
    normals = np.asarray(mesh.face_normals, np.float64)
    tri_lo, tri_hi = tris.min(axis=1), tris.max(axis=1)
    boxes = ray_bounds(origins, dirs, bounds=np.concatenate([tri_lo.min(0), tri_hi.max(0)]))  # [M, 6]
    step = max(1, RAY_PAIRS_PER_CHUNK // max(len(tris), 1))
    found = []
    for s in range(0, len(origins), step):
        b = boxes[s:s + step]
        overlap = np.ones((len(b), len(tris)), bool)  # [m, F]: boxes that overlap, touching counts (R-tree)
        for a in range(3):
            overlap &= (tri_lo[None, :, a] <= b[:, 3 + a, None]) & (tri_hi[None, :, a] >= b[:, a, None])
        ray_id, cand = np.nonzero(overlap)
        ray_id = ray_id + s
        if len(cand) == 0:
            continue
        location, valid = intersections.planes_lines(plane_origins=tris[cand, 0], plane_normals=normals[cand],
                                                     line_origins=origins[ray_id], line_directions=dirs[ray_id])
        if not valid.any():
            continue
        with np.errstate(divide="ignore", invalid="ignore"):  # a zero-area sliver of a union: NaN, never inside
            bary = triangles_mod.points_to_barycentric(tris[cand[valid]], location)
        inside = (bary > -tol.zero).all(axis=1) & (bary < 1 + tol.zero).all(axis=1)
        tri_hit, ray_hit, location = cand[valid][inside], ray_id[valid][inside], location[inside]
        forward = util.diagonal_dot(location - origins[ray_hit], dirs[ray_hit]) > -1e-6
        found.append((location[forward], ray_hit[forward], tri_hit[forward]))
    if not found or not sum(len(f[1]) for f in found):
        return np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)
    location, ray_hit, tri_hit = (np.concatenate(a) for a in zip(*found))
    unique = grouping.unique_rows(np.column_stack((location, ray_hit)))[0]
    return location[unique], ray_hit[unique], tri_hit[unique]


def _exit_points(mesh: trimesh.Trimesh, origins: np.ndarray, dirs: np.ndarray, eps: float = 1e-5):
    """First surface crossing past `eps` along each ray: (hit [M] bool, point [M, 3], normal [M, 3])."""
    m = origins.shape[0]
    hit = np.zeros(m, bool)
    point, normal = np.zeros((m, 3)), np.zeros((m, 3))
    loc, ray, tri = ray_hits(mesh, origins, dirs)
    if len(ray) == 0:
        return hit, point, normal
    dist = np.einsum("ij,ij->i", loc - origins[ray], dirs[ray])
    keep = dist > eps
    loc, ray, tri, dist = loc[keep], ray[keep], tri[keep], dist[keep]
    order = np.lexsort((dist, ray))
    ray_sorted = ray[order]
    first = order[np.r_[True, ray_sorted[1:] != ray_sorted[:-1]]] if len(order) else order
    hit[ray[first]] = True
    point[ray[first]] = loc[first]
    normal[ray[first]] = mesh.face_normals[tri[first]]
    return hit, point, normal


def _to_grasp_frame(d: jax.Array, R_tool_grasp: jax.Array) -> jax.Array:
    """[S, 3] tool-frame offsets from the grasp origin (m) -> grasp-frame coordinates, R^T d per row.

    Written as three products rather than `d @ R`: vmapped over grasps, a contraction over 3 becomes a
    batched dot that XLA's CPU backend runs ~25x slower than this fused elementwise form (`itup bench
    sample` times both; docs/benchmarks.md)."""
    return d[:, 0:1] * R_tool_grasp[0] + d[:, 1:2] * R_tool_grasp[1] + d[:, 2:3] * R_tool_grasp[2]


def gripper_hits(points_tool: jax.Array, R_tool_grasp: jax.Array, p_tool_grasp: jax.Array,
                  opening: jax.Array, margin: jax.Array, to_grasp_frame=_to_grasp_frame) -> jax.Array:
    """[] bool for ONE grasp: does any tool point [S, 3] lie inside the gripper's boxes grown by margin?"""
    local = to_grasp_frame(points_tool - p_tool_grasp, R_tool_grasp)
    hit = jnp.zeros((), bool)
    shifts = {"finger_neg": -0.5, "finger_pos": 0.5, "palm": 0.0}  # gripper_boxes(o) = boxes(0) + shift*o*e_y
    for name, lo, hi in gripper_boxes(0.0):
        off = shifts[name] * opening * jnp.array([0.0, 1.0, 0.0])
        hit |= jnp.any(jnp.all((local > lo + off - margin) & (local < hi + off + margin), axis=-1))
    return hit


#: The sampler's one jit: the collision check over a fixed-size chunk of candidates.
gripper_hits_batch = kept(jax.vmap(gripper_hits, in_axes=(None, 0, 0, 0, None)), "grasp_sampler.gripper_hits")  # no matrix products
CHUNK = 256
POINT_BUCKET_BITS = 4  # the tool points' count is padded to a bucket of 4 significant bits (shapes.py)


def _pad_span(points_tool: jax.Array, R_tool_grasp: jax.Array, p_tool_grasp: jax.Array) -> jax.Array:
    """[2] m for ONE grasp: the least and the greatest grasp-frame y of the tool points [S, 3] that lie in
    the pads' footprint (|x| <= PAD_WIDTH/2, |z| <= PAD_LENGTH/2) within the gripper's stroke
    (|y| <= GRIPPER_MAX_OPENING/2); (+inf, -inf) when none does."""
    local = _to_grasp_frame(points_tool - p_tool_grasp, R_tool_grasp)
    inside = ((jnp.abs(local[:, 0]) <= robot.PAD_WIDTH / 2) & (jnp.abs(local[:, 2]) <= robot.PAD_LENGTH / 2)
              & (jnp.abs(local[:, 1]) <= robot.GRIPPER_MAX_OPENING / 2))
    y = local[:, 1]
    return jnp.stack([jnp.min(jnp.where(inside, y, jnp.inf)), jnp.max(jnp.where(inside, y, -jnp.inf))])


#: contact="flat": the pads' span over a chunk of candidates (the sampler's second jit).
pad_span_batch = kept(jax.vmap(_pad_span, in_axes=(None, 0, 0)), "grasp_sampler.pad_span")


def pad_span(points_tool: np.ndarray, R_tool_grasp: np.ndarray, p_tool_grasp: np.ndarray) -> np.ndarray:
    """[M, 2] m: per grasp (R_tool_grasp [M, 3, 3], p_tool_grasp [M, 3]), the least and greatest y in the
    grasp frame of the tool points [S, 3] inside the pads' footprint (`_pad_span`), as float64 from the
    jitted float32 kernel (`_over_chunks`)."""
    return _over_chunks(pad_span_batch, points_tool, R_tool_grasp, p_tool_grasp).astype(float)


def _over_chunks(kernel, points_tool: np.ndarray, R_tool_grasp: np.ndarray, p_tool_grasp: np.ndarray,
                 *per_grasp: np.ndarray, shared: tuple = ()) -> np.ndarray:
    """kernel(points [S, 3], R [C, 3, 3], p [C, 3], *per_grasp [C], *shared) over chunks of C = 256 grasps
    in float32, the last chunk padded with grasps far from the tool (identity rotation, p = 1e3 m, zeros
    for the per-grasp arrays), and the points padded to a size bucket (`shapes.bucket`, <= 12.5 % more)
    with copies of the first point, which no kernel here can tell apart (any / min / max over points):
    the kernel compiles once per bucket, not once per tool. Its [M, ...] rows back."""
    m = len(p_tool_grasp)
    pad = (-m) % CHUNK
    R = np.concatenate([R_tool_grasp, np.broadcast_to(np.eye(3), (pad, 3, 3))]).astype(np.float32)
    p = np.concatenate([p_tool_grasp, np.full((pad, 3), 1e3)]).astype(np.float32)  # far away: no hit
    extra = [np.concatenate([a, np.zeros(pad)]).astype(np.float32) for a in per_grasp]
    pts = to_device(pad_rows_repeating(np.asarray(points_tool, np.float32), POINT_BUCKET_BITS))
    out = [np.asarray(kernel(pts, R[s:s + CHUNK], p[s:s + CHUNK], *(a[s:s + CHUNK] for a in extra), *shared))
           for s in range(0, m + pad, CHUNK)]
    return np.concatenate(out)[:m]


def gripper_collides(points_tool: np.ndarray, R_tool_grasp: np.ndarray, p_tool_grasp: np.ndarray,
                     opening: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """[M] bool: does any tool point [S, 3] lie inside the gripper's boxes (grown by margin) of each grasp?

    Grasps given as R_tool_grasp [M, 3, 3], p_tool_grasp [M, 3] and jaw opening [M] (m). Runs the
    jitted kernel on chunks of 256 (the last one padded), so it compiles once per bucket of the point
    count S (`_over_chunks`).
    """
    return _over_chunks(gripper_hits_batch, points_tool, R_tool_grasp, p_tool_grasp, opening,
                        shared=(np.float32(margin),))


def sample_grasps(tool: Tool, n: int, seed: Any = 0, *, config: SamplerConfig = SamplerConfig()) -> Grasps:
    """Sample `n` antipodal, collision-free grasps inside the tool's grasp region.

    Args:
      tool: the tool (mesh, grasp region, pad friction mu).
      n: number of grasps (>= 1).
      seed: int seed or JAX PRNG key; the same seed gives the same grasps.
      config: `SamplerConfig`.
    Returns:
      `Grasps` with [n] leading axis (tool frame).
    Raises:
      InputError for a bad n or seed; SamplingError when the region yields too few grasps.
    """
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"sample_grasps: n must be a positive integer, got {n!r}")
    if n > MAX_DRAWN:
        raise InputError(f"sample_grasps: n {n:,} is over the {MAX_DRAWN:,} one call samples (~3 min with their "
                         "reachability on a 2-core CPU); sample in several calls with other seeds")
    if config.contact not in CONTACT_MODELS:
        raise InputError(f"sample_grasps: config.contact must be one of {CONTACT_MODELS}, got {config.contact!r}")
    if not (0.0 <= config.flat_angle < math.pi / 2 and config.flat_excess >= 0.0):
        raise InputError(f"sample_grasps: config.flat_angle must lie in [0, pi/2) rad and config.flat_excess be "
                         f">= 0 m, got {config.flat_angle!r}, {config.flat_excess!r}")
    rng = _rng_from(seed)
    flat = config.contact == "flat"
    mu = float(tool.params.mu)
    cone = config.cone_half_angle if config.cone_half_angle is not None else math.atan(mu)
    cos_exit = math.cos(config.flat_angle) - 1e-9 if flat else math.cos(cone) - 1e-9
    max_width = robot.GRIPPER_MAX_OPENING - 2 * config.clearance
    pts = collision_points(tool, config.surface_spacing)
    region = tool.grasp_region
    mesh = tool.mesh
    cos_cone = math.cos(cone) - 1e-9

    out_p, out_R, out_w = [], [], []
    drawn = 0
    for _ in range(config.max_rounds):
        p1, face = trimesh.sample.sample_surface(mesh, config.batch, seed=int(rng.integers(2**31)))
        p1 = np.asarray(p1, float)
        n1 = np.asarray(mesh.face_normals[face], float)
        drawn += len(p1)
        inside = region.contains(p1)
        p1, n1 = p1[inside], n1[inside]
        if len(p1) == 0:
            continue
        u = -n1 if flat else _cone_directions(rng, -n1, cone)
        hit, p2, n2 = _exit_points(mesh, p1, u)
        width = np.linalg.norm(p2 - p1, axis=1)
        ok = (
            hit
            & (width >= config.min_width) & (width <= max_width)
            & (np.einsum("ij,ij->i", u, n2) >= cos_exit)
            & (np.einsum("ij,ij->i", -u, n1) >= cos_cone)
            & region.contains(p2) & region.contains(0.5 * (p1 + p2))
        )
        idx = np.nonzero(ok)[0]
        if len(idx) == 0:
            continue
        y = (p2[idx] - p1[idx]) / width[idx, None]
        e1, e2 = _perpendicular_basis(y)
        psi = rng.random(len(idx)) * 2 * math.pi
        z = np.cos(psi)[:, None] * e1 + np.sin(psi)[:, None] * e2
        x = np.cross(y, z)
        R = np.stack([x, y, z], axis=-1)  # columns: grasp axes in the tool frame
        centre = 0.5 * (p1[idx] + p2[idx])
        w = width[idx]
        if flat:  # the pads' planes: the tool's extent across their footprint (module docstring, 4')
            lo, hi = pad_span(pts, R, centre).T
            lo, hi = np.minimum(lo, -w / 2), np.maximum(hi, w / 2)  # p1 and p2 themselves lie on the planes
            keep = (hi - w / 2 <= config.flat_excess) & (-w / 2 - lo <= config.flat_excess)
            centre = centre + (0.5 * (lo + hi))[:, None] * y
            w = hi - lo
            keep &= w <= max_width
            R, centre, w = R[keep], centre[keep], w[keep]
            if len(w) == 0:
                continue
        free = ~gripper_collides(pts, R, centre, w + 2 * config.clearance, config.collision_margin)
        out_p.append(centre[free])
        out_R.append(R[free])
        out_w.append(w[free])
        if sum(len(a) for a in out_p) >= n:
            return make_grasps(np.concatenate(out_p)[:n], np.concatenate(out_R)[:n], np.concatenate(out_w)[:n])
    found = sum(len(a) for a in out_p)
    raise SamplingError(
        f"sample_grasps: found {found} of {n} grasps on tool {tool.name!r} after {drawn} surface "
        f"samples; check its grasp_region {region.lo.tolist()}..{region.hi.tolist()} and that the "
        f"graspable part is at most {max_width * 1000:.0f} mm thick"
    )


#: Candidates drawn per reachable one requested, at most, when no budget is given (`sample_reachable`):
#: a tool of which under 1 in 40 sampled grasps the arm can carry is reported, not sampled further.
REACHABLE_BUDGET_FACTOR = 40
#: The most candidates one call samples (`sample_grasps`), and the most drawn in search of reachable ones
#: (`sample_reachable`'s budget, whose default is capped here). Measured on a 2-core CPU (the built-in
#: hammer): 20,000 grasps sample in ~2.5 s and their reachability (closed-form IK along the task) takes
#: ~6 s, so 100,000 candidates take ~45 s and 400,000 draws ~3 min; more is refused before any work.
MAX_CANDIDATES = 100_000
MAX_DRAWN = 400_000
#: Below this reachable share `sample_reachable` says why the rest are unreachable (`ReachableGrasps.unreachable`),
#: from up to REACHABLE_NOTE_CHECK of its first round's candidates.
REACHABLE_NOTE_SHARE = 0.10
REACHABLE_NOTE_CHECK = 256


@dataclasses.dataclass(frozen=True)
class ReachableGrasps:
    """What `sample_reachable` found (host side).

    Attributes:
      grasps: [M] the reachable candidates, M <= requested, in the order they were drawn.
      requested: the count asked for.  drawn: candidates sampled and checked.  budget: the most that
      could be drawn.  rounds: sampling rounds.  unreachable: where fewer than REACHABLE_NOTE_SHARE of
      the drawn candidates were reachable, why the first round's were not (`sim.arm.unreachable_summary`
      of up to REACHABLE_NOTE_CHECK of them); else None.
    """

    grasps: Grasps
    requested: int
    drawn: int
    budget: int
    rounds: int
    unreachable: dict | None = None

    @property
    def complete(self) -> bool:
        """Whether the requested count was met within the budget."""
        return len(self.grasps) >= self.requested

    def to_json(self) -> dict:
        """The plan document's `sampling` record."""
        out = {"requested": self.requested, "reachable": len(self.grasps), "drawn": self.drawn,
               "budget": self.budget, "complete": self.complete}
        if self.unreachable is not None:
            out["unreachable"] = self.unreachable
        return out


def sample_reachable(tool: Tool, task, n: int, seed: Any = 0, *, budget: int | None = None,
                     config: SamplerConfig = SamplerConfig()) -> ReachableGrasps:
    """Sample grasps (`sample_grasps`) until `n` of them are ones the arm can carry through the whole task
    (closed-form IK at every trajectory sample, joint limits, the arm above the table:
    `sim.arm.reachable`), or until `budget` candidates have been drawn.

    Each round draws about as many as the reachable share so far says it needs (at least 256), so a tool of
    which the arm reaches a third of the grasps costs ~3n candidates. Deterministic for a seed.

    Args:
      n: reachable candidates wanted (>= 1).
      budget: the most candidates drawn (>= n); default REACHABLE_BUDGET_FACTOR x n.
    Returns:
      `ReachableGrasps`; `complete` is False when the budget ran out first (it may hold none).
    Raises:
      InputError for a bad n, budget or seed; SamplingError when the grasp region yields too few grasps.
    """
    from itup_jax.sim.arm import reachable, unreachable_summary  # the arm's kinematics: imported only when asked

    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
        raise InputError(f"sample_reachable: n must be a positive integer, got {n!r}")
    if n > MAX_CANDIDATES:
        raise InputError(f"sample_reachable: n {n:,} is over the {MAX_CANDIDATES:,} candidates one call finds "
                         "(~45 s to sample and check on a 2-core CPU)")
    budget = min(REACHABLE_BUDGET_FACTOR * int(n), MAX_DRAWN) if budget is None else budget
    if not isinstance(budget, (int, np.integer)) or isinstance(budget, bool) or not n <= budget <= MAX_DRAWN:
        raise InputError(f"sample_reachable: budget must be an integer in n ({n:,})..{MAX_DRAWN:,}, got {budget!r}")
    rng = _rng_from(seed)
    found: list[tuple[np.ndarray, ...]] = []  # host-side (p, q, width) of the reachable ones per round
    have = drawn = rounds = 0
    first_round = None
    while have < n and drawn < budget:
        share = have / drawn if drawn else 0.0
        want = int(math.ceil((n - have) / max(share, 0.05) * 1.2)) if drawn else 2 * (n - have)
        size = int(min(max(want, 256), budget - drawn))
        g = sample_grasps(tool, size, seed=int(rng.integers(2**31)), config=config)
        first_round = g if first_round is None else first_round
        ok = np.asarray(reachable(task, g))
        drawn += size
        rounds += 1
        if ok.any():
            found.append(tuple(np.asarray(a)[ok] for a in (g.p_tool_grasp, g.q_tool_grasp, g.width)))
            have += int(ok.sum())
    p, q, w = ((np.concatenate(a)[:n] for a in zip(*found)) if found  # to_device makes them the package's float
               else (np.zeros((0, 3)), np.zeros((0, 4)), np.zeros((0,))))
    cat = Grasps(p_tool_grasp=to_device(p), q_tool_grasp=to_device(q), width=to_device(w))
    why = (unreachable_summary(task, first_round[:REACHABLE_NOTE_CHECK])
           if drawn and have < REACHABLE_NOTE_SHARE * drawn else None)
    return ReachableGrasps(grasps=cat, requested=int(n), drawn=drawn, budget=int(budget), rounds=rounds, unreachable=why)
