"""The grasp sampler (flat pads and point contacts): every grasp antipodal, within the stroke, in the region,
not penetrating; flat-pad grasps square across the handle and still in the pads."""

import dataclasses
import math

import jax
import numpy as np
import pytest
import trimesh

import itup_jax as itup
from itup_jax import robot
from itup_jax.grasp import gripper_boxes
from itup_jax.grasp_sampler import SamplerConfig, SamplingError
from itup_jax.tools import Box

# Contact normals are read back from the nearest mesh face; on a 48-facet cylinder a point near a facet
# edge may snap to the neighbouring facet, 7.5 degrees away. The cone check allows that much.
FACET_ANGLE = 2 * math.pi / 48
# A sampled pad centre lies on the surface up to float rounding of the ray cast.
SURFACE_TOL = 1e-6
# The sampler resolves collisions to its surface-sample spacing (2.5 mm) and grows the gripper boxes by
# a 1 mm margin to catch shallow cuts between samples; a point of the gripper deeper than this inside
# the tool would mean the check failed.
PENETRATION_TOL = 2e-4


def _check_grasps(tool, grasps, config=SamplerConfig()):
    """Every grasp within the stroke and the region, its pads on the surface (flat pads: within
    `flat_excess`) with outward normals antipodal within the cone (flat pads: within `flat_angle`), and
    the open gripper cutting nothing."""
    flat = config.contact == "flat"
    mu = float(tool.params.mu)
    p = np.asarray(grasps.p_tool_grasp)
    R = np.asarray(grasps.rotation)
    w = np.asarray(grasps.width)
    assert np.all(w <= robot.GRIPPER_MAX_OPENING - 2 * config.clearance) and np.all(w >= config.min_width)
    assert np.all(tool.grasp_region.contains(p))
    pads = np.asarray(grasps.pad_centres())  # [N, 2, 3]: -y pad, +y pad
    assert np.all(tool.grasp_region.contains(pads, tol=1e-9))
    closest, dist, tri = trimesh.proximity.closest_point(tool.mesh, pads.reshape(-1, 3))
    assert dist.max() < (config.flat_excess + SURFACE_TOL if flat else SURFACE_TOL)
    normals = tool.mesh.face_normals[tri].reshape(-1, 2, 3)
    y = R[:, :, 1]
    cone = (config.flat_angle if flat else math.atan(mu)) + FACET_ANGLE
    # Outward normal at the -y pad points along -y, at the +y pad along +y: antipodal within the cone.
    assert np.all(np.einsum("ij,ij->i", normals[:, 0], -y) >= math.cos(cone))
    assert np.all(np.einsum("ij,ij->i", normals[:, 1], y) >= math.cos(cone))
    # No penetration, checked independently of the sampler: no point of a dense grid of each gripper box
    # (fingers opened by the clearance) lies inside the mesh deeper than PENETRATION_TOL (trimesh's
    # ray-parity containment, then its signed distance).
    grid = []
    for i in range(len(p)):
        for _, lo, hi in gripper_boxes(w[i] + 2 * config.clearance):
            axes = [np.linspace(lo[k] + 1e-4, hi[k] - 1e-4, 5) for k in range(3)]
            local = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
            grid.append(local @ R[i].T + p[i])
    grid = np.concatenate(grid)
    inside = tool.mesh.contains(grid)
    depth = trimesh.proximity.signed_distance(tool.mesh, grid[inside]) if inside.any() else np.zeros(1)
    assert depth.max() <= PENETRATION_TOL


@pytest.mark.parametrize("contact", ["flat", pytest.param("point", marks=pytest.mark.slow)])  # point: the old sampler
@pytest.mark.parametrize("name", ["hammer", "l_stick", "broom", "mallet"])
def test_sampled_grasps_are_valid(tools, name, contact):
    tool, config = tools[name], SamplerConfig(contact=contact)
    grasps = itup.sample_grasps(tool, 60, seed=3, config=config)
    assert len(grasps) == 60
    _check_grasps(tool, grasps, config)


def test_same_key_same_grasps_other_key_other_grasps(tools):
    tool = tools["l_stick"]
    key = jax.random.key(7)
    a = itup.sample_grasps(tool, 50, seed=key)
    b = itup.sample_grasps(tool, 50, seed=key)
    c = itup.sample_grasps(tool, 50, seed=jax.random.key(8))
    for f in ("p_tool_grasp", "q_tool_grasp", "width"):
        np.testing.assert_array_equal(np.asarray(getattr(a, f)), np.asarray(getattr(b, f)))
    assert not np.allclose(np.asarray(a.p_tool_grasp), np.asarray(c.p_tool_grasp))
    d = itup.sample_grasps(tool, 50, seed=jax.random.PRNGKey(7))  # raw uint32 keys work too
    assert len(d) == 50


def test_approach_axes_cover_the_circle_around_the_handle(tools):
    """Approach directions are drawn around the closure axis: both sides of the handle occur."""
    g = itup.sample_grasps(tools["hammer"], 200, seed=0)
    z = np.asarray(g.approach_axis)
    assert z[:, 0].max() > 0.5 and z[:, 0].min() < -0.5


