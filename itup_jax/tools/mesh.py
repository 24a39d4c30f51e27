"""A user's tool: a closed mesh file (STL, OBJ, PLY) and its TOML spec.

    from itup_jax.tools import load_tool
    tool = load_tool("my_hammer.stl", spec="my_hammer.toml")

The spec gives the tool's name and category, its contact point and grasp region, in the mesh file's
frame and units (`units = "mm"` or metres); its optional fields are in `load_tool`'s docstring. The mesh is
checked (closed, a hand tool's size, the contact on its surface, in the tool frame or with the frame
stated), turned into the tool frame, and its mass properties come from its volume and the category's
density (`priors`) unless the spec gives a mass. Every refusal is an `InputError` naming the file or
field.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from typing import Any

import numpy as np
import trimesh

from itup_jax.errors import InputError
from itup_jax.tools import priors
from itup_jax.tools.priors import CATEGORY_CONTACT_NORMAL
from itup_jax.tools.tool import (
    Box,
    Tool,
    box_from,
    box_overlaps,
    check_mesh,
    check_positive,
    make_tool_params,
    mesh_mass_properties,
    unit_vector,
    vec3,
)

_SPEC_REQUIRED = {"name", "category", "contact_point", "grasp_region"}


_SPEC_OPTIONAL = {"contact_normal", "contact_points", "mass", "density", "mu", "restitution", "contact_duration",
                  "units", "handle_axis", "x_axis", "parts"}


#: The mesh files read (by extension): the formats trimesh reads that carry a closed triangle mesh.
MESH_FORMATS = {".stl": "STL (binary or ASCII)", ".obj": "Wavefront OBJ", ".ply": "PLY"}
#: Length units a spec may state (`units`), in metres per unit: the mesh and every position in the spec.
SPEC_UNITS = {"m": 1.0, "mm": 1e-3}


#: m, the largest extent a hand tool's mesh may have, and the smallest: outside them the units are
#: almost surely wrong (a 300 mm hammer read as metres is 300 m long).
TOOL_EXTENT_RANGE = (0.02, 2.0)


#: m, the height of the slabs a mesh tool's collision shape is cut into along its handle (`convex_pieces`):
#: a handle's slab is its own convex hull, so the pads close on the handle, not on a hull that spans the head.
COLLISION_SLAB = 0.02
#: m^3, slab pieces smaller than this (slivers where a slab's plane grazes the mesh) are left out.
MIN_PIECE_VOLUME = 1e-9
#: m, how far a contact point may lie from the mesh's surface.
CONTACT_SURFACE_TOL = 0.005


#: rad: a mesh given without `handle_axis` must have its long axis within this of z and its contact
#: normal within FRAME_NORMAL_TOLERANCE of its category's direction, else the spec must state the frame.
FRAME_AXIS_TOLERANCE = math.radians(30.0)


FRAME_NORMAL_TOLERANCE = math.radians(45.0)


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


def load_mesh_tool(mesh_path: str, spec: str | os.PathLike | Mapping) -> Tool:
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
    ext = os.path.splitext(mesh_path)[1].lower()
    if ext not in MESH_FORMATS:
        raise InputError(f"tool mesh {mesh_path!r}: {ext or 'no extension'} is not a mesh format read here; give "
                         f"{', '.join(MESH_FORMATS.values())} (.stl, .obj, .ply)")
    try:
        mesh = trimesh.load(mesh_path, force="mesh", process=True)
    except Exception as exc:  # trimesh raises many types for unreadable files, some about its own modules
        why = "" if isinstance(exc, ImportError) else f" ({exc})"
        raise InputError(f"tool mesh {mesh_path!r}: not a readable {MESH_FORMATS[ext]} file{why}") from None
    mesh = check_mesh(mesh, f"tool mesh {mesh_path!r} (read as {MESH_FORMATS[ext]})")
    if scale != 1.0:
        mesh = mesh.copy()
        mesh.apply_scale(scale)
    _check_extent(mesh, mesh_path, unit_name)

    cp = scale * vec3(data["contact_point"], f"{label}: field 'contact_point'")
    extra = data.get("contact_points", [])
    if not isinstance(extra, list):
        raise InputError(f"{label}: field 'contact_points' must be a list of [x, y, z]")
    cps = np.array([cp] + [scale * vec3(p, f"{label}: field 'contact_points'") for p in extra])
    _check_on_surface(mesh, cps, label, unit_name)
    normal = unit_vector(data.get("contact_normal", _default_normal(mesh, cp)), f"{label}: field 'contact_normal'")
    region = data["grasp_region"]
    if not isinstance(region, Mapping) or set(region) != {"min", "max"}:
        raise InputError(f"{label}: field 'grasp_region' must be a table {{ min = [x,y,z], max = [x,y,z] }}")
    box = box_from(scale * vec3(region["min"], f"{label}: field 'grasp_region'.min"),
                    scale * vec3(region["max"], f"{label}: field 'grasp_region'.max"),
                    f"{label}: field 'grasp_region'")
    if not box_overlaps(box, mesh.bounds):  # a region away from the mesh can hold no grasp
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
    check_positive(density, f"{label}: field 'density'", "kg/m^3")
    mass, com, inertia = mesh_mass_properties(mesh, float(density))
    if "mass" in data:
        check_positive(data["mass"], f"{label}: field 'mass'", "kg")
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
        contact_normal=normal, contact_points=cps, grasp_region=box, primitives=convex_pieces(mesh),
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
        b = box_from(scale * vec3(region["min"], f"{what}.min"), scale * vec3(region["max"], f"{what}.max"), what)
        if not box_overlaps(b, mesh.bounds):
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
    z = unit_vector(data["handle_axis"], f"{label}: field 'handle_axis'")
    x_raw = unit_vector(data["x_axis"], f"{label}: field 'x_axis'")
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


def convex_pieces(mesh: trimesh.Trimesh) -> tuple:
    """The collision shape of a mesh tool (tool frame, m): the mesh cut into slabs COLLISION_SLAB thick along
    z (the handle), each slab's connected parts replaced by their convex hulls, as ("hull", vertices [K, 3],
    faces [F, 3]) primitives. MuJoCo collides a mesh geom as its convex hull, and one hull of a whole
    T-headed or L-shaped tool fills the space between its head and its handle, where the pads close and
    on which it would rest on a table; the slabs' hulls follow the handle and the head. A cross-section
    that is itself concave within one slab (a U-channel) is still filled."""
    lo, hi = np.asarray(mesh.bounds[0], float), np.asarray(mesh.bounds[1], float)
    edges = np.linspace(lo[2], hi[2], max(1, int(np.ceil((hi[2] - lo[2]) / COLLISION_SLAB))) + 1)
    centre, span = 0.5 * (lo + hi), 2.0 * float(np.max(hi - lo)) + 1.0
    pieces = []
    for z0, z1 in zip(edges[:-1], edges[1:]):
        cutter = trimesh.creation.box(extents=[span, span, z1 - z0],
                                      transform=trimesh.transformations.translation_matrix([centre[0], centre[1],
                                                                                            0.5 * (z0 + z1)]))
        slab = trimesh.boolean.intersection([mesh, cutter], engine="manifold")
        for part in slab.split(only_watertight=False):
            piece = _hull(np.asarray(part.vertices, float))
            if piece is not None:
                pieces.append(("hull", *piece))
    return tuple(pieces)


def _hull(points: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The convex hull of points [P, 3] as (vertices [K, 3], faces [F, 3] wound outwards), or None when it
    encloses less than MIN_PIECE_VOLUME (a sliver, or points in a plane)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        h = ConvexHull(points)
    except QhullError:
        return None
    if h.volume <= MIN_PIECE_VOLUME:
        return None
    keep = np.unique(h.simplices)
    faces = np.searchsorted(keep, h.simplices).astype(np.int32)
    verts = points[keep]
    tri = verts[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    inward = np.einsum("ij,ij->i", normal, tri.mean(1) - verts.mean(0)) < 0
    faces[inward] = faces[inward][:, ::-1]
    return verts, faces
