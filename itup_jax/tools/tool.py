"""A tool: a closed mesh, its physical parameters and its part annotations; the checks every tool passes.

Tool frame
----------
Every tool lives in its own *tool frame* (the mesh frame, metres). Built-in tools put the origin at
the butt of the handle with the handle along +z; the contact face sits at the far end. A user's mesh
comes in its file's frame; the TOML spec gives contact point and grasp region in that frame, and either
the file is in the tool frame already (checked: its long axis along z, its contact normal along its
category's direction) or the spec states the frame (`handle_axis`, `x_axis`) and the mesh is turned into
it (`Tool.mesh_to_tool`).

Split between host and device
-----------------------------
`Tool` is a host-side object (it holds a `trimesh.Trimesh`); `ToolParams` is the pytree of arrays
that JAX code takes (mass, centre of mass, inertia, restitution, pad friction, contact duration), so
costs are differentiable with respect to the physical parameters and can be vmapped over them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import jax
import numpy as np
import trimesh

from itup_jax.errors import InputError
from itup_jax.shapes import to_device


# ---------------------------------------------------------------------------------------------------
# Pytree of physical parameters
# ---------------------------------------------------------------------------------------------------
@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class ToolParams:
    """Physical parameters of one tool, as JAX arrays (all leaves; differentiable).

    Attributes:
      mass: [] kg.
      com: [3] m, centre of mass in the tool frame.
      inertia: [3, 3] kg m^2, inertia tensor about the centre of mass, tool-frame axes.
      restitution: [] coefficient of restitution e of the contact face against the target (-).
      mu: [] pad-tool Coulomb friction coefficient (-).
      contact_duration: [] s, time over which an impulse is delivered (F = J / dt).
    """

    mass: jax.Array
    com: jax.Array
    inertia: jax.Array
    restitution: jax.Array
    mu: jax.Array
    contact_duration: jax.Array

    def replace(self, **changes: Any) -> "ToolParams":
        return dataclasses.replace(self, **changes)


def make_tool_params(
    *,
    mass: float,
    com: Sequence[float],
    inertia: Any,
    restitution: float,
    mu: float,
    contact_duration: float,
    what: str = "tool",
) -> ToolParams:
    """Validated `ToolParams` from plain numbers (host side). Raises `InputError` naming the field."""
    com_a = vec3(com, f"{what}.com")
    inertia_a = np.asarray(inertia, dtype=float)
    if inertia_a.shape != (3, 3) or not np.all(np.isfinite(inertia_a)):
        raise InputError(f"{what}.inertia: expected a finite 3x3 matrix, got shape {inertia_a.shape}")
    if not np.allclose(inertia_a, inertia_a.T, atol=1e-12 + 1e-9 * np.abs(inertia_a).max()):
        raise InputError(f"{what}.inertia: not symmetric")
    eig = np.linalg.eigvalsh(inertia_a)
    if eig.min() <= 0:
        raise InputError(f"{what}.inertia: not positive definite (eigenvalues {eig})")
    check_positive(mass, f"{what}.mass", "kg")
    check_positive(contact_duration, f"{what}.contact_duration", "s")
    if not (math.isfinite(float(mu)) and float(mu) >= 0):
        raise InputError(f"{what}.mu: friction coefficient must be >= 0, got {mu}")
    if not (math.isfinite(float(restitution)) and 0.0 <= float(restitution) <= 1.0):
        raise InputError(f"{what}.restitution: must lie in [0, 1], got {restitution}")
    f = lambda x: to_device(x, dtype=float)  # noqa: E731  (dtype follows jax_enable_x64)
    return ToolParams(
        mass=f(mass), com=f(com_a), inertia=f(inertia_a), restitution=f(restitution),
        mu=f(mu), contact_duration=f(contact_duration),
    )


# ---------------------------------------------------------------------------------------------------
# Host-side tool
# ---------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Box:
    """Axis-aligned box in the tool frame: `lo` [3] and `hi` [3], metres."""

    lo: np.ndarray
    hi: np.ndarray

    def contains(self, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """[..., 3] points -> [...] bool, True inside the box grown by `tol` metres."""
        p = np.asarray(points)
        return np.all((p >= self.lo - tol) & (p <= self.hi + tol), axis=-1)


@dataclasses.dataclass(frozen=True, eq=False)
class Tool:
    """A tool: closed mesh, physical parameters and part annotations (tool frame, SI units).

    Attributes:
      name: the tool's name.
      category: a key of `priors.CATEGORY_PRIORS`.
      mesh: closed (watertight) triangle mesh, metres.
      params: `ToolParams` (mass, centre of mass, inertia, e, mu, dt).
      contact_point: [3] m, the primary contact point (hammer face, broom bristle tips, stick tip).
      contact_normal: [3] unit, the direction in which the contact face pushes (outward normal).
      contact_points: [K, 3] m, all contact points (K >= 1; row 0 is `contact_point`); several for
        tools that touch the target in several places at once (broom bristles).
      grasp_region: `Box` in which grasps are allowed (the handle).
      parts: description of the parts, ((name, material, mass_kg), ...), for documentation.
      part_regions: ((name, Box), ...) each part's bounding box in the tool frame (the same names as
        `parts`; from the spec's `[parts.<name>]` tables for a mesh tool, else empty): the regions
        grounding chooses among (`itup_jax.tools.parts`).
      primitives: collision primitives for the simulator, (("capsule", p0, p1, radius) |
        ("box", lo, hi) | ("hull", vertices [K, 3], faces [F, 3]), ...) in the tool frame: a built-in or
        family tool's parts, a mesh tool's convex pieces (`mesh.convex_pieces`).
      mesh_to_tool: [3, 3] rotation from the user's mesh file frame (after `units`) to the tool frame:
        a point x of the file is R @ x here (identity for built-ins and meshes given in the tool
        frame). Grasps are in the tool frame; `R.T @ p` takes a grasp position back to the file.
    """

    name: str
    category: str
    mesh: trimesh.Trimesh
    params: ToolParams
    contact_point: np.ndarray
    contact_normal: np.ndarray
    contact_points: np.ndarray
    grasp_region: Box
    parts: tuple = ()
    primitives: tuple = ()
    part_regions: tuple = ()
    mesh_to_tool: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(3))

    @property
    def mass(self) -> float:
        return float(self.params.mass)

    def with_params(self, **changes: float) -> "Tool":
        """A copy with some physical parameters replaced, validated like a spec (e.g. mu=0.5)."""
        p = self.params
        merged = dict(
            mass=float(p.mass), com=np.asarray(p.com), inertia=np.asarray(p.inertia),
            restitution=float(p.restitution), mu=float(p.mu),
            contact_duration=float(p.contact_duration),
        )
        unknown = set(changes) - set(merged)
        if unknown:
            raise InputError(f"tool {self.name!r}: unknown parameter(s) {sorted(unknown)}")
        if "mass" in changes and "inertia" not in changes:
            # Same shape, new mass: the inertia scales with it.
            check_positive(changes["mass"], f"tool {self.name!r}.mass", "kg")
            merged["inertia"] = merged["inertia"] * (float(changes["mass"]) / merged["mass"])
        merged.update(changes)
        return dataclasses.replace(self, params=make_tool_params(**merged, what=f"tool {self.name!r}"))


# ---------------------------------------------------------------------------------------------------
# Mass properties
# ---------------------------------------------------------------------------------------------------
def check_mesh(mesh: Any, what: str) -> trimesh.Trimesh:
    """Validate a closed triangle mesh; raise `InputError` naming `what` otherwise."""
    if isinstance(mesh, trimesh.Scene):
        geoms = list(mesh.geometry.values())
        mesh = trimesh.util.concatenate(geoms) if geoms else trimesh.Trimesh()
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{what}: not a triangle mesh (got {type(mesh).__name__})")
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise InputError(f"{what}: mesh is empty (no faces)")
    if not np.all(np.isfinite(mesh.vertices)):
        raise InputError(f"{what}: mesh has non-finite vertex coordinates")
    if not mesh.is_watertight:
        raise InputError(
            f"{what}: mesh is not watertight (it has open edges); mass properties and the grasp "
            "sampler's inside/outside tests need a closed surface"
        )
    if mesh.volume < 0:
        mesh = mesh.copy()
        mesh.invert()
    if not mesh.volume > 0:
        raise InputError(f"{what}: mesh encloses no volume")
    return mesh


def mesh_mass_properties(mesh: trimesh.Trimesh, density: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass kg, com [3] m, inertia [3, 3] kg m^2 about the com) of a closed mesh of uniform density."""
    mp = trimesh.triangles.mass_properties(mesh.triangles, density=density)
    return float(mp.mass), np.asarray(mp.center_mass), np.asarray(mp.inertia)