def test_region_without_room_raises(tools):
    tool = dataclasses.replace(tools["hammer"], grasp_region=Box(np.array([0.055, -0.003, 0.286]), np.array([0.06, 0.003, 0.294])))
    with pytest.raises(SamplingError, match="found 0 of 10"):
        itup.sample_grasps(tool, 10, seed=0, config=SamplerConfig(batch=512, max_rounds=2))


def test_bad_arguments(tools):
    with pytest.raises(itup.InputError, match="n must be a positive integer"):
        itup.sample_grasps(tools["hammer"], 0)
    with pytest.raises(itup.InputError, match="seed"):
        itup.sample_grasps(tools["hammer"], 5, seed="abc")
    with pytest.raises(itup.InputError, match="sample_grasps: seed must be an integer >= 0, got -1"):
        itup.sample_grasps(tools["hammer"], 5, seed=-1)


def test_collision_kernel_matches_a_float64_box_test(tools):
    """`gripper_collides` (float32, the grasp-frame transform as three products) against a NumPy float64
    test of every point in every gripper box, on random poses around the hammer that hit and miss. A point
    within 1e-6 m of a box face may round either way in float32; grasps with such a point are left out."""
    from itup_jax.grasp_sampler import collision_points, gripper_collides

    tool, margin = tools["hammer"], 1e-3
    pts = collision_points(tool, SamplerConfig().surface_spacing)
    rng = np.random.default_rng(7)
    m = 600
    p = pts[rng.integers(0, len(pts), m)] + rng.normal(0.0, 0.02, (m, 3))
    q = rng.normal(size=(m, 4))
    R = np.asarray(itup.rotations.quat_to_matrix(q / np.linalg.norm(q, axis=1, keepdims=True)), np.float64)
    opening = rng.uniform(0.01, 0.095, m)
    got = gripper_collides(pts, R, p, opening, margin)
    want, clear = np.zeros(m, bool), np.ones(m, bool)
    for i in range(m):
        local = (pts - p[i]) @ R[i]
        for _, lo, hi in gripper_boxes(opening[i]):
            lo, hi = lo - margin, hi + margin
            want[i] |= np.any(np.all((local > lo) & (local < hi), axis=1))
            # ambiguous: within 1e-6 m of a face of the box (near its plane, within its extent on the other axes)
            for k in range(3):
                others = [j for j in range(3) if j != k]
                on_plane = np.minimum(np.abs(local[:, k] - lo[k]), np.abs(local[:, k] - hi[k])) < 1e-6
                in_face = np.all((local[:, others] > lo[others] - 1e-6) & (local[:, others] < hi[others] + 1e-6), axis=1)
                clear[i] &= not np.any(on_plane & in_face)
    assert 0.2 < want.mean() < 0.9 and clear.mean() > 0.9  # both outcomes occur; few grasps left out
    np.testing.assert_array_equal(got[clear], want[clear])


#: The built-in tools' handles: a cylinder of radius r along the tool's z axis (tool.py).
HANDLE_RADIUS = {"hammer": 0.0145, "l_stick": 0.006, "broom": 0.011, "mallet": 0.012}


@pytest.mark.parametrize("name", ["hammer", "l_stick", "broom", "mallet"])
def test_flat_pad_grasps_lie_square_across_the_handle(tools, name):
    """contact="flat": the closure axis lies in the handle's cross-section, the grasp centre midway across it,
    and the jaw opening is the distance between two opposite facets of the 48-facet mesh, 2 r cos(pi/48),
    not the chord of a tilted axis (2 r / cos(phi)). No tool point in the pads' footprint stands proud of
    the pads' planes (float64, independent of the sampler's float32 kernel), and the open gripper cuts
    nothing."""
    tool, r = tools[name], HANDLE_RADIUS[name]
    config = SamplerConfig(contact="flat")
    g = itup.sample_grasps(tool, 40, seed=3, config=config)
    p, R, w = np.asarray(g.p_tool_grasp), np.asarray(g.rotation), np.asarray(g.width)
    assert np.abs(R[:, 2, 1]).max() <= math.sin(config.flat_angle) + 1e-6  # closure axis . handle axis
    # the centre: on the axis across the pads (y), within half a facet (r sin(pi/48)) along it
    assert np.abs(np.einsum("ij,ij->i", p[:, :2], R[:, :2, 1])).max() < 1e-5
    assert np.hypot(p[:, 0], p[:, 1]).max() <= r * math.sin(math.pi / 48) + 1e-6
    np.testing.assert_allclose(w, 2 * r * math.cos(math.pi / 48), atol=2e-6)
    from itup_jax.grasp_sampler import collision_points

    pts = collision_points(tool, config.surface_spacing)
    for i in range(len(g)):
        local = (pts - p[i]) @ R[i]
        foot = (np.abs(local[:, 0]) <= robot.PAD_WIDTH / 2) & (np.abs(local[:, 2]) <= robot.PAD_LENGTH / 2)
        assert foot.sum() > 10 and np.abs(local[foot, 1]).max() <= w[i] / 2 + 1e-6
    _check_grasps(tool, g, config)
    assert np.abs(R[:, 0, 2]).max() > 0.5 and np.abs(R[:, 2, 2]).max() > 0.5  # approach axes still vary


