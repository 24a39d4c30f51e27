"""The builders of the sealed-test families of the sealed evaluation's rounds 4 to 6 (`tools.families` registers
them; validation families since the rounds have run). Each is a shape of a built-in category that no
earlier family has, built from primitive parts as `tools.family_shapes` builds the others, whose shared
part builders they use. Lengths in metres; every builder's defaults are its family's default tool.

    from itup_jax.tools import sealed_shapes
    tool = sealed_shapes.skillet(pan_radius=0.08, name="my_skillet")
"""

from __future__ import annotations

import math

import trimesh

from itup_jax.tools.builtin import assemble_tool, box_part, cylinder_part
from itup_jax.tools.family_shapes import bar_and_end_plate, head_on_handle, short_of_end, striking_head_on_handle
from itup_jax.tools.tool import Tool


def hull_part(mesh: trimesh.Trimesh) -> tuple[trimesh.Trimesh, tuple]:
    """A convex solid part and its collision primitive, its own convex hull (for shapes that neither the
    simulator's capsules nor its tool-frame-aligned boxes fit)."""
    return mesh, ("hull", mesh.vertices.copy(), mesh.faces.copy())


def disc_part(radius: float, centre, axis: int, thickness: float) -> tuple[trimesh.Trimesh, tuple]:
    """A solid disc part (a cylinder `thickness` long along tool axis `axis`, 0/1/2 for x/y/z) and its
    collision primitive, its own convex hull: a capsule as long as a disc is thin would be a ball."""
    lo, hi = list(centre), list(centre)
    lo[axis] -= thickness / 2
    hi[axis] += thickness / 2
    mesh, _ = cylinder_part(radius, lo, hi)
    return hull_part(mesh)


def skillet(*, handle_length: float = 0.200, handle_radius: float = 0.013, pan_radius: float = 0.070,
            pan_thickness: float = 0.005, handle_material: str = "hickory", pan_material: str = "steel",
            name: str = "skillet") -> Tool:
    """A skillet: a handle along +z and a flat round pan on its top, thin along x (pan_thickness), its
    centre pan_radius above the handle's end, so most of the mass lies in a wide disc across the
    strike. It strikes with the pan's underside (+x face) at its centre (hammer's category: hammer,
    knock). The grasp region is the handle's lower three quarters. Default: 0.34 m, ~0.7 kg."""
    zc = handle_length + pan_radius
    return striking_head_on_handle(
        name=name, handle_length=handle_length, handle_radius=handle_radius, handle_material=handle_material,
        head=[("pan", pan_material, disc_part(pan_radius, (0.0, 0.0, zc), 0, pan_thickness))],
        contact=(pan_thickness / 2, 0.0, zc))


def deck_brush(*, half_width: float = 0.100, front: float = 0.070, back: float = 0.015, head_height: float = 0.075,
               handle_radius: float = 0.011, handle_length: float = 0.400, grasp_fraction: float = 0.5,
               head_material: str = "bristle_pack", handle_material: str = "hickory", name: str = "deck_brush") -> Tool:
    """A deck brush: a deep, tall bristle head (2 half_width wide along x, from `back` behind the handle's
    axis to `front` ahead of it along y, head_height tall, its bottom at z = 0) and a handle along +z from
    its top near the rear edge, so the drag on the leading face acts well ahead of the handle's line and
    pitches the grasp. The head is tall enough that the handle's foot clears the table when the sweep
    tilts the tool back (front <= 1.8 (head_height - 5 mm) at the sweep's 0.5 rad). It pushes along +y
    with the head's leading face 5 mm above its bottom edge, at its centre and +-0.75 half_width (broom's
    category: sweep). The grasp region is the handle's top grasp_fraction. Default: 0.48 m tall, 0.20 m
    wide, ~0.6 kg."""
    return head_on_handle(
        name=name, half_width=half_width, y0=-back, y1=front, head_height=head_height, contact_z=0.005,
        handle_radius=handle_radius, handle_length=handle_length, grasp_fraction=grasp_fraction,
        head_material=head_material, handle_material=handle_material, head_name="head")


