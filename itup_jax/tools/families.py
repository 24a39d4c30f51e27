"""Procedural tool families: parametric builders, their size ranges, and the tasks each can do.

    from itup_jax.tools import families
    families.names()                         # ('hammer', 'broom', ..., 'squeegee', 'baton', ..., 'pusher')
    families.held_out()                      # the five no training set holds
    families.training()                      # the four the shipped network trains on beside the built-ins
    families.calibration()                   # the four the guard is calibrated on
    families.sealed()                        # the three added for the shipped checkpoint's sealed evaluation
    families.get("screwdriver").tasks        # ('knock',)
    tool = families.draw("spanner", seed=3)  # a random spanner within the family's ranges
    tool = itup.load_tool("spanner@3")       # the same tool by name (the CLI's --tool spanner@3)
    tool = itup.load_tool("spanner")         # the family's default dimensions

Twenty families. The first four are the built-in tools' (`builtin.claw_hammer`, `hand_broom`,
`mallet`, `l_stick`), drawn part-wise by `variants.part_variant`. The next five are held out of every
training set (`held_out()`: the evaluations' families the network never saw), each assembled from
primitive parts with their own materials (`builtin.assemble_tool`: mass properties from the parts'
meshes and densities, a watertight union for sampling, capsules and boxes for the simulator):

  screwdriver  a cellulose-acetate handle and a thin steel shaft; taps with the side of the shaft's tip
               (knock).
  spanner      a flat steel bar with a square head; strikes with the head's side (hammer, knock).
  pry_bar      a heavy steel bar, hexagonal or round, with its end bent at a right angle; hooks and
               pulls with the bend's inner face (reach).
  hatchet      a hickory handle and an asymmetric steel head: a thin blade on one side, a square poll
               on the other; strikes with the poll (hammer, knock).
  squeegee     a T-headed long tool: a neoprene blade in a polypropylene holder on a hollow aluminium
               handle; pushes with the blade (sweep).

The next four are training families (`training()`): wide spans of a built-in category's shape and mass
distribution, each part's material drawn too, made for the network's training data and never used to
evaluate it:

  baton        a headless stick in two coaxial segments (handle and tip, each its radius and material):
               uniform, thin-tipped, heavy- or light-tipped; strikes with the tip's side (mallet's
               category; hammer, knock).
  headed_stick a handle and a box head, light to heavy, centred or lopsided; strikes with the head's face
               (hammer's category; hammer, knock).
  hook         a bar bent at the end, round or square, grasp region up to the bend; pulls with the
               bend (L-stick's category; reach).
  pusher       a T-head, short or wide, on a short or long handle; pushes with the head (broom's
               category; sweep).

The last four are calibration families (`calibration()`): other shapes of the built-in categories, in
no training set, drawn only to calibrate the out-of-distribution guard, so that the five held-out
families stay the set the guard and the network are judged on:

  paddle       a handle and a flat blade, thin along the strike (wood, plastic or aluminium); strikes
               with the blade's face (mallet's category; hammer, knock).
  mace         a handle and a tall box head on its axis, light to heavy; strikes with the head's side
               (hammer's category; hammer, knock).
  scraper      a thin steel or aluminium plate on a short or long handle; pushes with the plate's face
               (broom's category; sweep).
  t_hook       a round bar with a square crossbar across its end, long or short on either side; pulls
               with the crossbar's underside (L-stick's category; reach).

The last three are sealed-test families (`sealed()`): shapes of the built-in categories added for the
sealed evaluation of the checkpoint shipped with 0.25.0 (`experiments/sealed_eval.py`) and never rolled
out before it; that evaluation has run, so they are validation families now, like the held-out ones:

  rolling_pin  a handle, a thick barrel and a thin knob past it, of one material; strikes with the
               barrel's side, with mass beyond the contact (mallet's category; hammer, knock).
  rake         a crossbar on three flat tines on a handle; pushes with the tines (broom's category;
               sweep).
  hoe          a round bar with a thin flat blade across its end; pulls with the blade's underside
               (L-stick's category; reach).

Every family keeps its category's tool frame (`priors.CATEGORY_CONTACT_NORMAL`): the handle along +z
from its butt at the origin, the contact normal along the category's direction. The ranges are typical
hand-tool dimensions (assumed); every draw inside them builds a closed mesh with positive inertia, and
its contact lands on the task's target (tests/test_families.py).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable, Mapping
from types import MappingProxyType

import numpy as np
import trimesh

from itup_jax.errors import InputError
from itup_jax.tools.builtin import assemble_tool, box_part, claw_hammer, cylinder_part, hand_broom, l_stick, mallet
from itup_jax.tools.tool import Tool
from itup_jax.tools.variants import part_variant


def _prism(radius: float, p0, p1, sections: int) -> tuple[trimesh.Trimesh, tuple]:
    """A solid prism of `sections` sides (6: a hexagonal bar; many: a round one) whose flats lie `radius`
    from its axis, and its collision capsule (radius: the mean of the flats' and the corners' distances)."""
    circum = radius / math.cos(math.pi / sections)
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    u = (p1 - p0) / np.linalg.norm(p1 - p0)
    mesh = trimesh.creation.cylinder(radius=circum, segment=np.array([p0, p1]), sections=sections)
    r = 0.5 * (radius + circum)
    return mesh, ("capsule", p0 + r * u, p1 - r * u, r)


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


def pry_bar(*, length: float = 0.450, radius: float = 0.0095, hook_end: float = 0.080, sections: int = 6,
            name: str = "pry_bar") -> Tool:
    """A pry bar: a steel bar (hexagonal for sections = 6, `radius` to its flats) along +z and its end
    bent at a right angle along +x up to hook_end. The contact is the bend's inner face (facing -z, back
    along the bar), like the L-stick's hook. Default: 0.45 m long, ~1.3 kg."""
    r = radius
    circum = radius / math.cos(math.pi / sections)
    g = circum + 0.006
    hook = _prism(r, (circum, 0, length - r), (hook_end, 0, length - r), sections)
    return assemble_tool(
        name=name, category="pry_bar",
        parts=[
            ("bar", "steel", _prism(r, (0, 0, 0), (0, 0, length), sections)),
            ("hook", "steel", hook),
        ],
        # the hook's underside: a flat or, for a hexagon turned corner-down, its lowest edge
        contact_points=[(0.5 * (circum + hook_end), 0.0, float(hook[0].bounds[0][2]))],
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
        contact_points=[(max(hook_end - 0.030, 0.5 * (r + hook_end)), 0.0, z1 - r)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, min(grasp_fraction * length, z1 - 2 * r))),
    )


