"""The builders of the sealed-test families of the sealed evaluation's round 4 (`tools.families`
registers them; validation families since the round has run). Each is a shape of a built-in category that no
earlier family has, built from primitive parts as `tools.family_shapes` builds the others, whose shared
part builders they use. Lengths in metres; every builder's defaults are its family's default tool.

    from itup_jax.tools import sealed_shapes
    tool = sealed_shapes.skillet(pan_radius=0.08, name="my_skillet")
"""

from __future__ import annotations

import trimesh

from itup_jax.tools.builtin import cylinder_part
from itup_jax.tools.family_shapes import bar_and_end_plate, head_on_handle, striking_head_on_handle
from itup_jax.tools.tool import Tool


def disc_part(radius: float, centre, axis: int, thickness: float) -> tuple[trimesh.Trimesh, tuple]:
    """A solid disc part (a cylinder `thickness` long along tool axis `axis`, 0/1/2 for x/y/z) and its
    collision primitive, its own convex hull: a capsule as long as a disc is thin would be a ball."""
    lo, hi = list(centre), list(centre)
    lo[axis] -= thickness / 2
    hi[axis] += thickness / 2
    mesh, _ = cylinder_part(radius, lo, hi)
    return mesh, ("hull", mesh.vertices.copy(), mesh.faces.copy())


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
        contact_x=max(front - 0.015, 0.5 * (radius + front)), grasp_fraction=grasp_fraction,
        bar_material=bar_material, plate_material=bowl_material, plate_name="bowl", plate=bowl)