def ladle(*, length: float = 0.450, radius: float = 0.007, bowl_radius: float = 0.035, bowl_thickness: float = 0.012,
          grasp_fraction: float = 0.5, bar_material: str = "aluminium", bowl_material: str = "steel",
          name: str = "ladle") -> Tool:
    """A ladle: a round bar along +z and a round bowl on its end (a disc bowl_thickness thick along z, its
    top at z = length), reaching from the bar's back (x = -radius) forward along +x. It pulls with the
    bowl's underside (-z) 15 mm short of its front edge (halfway for a small bowl) (L-stick's category:
    reach). The grasp region runs from the butt over grasp_fraction of the length. Default: 0.45 m,
    ~0.5 kg."""
    front = 2.0 * bowl_radius - radius
    bowl = disc_part(bowl_radius, (bowl_radius - radius, 0.0, length - bowl_thickness / 2), 2, bowl_thickness)
    return bar_and_end_plate(
        name=name, length=length, radius=radius, x0=-radius, x1=front, half_y=bowl_radius, thickness=bowl_thickness,
        contact_x=short_of_end(radius, front, 0.015), grasp_fraction=grasp_fraction,
        bar_material=bar_material, plate_material=bowl_material, plate_name="bowl", plate=bowl)


def yawed_box_part(half_width: float, half_depth: float, height: float, yaw: float) -> tuple[trimesh.Trimesh, tuple]:
    """A solid box part (2 half_width along x, 2 half_depth along y, `height` along z from z = 0), turned by
    `yaw` rad about +z through its centre, and its collision primitive, its own convex hull (the
    simulator's boxes are the tool frame's axis-aligned ones)."""
    turn = trimesh.transformations.rotation_matrix(yaw, (0.0, 0.0, 1.0))
    turn[2, 3] = height / 2
    return hull_part(trimesh.creation.box(extents=(2 * half_width, 2 * half_depth, height), transform=turn))


def pommel_hammer(*, handle_length: float = 0.260, handle_radius: float = 0.013, head_radius: float = 0.014,
                  head_front: float = 0.045, head_back: float = 0.040, pommel_radius: float = 0.020,
                  pommel_length: float = 0.030, handle_material: str = "hickory", pommel_material: str = "steel",
                  name: str = "pommel_hammer") -> Tool:
    """A hammer with a heavy pommel: a round steel pommel (pommel_length along +z from the origin), the
    handle on it, and a round steel head across the handle's top along x, from -head_back to head_front,
    so mass sits at both ends and the centre of mass lies near the handle's middle, not by the head. It
    strikes with the head's +x end face at its centre (hammer's category: hammer, knock). The grasp region
    is the handle's lower three quarters, clear of the pommel. Default: 0.32 m, ~0.8 kg."""
    top = pommel_length + handle_length
    zc = top + head_radius
    g = handle_radius + 0.006
    return assemble_tool(
        name=name, category="hammer",
        parts=[("pommel", pommel_material, cylinder_part(pommel_radius, (0, 0, 0), (0, 0, pommel_length))),
               ("handle", handle_material, cylinder_part(handle_radius, (0, 0, pommel_length), (0, 0, top))),
               ("head", "steel", cylinder_part(head_radius, (-head_back, 0, zc), (head_front, 0, zc)))],
        contact_points=[(head_front, 0.0, zc)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, pommel_length + 0.025), (g, g, pommel_length + 0.75 * handle_length)),
    )


