"""Tool families: every family builds closed meshes with sane mass properties, loads through the spec
path like a user's mesh, and its contact lands on the task's target without the tool passing through the
table or the target's surroundings; the reachable sampler returns only grasps the arm can carry."""

from __future__ import annotations

import warnings

import mujoco
import numpy as np
import pytest
import trimesh

import itup_jax as itup
from itup_jax.errors import InputError
from itup_jax.grasp_sampler import sample_reachable
from itup_jax.sim.arm import reachable
from itup_jax.sim.scene import build_scene
from itup_jax.tools import CATEGORY_CONTACT_NORMAL, families, family_shapes, priors

NEW = [f for f in families.names() if not families.get(f).builtin]
#: m, how deep a tool's mesh may reach into the environment's solids at the first contact (the contact
#: sits on the target's face; a mesh facet may cut a corner).
PENETRATION_TOL = 0.002


def _tools(name):
    return [itup.load_tool(name)] + [families.draw(name, s) for s in (1, 2)]


@pytest.mark.parametrize("name", NEW)
def test_family_tools_are_closed_with_sane_mass_properties(name):
    for tool in _tools(name):
        assert tool.mesh.is_watertight and tool.mesh.volume > 0, tool.name
        assert 0.03 < tool.mass < 2.0, (tool.name, tool.mass)
        lo, hi = tool.mesh.bounds
        extent = float(np.max(hi - lo))
        assert 0.15 < extent < 0.8, (tool.name, extent)
        com = np.asarray(tool.params.com)
        assert np.all(com > lo) and np.all(com < hi), tool.name
        eig = np.linalg.eigvalsh(np.asarray(tool.params.inertia))
        assert eig.min() > 0 and eig.max() < eig.min() * 1e4, (tool.name, eig)  # positive, not degenerate
        _, dist, _ = trimesh.proximity.closest_point(tool.mesh, tool.contact_points)
        assert np.all(dist < 1e-6), (tool.name, dist)  # the contacts on the surface
        np.testing.assert_allclose(tool.contact_normal, CATEGORY_CONTACT_NORMAL[tool.category])
        assert tool.category == families.get(name).tool_category and tool.category in priors.CATEGORY_PRIORS
        # the grasp region holds the handle: the sampler finds grasps in it
        assert len(itup.sample_grasps(tool, 32, seed=0)) == 32


def test_draws_are_deterministic_and_vary():
    a, b, c = families.draw("hatchet", 5), families.draw("hatchet", 5), families.draw("hatchet", 6)
    assert a.name == "hatchet@5" and np.array_equal(a.mesh.vertices, b.mesh.vertices)
    assert a.mass != c.mass
    assert itup.load_tool("hatchet@5").mass == a.mass  # the same tool by name
    assert {families.draw("pry_bar", s).mesh.vertices.shape[0] for s in range(8)} == {27, 195}  # hex and round
    with pytest.raises(InputError, match="tool family 'wrench'"):
        families.draw("wrench", 0)
    with pytest.raises(InputError, match="seed must be an integer >= 0"):
        families.draw("spanner", -1)
    with pytest.raises(InputError, match=r"tool families .*screwdriver"):
        itup.load_tool("chisel")


@pytest.mark.parametrize("name", NEW)
def test_family_tool_loads_through_the_spec_path(tmp_path, name):
    """Written out as a user's STL and a spec in millimetres, without a stated frame: the frame check
    accepts it (the family keeps its category's frame) and the mass and contact come back."""
    tool = itup.load_tool(name)
    mesh = tool.mesh.copy()
    mesh.apply_scale(1e3)
    path = tmp_path / f"{name}.stl"
    mesh.export(path)
    lo, hi = tool.grasp_region.lo * 1e3, tool.grasp_region.hi * 1e3
    spec = {"name": name, "category": tool.category, "units": "mm", "mass": tool.mass,
            "contact_point": (tool.contact_point * 1e3).tolist(),
            "contact_normal": tool.contact_normal.tolist(),
            "grasp_region": {"min": lo.tolist(), "max": hi.tolist()}}
    user = itup.load_tool(str(path), spec=spec)
    assert user.mass == pytest.approx(tool.mass)
    np.testing.assert_allclose(user.contact_point, tool.contact_point, atol=1e-9)
    np.testing.assert_allclose(user.mesh_to_tool, np.eye(3))
    assert float(user.params.mu) == priors.CATEGORY_PRIORS[tool.category].mu.value


