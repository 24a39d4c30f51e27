"""Tools: mass properties against closed forms, built-in tools, user tools, bad input."""

import math

import numpy as np
import pytest
import trimesh

import itup_jax as itup
from itup_jax.tools import priors
from itup_jax.tools.tool import combine_mass_properties, mesh_mass_properties

# A 48-facet prism has 0.29 % less cross-section than its cylinder (n sin(2 pi / n) / (2 pi)); the
# second moments differ by ~0.6 %. Compare built-in (48-facet) parts to true cylinders at 1 %.
POLYGON_RTOL = 0.01
# Boxes are exact, but an STL file stores vertices in float32 (relative rounding ~6e-8 per coordinate;
# mass and inertia are cubic and quintic in them).
EXACT_RTOL = 1e-9
STL_RTOL = 1e-6


def _write_tool(tmp_path, mesh, spec_text, name="tool", ext="stl"):
    mesh_path = tmp_path / f"{name}.{ext}"
    mesh.export(mesh_path)
    spec_path = tmp_path / f"{name}.toml"
    spec_path.write_text(spec_text)
    return str(mesh_path), str(spec_path)


BOX_SPEC = """
name = "block"
category = "mallet"
contact_point = [0.015, 0.0, 0.14]
contact_normal = [1.0, 0.0, 0.0]
grasp_region = { min = [-0.02, -0.02, -0.15], max = [0.02, 0.02, 0.0] }
density = 700.0
"""


def test_box_tool_mass_and_inertia_equal_closed_form(tmp_path):
    a, b, c = 0.03, 0.02, 0.30
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((a, b, c)), BOX_SPEC)
    tool = itup.load_tool(mesh_path, spec=spec_path)
    m = 700.0 * a * b * c
    I = m / 12 * np.diag([b**2 + c**2, a**2 + c**2, a**2 + b**2])
    np.testing.assert_allclose(float(tool.params.mass), m, rtol=STL_RTOL)
    np.testing.assert_allclose(np.asarray(tool.params.com), 0.0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(tool.params.inertia), I, rtol=STL_RTOL, atol=1e-15)


def test_mass_override_scales_inertia(tmp_path):
    a, b, c = 0.03, 0.02, 0.30
    spec = BOX_SPEC.replace("density = 700.0", "mass = 0.5")
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((a, b, c)), spec)
    tool = itup.load_tool(mesh_path, spec=spec_path)
    np.testing.assert_allclose(np.asarray(tool.params.inertia)[2, 2], 0.5 / 12 * (a**2 + b**2), rtol=STL_RTOL)


def _cylinder_inertia(m, r, length):
    """Solid cylinder along z about its centre: (I_xx = I_yy, I_zz)."""
    return m * (3 * r**2 + length**2) / 12, m * r**2 / 2


def test_hammer_mass_properties_equal_closed_form_of_its_parts(tools):
    """Handle (hickory cylinder along z) + head (steel cylinder along x), parallel-axis by hand."""
    tool = tools["hammer"]
    rho_h, rho_s = priors.MATERIAL_DENSITY["hickory"], priors.MATERIAL_DENSITY["steel"]
    r_h, L_h = 0.0145, 0.290 - 0.011
    r_s, L_s, z_s, x_s = 0.011, 0.110, 0.290, 0.005
    m_h, m_s = rho_h * math.pi * r_h**2 * L_h, rho_s * math.pi * r_s**2 * L_s
    com = (m_h * np.array([0, 0, L_h / 2]) + m_s * np.array([x_s, 0, z_s])) / (m_h + m_s)
    it_h, ia_h = _cylinder_inertia(m_h, r_h, L_h)
    it_s, ia_s = _cylinder_inertia(m_s, r_s, L_s)
    I = np.diag([it_h, it_h, ia_h]) + np.diag([ia_s, it_s, it_s])
    for m, c in ((m_h, np.array([0, 0, L_h / 2])), (m_s, np.array([x_s, 0, z_s]))):
        d = c - com
        I = I + m * (d @ d * np.eye(3) - np.outer(d, d))
    np.testing.assert_allclose(float(tool.params.mass), m_h + m_s, rtol=POLYGON_RTOL)
    np.testing.assert_allclose(np.asarray(tool.params.com), com, atol=1e-3)
    np.testing.assert_allclose(np.asarray(tool.params.inertia), I, rtol=POLYGON_RTOL, atol=1e-6)


