"""The parametric builders of the procedural tool families (`tools.families` registers them with their
size ranges, tasks and roles): each builds a `Tool` from primitive parts with their own materials
(`builtin.assemble_tool`: mass properties from the parts' meshes and densities, a watertight union for
sampling, capsules and boxes for the simulator). Lengths in metres; every builder's defaults are its
family's default tool (`itup.load_tool(<family>)`).

    from itup_jax.tools import family_shapes
    tool = family_shapes.hook(length=0.5, hook_end=0.12, name="my_hook")
"""

from __future__ import annotations

import math

import numpy as np
import trimesh

from itup_jax.errors import InputError
from itup_jax.tools.builtin import assemble_tool, box_part, cylinder_part
from itup_jax.tools.tool import Tool


def _prism(radius: float, p0, p1, sections: int) -> tuple[trimesh.Trimesh, tuple]:
    """A solid prism of `sections` sides (6: a hexagonal bar; many: a round one) whose flats lie `radius`
    from its axis, and its collision capsule (radius: the mean of the flats' and the corners' distances)."""
    circum = radius / math.cos(math.pi / sections)
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    mesh = trimesh.creation.cylinder(radius=circum, segment=np.array([p0, p1]), sections=sections)
    r = 0.5 * (radius + circum)
    return mesh, ("capsule", p0 + r * u, p1 - r * u, r)


def short_of_end(start: float, end: float, from_end: float) -> float:
    """Where a working part that runs from `start` to `end` (m, along one axis) takes its contact:
    `from_end` short of its end, or halfway along a part shorter than twice that."""
    return max(end - from_end, 0.5 * (start + end))


# ---------------------------------------------------------------------------------------------------
# The five held-out families (the defaults are each family's `load_tool(<family>)` tool)
# ---------------------------------------------------------------------------------------------------
def screwdriver(*, handle_radius: float = 0.0135, handle_length: float = 0.100, shaft_radius: float = 0.003,
                shaft_length: float = 0.100, name: str = "screwdriver") -> Tool:
    """A screwdriver: a cellulose-acetate handle along +z, then a steel shaft to the tip. The contact is
    the side of the shaft 10 mm short of its tip, facing +x (it taps a block in the knock). Default:
    0.20 m long, ~0.1 kg."""
    top = handle_length + shaft_length
    return assemble_tool(
        name=name, category="screwdriver",
        parts=[
            ("handle", "cellulose_acetate", cylinder_part(handle_radius, (0, 0, 0), (0, 0, handle_length))),
            ("shaft", "steel", cylinder_part(shaft_radius, (0, 0, handle_length), (0, 0, top))),
        ],
        contact_points=[(shaft_radius, 0.0, top - 0.010)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-handle_radius - 0.006,) * 2 + (0.0,),
                      (handle_radius + 0.006,) * 2 + (handle_length,)),
    )


def spanner(*, bar_length: float = 0.160, bar_width: float = 0.018, bar_thickness: float = 0.005,
            head_half: float = 0.018, head_thickness: float = 0.008, name: str = "spanner") -> Tool:
    """A spanner: a flat steel bar along +z (bar_width along x, bar_thickness along y) and a square steel
    head (2 head_half along x and z, head_thickness along y) on top. The contact is the head's +x side.
    Default: 0.20 m long, ~0.19 kg."""
    w, t = bar_width / 2, bar_thickness / 2
    zc = bar_length + head_half
    g = max(w, t) + 0.006
    return assemble_tool(
        name=name, category="spanner",
        parts=[
            ("bar", "steel", box_part((-w, -t, 0.0), (w, t, bar_length))),
            ("head", "steel", box_part((-head_half, -head_thickness / 2, bar_length),
                                   (head_half, head_thickness / 2, bar_length + 2 * head_half))),
        ],
        contact_points=[(head_half, 0.0, zc)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, 0.7 * bar_length)),
    )


#: m, the farthest a pry bar's contact lies from its hook's tip: the reach holds the hook's tip 0.01 m
#: above the table against a block 0.06 m tall (`tasks.reach`), so a contact further up the hook than
#: 0.05 m would meet the block above its face; halfway along the hook unless that is further.
PRY_CONTACT_FROM_TIP = 0.048


