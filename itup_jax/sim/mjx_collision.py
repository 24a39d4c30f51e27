"""A capsule-box collider for MJX that agrees with native MuJoCo when the capsule is long.

Every contact a tool makes in the four scenes is a capsule against a box: the handle between the gripper's
pads (22 x 8 x 37.5 mm boxes), the hammer's head on the nail's head (10 x 10 x 2 mm), a handle or head
against a block. MJX 3.17.0 collides a capsule with a box by `collision_convex._capsule_convex`, which
chooses the box face of least penetration from the depth of the capsule segment's two *end points* below
each face's plane. For a capsule much longer than the box that is not parallel to the face, an end point
far outside the face is deep below its plane: a 0.44 m handle turned 3.4 degrees from a pad's face puts
its ends 13 mm below it. The face behind is then chosen, and the contact reports a 2 cm penetration with
its normal reversed, where native MuJoCo (`mjc_CapsuleBox`) reports 1.4 mm on the front face
(`tests/test_mjx_collision.py` keeps that case). In reach rollouts this pushed the
handle out of the pads in the first step of the settle phase: MJX lost the tool in 20-24 of 30 grasps
where native MuJoCo lost it in 13 (docs/benchmarks.md, "MJX against native").

`capsule_box` clips the capsule's segment to the box grown by the capsule's radius (plus `CLIP_SLACK`)
before handing it to MJX's own routine. No point of the segment outside that region can be within the
radius of the box, so no contact is lost, and the end points that remain lie within a few radii of the
box. Where the segment misses the region the pair is more than `CLIP_SLACK` apart, and the distance is
reported as at least that. What it does not change: over an edge of the box, MJX's routine can miss a
shallow contact (under 0.5 mm) that native MuJoCo reports, and near a face's rim native MuJoCo tilts the
normal towards the edge where MJX keeps the face's (depths then differ by up to 0.2 mm).

`native_capsule_box()` installs it in MJX's table of collision functions for the duration of a `with`
block; `sim.mjx.rollout_mjx` traces its jitted rollout inside one. MJX looks the function up while it
traces, so a program traced inside the block keeps the collider when called outside it, and MJX code
traced elsewhere in the process is not affected. It reads MJX's private modules (`mujoco.mjx._src`); the
package pins mujoco-mjx 3.17.0, and the tests compare the collider with native MuJoCo on that version.
"""

from __future__ import annotations

import contextlib

import jax
import jax.numpy as jnp

#: How far beyond the capsule's radius (m) the clip box reaches: contacts within a geom margin up to this
#: are kept. Larger is safe up to the box's own size; the scenes use margin 0.
CLIP_SLACK = 0.01


def clip_segment_to_box(p0: jax.Array, p1: jax.Array, half: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The part of the segment p0 -> p1 inside the box |x_j| <= half_j (all in the box's frame, m), as
    parameters (t0, t1) along it, 0 <= t0 <= t1 <= 1, and whether any part is inside (Liang-Barsky).
    Shapes: p0, p1, half [3]; returns three scalars. Traceable, no jit."""
    d = p1 - p0
    flat = jnp.abs(d) < 1e-12  # parallel to this slab: inside it or not at all
    safe = jnp.where(flat, 1.0, d)
    ta, tb = (-half - p0) / safe, (half - p0) / safe
    lo = jnp.where(flat, -jnp.inf, jnp.minimum(ta, tb))
    hi = jnp.where(flat, jnp.inf, jnp.maximum(ta, tb))
    t0 = jnp.maximum(0.0, lo.max())
    t1 = jnp.minimum(1.0, hi.min())
    inside_flat = jnp.all(~flat | (jnp.abs(p0) <= half))
    return t0, t1, (t0 <= t1) & inside_flat


def _mjx_modules():
    from mujoco.mjx._src import collision_convex, collision_driver  # noqa: F401  (private: pinned version)
    from mujoco.mjx._src.types import GeomType

    return collision_convex, collision_driver, GeomType


def _capsule_box(cap, box):
    """(dist [2], pos [2, 3], normal [2, 3]) of one capsule (`GeomInfo`) against one box (`ConvexInfo`
    from `mesh.box`): MJX's `_capsule_convex` on the capsule's segment clipped to the box grown by the
    radius plus CLIP_SLACK."""
    collision_convex, _, _ = _mjx_modules()
    radius, half_len = cap.size[0], cap.size[1]
    centre = box.mat.T @ (cap.pos - box.pos)  # capsule centre and axis in the box's frame
    axis = box.mat.T @ cap.mat[:, 2]
    p0, p1 = centre - axis * half_len, centre + axis * half_len
    t0, t1, hit = clip_segment_to_box(p0, p1, box.size[:3] + radius + CLIP_SLACK)
    # no overlap: a point of the segment (its nearest to the box's centre) stands in, and the distance
    # reported is at least CLIP_SLACK (the segment is farther than radius + CLIP_SLACK from the box)
    t_near = jnp.clip(-jnp.dot(p0, p1 - p0) / jnp.maximum(jnp.dot(p1 - p0, p1 - p0), 1e-30), 0.0, 1.0)
    t0, t1 = jnp.where(hit, t0, t_near), jnp.where(hit, t1, t_near)
    mid = p0 + (p1 - p0) * (0.5 * (t0 + t1))
    clipped = cap.replace(pos=box.pos + box.mat @ mid, size=cap.size.at[1].set(half_len * (t1 - t0)))
    dist, pos, n = collision_convex._capsule_convex(clipped, box)
    return jnp.where(hit, dist, jnp.maximum(dist, CLIP_SLACK)), pos, n


def _make_collider():
    collision_convex, _, _ = _mjx_modules()
    from mujoco.mjx._src import math as mjx_math

    @collision_convex.collider(ncon=2)
    def capsule_box(cap, box):
        """Contacts between a capsule and a box (MJX collider interface; see the module docstring)."""
        dist, pos, n = _capsule_box(cap, box)
        return dist, pos, jax.vmap(mjx_math.make_frame)(n)

    return capsule_box


_COLLIDER = None


def capsule_box_collider():
    """The collider (built once), in the form MJX's collision driver calls: (m, d, key, geom) -> contacts."""
    global _COLLIDER
    if _COLLIDER is None:
        _COLLIDER = _make_collider()
    return _COLLIDER


@contextlib.contextmanager
def native_capsule_box():
    """Within the block, MJX collides capsules with boxes by `capsule_box_collider()` (module docstring).
    Not thread-safe: it swaps an entry of MJX's module-level table and restores it on exit."""
    _, collision_driver, GeomType = _mjx_modules()
    key = (GeomType.CAPSULE, GeomType.BOX)
    table = collision_driver._COLLISION_FUNC
    old = table[key]
    table[key] = capsule_box_collider()
    try:
        yield
    finally:
        table[key] = old
