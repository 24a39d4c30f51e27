"""Named parts of a tool, with regions on its mesh: what grounding chooses among.

    from itup_jax.tools import parts
    ps = parts.tool_parts(tool)            # (Part('handle', roles=('grasp',)), Part('head', roles=('work',)), ...)
    parts.find(tool, "face")               # the part a word names ('face' -> the hammer's head)
    grounded = parts.apply(tool, work=ps[1], grasp=ps[0])   # the tool with Omega's c_tool from `work`

A part is a region of the tool frame (an axis-aligned box, metres) with a name and the roles it can
play in a task:

  * **work**: the part that touches the target. Its contact points and normal are the tool's contact
    annotation (`Tool.contact_points`, `contact_normal`): the part whose region holds the primary
    contact point is the working part (the hammer's head, the broom's bristles, the L-stick's hook).
  * **grasp**: a part the hand may hold: one whose region overlaps the tool's grasp region (the handle).
  * neither: the rest (the broom's block, the hatchet's blade).

Built-in and procedural tools name their parts when they are assembled (`Tool.part_regions`, one per
`Tool.parts` entry). A mesh tool's spec may name its own in `[parts.<name>]` tables (min, max, in the
spec's units and file frame); without them it has two: `handle` (its grasp region, clipped to the mesh)
and the working end (a box 15 mm around its contact points) named after its category's working part
(`WORK_PART_OF_CATEGORY`).

`apply(tool, work, grasp)` gives the tool that a two-level grounding describes: the contact of `work`
(Omega's c_tool and n) and the grasp region of `grasp` (the tool's annotated grasp region when `grasp`
is the part it lies on; the part's own region, grown by GRASP_PART_MARGIN, when the grounding asks
for another part).
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

from itup_jax.errors import InputError
from itup_jax.tools.tool import Box, Tool

#: Part roles.
ROLES = ("work", "grasp")
#: m, a part's region is grown by this much when testing whether it holds a contact point.
CONTACT_TOLERANCE = 0.003
#: m, half-size of the working-end box a mesh tool without `[parts]` gets around its contact points.
WORK_END_HALF = 0.015
#: m, how much a part's region is grown when it becomes the grasp region (the sampler's grasp
#: midpoints and pad contacts lie on the surface, not strictly inside the part's bounds).
GRASP_PART_MARGIN = 0.006
#: Share of a part's volume that must lie inside the grasp region for the part to be a grasp part.
GRASP_OVERLAP = 0.2

#: The name of a category's working part, for a mesh tool whose spec names no parts.
WORK_PART_OF_CATEGORY = {
    "hammer": "head", "mallet": "head", "broom": "bristles", "l_stick": "hook", "screwdriver": "shaft",
    "spanner": "head", "pry_bar": "hook", "hatchet": "poll", "squeegee": "blade",
}

#: Words that name a part, beyond the part's own name (lower case; several words are one phrase).
PART_WORDS = {
    "handle": ("handle", "grip", "haft", "handgrip"),
    "head": ("head", "face", "striking face", "hammerhead"),
    "bristles": ("bristles", "bristle", "brush head", "brush"),
    "hook": ("hook", "bend", "crook", "hooked end", "bent end"),
    "shaft": ("shaft", "tip", "stem"),
    "blade": ("blade", "edge", "rubber"),
    "poll": ("poll", "back of the head", "butt of the head"),
    "bar": ("bar", "body", "shank"),
    "holder": ("holder",),
    "block": ("block", "stock"),
    "claw": ("claw",),
}


@dataclasses.dataclass(frozen=True, eq=False)
class Part:
    """A named region of a tool (tool frame, metres).

    Attributes:
      name: the part's name ('handle', 'head', ...).
      region: `Box`, the part's bounds in the tool frame.
      roles: the subset of ROLES it can play.
      contact_points: [K, 3] m, a work part's contact points (None for other parts).
      contact_normal: [3] unit, a work part's contact normal (None for other parts).
      words: the words that name it (its name first).
    """

    name: str
    region: Box
    roles: tuple[str, ...]
    contact_points: np.ndarray | None = None
    contact_normal: np.ndarray | None = None
    words: tuple[str, ...] = ()

    def to_json(self) -> dict:
        out = {"name": self.name, "roles": list(self.roles), "region": {"min": np.round(self.region.lo, 5).tolist(),
                                                                       "max": np.round(self.region.hi, 5).tolist()}}
        if self.contact_points is not None:
            out["contact_points"] = np.round(self.contact_points, 5).tolist()
            out["contact_normal"] = np.round(self.contact_normal, 5).tolist()
        return out


def _volume(b: Box) -> float:
    return float(np.prod(np.maximum(b.hi - b.lo, 0.0)))


def _overlap(a: Box, b: Box) -> float:
    return _volume(Box(np.maximum(a.lo, b.lo), np.minimum(a.hi, b.hi)))


def _regions(tool: Tool) -> tuple[tuple[str, Box], ...]:
    if tool.part_regions:
        return tuple(tool.part_regions)
    lo, hi = np.asarray(tool.mesh.bounds[0], float), np.asarray(tool.mesh.bounds[1], float)
    g = tool.grasp_region
    handle = Box(np.maximum(g.lo, lo), np.minimum(g.hi, hi))
    cps = np.asarray(tool.contact_points, float)
    work = Box(np.maximum(cps.min(0) - WORK_END_HALF, lo), np.minimum(cps.max(0) + WORK_END_HALF, hi))
    return (("handle", handle), (WORK_PART_OF_CATEGORY.get(tool.category, "working end"), work))


def _words(name: str) -> tuple[str, ...]:
    base = name.lower().replace("_", " ")
    return (base,) + tuple(w for w in PART_WORDS.get(base, ()) if w != base)


def tool_parts(tool: Tool) -> tuple[Part, ...]:
    """The tool's parts with their roles (module docstring). Exactly one part is the work part (the one
    holding the primary contact point, the smallest if several do); at least one is a grasp part."""
    regions = _regions(tool)
    cp = np.asarray(tool.contact_point, float)
    holding = [i for i, (_, b) in enumerate(regions) if b.contains(cp, CONTACT_TOLERANCE)]
    if not holding:
        raise InputError(f"tool {tool.name!r}: no part's region holds the contact point {np.round(cp, 4).tolist()} "
                         f"(parts {[n for n, _ in regions]})")
    work = min(holding, key=lambda i: _volume(regions[i][1]))
    g = tool.grasp_region
    grasp = [i for i, (_, b) in enumerate(regions) if i != work and _overlap(b, g) >= GRASP_OVERLAP * _volume(b) > 0]
    if not grasp:  # a tool whose grasp region lies on its working part only (or on a tiny part)
        grasp = [max(range(len(regions)), key=lambda i: _overlap(regions[i][1], g))]
    out = []
    for i, (name, b) in enumerate(regions):
        roles = tuple(r for r, on in (("work", i == work), ("grasp", i in grasp)) if on)
        cps = np.asarray(tool.contact_points, float)
        if i == work:
            cps = cps[b.contains(cps, CONTACT_TOLERANCE)]
            cps = cps if len(cps) else np.asarray(tool.contact_points, float)[:1]
        out.append(Part(name=name, region=b, roles=roles,
                        contact_points=cps if i == work else None,
                        contact_normal=np.asarray(tool.contact_normal, float) if i == work else None,
                        words=_words(name)))
    return tuple(out)


def work_part(tool: Tool) -> Part:
    """The tool's working part."""
    return next(p for p in tool_parts(tool) if "work" in p.roles)