def test_held_out_training_calibration_and_sealed_families():
    """The five held-out families, the four training ones, the four calibration ones, the eighteen of the
    six sealed evaluations that have run (validation; none sealed until a next round adds its own),
    disjoint; every one but the held-out families' tools takes a built-in category (its priors and tool
    frame), so its labels teach (or its draws calibrate on) that category's network; each round's
    sealed-test families did every task between them."""
    assert families.held_out() == ("screwdriver", "spanner", "pry_bar", "hatchet", "squeegee")
    assert families.training() == ("baton", "headed_stick", "hook", "pusher")
    assert families.calibration() == ("paddle", "mace", "scraper", "t_hook")
    assert families.validation() == ("rolling_pin", "rake", "hoe", "pick", "offset_pusher", "club", "offset_hammer",
                                     "leaning_broom", "fork_hook", "skillet", "deck_brush", "ladle",
                                     "pommel_hammer", "angle_broom", "cranked_hook", "cranked_hammer",
                                     "ballast_broom", "tapered_hook")
    assert families.sealed() == ()  # the next round's families are added before its draw
    builtin = {f for f in families.names() if families.get(f).builtin}
    for name in families.training() + families.calibration() + families.validation() + families.sealed():
        fam = families.get(name)
        assert fam.tool_category in builtin and not fam.held_out
        assert fam.training + fam.calibration + fam.validation + fam.sealed == 1
        assert families.draw(name, 7).category == fam.tool_category
    for round_families in (("rolling_pin", "rake", "hoe"), ("pick", "offset_pusher", "club"),
                           ("offset_hammer", "leaning_broom", "fork_hook"), ("skillet", "deck_brush", "ladle"),
                           ("pommel_hammer", "angle_broom", "cranked_hook"),
                           ("cranked_hammer", "ballast_broom", "tapered_hook")):
        assert {k for f in round_families for k in families.get(f).tasks} == {"hammer", "sweep", "knock", "reach"}
    assert families.with_role("builtin") == ("hammer", "broom", "mallet", "l_stick")
    assert sorted(f for r in families.ROLES for f in families.with_role(r)) == sorted(families.names())
    with pytest.raises(InputError, match="family role 'test'"):
        families.with_role("test")
    with pytest.raises(ValueError, match="role 'test'"):
        families.Family("x", families.baton, ("knock",), {"length": (0.2, 0.3)}, role="test")
    with pytest.raises(ValueError, match="only they, have no ranges"):
        families.Family("x", families.baton, ("knock",), {"length": (0.2, 0.3)}, role="builtin")
    # every built-in category's tasks have a calibration family
    assert {k for f in families.calibration() for k in families.get(f).tasks} == {"hammer", "sweep", "knock", "reach"}
    assert all(families.get(f).tool_category == f for f in families.held_out())


def test_a_disc_collides_as_its_own_hull():
    """`sealed_shapes.disc_part`: a thin disc's collision primitive is its convex hull, the disc's own
    extent (a capsule as long as the disc is thin would be a ball of its radius)."""
    from itup_jax.tools.sealed_shapes import disc_part, skillet

    mesh, prim = disc_part(0.07, (0.0, 0.0, 0.3), 0, 0.005)
    assert prim[0] == "hull" and mesh.is_watertight
    np.testing.assert_allclose(np.ptp(prim[1], axis=0), [0.005, 0.14, 0.14], atol=1e-3)
    tool = skillet(pan_radius=0.07, pan_thickness=0.005)
    assert [p[0] for p in tool.primitives] == ["capsule", "hull"]
    assert tool.contact_point[0] == pytest.approx(0.0025) and tool.contact_point[2] == pytest.approx(0.27)


