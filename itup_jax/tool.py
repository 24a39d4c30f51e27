"""Tools: a closed mesh, its physical parameters and its part annotations.

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
import os
import tomllib
from collections.abc import Mapping, Sequence
from typing import Any

import jax
import numpy as np
import trimesh

from itup_jax import priors
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
    com_a = _vec3(com, f"{what}.com")
    inertia_a = np.asarray(inertia, dtype=float)
    if inertia_a.shape != (3, 3) or not np.all(np.isfinite(inertia_a)):
        raise InputError(f"{what}.inertia: expected a finite 3x3 matrix, got shape {inertia_a.shape}")
    if not np.allclose(inertia_a, inertia_a.T, atol=1e-12 + 1e-9 * np.abs(inertia_a).max()):
        raise InputError(f"{what}.inertia: not symmetric")
    eig = np.linalg.eigvalsh(inertia_a)
    if eig.min() <= 0:
        raise InputError(f"{what}.inertia: not positive definite (eigenvalues {eig})")
    _positive(mass, f"{what}.mass", "kg")
    _positive(contact_duration, f"{what}.contact_duration", "s")
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
        grounding chooses among (`itup_jax.parts`).
      primitives: collision primitives for the simulator, (("capsule", p0, p1, radius) |
        ("box", lo, hi), ...) in the tool frame; empty for a mesh tool (the simulator then uses the
        mesh's convex hull).
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
            _positive(changes["mass"], f"tool {self.name!r}.mass", "kg")
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
# Built-in tools: assembled from primitive parts with their own materials
# ---------------------------------------------------------------------------------------------------
_SECTIONS = 48  # facets around a cylinder: mass within 0.3 % of the true cylinder


def _cylinder(radius: float, p0: Sequence[float], p1: Sequence[float]) -> tuple[trimesh.Trimesh, tuple]:
    """A solid cylinder part and its collision primitive: a capsule of the same length overall."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    mesh = trimesh.creation.cylinder(radius=radius, segment=np.array([p0, p1]), sections=_SECTIONS)
    return mesh, ("capsule", p0 + radius * u, p1 - radius * u, radius)


def _box(lo: Sequence[float], hi: Sequence[float]) -> tuple[trimesh.Trimesh, tuple]:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    mesh = trimesh.creation.box(extents=hi - lo, transform=trimesh.transformations.translation_matrix((lo + hi) / 2))
    return mesh, ("box", lo, hi)


def assemble_tool(
    *,
    name: str,
    category: str,
    parts: Sequence[tuple],
    contact_points: Any,
    contact_normal: Sequence[float],
    grasp_region: tuple[Sequence[float], Sequence[float]],
) -> Tool:
    """Build a tool from parts `(part_name, material, (closed_mesh, primitive))` that do not overlap; a
    part may add a fourth entry, a density scale (its material's density times it: a hollow or a denser
    part).

    The mass properties are the sum of the parts' (each at its material's density); the collision and
    sampling mesh is their boolean union.
    """
    props, described, meshes, prims, regions = [], [], [], [], []
    for part_name, material, (mesh, prim), *scale in parts:
        prims.append(prim)
        mesh = check_mesh(mesh, f"tool {name!r} part {part_name!r}")
        density = priors.MATERIAL_DENSITY[material] * (float(scale[0]) if scale else 1.0)
        m, c, i = mesh_mass_properties(mesh, density)
        props.append((m, c, i))
        described.append((part_name, material, round(m, 4)))
        regions.append((part_name, Box(np.asarray(mesh.bounds[0], float), np.asarray(mesh.bounds[1], float))))
        meshes.append(mesh)
    mass, com, inertia = combine_mass_properties(props)
    union = meshes[0] if len(meshes) == 1 else trimesh.boolean.union(meshes, engine="manifold")
    union = check_mesh(union, f"tool {name!r} (union of its parts)")
    prior = priors.category_prior(category)
    params = make_tool_params(
        mass=mass, com=com, inertia=inertia, restitution=prior.restitution.value,
        mu=prior.mu.value, contact_duration=prior.contact_duration.value, what=f"tool {name!r}",
    )
    cps = np.atleast_2d(np.asarray(contact_points, float))
    return Tool(
        name=name, category=category, mesh=union, params=params, contact_point=cps[0],
        contact_normal=_unit(contact_normal, f"tool {name!r}.contact_normal"), contact_points=cps,
        grasp_region=_box_from(grasp_region[0], grasp_region[1], f"tool {name!r}.grasp_region"),
        parts=tuple(described), primitives=tuple(prims), part_regions=tuple(regions),
    )