def test_combine_mass_properties_of_two_halves_equals_the_whole():
    whole = trimesh.creation.box((0.2, 0.04, 0.02))
    left = trimesh.creation.box((0.1, 0.04, 0.02), transform=trimesh.transformations.translation_matrix((-0.05, 0, 0)))
    right = trimesh.creation.box((0.1, 0.04, 0.02), transform=trimesh.transformations.translation_matrix((0.05, 0, 0)))
    m, c, i = combine_mass_properties([mesh_mass_properties(left, 800.0), mesh_mass_properties(right, 800.0)])
    m0, c0, i0 = mesh_mass_properties(whole, 800.0)
    np.testing.assert_allclose(m, m0, rtol=EXACT_RTOL)
    np.testing.assert_allclose(c, c0, atol=1e-12)
    np.testing.assert_allclose(i, i0, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("name,mass_range,length_range", [
    ("hammer", (0.3, 0.6), (0.28, 0.34)),
    ("broom", (0.2, 0.8), (0.3, 0.5)),
    ("mallet", (0.15, 0.5), (0.35, 0.5)),
    ("l_stick", (0.08, 0.4), (0.4, 0.55)),
])
def test_builtin_tools_are_realistic_and_consistent(tools, name, mass_range, length_range):
    tool = tools[name]
    assert tool.mesh.is_watertight
    assert mass_range[0] <= tool.mass <= mass_range[1]
    lo, hi = tool.mesh.bounds
    assert length_range[0] <= (hi - lo).max() <= length_range[1]
    # every contact point lies on the surface, the contact normal is a unit vector
    _, dist, _ = trimesh.proximity.closest_point(tool.mesh, tool.contact_points)
    assert np.all(dist < 1.5e-3)
    assert abs(np.linalg.norm(tool.contact_normal) - 1) < 1e-12
    # the centre of mass lies inside the tool's bounding box; the grasp region meets the mesh
    assert np.all(np.asarray(tool.params.com) > lo) and np.all(np.asarray(tool.params.com) < hi)
    assert np.any(tool.grasp_region.contains(tool.mesh.vertices, tol=0.02))
    # priors come from the category table
    assert float(tool.params.mu) == priors.CATEGORY_PRIORS[tool.category].mu.value


def test_hammer_centre_of_mass_is_near_the_head(tools):
    """Steel head, wooden handle: the com sits in the top fifth of a claw hammer."""
    assert float(tools["hammer"].params.com[2]) > 0.8 * 0.30


def test_default_contact_normal_is_the_nearest_face_normal(tmp_path):
    spec = BOX_SPEC.replace('contact_normal = [1.0, 0.0, 0.0]\n', "")
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((0.03, 0.02, 0.30)), spec)
    np.testing.assert_allclose(itup.load_tool(mesh_path, spec=spec_path).contact_normal, [1, 0, 0], atol=1e-12)


def test_with_params_validates_and_scales():
    tool = itup.load_tool("hammer")
    heavier = tool.with_params(mass=2 * tool.mass)
    np.testing.assert_allclose(np.asarray(heavier.params.inertia), 2 * np.asarray(tool.params.inertia))
    assert float(tool.with_params(mu=0.3).params.mu) == 0.3


# ----------------------------------------------------------------------------------------------- bad input
def _expect(match, fn, *args, **kwargs):
    with pytest.raises(itup.InputError, match=match):
        fn(*args, **kwargs)


def test_empty_mesh_is_refused(tmp_path):
    path = tmp_path / "empty.obj"
    path.write_text("# no geometry\n")
    spec = tmp_path / "s.toml"
    spec.write_text(BOX_SPEC)
    _expect(r"empty\.obj.*(empty|cannot read)", itup.load_tool, str(path), spec=str(spec))