def _head_on_handle(*, name: str, half_width: float, y0: float, y1: float, head_height: float,
                    contact_z: float, handle_radius: float, handle_length: float, grasp_fraction: float,
                    head_material: str, handle_material: str, head_name: str) -> Tool:
    """A box head (2 half_width wide along x, y0..y1 along y, head_height tall) whose bottom is at z = 0 and
    a handle along +z from its top, pushing along +y with the head's +y face at height contact_z, at x = 0
    and +-0.75 half_width (broom's category: sweep); the grasp region is the handle's top grasp_fraction."""
    g = handle_radius + 0.009
    top = head_height + handle_length
    cx = 0.75 * half_width
    return assemble_tool(
        name=name, category="broom",
        parts=[
            (head_name, head_material, box_part((-half_width, y0, 0.0), (half_width, y1, head_height))),
            ("handle", handle_material, cylinder_part(handle_radius, (0, 0, head_height), (0, 0, top))),
        ],
        contact_points=[(0.0, y1, contact_z), (-cx, y1, contact_z), (cx, y1, contact_z)],
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
    return _head_on_handle(
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
    return _head_on_handle(
        name=name, half_width=half_width, y0=-t, y1=t, head_height=blade_height, contact_z=0.0,
        handle_radius=handle_radius, handle_length=handle_length, grasp_fraction=0.5,
        head_material=blade_material, handle_material=handle_material, head_name="blade")


def _bar_and_end_plate(*, name: str, length: float, radius: float, x0: float, x1: float, half_y: float,
                       thickness: float, contact_x: float, grasp_fraction: float, bar_material: str,
                       plate_material: str, plate_name: str) -> Tool:
    """A round bar along +z and a box plate across its end (x0..x1 along x, 2 half_y along y, `thickness`
    along z, its top at z = length), pulling with the plate's underside (-z) at x = contact_x, as the
    L-stick's category (reach); the grasp region runs from the butt over grasp_fraction of the length."""
    z1 = length - thickness
    g = radius + 0.006
    return assemble_tool(
        name=name, category="l_stick",
        parts=[
            ("bar", bar_material, cylinder_part(radius, (0, 0, 0), (0, 0, z1))),
            (plate_name, plate_material, box_part((x0, -half_y, z1), (x1, half_y, length))),
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
    return _bar_and_end_plate(
        name=name, length=length, radius=radius, x0=-back, x1=front, half_y=bar_half, thickness=2 * bar_half,
        contact_x=max(front - 0.030, 0.5 * (radius + front)), grasp_fraction=grasp_fraction,
        bar_material=material, plate_material=material, plate_name="crossbar")


# ---------------------------------------------------------------------------------------------------
# Sealed-test families: added for the shipped checkpoint's sealed evaluation, never rolled out before it
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
    return _bar_and_end_plate(
        name=name, length=length, radius=radius, x0=-radius, x1=blade_end, half_y=blade_half_width,
        thickness=blade_thickness, contact_x=max(blade_end - 0.020, 0.5 * (radius + blade_end)),
        grasp_fraction=grasp_fraction, bar_material=bar_material, plate_material=blade_material,
        plate_name="blade")


# ---------------------------------------------------------------------------------------------------
# The registry
# ---------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Family:
    """One procedural tool family.

    Attributes:
      name: the family's name (`load_tool`'s name for the default; its tools' category unless `category`).
      build: keyword dimensions (metres) -> Tool; its defaults are the family's default tool.
      tasks: the task kinds the family's tools can do.
      ranges: {keyword: (low, high)} uniform ranges of a draw (metres, or a count for `sections`);
        empty for the four built-in families, which `variants.part_variant` draws.
      choices: {keyword: (value, ...)} discrete choices of a draw (uniform).
      summary: one line for the docs and `itup tools`.
      training: a training family: a wide span of a category's shapes and mass distributions, drawn for
        the network's training data (`itup generate --family`), never for its evaluation.
      sealed: a sealed-test family: added for a checkpoint's sealed evaluation
        (`experiments/sealed_eval.py`), never rolled out before it; a validation family like the
        held-out ones once that evaluation has run.
      calibration: a calibration family: a category's shape that no training set holds, drawn to
        calibrate the out-of-distribution guard (`experiments/ood_guard.py --calibrate-on calibration`),
        never to train or to judge the network.
      category: its tools' category (priors and tool frame), when not the family's name.
    """

    name: str
    build: Callable[..., Tool]
    tasks: tuple[str, ...]
    ranges: Mapping[str, tuple[float, float]] = dataclasses.field(default_factory=dict)
    choices: Mapping[str, tuple] = dataclasses.field(default_factory=dict)
    summary: str = ""
    training: bool = False
    calibration: bool = False
    sealed: bool = False
    category: str = ""

    @property
    def builtin(self) -> bool:
        """One of the four families of the built-in tools (drawn by `variants.part_variant`)."""
        return not self.ranges

    @property
    def held_out(self) -> bool:
        """One of the five families kept out of every training set: the evaluation's unseen families."""
        return not (self.builtin or self.training or self.calibration or self.sealed)

    @property
    def tool_category(self) -> str:
        """The category of the family's tools."""
        return self.category or self.name


def _ranges(**r: tuple[float, float]) -> Mapping[str, tuple[float, float]]:
    return MappingProxyType(r)


FAMILIES: Mapping[str, Family] = MappingProxyType({
    "hammer": Family("hammer", claw_hammer, ("hammer",), summary="claw hammer (built-in; part-wise variants)"),
    "broom": Family("broom", hand_broom, ("sweep",), summary="hand broom (built-in; part-wise variants)"),
    "mallet": Family("mallet", mallet, ("knock",), summary="wooden mallet (built-in; part-wise variants)"),
    "l_stick": Family("l_stick", l_stick, ("reach",), summary="L-shaped aluminium stick (built-in; part-wise variants)"),
    "screwdriver": Family(
        "screwdriver", screwdriver, ("knock",),
        _ranges(handle_radius=(0.011, 0.018), handle_length=(0.080, 0.130), shaft_radius=(0.0025, 0.004),
                shaft_length=(0.075, 0.200)),
        summary="handle and thin steel shaft; taps with the shaft's side"),
    "spanner": Family(
        "spanner", spanner, ("hammer", "knock"),
        _ranges(bar_length=(0.120, 0.240), bar_width=(0.014, 0.026), bar_thickness=(0.004, 0.007),
                head_half=(0.014, 0.026), head_thickness=(0.006, 0.012)),
        summary="flat steel bar and square head; strikes with the head's side"),
    "pry_bar": Family(
        "pry_bar", pry_bar, ("reach",),
        _ranges(length=(0.350, 0.600), radius=(0.007, 0.011), hook_end=(0.060, 0.110)),
        MappingProxyType({"sections": (6, 48)}),
        summary="heavy steel bar (hexagonal or round) bent at the end; hooks with the bend"),
    "hatchet": Family(
        "hatchet", hatchet, ("hammer", "knock"),
        _ranges(handle_length=(0.250, 0.380), handle_radius=(0.013, 0.018), blade_length=(0.070, 0.110),
                blade_height=(0.060, 0.100), blade_thickness=(0.006, 0.010), poll_length=(0.020, 0.040),
                poll_size=(0.022, 0.034)),
        summary="handle and asymmetric steel head (blade and poll); strikes with the poll"),
    "squeegee": Family(
        "squeegee", squeegee, ("sweep",),
        _ranges(half_width=(0.100, 0.200), blade_height=(0.020, 0.040), handle_radius=(0.009, 0.013),
                handle_length=(0.300, 0.500)),
        summary="T-headed long tool: blade on a long handle; pushes with the blade"),
    "baton": Family(
        "baton", baton, ("hammer", "knock"),
        _ranges(length=(0.180, 0.450), handle_fraction=(0.35, 0.75), handle_radius=(0.010, 0.018),
                tip_radius=(0.003, 0.020)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "tip_material": HEAD_MATERIALS}),
        summary="training: headless two-segment stick, thin or thick, light or heavy tip; strikes with the tip's side",
        training=True, category="mallet"),
    "headed_stick": Family(
        "headed_stick", headed_stick, ("hammer", "knock"),
        _ranges(handle_length=(0.180, 0.450), handle_radius=(0.010, 0.018), head_back=(0.010, 0.070),
                head_front=(0.015, 0.070), head_height=(0.018, 0.045), head_width=(0.012, 0.040)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "head_material": HEAD_MATERIALS}),
        summary="training: handle and box head, light to heavy, centred or lopsided; strikes with the head",
        training=True, category="hammer"),
    "hook": Family(
        "hook", hook, ("reach",),
        _ranges(length=(0.300, 0.600), radius=(0.005, 0.010), hook_end=(0.050, 0.140), grasp_fraction=(0.3, 0.95)),
        MappingProxyType({"material": ("aluminium", "steel", "hickory", "polypropylene"),
                          "section": ("round", "square")}),
        summary="training: bar bent at the end, grasp region up to the bend; hooks with the bend",
        training=True, category="l_stick"),
    "pusher": Family(
        "pusher", pusher, ("sweep",),
        _ranges(half_width=(0.040, 0.220), head_height=(0.020, 0.060), head_depth=(0.015, 0.050),
                handle_radius=(0.008, 0.014), handle_length=(0.120, 0.550), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"head_material": ("beech", "polypropylene", "neoprene"), "handle_material": HANDLE_MATERIALS}),
        summary="training: T-head short or wide on a short or long handle; pushes with the head",
        training=True, category="broom"),
    "paddle": Family(
        "paddle", paddle, ("hammer", "knock"),
        _ranges(handle_length=(0.120, 0.300), handle_radius=(0.010, 0.016), blade_thickness=(0.006, 0.020),
                blade_width=(0.040, 0.120), blade_height=(0.060, 0.200)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS,
                          "blade_material": ("beech", "hickory", "polypropylene", "aluminium")}),
        summary="calibration: handle and flat blade; strikes with the blade's face",
        calibration=True, category="mallet"),
    "mace": Family(
        "mace", mace, ("hammer", "knock"),
        _ranges(handle_length=(0.180, 0.400), handle_radius=(0.010, 0.017), head_half_x=(0.010, 0.025),
                head_half_y=(0.010, 0.025), head_height=(0.030, 0.080)),
        MappingProxyType({"handle_material": HANDLE_MATERIALS, "head_material": HEAD_MATERIALS}),
        summary="calibration: handle and tall box head on its axis; strikes with the head's side",
        calibration=True, category="hammer"),
    "scraper": Family(
        "scraper", scraper, ("sweep",),
        _ranges(half_width=(0.050, 0.180), blade_height=(0.030, 0.080), blade_thickness=(0.0015, 0.003),
                handle_radius=(0.008, 0.014), handle_length=(0.150, 0.500)),
        MappingProxyType({"blade_material": ("steel", "aluminium"), "handle_material": HANDLE_MATERIALS}),
        summary="calibration: thin metal plate on a handle; pushes with the plate's face",
        calibration=True, category="broom"),
    "t_hook": Family(
        "t_hook", t_hook, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.005, 0.010), bar_half=(0.005, 0.010), front=(0.050, 0.130),
                back=(0.020, 0.080), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"material": ("aluminium", "steel", "hickory", "polypropylene")}),
        summary="calibration: bar with a square crossbar on its end; pulls with the crossbar",
        calibration=True, category="l_stick"),
    "rolling_pin": Family(
        "rolling_pin", rolling_pin, ("hammer", "knock"),
        _ranges(handle_length=(0.080, 0.150), handle_radius=(0.010, 0.015), barrel_length=(0.120, 0.250),
                barrel_radius=(0.018, 0.032), knob_length=(0.030, 0.100)),
        MappingProxyType({"material": ("beech", "hickory", "polypropylene", "nylon")}),
        summary="sealed test: handle, thick barrel and knob; strikes with the barrel's side",
        sealed=True, category="mallet"),
    "rake": Family(
        "rake", rake, ("sweep",),
        _ranges(half_width=(0.080, 0.200), bar_depth=(0.010, 0.025), bar_height=(0.010, 0.025),
                tine_length=(0.030, 0.080), tine_width=(0.006, 0.012), tine_thickness=(0.002, 0.004),
                handle_radius=(0.008, 0.014), handle_length=(0.200, 0.500)),
        MappingProxyType({"head_material": ("aluminium", "polypropylene", "beech"), "handle_material": HANDLE_MATERIALS}),
        summary="sealed test: crossbar on three flat tines, on a handle; pushes with the tines",
        sealed=True, category="broom"),
    "hoe": Family(
        "hoe", hoe, ("reach",),
        _ranges(length=(0.300, 0.550), radius=(0.005, 0.010), blade_end=(0.050, 0.120),
                blade_half_width=(0.015, 0.050), blade_thickness=(0.002, 0.006), grasp_fraction=(0.3, 0.8)),
        MappingProxyType({"bar_material": ("aluminium", "hickory", "steel"), "blade_material": ("steel", "aluminium")}),
        summary="sealed test: bar with a flat blade across its end; pulls with the blade's underside",
        sealed=True, category="l_stick"),
})