def pry_bar(*, length: float = 0.450, radius: float = 0.0095, hook_end: float = 0.080, sections: int = 6,
            name: str = "pry_bar") -> Tool:
    """A pry bar: a steel bar (hexagonal for sections = 6, `radius` to its flats) along +z and its end
    bent at a right angle along +x up to hook_end. The contact is the bend's inner face (facing -z, back
    along the bar), like the L-stick's hook: halfway along the hook, at most PRY_CONTACT_FROM_TIP from
    its tip. Default: 0.45 m long, ~1.3 kg."""
    r = radius
    circum = radius / math.cos(math.pi / sections)
    g = circum + 0.006
    hook = _prism(r, (circum, 0, length - r), (hook_end, 0, length - r), sections)
    contact_x = short_of_end(circum, hook_end, PRY_CONTACT_FROM_TIP)
    return assemble_tool(
        name=name, category="pry_bar",
        parts=[
            ("bar", "steel", _prism(r, (0, 0, 0), (0, 0, length), sections)),
            ("hook", "steel", hook),
        ],
        # the hook's underside: a flat or, for a hexagon turned corner-down, its lowest edge
        contact_points=[(contact_x, 0.0, float(hook[0].bounds[0][2]))],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, 0.45 * length)),
    )


def hatchet(*, handle_length: float = 0.300, handle_radius: float = 0.015, blade_length: float = 0.090,
            blade_height: float = 0.080, blade_thickness: float = 0.008, poll_length: float = 0.030,
            poll_size: float = 0.028, name: str = "hatchet") -> Tool:
    """A hatchet: a hickory handle along +z and a steel head on top, asymmetric about the handle: a thin
    blade towards -x (blade_length long, blade_height tall) and a square poll towards +x. The contact is
    the poll's face (+x). Default: 0.38 m long, ~0.8 kg."""
    z0 = handle_length
    zc = z0 + blade_height / 2
    g = handle_radius + 0.006
    return assemble_tool(
        name=name, category="hatchet",
        parts=[
            ("handle", "hickory", cylinder_part(handle_radius, (0, 0, 0), (0, 0, z0))),
            ("blade", "steel", box_part((-blade_length, -blade_thickness / 2, z0),
                                    (0.0, blade_thickness / 2, z0 + blade_height))),
            ("poll", "steel", box_part((0.0, -poll_size / 2, zc - poll_size / 2),
                                   (poll_length, poll_size / 2, zc + poll_size / 2))),
        ],
        contact_points=[(poll_length, 0.0, zc)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, 0.75 * handle_length)),
    )


#: Share of a hollow aluminium handle's solid volume that is metal (a 1 mm wall on an 11 mm radius).
HOLLOW_HANDLE_FILL = 1.0 - (10.0 / 11.0) ** 2


def squeegee(*, half_width: float = 0.150, blade_height: float = 0.030, handle_radius: float = 0.011,
             handle_length: float = 0.400, contact_x: float = 0.100, name: str = "squeegee") -> Tool:
    """A squeegee, a T-headed long tool: a neoprene blade (2 half_width wide, 3 mm thick) whose edge is at
    z = 0, a 20 x 20 mm polypropylene holder 5 mm wider each side, and a hollow aluminium handle along +z.
    It pushes along +y with the blade's leading edge, touching at x = 0 and +-contact_x. Default: 0.45 m tall, 0.3 m
    wide, ~0.22 kg."""
    holder_top = blade_height + 0.020
    g = handle_radius + 0.009
    return assemble_tool(
        name=name, category="squeegee",
        parts=[
            ("blade", "neoprene", box_part((-half_width, -0.0015, 0.0), (half_width, 0.0015, blade_height))),
            ("holder", "polypropylene", box_part((-half_width - 0.005, -0.010, blade_height),
                                             (half_width + 0.005, 0.010, holder_top))),
            ("handle", "aluminium", cylinder_part(handle_radius, (0, 0, holder_top), (0, 0, holder_top + handle_length)),
             HOLLOW_HANDLE_FILL),
        ],
        # the blade's leading edge: tilted back in the sweep, the rest of the blade stays above the table
        contact_points=[(0.0, 0.0015, 0.0), (-contact_x, 0.0015, 0.0), (contact_x, 0.0015, 0.0)],
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-g, -g, holder_top + 0.35 * handle_length), (g, g, holder_top + handle_length)),
    )


