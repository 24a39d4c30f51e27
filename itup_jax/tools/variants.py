"""Procedural variants of the built-in tools: the training data's tools (`itup generate --variants`).

    from itup_jax.tools import variants
    variants.vary_tool(tool, seed=3)          # the whole tool stretched and made denser or lighter
    variants.part_variant("hammer", seed=3)   # handle and head varied independently

`vary_tool` ("stretch") scales a tool along and across its handle and its density, with the mass
properties transformed exactly. `part_variant` ("parts") rebuilds a built-in tool from its parametric
builder (`builtin`) with each part's dimensions drawn in `PART_RANGES`; the tool families' draws of
the four built-in families are these (`families.draw`).
"""

from __future__ import annotations

import dataclasses
import inspect
from types import MappingProxyType

import numpy as np

from itup_jax.errors import InputError
from itup_jax.tools.builtin import BUILTIN_TOOLS
from itup_jax.tools.tool import Box, Tool, make_tool_params


@dataclasses.dataclass(frozen=True)
class VariantRanges:
    """Uniform ranges of a variant: handle-axis scale, radial scale, density scale (all relative)."""

    axial: tuple = (0.85, 1.15)
    radial: tuple = (0.8, 1.25)
    density: tuple = (0.8, 1.25)


def vary_tool(tool: Tool, seed: int, ranges: VariantRanges = VariantRanges()) -> Tool:
    """A procedural variant: the tool stretched by diag(r, r, a) (tool z is the handle axis) and made
    denser or lighter by d. Mass properties transform exactly (each part keeps a uniform density):
    m' = d r^2 a m, c' = D c, and with S = tr(I)/2 E - I the second moments, S' = d r^2 a D S D.
    """
    rng = np.random.default_rng(seed)
    a, r, d = (rng.uniform(*ranges.axial), rng.uniform(*ranges.radial), rng.uniform(*ranges.density))
    D = np.diag([r, r, a])
    p = tool.params
    I = np.asarray(p.inertia, float)
    S = 0.5 * np.trace(I) * np.eye(3) - I
    k = d * r * r * a
    S2 = k * D @ S @ D
    mesh = tool.mesh.copy()
    mesh.apply_transform(np.diag([r, r, a, 1.0]))
    prims = []
    for prim in tool.primitives:
        if prim[0] == "capsule":
            _, p0, p1, rad = prim
            prims.append(("capsule", D @ p0, D @ p1, rad * r))
        elif prim[0] == "box":
            _, lo, hi = prim
            prims.append(("box", D @ lo, D @ hi))
        else:  # a convex piece: its vertices stretched (still convex)
            _, verts, faces = prim
            prims.append(("hull", verts @ D, faces))
    normal = np.linalg.solve(D, tool.contact_normal)  # normals transform by D^-T (D is diagonal)
    params = make_tool_params(
        mass=k * float(p.mass), com=D @ np.asarray(p.com, float), inertia=np.trace(S2) * np.eye(3) - S2,
        restitution=float(p.restitution), mu=float(p.mu), contact_duration=float(p.contact_duration),
        what=f"variant of {tool.name!r}")
    return dataclasses.replace(
        tool, name=f"{tool.name}~{seed}", mesh=mesh, params=params, contact_point=D @ tool.contact_point,
        contact_points=tool.contact_points @ D, contact_normal=normal / np.linalg.norm(normal),
        grasp_region=Box(D @ tool.grasp_region.lo, D @ tool.grasp_region.hi), primitives=tuple(prims),
        parts=tuple((n, m, round(w * k, 4)) for n, m, w in tool.parts),
        part_regions=tuple((n, Box(D @ b.lo, D @ b.hi)) for n, b in tool.part_regions))