# The built-in tools are parametric: the defaults are the built-in tool, other values the procedural
# part-wise variants of `dataset.part_variant` (metres; density scales relative to the material).
def claw_hammer(*, handle_radius: float = 0.0145, head_z: float = 0.290, head_radius: float = 0.011,
                head_back: float = 0.050, head_front: float = 0.060, head_density: float = 1.0,
                grasp_top: float = 0.25, grasp_half: float = 0.02, name: str = "hammer") -> Tool:
    """A claw hammer: a hickory handle along +z up to the head, and a steel head across the top from
    x = -head_back (claw) to +head_front (the face, the contact). Built-in: ~0.30 m long, ~0.47 kg."""
    return assemble_tool(
        name=name, category="hammer",
        parts=[
            ("handle", "hickory", _cylinder(handle_radius, (0, 0, 0), (0, 0, head_z - head_radius))),
            ("head", "steel", _cylinder(head_radius, (-head_back, 0, head_z), (head_front, 0, head_z)), head_density),
        ],
        contact_points=[(head_front, 0.0, head_z)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-grasp_half, -grasp_half, 0.0), (grasp_half, grasp_half, grasp_top)),
    )


def hand_broom(*, half_width: float = 0.105, bristle_height: float = 0.050, handle_radius: float = 0.011,
               handle_top: float = 0.380, grasp_bottom: float = 0.15, contact_x: float = 0.080,
               grasp_half: float = 0.02, name: str = "broom") -> Tool:
    """A small push broom: a nylon bristle pack (2 half_width wide, 35 mm thick) under a 30 mm beech
    block 5 mm wider each side, and a polypropylene handle up to handle_top. Bristle tips at z = 0; it
    pushes along +y, touching at x = 0 and +-contact_x."""
    block_top = bristle_height + 0.030
    return assemble_tool(
        name=name, category="broom",
        parts=[
            ("bristles", "bristle_pack", _box((-half_width, -0.0175, 0.0), (half_width, 0.0175, bristle_height))),
            ("block", "beech", _box((-half_width - 0.005, -0.020, bristle_height), (half_width + 0.005, 0.020, block_top))),
            ("handle", "polypropylene", _cylinder(handle_radius, (0, 0, block_top), (0, 0, handle_top))),
        ],
        contact_points=[(0.0, 0.0175, 0.005), (-contact_x, 0.0175, 0.005), (contact_x, 0.0175, 0.005)],
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-grasp_half, -grasp_half, grasp_bottom), (grasp_half, grasp_half, handle_top)),
    )


def mallet(*, handle_radius: float = 0.012, head_z: float = 0.425, head_radius: float = 0.025,
           head_half: float = 0.045, head_density: float = 1.0, grasp_top: float = 0.30,
           grasp_half: float = 0.02, name: str = "mallet") -> Tool:
    """A knocking mallet: a beech handle along +z and a beech head (2 head_half long) across the top; the
    impact lands on the head's +x face, at the end of a long lever (the knock task)."""
    return assemble_tool(
        name=name, category="mallet",
        parts=[
            ("handle", "beech", _cylinder(handle_radius, (0, 0, 0), (0, 0, head_z - head_radius))),
            ("head", "beech", _cylinder(head_radius, (-head_half, 0, head_z), (head_half, 0, head_z)), head_density),
        ],
        contact_points=[(head_half, 0.0, head_z)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-grasp_half, -grasp_half, 0.0), (grasp_half, grasp_half, grasp_top)),
    )


def l_stick(*, radius: float = 0.006, shaft: float = 0.450, hook_end: float = 0.100, contact_x: float = 0.070,
            grasp_top: float = 0.20, grasp_half: float = 0.02, name: str = "l_stick") -> Tool:
    """An L-shaped reaching stick: an aluminium rod, a shaft along +z and a hook along +x at its far end.
    The contact is the hook's inner face (facing -z, back towards the grasp): it pulls a block in."""
    r = radius
    return assemble_tool(
        name=name, category="l_stick",
        parts=[
            ("shaft", "aluminium", _cylinder(r, (0, 0, 0), (0, 0, shaft))),
            ("hook", "aluminium", _cylinder(r, (r, 0, shaft), (hook_end, 0, shaft))),
        ],
        contact_points=[(contact_x, 0.0, shaft - r)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-grasp_half, -grasp_half, 0.0), (grasp_half, grasp_half, grasp_top)),
    )