def test_open_mesh_is_refused(tmp_path):
    box = trimesh.creation.box((0.03, 0.02, 0.3))
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2], process=False)
    mesh_path, spec_path = _write_tool(tmp_path, open_box, BOX_SPEC)
    _expect(r"tool\.stl.*not watertight", itup.load_tool, mesh_path, spec=spec_path)


@pytest.mark.parametrize("line,match", [
    ("mass = 0.0", r"field 'mass'.*> 0"),
    ("mass = -1.0", r"field 'mass'.*> 0"),
    ("mu = -0.1", r"mu.*>= 0"),
    ("restitution = 1.5", r"restitution.*\[0, 1\]"),
    ("contact_duration = 0.0", r"contact_duration.*> 0"),
    ("density = -5.0", r"field 'density'.*> 0"),
])
def test_bad_physical_values_are_refused(tmp_path, line, match):
    spec = BOX_SPEC.replace("density = 700.0", line) if "density" in line else BOX_SPEC + line + "\n"
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((0.03, 0.02, 0.3)), spec)
    _expect(match, itup.load_tool, mesh_path, spec=spec_path)


@pytest.mark.parametrize("old,new,match", [
    ('category = "mallet"', 'category = "spoon"', r"category.*unknown tool category 'spoon'.*known"),
    ("contact_normal = [1.0, 0.0, 0.0]", "contact_normal = [0.0, 0.0, 0.0]", r"contact_normal.*zero-length"),
    ("contact_point = [0.015, 0.0, 0.14]", "contact_point = [0.0, nan, 0.15]", r"contact_point.*NaN"),
    ("contact_point = [0.015, 0.0, 0.14]", "contact_point = [0.0, 0.15]", r"contact_point.*three numbers"),
    ('name = "block"', "", r"missing required field.*name"),
    ('name = "block"', 'name = "block"\ncolour = "red"', r"unknown field.*colour"),
    ("max = [0.02, 0.02, 0.0]", "max = [-0.03, 0.02, 0.0]", r"grasp_region.*below max"),
    ('name = "block"', 'name = "block', r"malformed TOML"),
])
def test_malformed_specs_are_refused(tmp_path, old, new, match):
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((0.03, 0.02, 0.3)), BOX_SPEC.replace(old, new))
    _expect(match, itup.load_tool, mesh_path, spec=spec_path)


def test_unknown_builtin_and_missing_spec_and_missing_file(tmp_path):
    _expect(r"'spoon'.*built-ins: hammer", itup.load_tool, "spoon")
    _expect(r"needs a TOML spec", itup.load_tool, "thing.stl")
    spec = tmp_path / "s.toml"
    spec.write_text(BOX_SPEC)
    _expect(r"nope\.stl.*not found", itup.load_tool, str(tmp_path / "nope.stl"), spec=str(spec))
    _expect(r"missing\.toml.*not found", itup.load_tool, str(tmp_path / "x.stl"), spec=str(tmp_path / "missing.toml"))


def test_with_params_refuses_bad_values(tools):
    _expect(r"mu.*>= 0", tools["hammer"].with_params, mu=-0.2)
    _expect(r"mass.*> 0", tools["hammer"].with_params, mass=0.0)
    _expect(r"unknown parameter", tools["hammer"].with_params, colour=1.0)


# --- A user's tool, safely: units, size, contact on the surface, the tool frame ------------------------
def _hammer_files(tmp_path, R=np.eye(3), scale=1.0, extra="", name="hammer", ext="stl"):
    """The built-in hammer's mesh and spec as a user would give them: the mesh turned by R and scaled
    by `scale` (1e3: millimetres), the spec's positions and directions with it."""
    h = itup.load_tool("hammer")
    mesh = h.mesh.copy()
    T = np.eye(4)
    T[:3, :3] = scale * R
    mesh.apply_transform(T)
    f = lambda v: np.round(scale * (R @ np.asarray(v, float)), 12).tolist()  # noqa: E731
    lo, hi = h.grasp_region.lo, h.grasp_region.hi
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) @ (scale * R).T
    spec = (f'name = "{name}"\ncategory = "hammer"\ncontact_point = {f(h.contact_point)}\n'
            f"contact_normal = {np.round(R @ h.contact_normal, 12).tolist()}\n"
            f"grasp_region = {{ min = {corners.min(0).round(12).tolist()}, max = {corners.max(0).round(12).tolist()} }}\n"
            f"mass = {h.mass}\n" + extra)
    return _write_tool(tmp_path, mesh, spec, name=name, ext=ext)