def names() -> tuple[str, ...]:
    """The families: the four built-in ones, the five held-out ones, the training families, the
    calibration families, then the sealed-test families."""
    return tuple(FAMILIES)


def held_out() -> tuple[str, ...]:
    """The five families no training set holds (the evaluations' unseen families)."""
    return tuple(f.name for f in FAMILIES.values() if f.held_out)


def training() -> tuple[str, ...]:
    """The training families (`Family.training`)."""
    return tuple(f.name for f in FAMILIES.values() if f.training)


def calibration() -> tuple[str, ...]:
    """The calibration families (`Family.calibration`)."""
    return tuple(f.name for f in FAMILIES.values() if f.calibration)


def sealed() -> tuple[str, ...]:
    """The sealed-test families (`Family.sealed`)."""
    return tuple(f.name for f in FAMILIES.values() if f.sealed)


def get(name: str) -> Family:
    """The family `name`, or InputError naming the known ones."""
    try:
        return FAMILIES[name]
    except (KeyError, TypeError):
        raise InputError(f"tool family {name!r}: unknown; known: {', '.join(FAMILIES)}") from None


def for_task(kind: str) -> tuple[str, ...]:
    """The families whose tools can do task `kind`."""
    return tuple(f.name for f in FAMILIES.values() if kind in f.tasks)