#: The part-wise family (`part_variant`): per built-in tool, each dimension's uniform range as a factor
#: of the built-in's (a head_density factor multiplies the head material's density). The handle and
#: the head vary independently, so the head's mass and shape change against the handle, unlike
#: `vary_tool`'s stretch of the whole tool.
PART_RANGES = MappingProxyType({
    "hammer": {"head_z": (0.8, 1.2), "handle_radius": (0.8, 1.25), "head_radius": (0.8, 1.3),
               "head_length": (0.75, 1.3), "head_density": (0.6, 1.5)},
    "mallet": {"head_z": (0.8, 1.2), "handle_radius": (0.8, 1.25), "head_radius": (0.8, 1.3),
               "head_length": (0.75, 1.3), "head_density": (0.6, 1.5)},
    "broom": {"half_width": (0.75, 1.25), "bristle_height": (0.8, 1.3), "handle_radius": (0.8, 1.25),
              "handle_length": (0.8, 1.2)},
    "l_stick": {"shaft": (0.85, 1.15), "radius": (0.8, 1.3), "hook_end": (0.75, 1.3)},
})


def part_variant(base: str, seed: int) -> Tool:
    """A procedural variant of built-in tool `base` whose parts vary independently (`PART_RANGES`): the
    hammer's and the mallet's handle length and radius, head radius, head length and head density; the
    broom's width, bristle height, handle radius and length; the L-stick's shaft length, rod radius and
    hook length. The grasp region and the contact points follow the parts (the same fractions as the
    built-in's). Built by the tool's own parametric builder (`builtin.claw_hammer`, ...), so mass properties
    come from the parts' meshes and densities. Name: '<base>#<seed>'."""
    if base not in PART_RANGES:
        raise InputError(f"part_variant: base must be one of {sorted(PART_RANGES)}, got {base!r}")
    rng = np.random.default_rng(seed)
    f = {k: rng.uniform(*r) for k, r in PART_RANGES[base].items()}
    name = f"{base}#{seed}"
    d = {k: p.default for k, p in inspect.signature(BUILTIN_TOOLS[base]).parameters.items()}  # the built-in's dimensions
    if base in ("hammer", "mallet"):
        z0, r0 = d["head_z"], d["head_radius"]
        hr = r0 * f["head_radius"]
        handle = (z0 - r0) * f["head_z"]  # the handle's length
        kw = dict(head_z=handle + hr, handle_radius=d["handle_radius"] * f["handle_radius"], head_radius=hr,
                  head_density=f["head_density"], grasp_top=d["grasp_top"] * handle / (z0 - r0))
        kw["grasp_half"] = max(0.02, kw["handle_radius"] + 0.0055)
        if base == "hammer":
            kw.update(head_back=d["head_back"] * f["head_length"], head_front=d["head_front"] * f["head_length"])
        else:
            kw.update(head_half=d["head_half"] * f["head_length"])
        return BUILTIN_TOOLS[base](name=name, **kw)
    if base == "broom":
        w, h = d["half_width"] * f["half_width"], d["bristle_height"] * f["bristle_height"]
        b0 = d["bristle_height"] + 0.030  # the built-in block's top
        length = (d["handle_top"] - b0) * f["handle_length"]
        hr = d["handle_radius"] * f["handle_radius"]
        return BUILTIN_TOOLS[base](name=name, half_width=w, bristle_height=h, handle_radius=hr, handle_top=h + 0.030 + length,
                              grasp_bottom=h + 0.030 + (d["grasp_bottom"] - b0) * f["handle_length"],
                              contact_x=d["contact_x"] * f["half_width"], grasp_half=max(0.02, hr + 0.009))
    return BUILTIN_TOOLS[base](name=name, shaft=d["shaft"] * f["shaft"], radius=d["radius"] * f["radius"],
                          hook_end=d["hook_end"] * f["hook_end"], contact_x=d["contact_x"] * f["hook_end"],
                          grasp_top=d["grasp_top"] * f["shaft"])


VARIANT_FAMILIES = ("stretch", "parts")  # `vary_tool`, `part_variant`
