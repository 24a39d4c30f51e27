"""A table with tools lying on it at rest, and the task targets: the scene the full pipeline starts from.

    from itup_jax import tabletop
    top = tabletop.make_tabletop(seed=3)                 # the four built-in tools, apart
    top = tabletop.make_tabletop(clutter=4, seed=3)      # and four procedural tools among them, close
    top.tools, top.poses                                 # Tool objects; [N, 4, 4] tool frames in the world
    tabletop.picture(top, "scene.png")                   # rendered (or a top view), tools numbered, parts lettered

Tools are dropped onto the table in MuJoCo (`drop`): each starts lying (its handle axis horizontal) at a
random yaw and roll, a little above the table, and falls and settles under gravity with the table's
and the other tools' contacts, until every tool is at rest (`REST_SPEED`). The layout is reproducible
from the seed. Without clutter the tools lie in separate lanes of the tool area; with clutter the extra
tools are dropped among them at random, so tools touch and lie close.

The tool area (`FOOTPRINT_AREA`) is the table's left side as the robot sees it (world +y), each tool's
grasp region within the UR5e's reach for grasps from above (`GRASP_RADIUS`); the task targets (the nail in its board, the debris, the tower, the
block) stand in front of the robot (`tasks`), where the task's own scene places them.

The picture (`picture`) is MuJoCo's offscreen rendering where an OpenGL backend works (`render.py`),
else a top view drawn with matplotlib (no OpenGL): a number per tool (1-based, the numbers an
instruction may use: "tool 2"), a letter per part ("2a"), the targets' names. In the rendering the
targets stand in a row on the robot's right (TARGET_ROW), each as its task's scene builds it: each task
runs in its own scene with its target in front of the robot; the top view marks them there. It is the
image `vlm.VLMGrounder` sends.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import mujoco
import numpy as np

from itup_jax.errors import InputError, check_seed
from itup_jax.grounding import TARGETS
from itup_jax.rotations import axis_angle_matrix_np
from itup_jax.tools import Tool, families, load_tool

#: m/s, a tool is at rest when every point of it moves slower than this.
REST_SPEED = 0.005
#: s, the drop's step, how long it runs at least and at most.
DROP_TIMESTEP = 0.002
DROP_MIN_TIME = 1.0
DROP_MAX_TIME = 6.0
#: -, friction of a tool on the table and on another tool (wood and metal on wood; assumed).
TABLE_FRICTION = 0.5
#: m, rolling friction of a tool on the table and on another tool (a round bar on wood stops rolling
#: within centimetres; assumed).
ROLLING_FRICTION = 0.002
#: No-slip solver iterations of the drop (and the pick): without them a tool lying across two others
#: crept at ~2 mm/s and never came to rest.
NOSLIP_ITERATIONS = 4
#: The procedural families clutter is drawn from (the built-in tools are the default layout).
CLUTTER_FAMILIES = ("screwdriver", "spanner", "pry_bar", "hatchet", "squeegee")
#: The most clutter tools a table takes (eight piled up did not always come to rest).
MAX_CLUTTER = 6
#: The built-in tools a table holds by default.
DEFAULT_TOOLS = ("hammer", "broom", "mallet", "l_stick")


@dataclasses.dataclass(frozen=True, eq=False)
class Tabletop:
    """Tools at rest on the table, and the task targets.

    Attributes:
      tools: the tools (tool frames as in `Tool`).
      poses: [N, 4, 4] each tool frame's pose in the world (metres), at rest.
      targets: the task targets on the table ('nail', 'debris', 'tower', 'block').
      seed: the layout's seed.  clutter: how many of the tools are clutter (the last ones).
      settle_time: s, how long the drop ran until every tool was at rest.
      rest_speed: m/s, the fastest tool point's speed at the end of the drop.
    """

    tools: tuple[Tool, ...]
    poses: np.ndarray
    targets: tuple[str, ...]
    seed: int
    clutter: int
    settle_time: float
    rest_speed: float

    def to_json(self) -> dict:
        from itup_jax.tools import parts

        return {"seed": self.seed, "clutter": self.clutter, "targets": list(self.targets),
                "settle_time_s": round(self.settle_time, 3), "rest_speed_m_s": float(self.rest_speed),
                "tools": [{"number": i + 1, "name": t.name, "category": t.category, "mass_kg": round(t.mass, 4),
                           "pose": np.round(self.poses[i], 5).tolist(),
                           "parts": [p.name for p in parts.tool_parts(t)]} for i, t in enumerate(self.tools)]}


def add_table_tool(spec: mujoco.MjSpec, i: int, tool: Tool, T: np.ndarray) -> list[str]:
    """A free body 'tool_<i>' at pose T that collides with the table and the other tools
    (`sim.scene.add_tool_body`). Returns the geom names."""
    from itup_jax.rotations import matrix_to_quat_np
    from itup_jax.sim.scene import add_tool_body

    return add_tool_body(spec, tool, f"tool_{i}", pos=T[:3, 3], quat=matrix_to_quat_np(T[:3, :3]), contype=1, conaffinity=1,
                         friction=[TABLE_FRICTION, 0.005, ROLLING_FRICTION], condim=6)


def _drop_model(tools: Sequence[Tool], poses: np.ndarray) -> mujoco.MjModel:
    return tools_spec(tools, poses, DROP_TIMESTEP).compile()


def tools_spec(tools: Sequence[Tool], poses: np.ndarray, timestep: float) -> mujoco.MjSpec:
    """The table and `tools` at `poses` [N, 4, 4], free, with the drop's contact options (step `timestep`)."""
    spec = mujoco.MjSpec()
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    # soft contacts let a tool resting across others creep (millimetres a second): impratio and a few
    # no-slip iterations hold static friction
    spec.option.impratio = 10.0
    spec.option.noslip_iterations = NOSLIP_ITERATIONS
    spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.5, 1.5, 0.01],
                            friction=[TABLE_FRICTION, 0.005, ROLLING_FRICTION], contype=1, conaffinity=1, condim=6)
    for i, (t, T) in enumerate(zip(tools, poses)):
        add_table_tool(spec, i, t, T)
    return spec