def draw(name: str, seed: int) -> Tool:
    """A tool of family `name` drawn with `seed` (the same tool for the same seed), named '<name>@<seed>'.
    The nine families defined here (held-out and training) draw every dimension uniformly in its range
    (and each choice uniformly); the four built-in families draw their part-wise variants
    (`variants.part_variant`)."""
    fam = get(name)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"families.draw({name!r}): seed must be an integer >= 0, got {seed!r}")
    if fam.builtin:
        return dataclasses.replace(part_variant(name, int(seed)), name=f"{name}@{int(seed)}")
    rng = np.random.default_rng([int(seed), sum(map(ord, name))])
    kw = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in fam.ranges.items()}
    kw.update({k: v[int(rng.integers(len(v)))] for k, v in fam.choices.items()})
    return fam.build(name=f"{name}@{int(seed)}", **kw)


_DRAWN = re.compile(r"^([a-z_]+)@(\d+)$")


def parse_name(name: str) -> tuple[str, int | None] | None:
    """('<family>', seed) for '<family>@<seed>', ('<family>', None) for a family's name, None otherwise."""
    if name in FAMILIES:
        return name, None
    m = _DRAWN.match(name)
    if m and m.group(1) in FAMILIES:
        return m.group(1), int(m.group(2))
    return None