# ---------------------------------------------------------------------------------------------------
# Training families: wide parametric spans of each category's shape and mass distribution
# ---------------------------------------------------------------------------------------------------
#: Materials a training family's parts are drawn from (`priors.MATERIAL_DENSITY`).
HANDLE_MATERIALS = ("hickory", "beech", "polypropylene", "cellulose_acetate", "aluminium")
HEAD_MATERIALS = ("steel", "aluminium", "beech", "polypropylene")


def baton(*, length: float = 0.320, handle_fraction: float = 0.55, handle_radius: float = 0.014,
          tip_radius: float = 0.012, handle_material: str = "hickory", tip_material: str = "hickory",
          name: str = "baton") -> Tool:
    """A headless stick in two coaxial segments along +z, each with its own radius and material: a handle
    (handle_fraction of the length, the grasp region) and a tip. A uniform baton, a thin steel shaft on a
    thick handle (a screwdriver's build), a heavy tip or a light one. It strikes with the side of the tip
    15 mm short of its end (+x), as a mallet's category (knock, hammer). Default: 0.32 m, ~0.14 kg."""
    z1 = handle_fraction * length
    g = max(handle_radius, tip_radius) + 0.006
    return assemble_tool(
        name=name, category="mallet",
        parts=[
            ("handle", handle_material, cylinder_part(handle_radius, (0, 0, 0), (0, 0, z1))),
            ("tip", tip_material, cylinder_part(tip_radius, (0, 0, z1), (0, 0, length))),
        ],
        contact_points=[(tip_radius, 0.0, length - 0.015)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, z1)),
    )


def _handle_and_box_head(*, name: str, category: str, handle_length: float, handle_radius: float,
                         handle_material: str, head_material: str, lo, hi, contact, grasp_share: float,
                         head_name: str = "head") -> Tool:
    """A handle along +z up to handle_length and a box head (lo [3], hi [3], metres) on its top, striking
    with its +x side at `contact`; the grasp region is the handle's lower grasp_share."""
    g = handle_radius + 0.006
    return assemble_tool(
        name=name, category=category,
        parts=[
            ("handle", handle_material, cylinder_part(handle_radius, (0, 0, 0), (0, 0, handle_length))),
            (head_name, head_material, box_part(lo, hi)),
        ],
        contact_points=[contact],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, grasp_share * handle_length)),
    )


def headed_stick(*, handle_length: float = 0.300, handle_radius: float = 0.014, head_back: float = 0.040,
                 head_front: float = 0.040, head_height: float = 0.030, head_width: float = 0.028,
                 handle_material: str = "hickory", head_material: str = "steel", name: str = "headed_stick") -> Tool:
    """A handle along +z and a box head across its top, from x = -head_back to +head_front (head_height
    tall along z, head_width along y): light or heavy, centred or lopsided (a short back is a hatchet's
    poll side, a long one its blade). It strikes with the head's +x face (hammer's category: hammer,
    knock). Default: 0.33 m, ~0.68 kg."""
    z0 = handle_length
    return _handle_and_box_head(
        name=name, category="hammer", handle_length=handle_length, handle_radius=handle_radius,
        handle_material=handle_material, head_material=head_material,
        lo=(-head_back, -head_width / 2, z0), hi=(head_front, head_width / 2, z0 + head_height),
        contact=(head_front, 0.0, z0 + head_height / 2), grasp_share=0.75)


def hook(*, length: float = 0.450, radius: float = 0.008, hook_end: float = 0.090, grasp_fraction: float = 0.6,
         material: str = "aluminium", section: str = "round", name: str = "hook") -> Tool:
    """A bar along +z bent at a right angle along +x at its far end, round or square in section
    (`radius` to its flats), of one material. It pulls with the bend's inner face (-z), as the
    L-stick's category (reach). The grasp region runs from the butt over grasp_fraction of the length, up
    to the bend for the largest fractions. The contact lies 30 mm from the hook's tip (halfway along a
    shorter hook). Default: 0.45 m, ~0.29 kg."""
    r = radius
    z1 = length - r
    if section not in ("round", "square"):
        raise InputError(f"hook {name!r}: section must be 'round' or 'square', got {section!r}")

    def segment(p0, p1):
        if section == "round":
            return cylinder_part(r, p0, p1)
        lo, hi = np.minimum(p0, p1) - r, np.maximum(p0, p1) + r
        axis = int(np.argmax(np.abs(np.subtract(p1, p0))))
        lo[axis], hi[axis] = min(p0[axis], p1[axis]), max(p0[axis], p1[axis])
        return box_part(lo, hi)

    g = r * math.sqrt(2.0) + 0.006
    return assemble_tool(
        name=name, category="l_stick",
        parts=[
            ("bar", material, segment(np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, length]))),
            ("hook", material, segment(np.array([r, 0.0, z1]), np.array([hook_end, 0.0, z1]))),
        ],
        # 30 mm from the hook's tip (halfway along a shorter hook): low on the block's face in the reach
        contact_points=[(short_of_end(r, hook_end, 0.030), 0.0, z1 - r)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, min(grasp_fraction * length, z1 - 2 * r))),
    )