def grasp_parts(tool: Tool) -> tuple[Part, ...]:
    """The parts the hand may hold."""
    return tuple(p for p in tool_parts(tool) if "grasp" in p.roles)


def find(tool: Tool, word: str) -> Part:
    """The part of `tool` that `word` names (a part's name or one of its words, case-insensitive), or
    InputError listing the tool's parts."""
    w = re.sub(r"\s+", " ", str(word).strip().lower().replace("_", " "))
    ps = tool_parts(tool)
    for p in ps:
        if w == p.name.lower().replace("_", " "):
            return p
    for p in ps:
        if w in p.words:
            return p
    raise InputError(f"tool {tool.name!r} has no part {word!r}; its parts: "
                     + ", ".join(f"{p.name} ({'/'.join(p.roles) or 'body'})" for p in ps))


def apply(tool: Tool, work: Part, grasp: Part) -> Tool:
    """The tool as a grounding describes it: contact points and normal from `work` (which must be a work
    part: it has contact points), and the grasp region from `grasp` (module docstring)."""
    if work.contact_points is None:
        raise InputError(f"tool {tool.name!r}: part {work.name!r} has no contact annotation; the work part is "
                         f"{work_part(tool).name!r}")
    if "grasp" in grasp.roles:
        region = tool.grasp_region
    else:
        region = Box(grasp.region.lo - GRASP_PART_MARGIN, grasp.region.hi + GRASP_PART_MARGIN)
    cps = np.asarray(work.contact_points, float)
    return dataclasses.replace(tool, contact_point=cps[0], contact_points=cps,
                               contact_normal=np.asarray(work.contact_normal, float), grasp_region=region)