def angle_broom(*, half_width: float = 0.110, head_depth: float = 0.035, head_height: float = 0.045,
                yaw: float = 0.10, handle_radius: float = 0.011, handle_length: float = 0.400,
                grasp_fraction: float = 0.5, head_material: str = "beech", handle_material: str = "hickory",
                name: str = "angle_broom") -> Tool:
    """An angle broom: a box head (2 half_width wide, head_depth deep, head_height tall, its bottom at
    z = 0) turned by `yaw` rad about the handle's axis, so one end of its leading face runs ahead of the
    other, and a handle along +z from the head's top centre. It pushes along +y with the leading face 5 mm
    above its bottom edge, at the face's centre and +-0.75 half_width along it (broom's category: sweep):
    the three debris cubes are met at different points of the stroke and the drag twists the handle.
    The family keeps yaw <= 0.14 rad: the sweep's square cubes meet the turned face along their own
    face, so one corner of each starts 20 mm tan(yaw) - 1 mm inside it, within the placement's 2 mm. The
    grasp region is the handle's top grasp_fraction. Default: 0.45 m tall, 0.22 m wide, ~0.36 kg."""
    c, s = math.cos(yaw), math.sin(yaw)
    top = head_height + handle_length
    g = handle_radius + 0.009
    face = [(u * c - head_depth / 2 * s, u * s + head_depth / 2 * c, 0.005)
            for u in (0.0, -0.75 * half_width, 0.75 * half_width)]
    return assemble_tool(
        name=name, category="broom",
        parts=[("head", head_material, yawed_box_part(half_width, head_depth / 2, head_height, yaw)),
               ("handle", handle_material, cylinder_part(handle_radius, (0, 0, head_height), (0, 0, top)))],
        contact_points=face,
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-g, -g, top - grasp_fraction * handle_length), (g, g, top)),
    )


def cranked_hook(*, length: float = 0.450, half: float = 0.007, jog: float = 0.045, jog_at: float = 0.6,
                 hook_end: float = 0.080, grasp_fraction: float = 0.7, material: str = "aluminium",
                 name: str = "cranked_hook") -> Tool:
    """A cranked hook: a square bar (2 half thick) along +z, jogged sideways by `jog` along +y at
    jog_at of its length, so its upper part and the hook run beside the lower part's line, and bent at a
    right angle along +x at its far end up to hook_end. It pulls with the hook's underside (-z) 30 mm from
    its tip (halfway along a shorter hook), as the L-stick's category (reach): the pull acts `jog` beside
    the grasped part's axis. The grasp region runs from the butt over grasp_fraction of the lower part.
    Default: 0.45 m, ~0.3 kg."""
    zj = jog_at * length
    r = half
    g = r * math.sqrt(2.0) + 0.006
    parts = [("lower", material, box_part((-r, -r, 0.0), (r, r, zj))),
             ("crank", material, box_part((-r, -r, zj), (r, jog + r, zj + 2 * r))),
             ("upper", material, box_part((-r, jog - r, zj + 2 * r), (r, jog + r, length))),
             ("hook", material, box_part((r, jog - r, length - 2 * r), (hook_end, jog + r, length)))]
    return assemble_tool(
        name=name, category="l_stick", parts=parts,
        contact_points=[(short_of_end(r, hook_end, 0.030), jog, length - 2 * r)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, grasp_fraction * zj)),
    )


# ---------------------------------------------------------------------------------------------------
# Sealed-test families of sealed evaluation round 6
# ---------------------------------------------------------------------------------------------------
def cranked_hammer(*, length: float = 0.280, radius: float = 0.009, crank_at: float = 0.55, jog: float = 0.040,
                   head_radius: float = 0.014, head_front: float = 0.045, head_back: float = 0.035,
                   shaft_material: str = "aluminium", name: str = "cranked_hammer") -> Tool:
    """A hammer on a cranked metal shaft: a round shaft along +z from the origin to crank_at of `length`,
    a crank block from there along x by `jog` (forward, +x, or back, -x), the shaft on up from there to
    `length`, and a round steel head across its top along x (from -head_back to head_front about the upper
    shaft's line), so the head and the blow's line lie `jog` ahead of or behind the grasped part's axis in
    the plane of the swing. It strikes with the head's +x end face (hammer's category: hammer, knock). The
    grasp region is the lower shaft, clear of the crank. Default: 0.31 m, ~0.6 kg."""
    r = radius
    z1 = crank_at * length
    zc = length + head_radius
    g = r + 0.006
    lo, hi = min(0.0, jog) - r, max(0.0, jog) + r
    return assemble_tool(
        name=name, category="hammer",
        parts=[("lower", shaft_material, cylinder_part(r, (0, 0, 0), (0, 0, z1))),
               ("crank", shaft_material, box_part((lo, -r, z1), (hi, r, z1 + 2 * r))),
               ("upper", shaft_material, cylinder_part(r, (jog, 0, z1 + 2 * r), (jog, 0, length))),
               ("head", "steel", cylinder_part(head_radius, (jog - head_back, 0, zc), (jog + head_front, 0, zc)))],
        contact_points=[(jog + head_front, 0.0, zc)],
        contact_normal=(1.0, 0.0, 0.0),
        grasp_region=((-g, -g, 0.0), (g, g, z1 - 0.010)),
    )