def head_on_handle(*, name: str, half_width: float, y0: float, y1: float, head_height: float,
                   contact_z: float, handle_radius: float, handle_length: float, grasp_fraction: float,
                   head_material: str, handle_material: str, head_name: str, x_centre: float = 0.0) -> Tool:
    """A box head (2 half_width wide along x about x_centre, y0..y1 along y, head_height tall) whose bottom
    is at z = 0 and a handle along +z from its top at x = 0, pushing along +y with the head's +y face at
    height contact_z, at the head's centre and +-0.75 half_width from it (broom's category: sweep); the
    grasp region is the handle's top grasp_fraction."""
    g = handle_radius + 0.009
    top = head_height + handle_length
    cx = 0.75 * half_width
    x0 = x_centre
    return assemble_tool(
        name=name, category="broom",
        parts=[
            (head_name, head_material, box_part((x0 - half_width, y0, 0.0), (x0 + half_width, y1, head_height))),
            ("handle", handle_material, cylinder_part(handle_radius, (0, 0, head_height), (0, 0, top))),
        ],
        contact_points=[(x0, y1, contact_z), (x0 - cx, y1, contact_z), (x0 + cx, y1, contact_z)],
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-g, -g, top - grasp_fraction * handle_length), (g, g, top)),
    )


def pusher(*, half_width: float = 0.120, head_height: float = 0.040, head_depth: float = 0.030,
           handle_radius: float = 0.011, handle_length: float = 0.300, grasp_fraction: float = 0.5,
           head_material: str = "beech", handle_material: str = "polypropylene", name: str = "pusher") -> Tool:
    """A T-headed pusher: a solid head (2 half_width wide along x, head_depth along y, head_height tall)
    whose bottom is at z = 0, and a handle along +z from its top; short and wide heads, long and short
    handles. It pushes along +y with the head's leading face 5 mm above its bottom edge, at x = 0 and
    +-0.75 half_width, as the broom's category (sweep). The grasp region is the handle's top
    grasp_fraction. Default: 0.34 m tall, 0.24 m wide, ~0.3 kg."""
    return head_on_handle(
        name=name, half_width=half_width, y0=-head_depth / 2, y1=head_depth / 2, head_height=head_height,
        contact_z=0.005, handle_radius=handle_radius, handle_length=handle_length,
        grasp_fraction=grasp_fraction, head_material=head_material, handle_material=handle_material,
        head_name="head")


# ---------------------------------------------------------------------------------------------------
# Calibration families: shapes of the built-in categories that no training set holds, kept for
# calibrating the out-of-distribution guard (so that the held-out families stay the judged set)
# ---------------------------------------------------------------------------------------------------
def paddle(*, handle_length: float = 0.200, handle_radius: float = 0.013, blade_thickness: float = 0.012,
           blade_width: float = 0.080, blade_height: float = 0.140, handle_material: str = "hickory",
           blade_material: str = "beech", name: str = "paddle") -> Tool:
    """A paddle: a handle along +z and a flat blade on top, thin along x (blade_thickness), wide along y
    (blade_width) and blade_height tall. It strikes with the blade's flat +x face, 70 % of the way up
    (mallet's category: hammer, knock). Default: 0.34 m, ~0.19 kg."""
    z0 = handle_length
    t = blade_thickness / 2
    return _handle_and_box_head(
        name=name, category="mallet", handle_length=handle_length, handle_radius=handle_radius,
        handle_material=handle_material, head_material=blade_material,
        lo=(-t, -blade_width / 2, z0), hi=(t, blade_width / 2, z0 + blade_height),
        contact=(t, 0.0, z0 + 0.7 * blade_height), grasp_share=0.8, head_name="blade")