def test_a_hammer_in_millimetres_is_refused_with_the_likely_mistake_and_loads_with_units(tmp_path):
    mesh_path, spec_path = _hammer_files(tmp_path, scale=1e3)
    _expect(r"largest extent is 301 m.*hand tool.*looks like millimetres: add units = \"mm\"", itup.load_tool,
            mesh_path, spec=spec_path)
    mesh_path, spec_path = _hammer_files(tmp_path, scale=1e3, extra='units = "mm"\n')
    tool = itup.load_tool(mesh_path, spec=spec_path)
    ref = itup.load_tool("hammer")
    np.testing.assert_allclose(tool.contact_point, ref.contact_point, atol=1e-9)
    np.testing.assert_allclose(tool.mesh.extents, ref.mesh.extents, rtol=1e-6)  # STL: float32
    mesh_path, spec_path = _hammer_files(tmp_path, extra='units = "mm"\n')  # metres, said to be millimetres
    _expect(r"largest extent is 0.000301 m.*looks like metres already: remove units", itup.load_tool,
            mesh_path, spec=spec_path)
    mesh_path, spec_path = _hammer_files(tmp_path, extra='units = "inch"\n')
    _expect(r"field 'units' must be one of m, mm", itup.load_tool, mesh_path, spec=spec_path)


def test_a_contact_point_off_the_surface_is_refused(tmp_path):
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((0.03, 0.02, 0.3)),
                                       BOX_SPEC.replace("contact_point = [0.015, 0.0, 0.14]",
                                                        "contact_point = [1.0, 0.0, 0.14]"))
    _expect(r"field 'contact_point' lies 0.98\d* m from the mesh's surface", itup.load_tool, mesh_path, spec=spec_path)
    spec = BOX_SPEC + "contact_points = [[0.015, 0.0, 0.10], [0.015, 0.0, 0.5]]\n"
    mesh_path, spec_path = _write_tool(tmp_path, trimesh.creation.box((0.03, 0.02, 0.3)), spec)
    _expect(r"field 'contact_points\[1\]' lies 0.35\d* m", itup.load_tool, mesh_path, spec=spec_path)


def _turn(axis, deg):
    import jaxlie
    return np.asarray(jaxlie.SO3.exp(np.asarray(axis, float) * np.radians(deg)).as_matrix())


def test_a_tool_turned_without_its_frame_is_refused(tmp_path):
    """A consistently turned mesh and spec exit with a message naming the fields to state, whether the
    handle leaves z or the face turns about it."""
    for R in (_turn([1.0, 0.0, 0.0], 90), _turn([0.0, 0.0, 1.0], 90)):
        mesh_path, spec_path = _hammer_files(tmp_path, R=R)
        _expect(r"the mesh is not in the tool frame.*handle_axis.*x_axis", itup.load_tool, mesh_path, spec=spec_path)
    mesh_path, spec_path = _hammer_files(tmp_path, R=_turn([1.0, 0.0, 0.0], 90), extra="handle_axis = [0, 1, 0]\n")
    _expect(r"'handle_axis' and 'x_axis' go together", itup.load_tool, mesh_path, spec=spec_path)
    mesh_path, spec_path = _hammer_files(tmp_path, extra="handle_axis = [0, 0, 1]\nx_axis = [0, 0, -1]\n")
    _expect(r"'x_axis'.*parallel to 'handle_axis'", itup.load_tool, mesh_path, spec=spec_path)