BUILTIN_TOOLS = {
    "hammer": claw_hammer,
    "broom": hand_broom,
    "mallet": mallet,
    "l_stick": l_stick,
}

_BUILTIN_CACHE: dict[str, Tool] = {}


# ---------------------------------------------------------------------------------------------------
# User tools: mesh file + TOML spec
# ---------------------------------------------------------------------------------------------------
_SPEC_REQUIRED = {"name", "category", "contact_point", "grasp_region"}
_SPEC_OPTIONAL = {"contact_normal", "contact_points", "mass", "density", "mu", "restitution", "contact_duration",
                  "units", "handle_axis", "x_axis", "parts"}
#: Length units a spec may state (`units`), in metres per unit: the mesh and every position in the spec.
SPEC_UNITS = {"m": 1.0, "mm": 1e-3}
#: m, the largest extent a hand tool's mesh may have, and the smallest: outside them the units are
#: almost surely wrong (a 300 mm hammer read as metres is 300 m long).
TOOL_EXTENT_RANGE = (0.02, 2.0)
#: m, how far a contact point may lie from the mesh's surface.
CONTACT_SURFACE_TOL = 0.005
#: The tool frame of each category: the contact normal's direction in it. Every category has the handle
#: along z; hammer, mallet, hatchet, spanner and screwdriver strike with a face (or side) whose normal is
#: +x, the broom and the squeegee push with their head's +y side (the head is wide along x), the L-stick
#: and the pry bar pull with the hook's inner face, which faces back along the handle (-z; the hook itself
#: extends along +x).
CATEGORY_CONTACT_NORMAL = {"hammer": (1.0, 0.0, 0.0), "mallet": (1.0, 0.0, 0.0), "broom": (0.0, 1.0, 0.0),
                           "l_stick": (0.0, 0.0, -1.0), "screwdriver": (1.0, 0.0, 0.0), "spanner": (1.0, 0.0, 0.0),
                           "pry_bar": (0.0, 0.0, -1.0), "hatchet": (1.0, 0.0, 0.0), "squeegee": (0.0, 1.0, 0.0)}
#: rad: a mesh given without `handle_axis` must have its long axis within this of z and its contact
#: normal within FRAME_NORMAL_TOLERANCE of its category's direction, else the spec must state the frame.
FRAME_AXIS_TOLERANCE = math.radians(30.0)
FRAME_NORMAL_TOLERANCE = math.radians(45.0)


def load_tool(name_or_path: str | os.PathLike, spec: str | os.PathLike | Mapping | None = None) -> Tool:
    """Load a built-in tool by name, or a user's tool from a mesh file plus a TOML spec.

    Args:
      name_or_path: a built-in name (`hammer`, `broom`, `mallet`, `l_stick`), a tool family's name
        (`screwdriver`, ...: its default dimensions) or '<family>@<seed>' (a tool drawn from the family,
        `families.draw`), or the path of a mesh file (STL/OBJ/PLY, metres).
      spec: for a mesh file, the path of its TOML spec (or an already-parsed mapping). Fields:
        `name`, `category`, `contact_point` [3], `grasp_region = {min = [3], max = [3]}` (required);
        `contact_normal` [3], `contact_points` [[3], ...], `mass` kg, `density` kg/m^3, `mu`,
        `restitution`, `contact_duration` s (optional; defaults from the category's prior);
        `units` ("m" or "mm": the mesh's and the spec's lengths); `handle_axis` [3] and `x_axis` [3]
        (the file's directions that become the tool frame's +z and +x, when the mesh is not in the
        tool frame; the docs' "Your own tool" has the frame of each category).

    Returns:
      A `Tool`. Built-in and family tools are built once per process and shared.

    Raises:
      InputError: unknown built-in, unreadable/empty/open mesh, a mesh whose size is implausible for
        a hand tool (wrong units), a contact point off the surface, a mesh not in the tool frame without
        a stated frame, malformed spec; the message names the file or field.
    """
    key = os.fspath(name_or_path)
    if spec is None:
        from itup_jax import families  # families build on this module

        parsed = families.parse_name(key)
        if parsed is not None:
            if key not in _BUILTIN_CACHE:
                family, seed = parsed
                # a built-in tool is its family's default (the registry holds the same builders)
                _BUILTIN_CACHE[key] = families.get(family).build() if seed is None else families.draw(family, seed)
            return _BUILTIN_CACHE[key]
        if os.path.splitext(key)[1]:
            raise InputError(f"tool mesh {key!r}: a mesh file needs a TOML spec (spec=...)")
        raise InputError(f"tool {key!r}: not a built-in tool; built-ins: {', '.join(BUILTIN_TOOLS)}; tool families "
                         f"(their default, or '<family>@<seed>' for a drawn one): {', '.join(families.names())}")
    return _load_mesh_tool(key, spec)