def mace(*, handle_length: float = 0.280, handle_radius: float = 0.014, head_half_x: float = 0.018,
         head_half_y: float = 0.018, head_height: float = 0.060, handle_material: str = "hickory",
         head_material: str = "steel", name: str = "mace") -> Tool:
    """A mace: a handle along +z and a tall box head on its axis (2 head_half_x along x, 2 head_half_y
    along y, head_height tall), its mass along the handle's line rather than across it. It strikes with
    the head's +x side at the head's mid-height (hammer's category: hammer, knock). Default: 0.34 m,
    ~0.76 kg."""
    z0 = handle_length
    return _handle_and_box_head(
        name=name, category="hammer", handle_length=handle_length, handle_radius=handle_radius,
        handle_material=handle_material, head_material=head_material,
        lo=(-head_half_x, -head_half_y, z0), hi=(head_half_x, head_half_y, z0 + head_height),
        contact=(head_half_x, 0.0, z0 + head_height / 2), grasp_share=0.75)


def scraper(*, half_width: float = 0.100, blade_height: float = 0.050, blade_thickness: float = 0.0025,
            handle_radius: float = 0.011, handle_length: float = 0.300, blade_material: str = "steel",
            handle_material: str = "beech", name: str = "scraper") -> Tool:
    """A floor scraper: a thin metal plate (2 half_width wide along x, blade_thickness along y,
    blade_height tall) whose bottom edge is at z = 0, and a handle along +z from its top. It pushes along
    +y with the plate's leading bottom edge, at x = 0 and +-0.75 half_width (broom's category: sweep; the
    sweep tilts the tool back, so the plate's trailing edge, a thickness behind, sits lower by under
    1.5 mm). The grasp region is the handle's top half. Default: 0.35 m tall, 0.2 m wide, ~0.28 kg."""
    t = blade_thickness / 2
    return head_on_handle(
        name=name, half_width=half_width, y0=-t, y1=t, head_height=blade_height, contact_z=0.0,
        handle_radius=handle_radius, handle_length=handle_length, grasp_fraction=0.5,
        head_material=blade_material, handle_material=handle_material, head_name="blade")


def bar_and_end_plate(*, name: str, length: float, radius: float, x0: float, x1: float, half_y: float,
                      thickness: float, contact_x: float, grasp_fraction: float, bar_material: str,
                      plate_material: str, plate_name: str, plate: tuple | None = None) -> Tool:
    """A round bar along +z and a plate across its end (`thickness` along z, its top at z = length; by
    default a box x0..x1 along x, 2 half_y along y; `plate`: another part, (mesh, primitive), in that
    slab), pulling with the plate's underside (-z) at x = contact_x, as the L-stick's category (reach);
    the grasp region runs from the butt over grasp_fraction of the length."""
    z1 = length - thickness
    g = radius + 0.006
    return assemble_tool(
        name=name, category="l_stick",
        parts=[
            ("bar", bar_material, cylinder_part(radius, (0, 0, 0), (0, 0, z1))),
            (plate_name, plate_material, plate or box_part((x0, -half_y, z1), (x1, half_y, length))),
        ],
        contact_points=[(contact_x, 0.0, z1)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, min(grasp_fraction * length, z1 - 0.02))),
    )


def t_hook(*, length: float = 0.450, radius: float = 0.007, bar_half: float = 0.007, front: float = 0.080,
           back: float = 0.040, grasp_fraction: float = 0.5, material: str = "aluminium",
           name: str = "t_hook") -> Tool:
    """A T-hook: a round bar along +z and a square crossbar (2 bar_half thick) across its end, from
    x = -back to +front. It pulls with the crossbar's underside (-z) 30 mm short of its front end (halfway
    along a shorter front arm), as the L-stick's category (reach). The grasp region runs from the butt
    over grasp_fraction of the length. Default: 0.45 m, ~0.22 kg."""
    return bar_and_end_plate(
        name=name, length=length, radius=radius, x0=-back, x1=front, half_y=bar_half, thickness=2 * bar_half,
        contact_x=short_of_end(radius, front, 0.030), grasp_fraction=grasp_fraction,
        bar_material=material, plate_material=material, plate_name="crossbar")