def _lying_pose(tool: Tool, xy: np.ndarray, yaw: float, roll: float, z_gap: float) -> np.ndarray:
    """A pose with the tool's handle axis (its z) horizontal along yaw, turned by `roll` about it, its
    lowest point z_gap above the table."""
    R = axis_angle_matrix_np((0, 0, 1), yaw) @ axis_angle_matrix_np((0, 1, 0), math.pi / 2) @ axis_angle_matrix_np((0, 0, 1), roll)
    v = np.asarray(tool.mesh.vertices, float) @ R.T
    centre = 0.5 * (v.min(0) + v.max(0))
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [xy[0] - centre[0], xy[1] - centre[1], z_gap - v[:, 2].min()]
    return T


def _footprint(tool: Tool, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    v = np.asarray(tool.mesh.vertices, float) @ T[:3, :3].T + T[:3, 3]
    return v[:, :2].min(0), v[:, :2].max(0)


def _hull(tool: Tool, T: np.ndarray) -> np.ndarray:
    """The tool's footprint on the table at pose T: its 2-D convex hull [M, 2] (m)."""
    from scipy.spatial import ConvexHull

    v = (np.asarray(tool.mesh.vertices, float) @ T[:3, :3].T + T[:3, 3])[:, :2]
    return v[ConvexHull(v).vertices]


def _cells(hull: np.ndarray, grow: float) -> np.ndarray:
    """[G, G] bool: the cells of the layout grid (LAYOUT_CELL) within `grow` m of the footprint."""
    from matplotlib.path import Path

    inside = Path(hull).contains_points(_GRID, radius=0.0)
    if grow > 0:
        d = np.min(np.linalg.norm(_GRID[:, None, :] - hull[None, ::max(1, len(hull) // 24)], axis=-1), axis=1)
        inside |= d <= grow
    return inside.reshape(_GRID_SHAPE)


#: m, the layout grid's cell, and the grid over the table area tools may cover (FOOTPRINT_AREA).
LAYOUT_CELL = 0.005
#: m, x and y ranges that every tool's footprint stays within.
FOOTPRINT_AREA = ((0.05, 0.80), (0.16, 0.76))
#: m, the distance from the robot's base axis within which each tool's grasp region's centre lies.
GRASP_RADIUS = (0.30, 0.66)
#: m, the gap between tools laid apart (no clutter).
APART_GAP = 0.03
_gx = np.arange(FOOTPRINT_AREA[0][0], FOOTPRINT_AREA[0][1], LAYOUT_CELL)
_gy = np.arange(FOOTPRINT_AREA[1][0], FOOTPRINT_AREA[1][1], LAYOUT_CELL)
_GRID_SHAPE = (len(_gx), len(_gy))
_GRID = np.stack(np.meshgrid(_gx, _gy, indexing="ij"), -1).reshape(-1, 2)


#: Drops tried (each from a new layout) before giving up on a table that does not come to rest.
DROP_TRIES = 4
#: Whole layouts tried before giving up, and placements tried per tool in each.
LAYOUT_TRIES = 30
PLACE_TRIES = 400


def _layout(tools: Sequence[Tool], n_apart: int, rng: np.random.Generator) -> np.ndarray:
    """`_layout_once` until every tool has found a place (LAYOUT_TRIES layouts at most)."""
    for _ in range(LAYOUT_TRIES):
        poses = _layout_once(tools, n_apart, rng)
        if poses is not None:
            return poses
    raise InputError(f"make_tabletop: no room for the {len(tools)} tools in the tool area {FOOTPRINT_AREA} m after "
                     f"{LAYOUT_TRIES} layouts (try fewer tools or another seed)")


def _layout_once(tools: Sequence[Tool], n_apart: int, rng: np.random.Generator) -> np.ndarray | None:
    """Initial lying poses (None when a tool finds no place): the first n_apart tools with footprints APART_GAP apart and their handles
    roughly radial from the robot; the rest (clutter) at any yaw and place, their footprints free to
    overlap the others', dropped from above them. Every footprint lies in FOOTPRINT_AREA and every grasp
    region's centre within GRASP_RADIUS of the robot."""
    (x0, x1), (y0, y1) = FOOTPRINT_AREA
    taken = np.zeros(_GRID_SHAPE, bool)
    poses = []
    for i, t in enumerate(tools):
        g = 0.5 * (t.grasp_region.lo + t.grasp_region.hi)
        for _ in range(PLACE_TRIES):
            roll = rng.uniform(-math.pi, math.pi)
            xy = np.array([rng.uniform(x0, x1), rng.uniform(y0, y1)])
            if i < n_apart:  # handle towards the robot, the working end away (jittered)
                yaw = math.atan2(xy[1], xy[0]) + rng.uniform(-0.5, 0.5) + (math.pi if rng.random() < 0.3 else 0.0)
                z = 0.003
            else:
                yaw = rng.uniform(-math.pi, math.pi)
                z = 0.06 + 0.05 * (i - n_apart)
            T = _lying_pose(t, xy, yaw, roll, z)
            hull = _hull(t, T)
            if hull[:, 0].min() < x0 or hull[:, 0].max() > x1 or hull[:, 1].min() < y0 or hull[:, 1].max() > y1:
                continue
            r = float(np.linalg.norm((T[:3, :3] @ g + T[:3, 3])[:2]))
            if not GRASP_RADIUS[0] <= r <= GRASP_RADIUS[1]:
                continue
            if i < n_apart:
                cells = _cells(hull, APART_GAP)
                if np.any(cells & taken):
                    continue
                taken |= cells
            poses.append(T)
            break
        else:
            return None
    return np.array(poses)


def point_speeds(m: mujoco.MjModel, d: mujoco.MjData, tools: Sequence[Tool]) -> float:
    """The fastest speed (m/s) of any tool's bounding-box corner."""
    best = 0.0
    for i, t in enumerate(tools):
        jnt = m.joint(f"tool_{i}")
        v, w = d.qvel[jnt.dofadr[0]:jnt.dofadr[0] + 3], d.qvel[jnt.dofadr[0] + 3:jnt.dofadr[0] + 6]
        lo, hi = t.mesh.bounds
        radius = float(np.linalg.norm(np.maximum(np.abs(lo), np.abs(hi))))
        best = max(best, float(np.linalg.norm(v) + np.linalg.norm(w) * radius))
    return best


def drop(tools: Sequence[Tool], poses: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Let the tools fall from `poses` [N, 4, 4] onto the table and settle. Returns (rest poses [N, 4, 4],
    the time it took (s), the fastest tool point's speed at the end (m/s)). Raises InputError when they
    have not come to rest within DROP_MAX_TIME."""
    m = _drop_model(tools, poses)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    t, speed = 0.0, math.inf
    check_every = int(round(0.05 / DROP_TIMESTEP))
    while t < DROP_MAX_TIME:
        mujoco.mj_step(m, d, nstep=check_every)
        t += check_every * DROP_TIMESTEP
        speed = point_speeds(m, d, tools)
        if t >= DROP_MIN_TIME and speed < REST_SPEED:
            break
    else:
        raise InputError(f"make_tabletop: the tools did not come to rest within {DROP_MAX_TIME} s (fastest point "
                         f"{speed:.3f} m/s)")
    return tool_poses(m, d, len(tools)), t, speed


def tool_poses(m: mujoco.MjModel, d: mujoco.MjData, n: int) -> np.ndarray:
    """[n, 4, 4] the world poses of the bodies 'tool_0' .. 'tool_<n-1>' in MuJoCo's current state."""
    out = np.empty((n, 4, 4))
    for i in range(n):
        b = m.body(f"tool_{i}").id
        out[i] = np.eye(4)
        out[i][:3, :3] = d.xmat[b].reshape(3, 3)
        out[i][:3, 3] = d.xpos[b]
    return out


def rest_loads(top: Tabletop, index: int) -> tuple[np.ndarray, np.ndarray]:
    """The forces the other tools exert on tool `index` where they touch it, at rest: (points [K, 3] m,
    forces [K, 3] N), world frame, one row per MuJoCo contact (a tool lying across it presses down on
    it; the table's own contacts are left out). Solved by MuJoCo's constraint solver at the rest poses
    (`mj_forward`: each tool's contact forces balance its weight)."""
    if not 0 <= index < len(top.tools):
        raise InputError(f"rest_loads: index {index} is not one of the table's 0-{len(top.tools) - 1}")
    m = _drop_model(top.tools, top.poses)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return tool_contacts(m, d, m.body(f"tool_{index}").id)


def tool_contacts(m: mujoco.MjModel, d: mujoco.MjData, body: int) -> tuple[np.ndarray, np.ndarray]:
    """The contacts of `body` with other bodies than the world's (the table) in MuJoCo's current state:
    (points [K, 3] m, forces on `body` [K, 3] N), world frame."""
    points, forces = [], []
    f6 = np.zeros(6)
    for k in range(d.ncon):
        c = d.contact[k]
        b1, b2 = int(m.geom_bodyid[c.geom1]), int(m.geom_bodyid[c.geom2])
        if body not in (b1, b2) or 0 in (b1, b2):
            continue
        mujoco.mj_contactForce(m, d, k, f6)
        f = c.frame.reshape(3, 3).T @ f6[:3]  # on geom2's body, from geom1's (world)
        points.append(np.array(c.pos))
        forces.append(f if body == b2 else -f)
    return np.reshape(points, (-1, 3)), np.reshape(forces, (-1, 3))


def _as_tools(tools: Sequence[Tool | str] | None) -> list[Tool]:
    if tools is None:
        return [load_tool(n) for n in DEFAULT_TOOLS]
    if isinstance(tools, (str, Tool)) or not isinstance(tools, Sequence) or not tools:
        raise InputError("make_tabletop: tools must be a non-empty list of tools or tool names")
    return [t if isinstance(t, Tool) else load_tool(t) for t in tools]


def make_tabletop(tools: Sequence[Tool | str] | None = None, *, clutter: int = 0, seed: int = 0,
                  targets: Sequence[str] | None = None) -> Tabletop:
    """A table with `tools` (default: the four built-in tools) apart in the tool area and `clutter`
    procedural tools (drawn from CLUTTER_FAMILIES) dropped among them, all at rest; `targets` the task
    targets on the table (default all four). The same seed gives the same table."""
    check_seed(seed, "make_tabletop")
    if isinstance(clutter, bool) or not isinstance(clutter, (int, np.integer)) or not 0 <= clutter <= MAX_CLUTTER:
        raise InputError(f"make_tabletop: clutter must be an integer in 0..{MAX_CLUTTER} (extra tools), got {clutter!r}")
    base = _as_tools(tools)
    if len(base) > 6:
        raise InputError(f"make_tabletop: at most 6 tools lie apart on the table, got {len(base)}; add more as clutter")
    known = tuple(TARGETS.values())
    targets = known if targets is None else tuple(targets)
    bad = [t for t in targets if t not in known]
    if bad:
        raise InputError(f"make_tabletop: unknown target(s) {bad}; known: {', '.join(known)}")
    rng = np.random.default_rng([int(seed), 7713])
    extra = [families.draw(CLUTTER_FAMILIES[int(rng.integers(len(CLUTTER_FAMILIES)))], int(rng.integers(10**6)))
             for _ in range(int(clutter))]
    all_tools = base + extra
    for attempt in range(DROP_TRIES):  # a pile that does not settle is dropped again from a new layout
        try:
            poses, t, speed = drop(all_tools, _layout(all_tools, len(base), rng))
            break
        except InputError:
            if attempt == DROP_TRIES - 1:
                raise
    return Tabletop(tools=tuple(all_tools), poses=poses, targets=targets, seed=int(seed), clutter=int(clutter),
                    settle_time=t, rest_speed=speed)


def target_positions() -> dict[str, np.ndarray]:
    """Each target's position on the table (m, world), as the task kinds' defaults place it for their
    default tools (the nail head, the first debris cube, the tower's struck face, the block)."""
    from itup_jax import tasks
    from itup_jax.task import make_task

    out = {}
    for kind, name in TARGETS.items():
        if kind in tasks.names():
            task = make_task(kind, load_tool(tasks.get(kind).default_tool))
            out[name] = np.asarray(task.c_obj_world, float)[0]
    return out


#: Where each target's label goes from its mark: (dx, dy) m, horizontal and vertical alignment.
_LABEL_PLACE = {"nail": (0.02, 0.0, "left", "center"), "tower": (-0.02, 0.0, "right", "center"),
                "debris": (0.0, -0.03, "center", "top"), "block": (0.0, -0.03, "center", "top")}


#: The picture's views (`picture`).
VIEWS = ("auto", "camera", "top")
#: The camera view's camera: looking from behind the robot (world +x ahead, the tool area on the left).
CAMERA_VIEW = {"lookat": (0.42, 0.12, 0.0), "distance": 1.55, "azimuth": 0.0, "elevation": -58.0}
#: Pixels of the camera view.
CAMERA_SIZE = (960, 760)
#: m, where the camera view stands each target (in a row on the robot's right, -y; module docstring).
TARGET_ROW = {"tower": (0.86, -0.2), "nail": (0.66, -0.2), "debris": (0.44, -0.27), "block": (0.2, -0.3)}


def picture(top: Tabletop, path: str | None = None, *, title: str | None = None, highlight: int | None = None,
            view: str = "auto"):
    """A picture of the table with numbered tools and lettered parts (module docstring): `view` 'camera'
    (MuJoCo's offscreen renderer; `render.RenderUnavailable` where no OpenGL backend works), 'top' (a
    drawing, no OpenGL), or 'auto' (the camera where `render.gl_backend()` finds a backend, else the top
    view). `highlight`: the 0-based index of a tool to draw strong, the others faint. Writes a PNG to
    `path` when given; returns the matplotlib Figure (its texts are the marks)."""
    if resolve_view(view) == "camera":
        fig = _camera_picture(top, title=title, highlight=highlight)
    else:
        fig = _top_picture(top, title=title, highlight=highlight)
    if path is not None:
        fig.savefig(path)
    return fig


def resolve_view(view: str) -> str:
    """The view `picture` draws for `view`: 'camera' or 'top' ('auto': the camera where an OpenGL backend
    works). InputError for a view not in VIEWS; `render.RenderUnavailable` for 'camera' where no
    backend works (checked before any drawing)."""
    from itup_jax import render

    if view not in VIEWS:
        raise InputError(f"picture: view {view!r} is not one of {', '.join(VIEWS)}")
    if view == "camera":
        render.require_gl()
    if view == "auto":
        return "camera" if render.gl_backend() is not None else "top"
    return view


def _render_model(top: Tabletop, highlight: int | None) -> tuple[mujoco.MjModel, dict[str, np.ndarray]]:
    """The table, the tools at their poses (their meshes, each in its colour), the targets in TARGET_ROW
    (their geoms as their tasks' scenes place them) and the robot's base; static. Returns the model and
    each target's label point (m, world)."""
    import matplotlib.pyplot as plt

    from itup_jax import tasks
    from itup_jax.rotations import matrix_to_quat_np
    from itup_jax.sim.scene import MJCF_DIR
    from itup_jax.task import make_task

    spec = mujoco.MjSpec()
    spec.visual.headlight.ambient = [0.4, 0.4, 0.4]
    spec.visual.headlight.diffuse = [0.3, 0.3, 0.3]
    spec.visual.headlight.specular = [0.0, 0.0, 0.0]
    spec.worldbody.add_light(pos=[0.4, 0.2, 2.5], dir=[0, 0, -1], diffuse=[0.45, 0.45, 0.45], specular=[0.1, 0.1, 0.1])
    spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.5, 1.5, 0.01],
                            rgba=[0.85, 0.82, 0.75, 1])
    spec.worldbody.add_geom(name="robot_base", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.075, 0.045, 0],
                            pos=[0, 0, 0.045], rgba=[0.3, 0.3, 0.32, 1])
    colours = plt.get_cmap("tab10")
    for i, (t, T) in enumerate(zip(top.tools, top.poses)):
        spec.add_mesh(name=f"tool_{i}", uservert=np.asarray(t.mesh.vertices, float).ravel(),
                      userface=np.asarray(t.mesh.faces, np.int32).ravel())
        rgba = list(colours(i % 10))
        if highlight is not None and highlight != i:
            rgba = [0.6 + 0.4 * c for c in rgba[:3]] + [1.0]  # faint: towards white
        body = spec.worldbody.add_body(name=f"tool_{i}", pos=T[:3, 3], quat=matrix_to_quat_np(T[:3, :3]))
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"tool_{i}", rgba=rgba)
    labels = {}
    for kind, name in TARGETS.items():
        if name not in top.targets or kind not in tasks.names():
            continue
        k = tasks.get(kind)
        scene_spec = mujoco.MjSpec.from_file(str(MJCF_DIR / k.scene_file))
        k.place(scene_spec, make_task(kind, load_tool(k.default_tool)))
        m = scene_spec.compile()
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        keep = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0 and m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH]
        if not keep:
            continue
        xy = np.mean(d.geom_xpos[keep, :2], axis=0)
        shift = np.r_[np.asarray(TARGET_ROW[name]) - xy, 0.0]
        for g in keep:
            quat = np.empty(4)
            mujoco.mju_mat2Quat(quat, d.geom_xmat[g])
            spec.worldbody.add_geom(type=mujoco.mjtGeom(m.geom_type[g]), size=m.geom_size[g], pos=d.geom_xpos[g] + shift,
                                    quat=quat, rgba=m.geom_rgba[g])
        top_z = max(float(d.geom_xpos[g, 2] + m.geom_rbound[g]) for g in keep)
        labels[name] = np.r_[TARGET_ROW[name], top_z]
    return spec.compile(), labels


def _tool_marks(top: Tabletop) -> list[tuple[dict[str, np.ndarray], np.ndarray]]:
    """The marks both views draw, per tool: its parts' labels ('2a': tool 2's first part) with each
    part's centre, and its grasp part's centre, where its number goes (m, world)."""
    from itup_jax.tools import parts

    out = []
    for i, (t, T) in enumerate(zip(top.tools, top.poses)):
        ps = parts.tool_parts(t)
        centres = [T[:3, :3] @ (0.5 * (p.region.lo + p.region.hi)) + T[:3, 3] for p in ps]
        handle = next(k for k, p in enumerate(ps) if "grasp" in p.roles)
        out.append(({f"{i + 1}{chr(97 + k)}": c for k, c in enumerate(centres)}, centres[handle]))
    return out


def _camera_picture(top: Tabletop, *, title: str | None, highlight: int | None):
    """The table rendered offscreen by MuJoCo (CAMERA_VIEW), the marks drawn where `render.project` puts
    their points."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from itup_jax import render

    m, target_labels = _render_model(top, highlight)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    cam = render.free_camera(**CAMERA_VIEW)
    w, h = CAMERA_SIZE
    with render.Offscreen(m, w, h) as off:
        rgb = off.render(d, cam)
    glcam = render.gl_camera(m, d, cam)

    def at(point):
        return render.project(np.asarray(point, float)[None], glcam, w, h)[0][0]

    dpi = 110
    fig = plt.figure(figsize=(w / dpi, (h + 40) / dpi), dpi=dpi)
    ax = fig.add_axes([0, 0, 1, h / (h + 40)])
    ax.imshow(rgb)
    ax.set_axis_off()
    colours = plt.get_cmap("tab10")
    for i, (part_marks, grip) in enumerate(_tool_marks(top)):
        for label, centre in part_marks.items():
            ax.annotate(label, at(centre), fontsize=7, ha="center", va="center", color="black",
                        bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.75))
        ax.annotate(str(i + 1), at(grip) + np.array([0.0, -24.0]), fontsize=13, weight="bold", ha="center",
                    va="center", color=colours(i % 10), bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
    for name, point in target_labels.items():
        ax.annotate(name, at(point) + np.array([0.0, -12.0]), fontsize=9, ha="center", va="bottom", color="crimson",
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8))
    ax.annotate("robot", at([0.0, 0.0, 0.1]) + np.array([0.0, -8.0]), fontsize=9, ha="center", va="bottom")
    fig.suptitle(title or f"table, seed {top.seed}: tools numbered, parts lettered", y=0.995, va="top", fontsize=11)
    return fig


def _top_picture(top: Tabletop, *, title: str | None, highlight: int | None):
    """The top view: the tools' outlines, the targets where their tasks place them."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    fig, ax = plt.subplots(figsize=(7.5, 7.5), dpi=110)
    ax.set_facecolor((0.93, 0.9, 0.84))
    colours = plt.get_cmap("tab10")
    for i, ((t, T), (part_marks, at)) in enumerate(zip(zip(top.tools, top.poses), _tool_marks(top))):
        v = np.asarray(t.mesh.vertices, float) @ T[:3, :3].T + T[:3, 3]
        tri = v[np.asarray(t.mesh.faces)][:, :, :2]
        c = colours(i % 10)
        ax.add_collection(PolyCollection(tri, facecolors=[c], edgecolors="none", alpha=0.9 if highlight in (None, i) else 0.35))
        for label, centre in part_marks.items():
            ax.annotate(label, centre[:2], fontsize=7, ha="center", va="center", color="black",
                        bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7))
        # the number beside the handle
        ax.annotate(str(i + 1), (at[0] - 0.035, at[1]), fontsize=13, weight="bold", ha="center", va="center", color=c)
    for name, p in target_positions().items():
        if name in top.targets:  # the nail and the tower stand close: their labels go either side
            dx, dy, ha, va = _LABEL_PLACE.get(name, (0.0, -0.03, "center", "top"))
            ax.plot(p[0], p[1], marker="X", ms=11, color="crimson")
            ax.annotate(name, (p[0] + dx, p[1] + dy), fontsize=9, ha=ha, va=va, color="crimson")
    ax.plot(0, 0, marker="o", ms=14, color="dimgray")
    ax.annotate("robot", (0, -0.04), fontsize=9, ha="center", va="top")
    ax.set_xlim(-0.1, 1.0)
    ax.set_ylim(-0.45, 0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, forward)")
    ax.set_ylabel("y (m, left)")
    ax.set_title(title or f"table, seed {top.seed}: tools numbered, parts lettered")
    fig.tight_layout()
    return fig