def read_tool_spec(spec: str | os.PathLike | Mapping) -> tuple[dict, str]:
    """Parse a TOML spec file (or pass a mapping through). Returns (dict, label for messages)."""
    if isinstance(spec, Mapping):
        return dict(spec), "tool spec"
    path = os.fspath(spec)
    label = f"tool spec {path!r}"
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh), label
    except FileNotFoundError:
        raise InputError(f"{label}: file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{label}: malformed TOML: {exc}") from None


def _load_mesh_tool(mesh_path: str, spec: str | os.PathLike | Mapping) -> Tool:
    data, label = read_tool_spec(spec)
    missing = _SPEC_REQUIRED - set(data)
    if missing:
        raise InputError(f"{label}: missing required field(s): {', '.join(sorted(missing))}")
    unknown = set(data) - _SPEC_REQUIRED - _SPEC_OPTIONAL
    if unknown:
        raise InputError(
            f"{label}: unknown field(s): {', '.join(sorted(unknown))}; allowed: "
            f"{', '.join(sorted(_SPEC_REQUIRED | _SPEC_OPTIONAL))}"
        )
    name = data["name"]
    if not isinstance(name, str) or not name:
        raise InputError(f"{label}: field 'name' must be a non-empty string")
    category = data["category"]
    prior = priors.category_prior(category, what=f"{label}: field 'category'")
    unit_name = data.get("units", "m")
    if unit_name not in SPEC_UNITS:
        raise InputError(f"{label}: field 'units' must be one of {', '.join(SPEC_UNITS)} (the mesh's and the "
                         f"spec's lengths), got {unit_name!r}")
    scale = SPEC_UNITS[unit_name]

    if not os.path.exists(mesh_path):
        raise InputError(f"tool mesh {mesh_path!r}: file not found")
    try:
        mesh = trimesh.load(mesh_path, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise InputError(f"tool mesh {mesh_path!r}: cannot read it as a mesh ({exc})") from None
    mesh = check_mesh(mesh, f"tool mesh {mesh_path!r}")
    if scale != 1.0:
        mesh = mesh.copy()
        mesh.apply_scale(scale)
    _check_extent(mesh, mesh_path, unit_name)

    cp = scale * _vec3(data["contact_point"], f"{label}: field 'contact_point'")
    extra = data.get("contact_points", [])
    if not isinstance(extra, list):
        raise InputError(f"{label}: field 'contact_points' must be a list of [x, y, z]")
    cps = np.array([cp] + [scale * _vec3(p, f"{label}: field 'contact_points'") for p in extra])
    _check_on_surface(mesh, cps, label, unit_name)
    normal = _unit(data.get("contact_normal", _default_normal(mesh, cp)), f"{label}: field 'contact_normal'")
    region = data["grasp_region"]
    if not isinstance(region, Mapping) or set(region) != {"min", "max"}:
        raise InputError(f"{label}: field 'grasp_region' must be a table {{ min = [x,y,z], max = [x,y,z] }}")
    box = _box_from(scale * _vec3(region["min"], f"{label}: field 'grasp_region'.min"),
                    scale * _vec3(region["max"], f"{label}: field 'grasp_region'.max"),
                    f"{label}: field 'grasp_region'")
    if not _box_overlaps(box, mesh.bounds):  # a region away from the mesh can hold no grasp
        raise InputError(f"{label}: field 'grasp_region' does not overlap the mesh (bounds {mesh.bounds.tolist()})")
    regions = _spec_parts(data.get("parts", {}), scale, mesh, label)

    R = _stated_frame(data, label)
    if R is None:
        _check_assumed_frame(mesh, cp, normal, category, label)
        R = np.eye(3)
    else:  # the stated frame, applied to the mesh and to every direction and position of the spec
        mesh = mesh.copy()
        T = np.eye(4)
        T[:3, :3] = R
        mesh.apply_transform(T)
        cps, normal = cps @ R.T, R @ normal
        box = _rotated_box(box, R)
        regions = tuple((n, _rotated_box(b, R)) for n, b in regions)
    density = data.get("density", prior.density.value)
    _positive(density, f"{label}: field 'density'", "kg/m^3")
    mass, com, inertia = mesh_mass_properties(mesh, float(density))
    if "mass" in data:
        _positive(data["mass"], f"{label}: field 'mass'", "kg")
        ratio = float(data["mass"]) / mass
        mass, inertia = float(data["mass"]), inertia * ratio
    params = make_tool_params(
        mass=mass, com=com, inertia=inertia,
        restitution=data.get("restitution", prior.restitution.value),
        mu=data.get("mu", prior.mu.value),
        contact_duration=data.get("contact_duration", prior.contact_duration.value),
        what=f"{label}: field",
    )
    return Tool(
        name=name, category=category, mesh=mesh, params=params, contact_point=cps[0],
        contact_normal=normal, contact_points=cps, grasp_region=box,
        parts=((name, f"{category} prior" if "density" not in data else "spec density", round(mass, 4)),),
        mesh_to_tool=R, part_regions=regions,
    )


def _spec_parts(table: Any, scale: float, mesh: trimesh.Trimesh, label: str) -> tuple:
    """The spec's `[parts.<name>]` tables ({min = [x,y,z], max = [x,y,z]}, the spec's units) as
    ((name, Box), ...) in metres; each must overlap the mesh."""
    if not isinstance(table, Mapping):
        raise InputError(f"{label}: field 'parts' must be a table of [parts.<name>] tables with min and max")
    out = []
    for pname, region in table.items():
        what = f"{label}: field 'parts.{pname}'"
        if not isinstance(region, Mapping) or set(region) != {"min", "max"}:
            raise InputError(f"{what} must be a table {{ min = [x,y,z], max = [x,y,z] }}")
        b = _box_from(scale * _vec3(region["min"], f"{what}.min"), scale * _vec3(region["max"], f"{what}.max"), what)
        if not _box_overlaps(b, mesh.bounds):
            raise InputError(f"{what} does not overlap the mesh (bounds {mesh.bounds.tolist()})")
        out.append((str(pname), b))
    return tuple(out)


def _check_extent(mesh: trimesh.Trimesh, mesh_path: str, unit_name: str) -> None:
    """Refuse a mesh whose largest extent is implausible for a hand tool, naming the likely unit mistake."""
    extent = float(np.max(mesh.extents))
    lo, hi = TOOL_EXTENT_RANGE
    if lo <= extent <= hi:
        return
    hint = ""
    if extent > hi and lo <= extent * 1e-3 <= hi:
        hint = "; it looks like millimetres: add units = \"mm\" to the spec"
    elif extent < lo and unit_name == "mm" and lo <= extent * 1e3 <= hi:
        hint = "; the file looks like metres already: remove units = \"mm\" from the spec"
    raise InputError(f"tool mesh {mesh_path!r}: its largest extent is {extent:.4g} m (units = {unit_name!r}), "
                     f"outside the {lo}-{hi} m of a hand tool{hint}")


def _check_on_surface(mesh: trimesh.Trimesh, points: np.ndarray, label: str, unit_name: str) -> None:
    """Refuse contact points farther than CONTACT_SURFACE_TOL from the mesh's surface."""
    _, dist, _ = trimesh.proximity.closest_point(mesh, points)
    far = np.nonzero(dist > CONTACT_SURFACE_TOL)[0]
    if far.size:
        i = int(far[0])
        what = "contact_point" if i == 0 else f"contact_points[{i - 1}]"
        raise InputError(f"{label}: field '{what}' lies {dist[i]:.4g} m from the mesh's surface (at most "
                         f"{CONTACT_SURFACE_TOL} m; positions are in the mesh file's frame, units = {unit_name!r})")


def _stated_frame(data: Mapping, label: str) -> np.ndarray | None:
    """The rotation from the file's frame to the tool frame that the spec states (`handle_axis` becomes +z,
    `x_axis` becomes +x after removing its part along the handle), or None when it states none."""
    if "handle_axis" not in data and "x_axis" not in data:
        return None
    if "handle_axis" not in data or "x_axis" not in data:
        raise InputError(f"{label}: fields 'handle_axis' and 'x_axis' go together (the file's directions that "
                         "become the tool frame's +z and +x)")
    z = _unit(data["handle_axis"], f"{label}: field 'handle_axis'")
    x_raw = _unit(data["x_axis"], f"{label}: field 'x_axis'")
    x = x_raw - (x_raw @ z) * z
    if np.linalg.norm(x) < 0.1:
        raise InputError(f"{label}: field 'x_axis' {list(data['x_axis'])} is (nearly) parallel to 'handle_axis'")
    x = x / np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])