# ---------------------------------------------------------------------------------------------------
# Validation families: the sealed-test families of round 1 of the sealed evaluation (0.25.0), looked at since
# ---------------------------------------------------------------------------------------------------
def rolling_pin(*, handle_length: float = 0.110, handle_radius: float = 0.012, barrel_length: float = 0.180,
                barrel_radius: float = 0.024, knob_length: float = 0.060, material: str = "beech",
                name: str = "rolling_pin") -> Tool:
    """A rolling pin held by one end: three coaxial segments along +z of one material, a handle, a thick
    barrel and a knob as thin as the handle beyond it. It strikes with the barrel's side 15 mm short of
    the barrel's end (+x), so part of its mass lies past the contact (mallet's category: hammer, knock).
    Default: 0.35 m, ~0.28 kg."""
    z1, z2 = handle_length, handle_length + barrel_length
    g = handle_radius + 0.006
    return assemble_tool(
        name=name, category="mallet",
        parts=[
            ("handle", material, cylinder_part(handle_radius, (0, 0, 0), (0, 0, z1))),
            ("barrel", material, cylinder_part(barrel_radius, (0, 0, z1), (0, 0, z2))),
            ("knob", material, cylinder_part(handle_radius, (0, 0, z2), (0, 0, z2 + knob_length))),
        ],
        contact_points=[(barrel_radius, 0.0, z2 - 0.015)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, z1)),
    )


def rake(*, half_width: float = 0.120, bar_depth: float = 0.016, bar_height: float = 0.016,
         tine_length: float = 0.050, tine_width: float = 0.008, tine_thickness: float = 0.003,
         handle_radius: float = 0.011, handle_length: float = 0.300, head_material: str = "aluminium",
         handle_material: str = "hickory", name: str = "rake") -> Tool:
    """A rake with three tines: a crossbar (2 half_width wide along x, bar_depth along y, bar_height tall)
    on three flat tines (at x = 0 and +-0.75 half_width, tine_width wide, tine_thickness thick, flush with
    the crossbar's front face), their tips at z = 0, and a handle along +z from the crossbar's top. It
    pushes along +y with the tines' front bottom edges (broom's category: sweep). The grasp region is the
    handle's top half. Default: 0.37 m tall, 0.24 m wide, ~0.26 kg."""
    z0 = tine_length
    top = z0 + bar_height + handle_length
    yf = bar_depth / 2
    cx = 0.75 * half_width
    w = tine_width / 2
    g = handle_radius + 0.009
    return assemble_tool(
        name=name, category="broom",
        parts=[
            ("tine_centre", head_material, box_part((-w, yf - tine_thickness, 0.0), (w, yf, z0))),
            ("tine_left", head_material, box_part((-cx - w, yf - tine_thickness, 0.0), (-cx + w, yf, z0))),
            ("tine_right", head_material, box_part((cx - w, yf - tine_thickness, 0.0), (cx + w, yf, z0))),
            ("crossbar", head_material, box_part((-half_width, -yf, z0), (half_width, yf, z0 + bar_height))),
            ("handle", handle_material, cylinder_part(handle_radius, (0, 0, z0 + bar_height), (0, 0, top))),
        ],
        contact_points=[(0.0, yf, 0.0), (-cx, yf, 0.0), (cx, yf, 0.0)],
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-g, -g, top - 0.5 * handle_length), (g, g, top)),
    )


def hoe(*, length: float = 0.450, radius: float = 0.007, blade_end: float = 0.080, blade_half_width: float = 0.035,
        blade_thickness: float = 0.004, grasp_fraction: float = 0.5, bar_material: str = "aluminium",
        blade_material: str = "steel", name: str = "hoe") -> Tool:
    """A hoe: a round bar along +z and a flat blade across its end, thin along z (blade_thickness), from
    x = -radius to +blade_end and 2 blade_half_width wide along y. It pulls with the blade's underside
    (-z) 20 mm short of its front edge (L-stick's category: reach). The grasp region runs from the butt
    over grasp_fraction of the length. Default: 0.45 m, ~0.38 kg."""
    return bar_and_end_plate(
        name=name, length=length, radius=radius, x0=-radius, x1=blade_end, half_y=blade_half_width,
        thickness=blade_thickness, contact_x=short_of_end(radius, blade_end, 0.020),
        grasp_fraction=grasp_fraction, bar_material=bar_material, plate_material=blade_material,
        plate_name="blade")