def test_a_tool_turned_with_its_frame_stated_plans_the_same_grasps(tmp_path):
    """The hammer turned by a general rotation, its spec turned with it and the frame stated, is the
    same tool: mass properties, contact, grasp region, sampled grasps and their costs (the tool frame)."""
    ref_path, ref_spec = _hammer_files(tmp_path, name="upright", ext="ply")  # PLY: float64 vertices
    ref = itup.load_tool(ref_path, spec=ref_spec)
    R = _turn([0.3, -0.5, 0.8], 137.0)
    z, x = R @ [0.0, 0.0, 1.0], R @ [1.0, 0.0, 0.0]
    mesh_path, spec_path = _hammer_files(tmp_path, R=R, name="turned", ext="ply",
                                         extra=f"handle_axis = {z.tolist()}\nx_axis = {x.tolist()}\n")
    tool = itup.load_tool(mesh_path, spec=spec_path)
    np.testing.assert_allclose(tool.mesh_to_tool, R.T, atol=1e-12)
    np.testing.assert_allclose(tool.mesh.vertices, ref.mesh.vertices, atol=1e-6)  # STL: float32
    np.testing.assert_allclose(tool.contact_point, ref.contact_point, atol=1e-9)
    np.testing.assert_allclose(tool.contact_normal, ref.contact_normal, atol=1e-9)
    np.testing.assert_allclose(np.asarray(tool.params.inertia), np.asarray(ref.params.inertia), rtol=1e-5, atol=1e-10)
    np.testing.assert_allclose(np.asarray(tool.params.com), np.asarray(ref.params.com), atol=1e-9)
    # the sampler runs in float32: the turned file's last bits differ, and after the first few draws a
    # feasibility test may fall the other way, so the draws agree while they run in step
    g_ref, g = itup.sample_grasps(ref, 64, seed=0), itup.sample_grasps(tool, 64, seed=0)
    np.testing.assert_allclose(np.asarray(g.p_tool_grasp)[:8], np.asarray(g_ref.p_tool_grasp)[:8], atol=1e-6)
    # the same grasps cost the same on both: the trajectory, the contact and the mass properties agree
    task_ref, task = itup.make_task("hammer", ref), itup.make_task("hammer", tool)
    c_ref, c = itup.wrench_costs(ref, task_ref, g_ref), itup.wrench_costs(tool, task, g_ref)
    np.testing.assert_allclose(np.asarray(c.total), np.asarray(c_ref.total), rtol=1e-4, atol=1e-6)
    assert int(np.argmin(np.asarray(c.total))) == int(np.argmin(np.asarray(c_ref.total)))


def test_a_mesh_tool_collides_by_convex_pieces_that_follow_its_shape(user_mallet):
    """A mesh tool's collision shape is its slabs' convex hulls: they lie inside the mesh's bounds, their
    volume is near the mesh's (a handle's slab is its own hull), where the one hull of the whole T-headed
    tool is more than twice it; every piece is a closed, outward-wound convex mesh."""
    import trimesh

    from itup_jax.sim.scene import build_scene
    from itup_jax.tools.mesh import COLLISION_SLAB

    tool = user_mallet
    pieces = [p for p in tool.primitives if p[0] == "hull"]
    assert len(pieces) == len(tool.primitives) >= int(np.ptp(tool.mesh.vertices[:, 2]) / COLLISION_SLAB)
    lo, hi = tool.mesh.bounds
    volume = 0.0
    for _, verts, faces in pieces:
        assert np.all(verts >= lo - 1e-9) and np.all(verts <= hi + 1e-9)
        m = trimesh.Trimesh(verts, faces, process=False)
        assert m.is_watertight and m.volume > 0  # outward: a positive signed volume
        volume += m.volume
    assert tool.mesh.volume <= volume < 1.1 * tool.mesh.volume
    assert tool.mesh.convex_hull.volume > 2 * tool.mesh.volume
    scene = build_scene(tool, itup.make_task("knock", tool))  # one pad-tool pair per piece
    assert len(scene.pad_tool_pairs) == 2 * len(pieces)