def test_round_5_shapes_put_their_mass_and_contacts_where_they_say():
    """`sealed_shapes`: a turned box collides as its own hull and the angle broom's three contact points
    lie on its turned leading face, one end ahead of the other; the cranked hook pulls `jog` beside the
    grasped part's axis; the pommel hammer's grasp region starts clear of its pommel, and a steel pommel
    pulls the centre of mass further down the handle than an aluminium one."""
    from itup_jax.tools.sealed_shapes import angle_broom, cranked_hook, pommel_hammer, yawed_box_part

    mesh, prim = yawed_box_part(0.1, 0.02, 0.05, 0.1)
    assert prim[0] == "hull" and mesh.is_watertight and mesh.bounds[0][2] == pytest.approx(0.0)
    np.testing.assert_allclose(np.ptp(prim[1], axis=0)[:2], [0.2 * np.cos(0.1) + 0.04 * np.sin(0.1),
                                                            0.2 * np.sin(0.1) + 0.04 * np.cos(0.1)], atol=1e-9)
    tool = angle_broom(yaw=0.1, head_depth=0.04)
    normal = np.array([-np.sin(0.1), np.cos(0.1), 0.0])
    np.testing.assert_allclose(tool.contact_points @ normal, 0.02, atol=1e-9)  # on the leading face
    assert tool.contact_points[2, 1] - tool.contact_points[1, 1] == pytest.approx(1.5 * 0.11 * np.sin(0.1))
    hook = cranked_hook(jog=0.05)
    assert hook.contact_point[1] == pytest.approx(0.05) and hook.grasp_region.hi[1] < 0.05 - 0.007
    ham = pommel_hammer(pommel_length=0.03, handle_length=0.26)
    light = pommel_hammer(pommel_length=0.03, handle_length=0.26, pommel_material="aluminium")
    assert ham.grasp_region.lo[2] > 0.03 and ham.params.com[2] < light.params.com[2] - 0.03


def _span(name, measure, n=24):
    values = [measure(families.draw(name, s)) for s in range(n)]
    return min(values), max(values)


def test_round_6_shapes_put_their_mass_and_contacts_where_they_say():
    """`sealed_shapes`: the cranked hammer's head and blow lie `jog` ahead of or behind its grasp region's
    axis, which ends below the crank; the ballast broom's centre of mass lies on the ballast's side, its
    three contacts on the leading face; the tapered hook's butt holds most of its pole's mass and a steel
    hook moves the centre of mass out toward it."""
    from itup_jax.tools.sealed_shapes import ballast_broom, cranked_hammer, tapered_hook

    def com(tool):
        return np.asarray(tool.params.com)

    for jog in (-0.03, 0.05):
        ham = cranked_hammer(jog=jog, head_front=0.04, length=0.28, crank_at=0.5)
        assert ham.contact_point[0] == pytest.approx(jog + 0.04) and ham.contact_point[1] == 0
        lo, hi = ham.grasp_region.lo, ham.grasp_region.hi
        assert hi[2] < 0.5 * 0.28 and abs(lo[0] + hi[0]) < 1e-12  # the lower shaft, about x = 0
    broom = ballast_broom(ballast_from=0.03, ballast_length=0.06)
    assert com(broom)[0] > 0.01  # the steel on +x pulls the centre of mass off the handle's line
    np.testing.assert_allclose([p[1] for p in broom.contact_points], 0.02)  # the leading face, y = head_depth / 2
    assert ballast_broom(half_width=0.07, ballast_from=0.05, ballast_length=0.08).mesh.bounds[1][0] == pytest.approx(0.07)
    light, heavy = tapered_hook(), tapered_hook(hook_material="steel")
    parts = {name: mass for name, _, mass in light.parts}
    assert parts["butt"] > parts["middle"] + parts["tip"]
    assert com(heavy)[2] > com(light)[2] + 0.02 and heavy.mass > light.mass


def test_training_families_span_mass_distribution_size_and_reach():
    """What the training families are for: across draws, centres of mass from the handle's side to the
    working end's, light and heavy heads, grasp regions near to and far from the hook's bend, narrow and
    wide T-heads on short and long handles."""
    def com_fraction(t):  # centre of mass along the handle axis, as a share of the tool's length
        lo, hi = t.mesh.bounds
        return float(t.params.com[2] - lo[2]) / float(hi[2] - lo[2])

    lo, hi = _span("baton", com_fraction)
    assert lo < 0.35 and hi > 0.6, (lo, hi)  # tip lighter than the handle ... much heavier
    def head_share(t):
        return dict((n, m) for n, _, m in t.parts)["head"] / t.mass

    lo, hi = _span("headed_stick", head_share)
    assert lo < 0.3 and hi > 0.75, (lo, hi)

    def bend_gap(t):  # from the grasp region's top to the hook's underside
        return float(t.contact_point[2] - t.grasp_region.hi[2])

    lo, hi = _span("hook", bend_gap)
    assert lo < 0.03 and hi > 0.25, (lo, hi)
    width = _span("pusher", lambda t: float(np.ptp(t.mesh.vertices[:, 0])))
    height = _span("pusher", lambda t: float(np.ptp(t.mesh.vertices[:, 2])))
    assert width[0] < 0.12 and width[1] > 0.35 and height[0] < 0.25 and height[1] > 0.5, (width, height)