def ballast_broom(*, half_width: float = 0.110, head_depth: float = 0.040, head_height: float = 0.040,
                  ballast_from: float = 0.030, ballast_length: float = 0.060, ballast_height: float = 0.015,
                  handle_radius: float = 0.011, handle_length: float = 0.400, grasp_fraction: float = 0.5,
                  head_material: str = "beech", handle_material: str = "hickory", name: str = "ballast_broom") -> Tool:
    """A broom with a steel ballast on one side of its head: a box head (2 half_width wide along x,
    head_depth deep along y about the handle's axis, head_height tall, its bottom at z = 0), a handle
    along +z from its top centre, and a steel block on the head's top from x = ballast_from to
    ballast_from + ballast_length (+x side only, the head's full depth, ballast_height tall), so the head's
    mass sits off the handle's line across the push. It pushes along +y with the leading face 5 mm above
    its bottom edge, at its centre and +-0.75 half_width along it (broom's category: sweep). The grasp
    region is the handle's top grasp_fraction. Default: 0.44 m tall, 0.22 m wide, ~0.6 kg."""
    top = head_height + handle_length
    g = handle_radius + 0.009
    d = head_depth / 2
    x1 = min(ballast_from + ballast_length, half_width)
    return assemble_tool(
        name=name, category="broom",
        parts=[("head", head_material, box_part((-half_width, -d, 0.0), (half_width, d, head_height))),
               ("ballast", "steel", box_part((ballast_from, -d, head_height), (x1, d, head_height + ballast_height))),
               ("handle", handle_material, cylinder_part(handle_radius, (0, 0, head_height), (0, 0, top)))],
        contact_points=[(u, d, 0.005) for u in (0.0, -0.75 * half_width, 0.75 * half_width)],
        contact_normal=(0.0, 1.0, 0.0),
        grasp_region=((-g, -g, top - grasp_fraction * handle_length), (g, g, top)),
    )


def tapered_hook(*, length: float = 0.450, butt_radius: float = 0.012, tip_radius: float = 0.006,
                 butt_fraction: float = 0.4, hook_end: float = 0.080, grasp_fraction: float = 0.8,
                 material: str = "aluminium", hook_material: str = "aluminium", name: str = "tapered_hook") -> Tool:
    """A tapered pole with a hook: a round pole along +z in three coaxial sections, a thick butt
    (butt_radius) over butt_fraction of the length, a middle section halfway between the two radii, and a
    thin tip section (tip_radius) up to the hook, a square bar bent at a right angle along +x at the far
    end (tip_radius to its flats) up to hook_end, so most of the pole's own mass lies in the butt and the
    hook's material (a steel hook on a light pole) sets how much lies at the far end. It pulls with the
    hook's underside (-z) 30 mm from its tip (halfway along a shorter hook), as the L-stick's category
    (reach). The grasp region is the butt's lower grasp_fraction. Default: 0.45 m, ~0.4 kg."""
    r0, r2 = butt_radius, tip_radius
    r1 = 0.5 * (r0 + r2)
    z0 = butt_fraction * length
    z1 = z0 + 0.5 * (length - 2 * r2 - z0)
    z2 = length - 2 * r2
    g = r0 + 0.006
    return assemble_tool(
        name=name, category="l_stick",
        parts=[("butt", material, cylinder_part(r0, (0, 0, 0), (0, 0, z0))),
               ("middle", material, cylinder_part(r1, (0, 0, z0), (0, 0, z1))),
               ("tip", material, cylinder_part(r2, (0, 0, z1), (0, 0, z2))),
               ("hook", hook_material, box_part((-r2, -r2, z2), (hook_end, r2, length)))],
        contact_points=[(short_of_end(r2, hook_end, 0.030), 0.0, z2)],
        contact_normal=(0.0, 0.0, -1.0),
        grasp_region=((-g, -g, 0.0), (g, g, grasp_fraction * z0)),
    )