def _check_assumed_frame(mesh: trimesh.Trimesh, cp: np.ndarray, normal: np.ndarray, category: str, label: str) -> None:
    """A spec without `handle_axis` says its mesh is in the tool frame: check the mesh's long axis lies
    along z and the contact normal along its category's direction, else ask for the frame."""
    expected = CATEGORY_CONTACT_NORMAL.get(category)
    # uniform density: the shape's principal axes; the long one has the least moment
    long_axis = np.asarray(mesh.principal_inertia_vectors)[int(np.argmin(mesh.principal_inertia_components))]
    long_axis = long_axis * (1.0 if long_axis @ (cp - mesh.center_mass) >= 0 else -1.0)
    off_axis = math.acos(min(1.0, abs(float(long_axis[2]))))
    off_normal = math.acos(float(np.clip(normal @ np.asarray(expected), -1.0, 1.0))) if expected else 0.0
    if off_axis <= FRAME_AXIS_TOLERANCE and off_normal <= FRAME_NORMAL_TOLERANCE:
        return
    raise InputError(
        f"{label}: the mesh is not in the tool frame: its long axis points along {np.round(long_axis, 3).tolist()} "
        f"({math.degrees(off_axis):.0f} deg from z) and its contact normal along {np.round(normal, 3).tolist()} "
        + (f"({math.degrees(off_normal):.0f} deg from a {category}'s {list(expected)}) " if expected else "")
        + "; state the frame in the spec: handle_axis = the file's direction along the handle (it becomes +z) "
        "and x_axis = the file's direction that becomes +x (hammer, mallet: the face normal; broom: across the "
        "head; L-stick: where the hook points), or rotate the mesh")