# ---------------------------------------------------------------------------------------------------
# Sealed-test families of the next sealed evaluation: never rolled out before it
# ---------------------------------------------------------------------------------------------------
def pick(*, handle_length: float = 0.300, handle_radius: float = 0.014, hub: float = 0.030, front: float = 0.110,
         back: float = 0.090, arm_thickness: float = 0.012, arm_width: float = 0.016,
         handle_material: str = "hickory", head_material: str = "steel", name: str = "pick") -> Tool:
    """A pick: a handle along +z, a cubic hub (side `hub`) on its top and two thin arms out of the hub's
    sides along +x (front) and -x (back), arm_thickness tall and arm_width wide, centred on the hub's
    mid-height: much of the head's mass sits far from the handle's line, little of it at the striking
    end. It strikes with the front arm's +x end face (hammer's category: hammer, knock). The grasp
    region is the handle's lower three quarters. Default: 0.33 m, ~0.7 kg."""
    z0, h = handle_length, hub / 2
    zc, t, w = z0 + h, arm_thickness / 2, arm_width / 2
    return striking_head_on_handle(
        name=name, handle_length=z0, handle_radius=handle_radius, handle_material=handle_material,
        head=[("hub", head_material, box_part((-h, -h, z0), (h, h, z0 + hub))),
              ("front_arm", head_material, box_part((h, -w, zc - t), (h + front, w, zc + t))),
              ("back_arm", head_material, box_part((-h - back, -w, zc - t), (-h, w, zc + t)))],
        contact=(h + front, 0.0, zc))


def striking_head_on_handle(*, name: str, handle_length: float, handle_radius: float, handle_material: str,
                            head: list, contact: tuple) -> Tool:
    """A hammer-category tool: a round handle along +z from the origin to handle_length, the `head`
    parts (name, material, part) on its top, striking along +x at `contact`; the grasp region is the
    handle's lower three quarters."""
    g = handle_radius + 0.006
    return assemble_tool(
        name=name, category="hammer",
        parts=[("handle", handle_material, cylinder_part(handle_radius, (0, 0, 0), (0, 0, handle_length))), *head],
        contact_points=[contact],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, 0.75 * handle_length)),
    )


def offset_pusher(*, half_width: float = 0.110, offset: float = 0.060, head_height: float = 0.035,
                  head_depth: float = 0.025, handle_radius: float = 0.011, handle_length: float = 0.350,
                  grasp_fraction: float = 0.5, head_material: str = "beech", handle_material: str = "hickory",
                  name: str = "offset_pusher") -> Tool:
    """A pusher whose handle meets its head off-centre: a solid head (2 half_width wide along x, centred
    at x = offset, head_depth along y, head_height tall) whose bottom is at z = 0, and a handle along +z
    from its top at x = 0, so the drag on the head twists the handle. It pushes along +y with the head's
    leading face 5 mm above its bottom edge, at the head's centre and +-0.75 half_width from it (broom's
    category: sweep). The grasp region is the handle's top grasp_fraction. Default: 0.39 m tall, 0.22 m
    wide, ~0.4 kg."""
    return head_on_handle(
        name=name, half_width=half_width, y0=-head_depth / 2, y1=head_depth / 2, head_height=head_height,
        contact_z=0.005, handle_radius=handle_radius, handle_length=handle_length,
        grasp_fraction=grasp_fraction, head_material=head_material, handle_material=handle_material,
        head_name="head", x_centre=offset)


def club(*, length: float = 0.450, radius: float = 0.008, head_front: float = 0.070, head_back: float = 0.015,
         head_half_width: float = 0.020, head_thickness: float = 0.030, grasp_fraction: float = 0.5,
         bar_material: str = "aluminium", head_material: str = "steel", name: str = "club") -> Tool:
    """A club: a round bar along +z and a thick block head across its end (from x = -head_back to
    +head_front, 2 head_half_width wide along y, head_thickness tall along z), heavy where a hoe's blade
    is thin. It pulls with the head's underside (-z) 15 mm short of its front face (halfway along a
    shorter head) (L-stick's category: reach). The grasp region runs from the butt over grasp_fraction of
    the length. Default: 0.45 m, ~0.8 kg."""
    return bar_and_end_plate(
        name=name, length=length, radius=radius, x0=-head_back, x1=head_front, half_y=head_half_width,
        thickness=head_thickness, contact_x=short_of_end(radius, head_front, 0.015),
        grasp_fraction=grasp_fraction, bar_material=bar_material, plate_material=head_material,
        plate_name="head")