def combine_mass_properties(
    parts: Sequence[tuple[float, np.ndarray, np.ndarray]],
) -> tuple[float, np.ndarray, np.ndarray]:
    """Sum rigid parts (mass, com, inertia about own com) into one body (parallel-axis theorem)."""
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass
    inertia = np.zeros((3, 3))
    for m, c, i_c in parts:
        d = c - com
        inertia += i_c + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return mass, com, inertia


# ---------------------------------------------------------------------------------------------------
# Validators of a tool's fields (host side; each raises InputError naming `what`)
# ---------------------------------------------------------------------------------------------------
def vec3(x: Any, what: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected three numbers [x, y, z], got {x!r}") from None
    if a.shape != (3,):
        raise InputError(f"{what}: expected three numbers [x, y, z], got {x!r}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what}: contains NaN or infinity: {x!r}")
    return a


def unit_vector(x: Any, what: str) -> np.ndarray:
    a = vec3(x, what)
    n = np.linalg.norm(a)
    if n < 1e-9:
        raise InputError(f"{what}: zero-length normal {x!r}")
    return a / n


def check_positive(x: Any, what: str, unit: str) -> None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a number in {unit}, got {x!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{what}: must be > 0 {unit}, got {x!r}")


def box_from(lo: Any, hi: Any, what: str) -> Box:
    lo_a, hi_a = vec3(lo, f"{what}.min"), vec3(hi, f"{what}.max")
    if np.any(lo_a >= hi_a):
        raise InputError(f"{what}: min {lo_a.tolist()} must be below max {hi_a.tolist()} on every axis")
    return Box(lo_a, hi_a)


def box_overlaps(box: Box, bounds: np.ndarray) -> bool:
    return bool(np.all(box.lo <= bounds[1]) and np.all(box.hi >= bounds[0]))