def _first_contact_step(task) -> int:
    on = (np.asarray(task.impact)[:, 0] > 0) | (np.asarray(task.drag)[:, 0] > 0)
    return int(np.argmax(on))


def _box_depth(points: np.ndarray, centre: np.ndarray, R: np.ndarray, half: np.ndarray) -> np.ndarray:
    """[P] how deep each point lies inside an oriented box (<= 0: outside)."""
    local = (points - centre) @ R
    return np.min(half - np.abs(local), axis=-1)


COMBOS = [(f, k) for f in families.names() for k in families.get(f).tasks]


def _inside_primitive(prim, points, tol=1e-6):
    """[n] bool: the points (tool frame) inside a box primitive or a convex hull one (float32 vertices:
    `tol` m of slack)."""
    if prim[0] == "box":
        _, lo, hi = prim
        return np.all((points >= lo - tol) & (points <= hi + tol), axis=1)
    hull = trimesh.Trimesh(prim[1], prim[2])
    n, v = hull.face_normals, hull.vertices[hull.faces[:, 0]]
    return np.all(np.einsum("fk,pk->pf", n, points) - np.sum(n * v, axis=1) <= tol, axis=1)


@pytest.mark.parametrize("name,kind", COMBOS)
def test_placement_puts_the_contact_on_the_target(name, kind):
    """The task is within the arm's speed limits; at the first contact the tool's contact point is on the
    target point, and no part of the mesh lies
    inside the table or inside any solid of the scene (the board, the tower, the debris, the block) by
    more than PENETRATION_TOL: for the family's default and a drawn tool."""
    for tool in (itup.load_tool(name), families.draw(name, 3)):
        with warnings.catch_warnings():  # within the UR5e's speed limits (a short tool's swing pivots further back)
            warnings.simplefilter("error")
            task = itup.make_task(kind, tool)
        k = _first_contact_step(task)
        R = np.asarray(task.traj.R_world_tool)[k]
        p = np.asarray(task.traj.p_world_tool)[k]
        np.testing.assert_allclose(R @ tool.contact_point + p, np.asarray(task.c_obj_world)[0], atol=1e-6)
        surface = np.concatenate([tool.mesh.vertices, trimesh.sample.sample_surface(tool.mesh, 3000, seed=0)[0]])
        verts = surface @ R.T + p
        above = verts
        if tool.category == "broom":  # its bristle pack bends on the table: the block and the handle must clear it
            above = verts[~_inside_primitive(tool.primitives[0], surface)]
        assert above[:, 2].min() > -PENETRATION_TOL, (tool.name, kind, above[:, 2].min())  # the table top: z = 0
        scene = build_scene(tool, task)
        m, d = scene.model, mujoco.MjData(scene.model)
        mujoco.mj_forward(m, d)
        # the environment: the bodies hung from the world other than the arm and the tool
        env = {b for b in range(1, m.nbody) if m.body_parentid[b] == 0 and m.body(b).name not in ("ur5e/base", "tool")}
        boxes = [g for g in range(m.ngeom) if m.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX and m.geom_bodyid[g] in env]
        assert boxes, kind
        for g in boxes:
            depth = _box_depth(verts, d.geom_xpos[g], d.geom_xmat[g].reshape(3, 3), m.geom_size[g])
            assert depth.max() < PENETRATION_TOL, (tool.name, kind, m.geom(g).name, depth.max())


def _range_ends(fam) -> list[dict]:
    """A family's dimensions at the ends of their ranges: all low, all high, and each alone at either end
    with the rest mid-range; each choice in turn with every dimension mid-range."""
    mid = {k: 0.5 * (lo + hi) for k, (lo, hi) in fam.ranges.items()}
    first = {k: v[0] for k, v in fam.choices.items()}
    out = [{**first, **{k: lo for k, (lo, _) in fam.ranges.items()}}, {**first, **{k: hi for k, (_, hi) in fam.ranges.items()}}]
    out += [{**first, **mid, k: end} for k, ends in fam.ranges.items() for end in ends]
    out += [{**first, **mid, k: v} for k, values in fam.choices.items() for v in values]
    return out