def _rotated_box(box: Box, R: np.ndarray) -> Box:
    """The axis-aligned box around `box` turned by R (exact for quarter turns; larger otherwise)."""
    corners = np.array([[x, y, z] for x in (box.lo[0], box.hi[0]) for y in (box.lo[1], box.hi[1])
                        for z in (box.lo[2], box.hi[2])]) @ R.T
    return Box(corners.min(0), corners.max(0))


def _default_normal(mesh: trimesh.Trimesh, point: np.ndarray) -> np.ndarray:
    """Outward surface normal of the mesh face nearest to `point` (when the spec gives none)."""
    _, _, tri = trimesh.proximity.closest_point(mesh, point[None])
    return np.asarray(mesh.face_normals[int(tri[0])])


# ---------------------------------------------------------------------------------------------------
# Small validators (host side)
# ---------------------------------------------------------------------------------------------------
def _vec3(x: Any, what: str) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected three numbers [x, y, z], got {x!r}") from None
    if a.shape != (3,):
        raise InputError(f"{what}: expected three numbers [x, y, z], got {x!r}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{what}: contains NaN or infinity: {x!r}")
    return a


def _unit(x: Any, what: str) -> np.ndarray:
    a = _vec3(x, what)
    n = np.linalg.norm(a)
    if n < 1e-9:
        raise InputError(f"{what}: zero-length normal {x!r}")
    return a / n


def _positive(x: Any, what: str, unit: str) -> None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a number in {unit}, got {x!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{what}: must be > 0 {unit}, got {x!r}")


def _box_from(lo: Any, hi: Any, what: str) -> Box:
    lo_a, hi_a = _vec3(lo, f"{what}.min"), _vec3(hi, f"{what}.max")
    if np.any(lo_a >= hi_a):
        raise InputError(f"{what}: min {lo_a.tolist()} must be below max {hi_a.tolist()} on every axis")
    return Box(lo_a, hi_a)


def _box_overlaps(box: Box, bounds: np.ndarray) -> bool:
    return bool(np.all(box.lo <= bounds[1]) and np.all(box.hi >= bounds[0]))