# ---------------------------------------------------------------------------------------------------
# Sealed-test families of sealed evaluation round 3: never rolled out before it
# ---------------------------------------------------------------------------------------------------
def offset_hammer(*, handle_length: float = 0.300, handle_radius: float = 0.014, offset: float = 0.040,
                  head_radius: float = 0.015, head_front: float = 0.050, head_back: float = 0.040,
                  handle_material: str = "hickory", head_material: str = "steel", name: str = "offset_hammer") -> Tool:
    """A hammer whose head sits beside the handle's line: a handle along +z, a neck block from its top
    out along +y, and a round head along x (head_radius) whose axis lies `offset` from the handle's axis
    along y, so the blow on its face twists the handle about its own axis. It strikes with the head's +x
    end face (hammer's category: hammer, knock). The grasp region is the handle's lower three quarters.
    Default: 0.33 m, ~0.9 kg."""
    z0, zc = handle_length, handle_length + head_radius
    w = 0.7 * head_radius
    return striking_head_on_handle(
        name=name, handle_length=z0, handle_radius=handle_radius, handle_material=handle_material,
        head=[("neck", head_material, box_part((-w, -handle_radius, z0), (w, offset, z0 + 2 * head_radius))),
              ("head", head_material, cylinder_part(head_radius, (-head_back, offset, zc), (head_front, offset, zc)))],
        contact=(head_front, offset, zc))


def leaning_broom(*, half_width: float = 0.120, head_height: float = 0.040, head_depth: float = 0.035,
                  handle_radius: float = 0.011, handle_length: float = 0.400, lean: float = 0.30,
                  grasp_fraction: float = 0.5, head_material: str = "beech", handle_material: str = "hickory",
                  name: str = "leaning_broom") -> Tool:
    """A broom whose handle leans back: a box head (2 half_width wide along x, head_depth along y,
    head_height tall, its bottom at z = 0) and a handle from the top of its centre tilted by `lean` (rad)
    from +z towards -y, away from the push, as a floor broom's handle is, so the handle's top and the
    grasp lie behind the head. It pushes along +y with the head's leading face 5 mm above its bottom edge,
    at the head's centre and +-0.75 half_width from it (broom's category: sweep). The grasp region is the
    handle's top grasp_fraction (a box about that part of the leaning handle). Default: 0.42 m tall,
    0.24 m wide, ~0.4 kg."""
    u = np.array([0.0, -math.sin(lean), math.cos(lean)])
    base = np.array([0.0, 0.0, head_height])
    top = base + handle_length * u
    start = base + (1.0 - grasp_fraction) * handle_length * u
    g = handle_radius + 0.009
    cx = 0.75 * half_width
    y1 = head_depth / 2
    return assemble_tool(
        name=name, category="broom",
        parts=[
            ("head", head_material, box_part((-half_width, -y1, 0.0), (half_width, y1, head_height))),
            ("handle", handle_material, cylinder_part(handle_radius, base, top)),
        ],
        contact_points=[(0.0, y1, 0.005), (-cx, y1, 0.005), (cx, y1, 0.005)],
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-g, top[1] - g, start[2] - g), (g, start[1] + g, top[2] + g)),
    )


def fork_hook(*, length: float = 0.450, radius: float = 0.006, spread: float = 0.030, hook_end: float = 0.080,
              grasp_fraction: float = 0.5, material: str = "aluminium", name: str = "fork_hook") -> Tool:
    """A hook with two prongs: a round bar along +z, a crossbar across its far end along y (2 spread
    long) and two prongs from the crossbar's ends along +x, parallel, `spread` either side of the bar's
    plane, of one material. It pulls with both prongs' inner faces (-z), 30 mm from their tips (halfway
    along shorter prongs) (L-stick's category: reach). The grasp region runs from the butt over
    grasp_fraction of the length. Default: 0.45 m, ~0.2 kg."""
    r = radius
    z1 = length - r
    g = r + 0.006
    xc = short_of_end(r, hook_end, 0.030)
    return assemble_tool(
        name=name, category="l_stick",
        parts=[
            ("bar", material, cylinder_part(r, (0, 0, 0), (0, 0, z1))),
            ("crossbar", material, cylinder_part(r, (0, -spread, z1), (0, spread, z1))),
            ("prong_a", material, cylinder_part(r, (0, -spread, z1), (hook_end, -spread, z1))),
            ("prong_b", material, cylinder_part(r, (0, spread, z1), (hook_end, spread, z1))),
        ],
        contact_points=[(xc, -spread, z1 - r), (xc, spread, z1 - r)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, min(grasp_fraction * length, z1 - 2 * r))),
    )