@pytest.mark.parametrize("name", [f for f in families.names() if not families.get(f).builtin])
def test_every_task_of_a_family_is_built_at_the_ends_of_its_ranges(name):
    """make_task places every tool a family can draw: the task's contact meets its target (the reach's
    block face, the nail, the tower, the debris) at the ends of the family's ranges, where a drawn test
    tool can lie (a pry bar's long hook once put its contact above the reach's block)."""
    fam = families.get(name)
    for kw in _range_ends(fam):
        tool = fam.build(name=name, **kw)
        for kind in fam.tasks:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a swing a little over the speed limit: the task stands
                itup.make_task(kind, tool)


def test_a_pry_bars_contact_meets_the_reach_block_for_its_longest_hook(monkeypatch):
    fam = families.get("pry_bar")
    kw = {k: hi for k, (_, hi) in fam.ranges.items()} | {"radius": fam.ranges["radius"][0], "sections": 6}
    itup.make_task("reach", fam.build(name="pry_bar", **kw))
    monkeypatch.setattr(family_shapes, "PRY_CONTACT_FROM_TIP", 1.0)  # halfway along the hook, uncapped
    with pytest.raises(InputError, match="off its face"):
        itup.make_task("reach", fam.build(name="pry_bar", **kw))


@pytest.mark.parametrize("name,kind", [("screwdriver", "knock"), ("pry_bar", "reach"), ("hatchet", "hammer")])
def test_reachable_sampler_returns_only_reachable_grasps(name, kind):
    tool = itup.load_tool(name)
    task = itup.make_task(kind, tool)
    r = sample_reachable(tool, task, 48, seed=0)
    assert r.complete and len(r.grasps) == 48 and r.drawn >= 48
    assert np.all(np.asarray(reachable(task, r.grasps)))  # checked again by the IK
    again = sample_reachable(tool, task, 48, seed=0)
    np.testing.assert_array_equal(np.asarray(again.grasps.p_tool_grasp), np.asarray(r.grasps.p_tool_grasp))
    # a budget too small for the count: what was found, reported as incomplete
    small = sample_reachable(tool, task, 200, seed=0, budget=256)
    assert not small.complete and small.drawn == 256 and len(small.grasps) < 200
    assert small.to_json() == {"requested": 200, "reachable": len(small.grasps), "drawn": 256, "budget": 256,
                               "complete": False}
    with pytest.raises(InputError, match=r"budget must be an integer in n \(10\)\.\.400,000"):
        sample_reachable(tool, task, 10, budget=5)


def test_a_short_tool_swings_about_a_pivot_further_back():
    """The swing's lever grows for a tool too short to reach the impact speed within the joint-speed
    limit; a long one keeps the kind's pivot_offset."""
    from itup_jax.robot import UR5E_MAX_JOINT_SPEED
    from itup_jax.task import SWING_SPEED_SHARE, swing_pivot_offset

    c = np.array([0.003, 0.0, 0.19])  # a screwdriver's contact
    off = swing_pivot_offset(c, 1.0, 0.10)
    assert off > 0.10
    assert np.linalg.norm(c + [0, 0, off]) == pytest.approx(1.0 / (SWING_SPEED_SHARE * UR5E_MAX_JOINT_SPEED))
    assert swing_pivot_offset(np.array([0.06, 0.0, 0.29]), 0.8, 0.10) == 0.10  # the built-in hammer's


def test_a_dataset_of_a_family_draws_its_tools_and_checks_its_tasks():
    from itup_jax.dataset import GenerateConfig, unit_tool

    c = GenerateConfig(tasks=("knock",), tools_per_task=2, grasps=4, seed=3, family="screwdriver")
    c.validate()
    (t0, _), (t1, _) = unit_tool(c, "knock", 0), unit_tool(c, "knock", 1)
    assert t0.name == "screwdriver" and t1.name.startswith("screwdriver@") and t0.mass != t1.mass
    assert GenerateConfig.from_json(c.to_json()) == c and "family" not in GenerateConfig().to_json()
    with pytest.raises(InputError, match="family 'squeegee' does the tasks"):
        GenerateConfig(tasks=("hammer",), family="squeegee").validate()
