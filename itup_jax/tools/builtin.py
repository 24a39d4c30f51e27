"""The built-in tools, assembled from primitive parts with their own materials.

    from itup_jax.tools import builtin
    builtin.claw_hammer()                   # the built-in hammer (`itup.load_tool("hammer")`)
    builtin.claw_hammer(head_density=1.4)   # a heavier head; every dimension is a keyword (metres)

A tool is a list of parts, each a closed mesh with its collision primitive (`cylinder_part`,
`box_part`) and a material (`priors.MATERIAL_DENSITY`). `assemble_tool` sums the parts' mass
properties and unions their meshes. The four builders' defaults are the built-in tools; other values
are the part-wise variants of `variants.part_variant` and the tool families' draws (`families`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import trimesh

from itup_jax.tools import priors
from itup_jax.tools.tool import (
    Box,
    Tool,
    box_from,
    check_mesh,
    combine_mass_properties,
    make_tool_params,
    mesh_mass_properties,
    unit_vector,
)

_SECTIONS = 48  # facets around a cylinder: mass within 0.3 % of the true cylinder


def cylinder_part(radius: float, p0: Sequence[float], p1: Sequence[float]) -> tuple[trimesh.Trimesh, tuple]:
    """A solid cylinder part and its collision primitive: a capsule of the same length overall."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    mesh = trimesh.creation.cylinder(radius=radius, segment=np.array([p0, p1]), sections=_SECTIONS)
    return mesh, ("capsule", p0 + radius * u, p1 - radius * u, radius)


def box_part(lo: Sequence[float], hi: Sequence[float]) -> tuple[trimesh.Trimesh, tuple]:
    """A solid axis-aligned box part (lo [3], hi [3], metres) and its collision primitive, the same box."""
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
        contact_normal=unit_vector(contact_normal, f"tool {name!r}.contact_normal"), contact_points=cps,
        grasp_region=box_from(grasp_region[0], grasp_region[1], f"tool {name!r}.grasp_region"),
        parts=tuple(described), primitives=tuple(prims), part_regions=tuple(regions),
    )


# The built-in tools are parametric: the defaults are the built-in tool, other values the procedural
# part-wise variants of `variants.part_variant` (metres; density scales relative to the material).
def claw_hammer(*, handle_radius: float = 0.0145, head_z: float = 0.290, head_radius: float = 0.011,
                head_back: float = 0.050, head_front: float = 0.060, head_density: float = 1.0,
                grasp_top: float = 0.25, grasp_half: float = 0.02, name: str = "hammer") -> Tool:
    """A claw hammer: a hickory handle along +z up to the head, and a steel head across the top from
    x = -head_back (claw) to +head_front (the face, the contact). Built-in: ~0.30 m long, ~0.47 kg."""
    return assemble_tool(
        name=name, category="hammer",
        parts=[
            ("handle", "hickory", cylinder_part(handle_radius, (0, 0, 0), (0, 0, head_z - head_radius))),
            ("head", "steel", cylinder_part(head_radius, (-head_back, 0, head_z), (head_front, 0, head_z)), head_density),
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
            ("bristles", "bristle_pack", box_part((-half_width, -0.0175, 0.0), (half_width, 0.0175, bristle_height))),
            ("block", "beech", box_part((-half_width - 0.005, -0.020, bristle_height), (half_width + 0.005, 0.020, block_top))),
            ("handle", "polypropylene", cylinder_part(handle_radius, (0, 0, block_top), (0, 0, handle_top))),
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
            ("handle", "beech", cylinder_part(handle_radius, (0, 0, 0), (0, 0, head_z - head_radius))),
            ("head", "beech", cylinder_part(head_radius, (-head_half, 0, head_z), (head_half, 0, head_z)), head_density),
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
            ("shaft", "aluminium", cylinder_part(r, (0, 0, 0), (0, 0, shaft))),
            ("hook", "aluminium", cylinder_part(r, (r, 0, shaft), (hook_end, 0, shaft))),
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