def test_flat_pad_grasps_start_at_the_squeeze_and_do_not_turn(tasks):
    """In MuJoCo (nominal physics, the hammer): flat-pad grasps start with the pads the squeeze s inside
    the handle's capsule (r - r cos(pi/48) more, the mesh facets' sag), and the tool turns less than a
    degree in the pads over the settle. Point-contact grasps of the same tool start deeper and turn
    several degrees (a median 4-9 degrees in the first 50 ms)."""
    import dataclasses as dc
    import importlib

    S = importlib.import_module("itup_jax.sim")
    from itup_jax.rotations import quat_angle
    from itup_jax.sim.arm import INITIAL_SQUEEZE, plan
    from itup_jax.sim.labels import initial_pad_overlap
    from itup_jax.sim.native import rollout_native
    tool, task = tasks["hammer"]
    scene = itup.build_scene(tool, task)
    r = HANDLE_RADIUS["hammer"]
    turned = {}
    for contact in ("flat", "point"):
        g = itup.sample_grasps(tool, 24, seed=0, config=SamplerConfig(contact=contact))
        g = g[np.flatnonzero(S.reachable(task, g))[:6]]
        phys = S.sample_physics(tool, len(g), spread=None)
        p = plan(scene, task, g, phys)
        overlap = initial_pad_overlap(scene, p.qpos0)
        settle = dc.replace(p, ctrl=p.ctrl[:, :p.n_settle], nstep=p.n_settle)
        _, sd = rollout_native(scene, settle, phys)
        q = scene.sensor(sd, "tool_quat_grasp")
        turned[contact] = np.degrees(quat_angle(q, q[:, :1]).max(1))
        if contact == "flat":
            assert len(g) == 6
            np.testing.assert_allclose(overlap, INITIAL_SQUEEZE + r * (1 - math.cos(math.pi / 48)), atol=2e-6)
        else:
            assert np.nanmedian(overlap) > 3 * INITIAL_SQUEEZE  # (NaN: a pad misses the capsule)
    assert turned["flat"].max() < 1.0 < np.median(turned["point"])


def test_bad_contact_model_is_refused(tools):
    with pytest.raises(itup.InputError, match="config.contact must be one of"):
        itup.sample_grasps(tools["hammer"], 5, config=SamplerConfig(contact="soft"))
    with pytest.raises(itup.InputError, match="flat_angle"):
        itup.sample_grasps(tools["hammer"], 5, config=SamplerConfig(contact="flat", flat_angle=-0.1))


def _as_set(loc, ray, tri):
    return sorted(zip(np.asarray(ray).tolist(), np.asarray(tri).tolist(), map(tuple, np.asarray(loc).tolist())))


@pytest.mark.parametrize("chunk", [None, 1000])
def test_ray_hits_are_trimeshs_hits(tools, chunk, monkeypatch):
    """The sampler's vectorised broad phase finds every hit trimesh's R-tree path finds, the same floats,
    on the built-in tools and a finely tessellated sphere (also in chunks smaller than one ray's pairs)."""
    from itup_jax import grasp_sampler

    if chunk is not None:
        monkeypatch.setattr(grasp_sampler, "RAY_PAIRS_PER_CHUNK", chunk)
    rng = np.random.default_rng(0)
    for mesh in [tools[n].mesh for n in ("hammer", "broom")] + [trimesh.creation.icosphere(3, radius=0.03)]:
        p, face = trimesh.sample.sample_surface(mesh, 400, seed=1)
        d = -mesh.face_normals[face] + 0.4 * rng.normal(size=(400, 3))  # into the tool, spread like the cone
        d[:20] = rng.normal(size=(20, 3))  # some outward: they hit nothing past their start
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        ours = grasp_sampler.ray_hits(mesh, p, d)
        assert len(ours[0]) > 300
        assert _as_set(*ours) == _as_set(*mesh.ray.intersects_location(p, d, multiple_hits=True))
    none = grasp_sampler.ray_hits(tools["hammer"].mesh, np.array([[5.0, 5.0, 5.0]]), np.array([[1.0, 0.0, 0.0]]))
    assert [len(a) for a in none] == [0, 0, 0]


def test_grasp_quaternions_are_the_op_by_op_ones(hammer_grasps):
    """make_grasps converts rotations in one compiled kernel: the same float32 bits as op by op."""
    import jax.numpy as jnp
    import jaxlie

    R = np.asarray(hammer_grasps.rotation)
    eager = np.asarray(jax.vmap(lambda m: jaxlie.SO3.from_matrix(m).wxyz)(jnp.asarray(R)))
    assert np.asarray(itup.make_grasps(hammer_grasps.p_tool_grasp, R, hammer_grasps.width).q_tool_grasp).tobytes() \
        == eager.tobytes()
