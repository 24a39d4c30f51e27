"""Label datasets for SDG-Net: shards of arrays plus a manifest (`itup generate`).

    manifest = generate("data/", GenerateConfig(tasks=("hammer",), tools_per_task=4, grasps=256))

One shard per (task, tool variant): the tool (variant 0 is the built-in, the others are procedural
variants of it: `vary_tool` stretches the whole tool, `part_variant` varies its handle and head
independently; `GenerateConfig.variants`), `grasps` sampled grasps, their rollouts in MuJoCo with
randomised physics (`simulate`), each grasp's second rollout at a weak grip on the same physics draw
(`weak_rollouts`, labels `label_weak_*`), the SDG-Net features (`features.py`) and the analytic costs. Every shard is a
.npz written atomically (temporary file, then rename) with fixed zip timestamps, so the same config
and seed give the same bytes. The manifest (JSON, also written atomically after each shard) holds the
config, seed, code version, per-shard SHA-256 and the counts of valid, diverged and infeasible
rollouts. A run killed at any point and started again skips the shards whose checksum matches and
makes the rest: nothing lost, nothing duplicated. Several processes, on one machine or on several
sharing the folder, make one dataset together (`generate(..., process_index=i, process_count=n)`,
`itup generate --process-index I --process-count N`): each makes every n-th shard and adds it to the
one manifest under a file lock, so the finished folder is the one a single process makes. Diverged
and infeasible rollouts are stored with their flags (and counted) so that nothing is dropped silently
(an infeasible rollout is not stepped: its measured labels are NaN); `load_shard(valid_only=True)`
gives the labels.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import inspect
import io
import json
import os
import warnings
import zipfile
from collections.abc import Callable, Collection, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from itup_jax import __version__
from itup_jax.atomic import atomic_write
from itup_jax.costs import CostParams, wrench_costs
from itup_jax.errors import InputError, is_integer
from itup_jax.features import FeatureSpec, batched_features, tool_field
from itup_jax.grasp import Grasps
from itup_jax.grasp_sampler import CONTACT_MODELS, SamplerConfig, sample_grasps
from itup_jax.scene import TIMESTEP, build_scene, check_timestep, task_timestep
from itup_jax.simulate import (
    DETERMINISTIC_GPU_FLAG,
    LABEL_FIELDS,
    Randomization,
    SimConfig,
    default_backend,
    gpu_determinism,
    simulate,
)
from itup_jax.task import DEFAULT_TOOL, TASK_KINDS, Task, make_task
from itup_jax.tool import BUILTIN_TOOLS as BUILDERS
from itup_jax.tool import Box, Tool, load_tool, make_tool_params
from itup_jax.wrench import task_loads

FORMAT = "itup.dataset/1"
MANIFEST = "manifest.json"
#: The version of the labels: what a row's labels mean (scenes, thresholds, measures). It changes only
#: when labels change (CHANGELOG.md lists each change), not with the package's version. A dataset records
#: it, and a folder of another label version refuses to resume (its rows would mean something else).
LABEL_VERSION = "0.11.0"
LOCK = ".manifest.lock"  # the manifest's read-modify-write lock (`_manifest_lock`): an empty file
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed timestamps: byte-reproducible shards


# ---------------------------------------------------------------------------------------------------
# Procedural tool variants
# ---------------------------------------------------------------------------------------------------
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
        else:
            _, lo, hi = prim
            prims.append(("box", D @ lo, D @ hi))
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
    built-in's). Built by the tool's own parametric builder (`tool.claw_hammer`, ...), so mass properties
    come from the parts' meshes and densities. Name: '<base>#<seed>'."""
    if base not in PART_RANGES:
        raise InputError(f"part_variant: base must be one of {sorted(PART_RANGES)}, got {base!r}")
    rng = np.random.default_rng(seed)
    f = {k: rng.uniform(*r) for k, r in PART_RANGES[base].items()}
    name = f"{base}#{seed}"
    d = {k: p.default for k, p in inspect.signature(BUILDERS[base]).parameters.items()}  # the built-in's dimensions
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
        return BUILDERS[base](name=name, **kw)
    if base == "broom":
        w, h = d["half_width"] * f["half_width"], d["bristle_height"] * f["bristle_height"]
        b0 = d["bristle_height"] + 0.030  # the built-in block's top
        length = (d["handle_top"] - b0) * f["handle_length"]
        hr = d["handle_radius"] * f["handle_radius"]
        return BUILDERS[base](name=name, half_width=w, bristle_height=h, handle_radius=hr, handle_top=h + 0.030 + length,
                              grasp_bottom=h + 0.030 + (d["grasp_bottom"] - b0) * f["handle_length"],
                              contact_x=d["contact_x"] * f["half_width"], grasp_half=max(0.02, hr + 0.009))
    return BUILDERS[base](name=name, shaft=d["shaft"] * f["shaft"], radius=d["radius"] * f["radius"],
                          hook_end=d["hook_end"] * f["hook_end"], contact_x=d["contact_x"] * f["hook_end"],
                          grasp_top=d["grasp_top"] * f["shaft"])


VARIANT_FAMILIES = ("stretch", "parts")  # `vary_tool`, `part_variant`

#: N per pad: the weak grip at which `generate` rolls every candidate out a second time (`weak_rollouts`),
#: a little above the Robotiq 2F-85's least setting of 20 N. At the default grip (100 N, +-20 %) almost
#: no grasp fails in the grip, and the grasps that fail at a weak grip are not ranked by anything the
#: default rollout measures (docs/results.md, "What fails under a weak grip"): this rollout labels them.
WEAK_GRIP = 25.0
#: The labels of the weak-grip rollout, stored per row as `label_weak_<name>` (`simulate.Labels`' meaning).
WEAK_FIELDS = ("failed", "success", "slip_translation", "slip_rotation", "valid")


# ---------------------------------------------------------------------------------------------------
# Generation
# ---------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class GenerateConfig:
    """What `generate` makes: per task, `tools_per_task` tools (the built-in + variants) x `grasps`."""

    tasks: tuple = TASK_KINDS
    tools_per_task: int = 4
    grasps: int = 128
    seed: int = 0
    backend: str | None = None
    randomize: bool = True
    feature_spec: dict = dataclasses.field(default_factory=lambda: FeatureSpec().to_dict())
    # s, the scenes' integration step for every task; None: each task's own (`scene.TASK_TIMESTEP`).
    # Contacts are the same at any step (scene.py). Labels made at different steps differ
    # (experiments/timestep_convergence.py), so one task's rows of different steps are not mixed
    # (`load_datasets`); the manifest records each task's step
    timestep: float | None = None
    # the procedural family of variants >= 1: "stretch" (`vary_tool`)
    # or "parts" (`part_variant`: handle and head varied independently)
    variants: str = "stretch"
    # the grasp sampler's contact model (`SamplerConfig.contact`): "flat" (the pads lie flat on the tool;
    # since code 0.6.0) or "point" (every dataset up to code 0.5.0; a manifest without the key)
    contact: str = "flat"
    # a tool family (`families.FAMILIES`) whose tools every shard draws instead of the task's built-in tool
    # and its variants: variant 0 the family's default tool, v >= 1 `families.draw`; None: the built-ins
    family: str | None = None
    # N per pad: every candidate is rolled out a second time at this fixed grip, on the same physics
    # draw otherwise (`weak_rollouts`; labels `label_weak_*`, WEAK_FIELDS); about doubles the stepping.
    # None: no second rollout (every dataset before label version 0.11.0; a manifest without the key)
    weak_grip: float | None = WEAK_GRIP

    def validate(self) -> None:
        unknown = set(self.tasks) - set(TASK_KINDS)
        if not self.tasks or unknown:
            raise InputError(f"generate: tasks must be among {TASK_KINDS}, got {list(self.tasks)}")
        if self.variants not in VARIANT_FAMILIES:
            raise InputError(f"generate: variants must be one of {VARIANT_FAMILIES}, got {self.variants!r}")
        if self.contact not in CONTACT_MODELS:
            raise InputError(f"generate: contact must be one of {CONTACT_MODELS}, got {self.contact!r}")
        if self.tools_per_task < 1 or self.grasps < 1:
            raise InputError(f"generate: tools_per_task and grasps must be >= 1, got {self.tools_per_task}, {self.grasps}")
        if self.timestep is not None:
            check_timestep(self.timestep, "generate")
        if self.weak_grip is not None:
            from itup_jax.stress import check_grip

            check_grip(self.weak_grip, "generate: weak_grip")
        if self.family is not None:
            from itup_jax import families

            fam = families.get(self.family)
            if set(self.tasks) - set(fam.tasks):
                raise InputError(f"generate: family {self.family!r} does the tasks {list(fam.tasks)}, not "
                                 f"{sorted(set(self.tasks) - set(fam.tasks))}; give --tasks {','.join(fam.tasks)}")

    def task_timestep(self, kind: str) -> float:
        """s, the step `kind`'s scenes are integrated at."""
        return task_timestep(kind) if self.timestep is None else float(self.timestep)

    def to_json(self) -> dict:
        """The config as the manifest records it. The default family, "stretch", and the point-contact
        sampler are left out, so that a config made before `variants` or `contact` existed reads the same
        and its datasets resume."""
        d = dict(dataclasses.asdict(self), tasks=list(self.tasks))
        if d["variants"] == "stretch":
            del d["variants"]
        if d["contact"] == "point":
            del d["contact"]
        if d["family"] is None:
            del d["family"]
        if d["weak_grip"] is None:
            del d["weak_grip"]
        return d

    @classmethod
    def from_json(cls, d: dict) -> "GenerateConfig":
        """The config a manifest records (`to_json`'s inverse); unknown keys are refused. A config
        recording no timestep (made before steps were recorded) was simulated at 2 ms; one recording no
        contact model (made before code 0.6.0) sampled point-contact grasps; one recording no weak grip
        (labels before 0.11.0, or `weak_grip=None`) has no weak-grip rollouts."""
        names = {f.name for f in dataclasses.fields(cls)}
        if set(d) - names:
            raise InputError(f"generate config: unknown keys {sorted(set(d) - names)}")
        return cls(**dict(d, tasks=tuple(d.get("tasks", TASK_KINDS)), timestep=d.get("timestep", TIMESTEP),
                          contact=d.get("contact", "point"), weak_grip=d.get("weak_grip")))


def shard_units(config: GenerateConfig) -> list[tuple[str, int]]:
    """(task, variant index) of every shard, in generation order."""
    return [(task, v) for task in config.tasks for v in range(config.tools_per_task)]


def _shard_name(task: str, variant: int) -> str:
    return f"shard_{task}_{variant:03d}.npz"


def _unit_seed(config: GenerateConfig, task: str, variant: int) -> int:
    """A seed per shard from the run seed, stable under reordering of the tasks."""
    h = hashlib.sha256(f"{config.seed}/{task}/{variant}".encode()).digest()
    return int.from_bytes(h[:4], "little")


def unit_tool(config: GenerateConfig, task_kind: str, variant: int) -> tuple[Tool, Task]:
    """The tool and task of a shard: variant 0 is the task's built-in tool, variant v >= 1 the
    procedural variant of the config's family (`variants`) seeded from the run seed (the same tool
    every time, so experiments can rebuild a shard's tool from its manifest entry); with a tool
    `family`, that family's default tool and its draws (`families.draw`) instead."""
    seed = _unit_seed(config, task_kind, variant)
    if config.family is not None:
        from itup_jax import families

        tool = load_tool(config.family) if variant == 0 else families.draw(config.family, seed)
    elif variant == 0:
        tool = load_tool(DEFAULT_TOOL[task_kind])
    elif config.variants == "parts":
        tool = part_variant(DEFAULT_TOOL[task_kind], seed)
    else:
        tool = vary_tool(load_tool(DEFAULT_TOOL[task_kind]), seed)
    with warnings.catch_warnings():  # a stretched tool may swing a little over the speed limit: flagged per rollout
        warnings.simplefilter("ignore", UserWarning)
        task = make_task(task_kind, tool)
    return tool, task


def shard_candidates(config: GenerateConfig, task_kind: str, variant: int) -> tuple[Tool, Task, Grasps]:
    """The tool, task and candidate grasps of a shard (every one, reachable or not), as `make_shard` rolls
    them out."""
    tool, task = unit_tool(config, task_kind, variant)
    grasps = sample_grasps(tool, config.grasps, seed=_unit_seed(config, task_kind, variant),
                           config=SamplerConfig(contact=config.contact))
    return tool, task, grasps


def shard_features(config: GenerateConfig, tool: Tool, task: Task, grasps: Grasps) -> np.ndarray:
    """[N, F] float32 SDG-Net features of a shard's candidates, as the shard stores them (a row's features
    depend on the tool, task and grasp only, not on its rollout)."""
    spec = FeatureSpec(**config.feature_spec)
    feats = batched_features(tool_field(tool, spec), task_loads(tool.params, task), tool.params, grasps, spec=spec)
    return np.asarray(feats, np.float32)


def make_shard(config: GenerateConfig, task_kind: str, variant: int, *, mcap_dir: str | None = None,
               mcap_per_shard: int = 2, nthread: int | None = None) -> dict[str, np.ndarray]:
    """Arrays of one shard (host side; the features and costs run jitted at their outer calls).

    With `mcap_dir`, the first `mcap_per_shard` valid rollouts are also logged there as MCAP
    (`mcap_log`), named `<task>_<variant>_<index>.mcap`; the shard's bytes do not change.
    `nthread`: native stepping threads (None: every core); each rollout is stepped on its own, so the
    shard's bytes do not depend on it.
    """
    seed = _unit_seed(config, task_kind, variant)
    tool, task, grasps = shard_candidates(config, task_kind, variant)
    scene = build_scene(tool, task, timestep=config.task_timestep(task_kind))
    res = simulate(tool, task, grasps, backend=config.backend, seed=seed, scene=scene, traces=mcap_dir is not None,
                   randomize=Randomization() if config.randomize else None, nthread=nthread)
    if mcap_dir is not None:
        from itup_jax.mcap_log import write_rollout_mcap

        for i in np.nonzero(res.labels.valid)[0][:mcap_per_shard]:
            write_rollout_mcap(os.path.join(mcap_dir, f"{task_kind}_{variant:03d}_{i:04d}.mcap"), scene, task, res,
                               int(i), grasp=grasps[int(i)])
    costs = wrench_costs(tool, task, grasps, CostParams())
    arrays = {f"label_{f}": np.asarray(v) for f, v in res.labels.as_dict().items()}
    if config.weak_grip is not None:
        arrays.update(weak_rollouts(tool, task, grasps, config, seed=seed, scene=scene, nthread=nthread))
    arrays.update(
        features=shard_features(config, tool, task, grasps),
        grasp_p=np.asarray(grasps.p_tool_grasp, np.float64), grasp_q=np.asarray(grasps.q_tool_grasp, np.float64),
        grasp_width=np.asarray(grasps.width, np.float64),
        physics=np.stack([getattr(res.physics, f.name) for f in dataclasses.fields(res.physics)], axis=1),
        analytic_tau=np.asarray(costs.tau, np.float64), analytic_slip=np.asarray(costs.slip, np.float64),
        analytic_align=np.asarray(costs.align, np.float64),
        tool_id=np.full(config.grasps, variant, np.int32),
    )
    arrays["meta_json"] = np.frombuffer(json.dumps(
        {"task": task_kind, "tool": tool.name, "variant": variant, "seed": seed, "backend": res.backend,
         "physics_fields": [f.name for f in dataclasses.fields(res.physics)]}, sort_keys=True).encode(), np.uint8)
    return arrays


def weak_rollouts(tool: Tool, task: Task, grasps: Grasps, config: GenerateConfig, *, seed: int, scene,
                  nthread: int | None = None) -> dict[str, np.ndarray]:
    """{`label_weak_<name>`: [N]} (WEAK_FIELDS): each grasp rolled out again at `config.weak_grip` N per pad,
    on the physics draw of its default rollout (same `seed`: the same mass, friction, restitution and
    contact duration per row; the grip fixed, not randomised; below the gripper's 20 N the scene's grip
    actuator is opened, `stress.fixed_grip`). Rows infeasible in the default rollout are infeasible here
    too (feasibility is the arm's reach, not the grip) and are not stepped."""
    from itup_jax.stress import fixed_grip

    g = float(config.weak_grip)
    scene, spread = fixed_grip(scene, Randomization() if config.randomize else None, g)
    res = simulate(tool, task, grasps, backend=config.backend, seed=seed, scene=scene, randomize=spread,
                   config=SimConfig(grip_force=g), nthread=nthread)
    return {f"label_weak_{f}": np.asarray(getattr(res.labels, f)) for f in WEAK_FIELDS}


def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """A .npz with fixed timestamps and sorted members: the same arrays give the same bytes."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_STORED) as zf:
        for name in sorted(arrays):
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(arrays[name]), allow_pickle=False)
            zf.writestr(zipfile.ZipInfo(name + ".npy", date_time=_ZIP_TIME), member.getvalue())
    return buf.getvalue()


def sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _counts(arrays: dict[str, np.ndarray]) -> dict[str, int]:
    return {"n": int(len(arrays["label_valid"])), "valid": int(arrays["label_valid"].sum()),
            "diverged": int(arrays["label_diverged"].sum()), "infeasible": int(arrays["label_infeasible"].sum())}


def _check_process(process_index, process_count) -> None:
    for name, v in (("process_count", process_count), ("process_index", process_index)):
        if not is_integer(v):
            raise InputError(f"generate: {name} must be an integer, got {v!r}")
    if process_count < 1:
        raise InputError(f"generate: process_count must be >= 1, got {process_count}")
    if not 0 <= process_index < process_count:
        raise InputError(f"generate: process_index must be in 0..{process_count - 1} (process_count "
                         f"{process_count}), got {process_index}")


@contextlib.contextmanager
def _manifest_lock(out_dir: str):
    """Hold an exclusive lock on `out_dir`/.manifest.lock for the block: POSIX record locks
    (`fcntl.lockf`), which processes on one machine share and which NFS carries between machines; the
    lock goes when the block ends or the process dies. The lock is a process's: threads of one process
    do not exclude each other, so run `generate` in several processes, not threads. Where there are no
    POSIX locks (Windows), one process needs none: the block runs unlocked."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    fd = os.open(os.path.join(out_dir, LOCK), os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.lockf(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing the descriptor releases the lock


def _existing_shards(mpath: str, header: dict[str, Any]) -> list[dict]:
    """The shard entries of the manifest at `mpath` ([] if there is none), after checking that it was made
    by the same config, at the same steps and by the same code version as `header` (InputError if not:
    resuming would mix shards that mean different things)."""
    if not os.path.exists(mpath):
        return []
    old = _parse_manifest(mpath)
    if old.get("config") != header["config"]:
        raise InputError(f"generate: {mpath} was made with another config; use a new folder")
    old_steps = dataset_timesteps(old)
    if old_steps != header["timesteps"]:  # a default step changed since
        raise InputError(f"generate: {mpath} was simulated at {old_steps} s, this run would use "
                         f"{header['timesteps']} s; resuming would mix their labels: use a new folder")
    old_labels = old.get("label_version", old.get("code_version"))  # older manifests: the code's version
    if old_labels != LABEL_VERSION:  # labels mean something else across label versions
        raise InputError(f"generate: {mpath} holds labels of version {old_labels} (made by itup-jax "
                         f"{old.get('code_version')}), this code makes version {LABEL_VERSION}; resuming would mix "
                         "their shards: use a new folder")
    return old["shards"]


def _merged_manifest(mpath: str, header: dict[str, Any], units: list, mine: set[str],
                     made: dict[str, dict]) -> dict[str, Any]:
    """The manifest with this process's shards: the entries on disk for other processes' shards, plus
    `made` ({file: entry}, this process's verified or new shards) for its own (`mine`, file names); an
    entry of its own not in `made` (a shard that failed its checksum) is dropped. Call under the lock."""
    shards = {s["file"]: s for s in _existing_shards(mpath, header) if s["file"] not in mine}
    shards.update(made)
    order = {_shard_name(*u): k for k, u in enumerate(units)}
    manifest = dict(header, shards=sorted(shards.values(), key=lambda s: order[s["file"]]))
    manifest["totals"] = {c: sum(s[c] for s in manifest["shards"]) for c in ("n", "valid", "diverged", "infeasible")}
    return manifest


def gpu_determinism_warning(backend: str | None) -> str | None:
    """Why a dataset made with `backend` here would not be reproducible, or None: MJX on a GPU whose
    XLA_FLAGS leave scatters non-deterministic (`simulate.DETERMINISTIC_GPU_FLAG`; `itup generate` sets it)."""
    import jax

    if (backend or default_backend()) != "mjx" or jax.default_backend() != "gpu":
        return None
    if gpu_determinism():
        return None
    return ("generate: MJX on a GPU without deterministic scatters gives different labels from run to run, so the "
            f"dataset will not be reproducible byte for byte; start Python with XLA_FLAGS={DETERMINISTIC_GPU_FLAG} "
            "(as `itup generate` does)")


def generate(out_dir: str, config: GenerateConfig = GenerateConfig(), *, progress: bool = True,
             after_shard: Callable[[int], None] | None = None, mcap_dir: str | None = None,
             mcap_per_shard: int = 2, process_index: int = 0, process_count: int = 1,
             nthread: int | None = None) -> dict[str, Any]:
    """Make (or complete) the dataset in `out_dir`; returns the manifest.

    `mcap_dir`: also log `mcap_per_shard` valid rollouts of every shard made in this call as MCAP.

    Resumes: shards already listed in the manifest whose file has the recorded checksum are kept; a
    manifest made with another config or by another code version is refused. `after_shard(k)` is called after the k-th shard
    is written (tests use it to interrupt a run).

    Several processes: with `process_count` n > 1, this process makes the shards `process_index`,
    `process_index` + n, ... of `shard_units` (round robin, so each gets a share of every task). Run n
    of them, at once or one after another, on one machine or on several that share `out_dir` (under
    `jax.distributed`: `jax.process_index()`, `jax.process_count()`). Each adds its shards to the one
    manifest under a file lock (`_manifest_lock`: read, merge, write atomically), so the manifest always
    lists every finished shard and, once all n have run, the folder is byte for byte the one a single
    process makes. Each resumes its own shards after a kill. `nthread`: native stepping threads of this
    process (None: every core; give cores / n when n processes share a machine); the bytes do not
    depend on it.
    """
    config.validate()
    _check_process(process_index, process_count)
    note = gpu_determinism_warning(config.backend)
    if note:
        warnings.warn(note, stacklevel=2)
    if process_count > 1 and os.name != "posix":
        raise InputError("generate: several processes share the manifest through POSIX file locks, which this "
                         f"platform ({os.name}) lacks; run one process")
    if mcap_per_shard < 0:
        raise InputError(f"generate: mcap_per_shard must be >= 0, got {mcap_per_shard}")
    if nthread is not None and (not is_integer(nthread) or nthread < 1):
        raise InputError(f"generate: nthread must be an integer >= 1 (or None: every core), got {nthread!r}")
    os.makedirs(out_dir, exist_ok=True)
    if mcap_dir is not None:
        os.makedirs(mcap_dir, exist_ok=True)
    mpath = os.path.join(out_dir, MANIFEST)
    header = {"format": FORMAT, "config": config.to_json(), "seed": config.seed, "code_version": __version__,
              "label_version": LABEL_VERSION,
              "label_fields": list(LABEL_FIELDS) + ([f"weak_{f}" for f in WEAK_FIELDS] if config.weak_grip is not None else []),
              "timesteps": {t: config.task_timestep(t) for t in config.tasks}}
    units = shard_units(config)
    own = units[process_index::process_count]
    mine = {_shard_name(*u) for u in own}
    with _manifest_lock(out_dir):
        listed = [s for s in _existing_shards(mpath, header) if s["file"] in mine]
    made = {s["file"]: s for s in listed  # checksums outside the lock: the other processes go on meanwhile
            if os.path.exists(os.path.join(out_dir, s["file"]))
            and sha256_file(os.path.join(out_dir, s["file"])) == s["sha256"]}
    todo = [u for u in own if _shard_name(*u) not in made]
    bar = None
    if progress:
        from tqdm import tqdm

        desc = "generate" if process_count == 1 else f"generate {process_index}/{process_count}"
        bar = tqdm(total=len(own) * config.grasps, initial=len(made) * config.grasps, unit="rollout",
                   desc=desc, dynamic_ncols=True)
    try:
        for k, (task_kind, variant) in enumerate(todo):
            arrays = make_shard(config, task_kind, variant, mcap_dir=mcap_dir, mcap_per_shard=mcap_per_shard,
                                nthread=nthread)
            name = _shard_name(task_kind, variant)
            atomic_write(os.path.join(out_dir, name), _npz_bytes(arrays))
            made[name] = {"file": name, "task": task_kind, "variant": variant,
                          "sha256": sha256_file(os.path.join(out_dir, name)), **_counts(arrays)}
            with _manifest_lock(out_dir):
                manifest = _merged_manifest(mpath, header, units, mine, made)
                atomic_write(mpath, (json.dumps(manifest, indent=2, sort_keys=True) + "\n").encode())
            if bar is not None:
                bar.update(config.grasps)
            if after_shard is not None:
                after_shard(k)
    finally:
        if bar is not None:
            bar.close()
    if not todo:  # nothing made: the manifest as it stands, with this process's verified shards
        with _manifest_lock(out_dir):
            manifest = _merged_manifest(mpath, header, units, mine, made)
    return manifest


def load_shard(out_dir: str, entry: dict, *, valid_only: bool = False, verify: bool = True) -> dict[str, np.ndarray]:
    """Arrays of a manifest entry; checks its SHA-256 first (a corrupted shard raises InputError)."""
    path = os.path.join(out_dir, entry["file"])
    if not os.path.isfile(path):
        raise InputError(f"dataset shard {path!r}: listed in {MANIFEST} but missing; restore it, or run the same "
                         "`itup generate` again to remake it")
    if verify and sha256_file(path) != entry["sha256"]:
        raise InputError(f"dataset shard {path!r}: checksum mismatch (corrupted or changed); regenerate it")
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    if valid_only:
        keep = arrays["label_valid"]
        arrays = {k: (v[keep] if v.ndim and len(v) == len(keep) and k != "meta_json" else v) for k, v in arrays.items()}
    return arrays


#: What a manifest must hold: its keys, and each shard entry's.
MANIFEST_KEYS = ("config", "code_version", "shards")
SHARD_KEYS = ("file", "task", "sha256")


def _parse_manifest(mpath: str) -> dict[str, Any]:
    """The manifest at `mpath`, checked for the keys every reader needs; InputError naming the file and
    what is wrong (not JSON, truncated, a key or a shard's key missing)."""
    try:
        with open(mpath) as fh:
            m = json.load(fh)
    except json.JSONDecodeError as exc:
        raise InputError(f"dataset manifest {mpath!r}: not valid JSON ({exc}); truncated or edited by hand? "
                         "Make the dataset again with `itup generate`") from None
    except UnicodeDecodeError:
        raise InputError(f"dataset manifest {mpath!r}: not a text file") from None
    if not isinstance(m, dict):
        raise InputError(f"dataset manifest {mpath!r}: expected a JSON object, got {type(m).__name__}")
    missing = [k for k in MANIFEST_KEYS if k not in m]
    if missing:
        raise InputError(f"dataset manifest {mpath!r}: missing {', '.join(missing)}; not a manifest written by "
                         "`itup generate`")
    if not isinstance(m["shards"], list) or any(not isinstance(e, dict) or any(k not in e for k in SHARD_KEYS)
                                                  for e in m["shards"]):
        raise InputError(f"dataset manifest {mpath!r}: 'shards' must be a list of entries with "
                         f"{', '.join(SHARD_KEYS)}")
    return m


def read_manifest(out_dir: str) -> dict[str, Any]:
    """The manifest of the dataset in `out_dir`, checked (`_parse_manifest`); InputError if there is none."""
    mpath = os.path.join(out_dir, MANIFEST)
    if not os.path.exists(mpath):
        raise InputError(f"dataset {out_dir!r}: no {MANIFEST} there (make one with `itup generate`)")
    return _parse_manifest(mpath)


def dataset_timesteps(manifest: dict[str, Any]) -> dict[str, float]:
    """{task: s} the integration step of each task's rows in a dataset, from its manifest: recorded per
    task since per-task steps; before, the config's one step for all (`GenerateConfig.from_json`: 2 ms
    when it records none)."""
    if "timesteps" in manifest:
        return {t: float(v) for t, v in manifest["timesteps"].items()}
    config = GenerateConfig.from_json(manifest["config"])
    return {t: config.task_timestep(t) for t in config.tasks}


def load_dataset(out_dir: str, *, valid_only: bool = True, tasks: Sequence[str] | None = None,
                 manifest: dict[str, Any] | None = None, skip: Collection[str] = ()) -> dict[str, np.ndarray]:
    """All shards of a dataset (verified), concatenated; adds `task` [N] (str) and `tool` [N] (str, the
    tool's name: unique per procedural variant, the same for a built-in tool in every dataset) per row.
    `manifest`: the folder's manifest if already read (`read_manifest`); `skip`: shard file names not to
    read (`load_datasets`: shards already read from another folder)."""
    manifest = read_manifest(out_dir) if manifest is None else manifest
    parts = []
    for entry in manifest["shards"]:
        if (tasks is not None and entry["task"] not in tasks) or entry["file"] in skip:
            continue
        a = load_shard(out_dir, entry, valid_only=valid_only)
        meta = json.loads(bytes(a.pop("meta_json")))
        a["task"] = np.array([entry["task"]] * len(a["label_valid"]))
        a["tool"] = np.array([meta["tool"]] * len(a["label_valid"]))
        parts.append(a)
    if not parts:
        raise InputError(f"dataset {out_dir!r}: no shards{' for ' + ','.join(tasks) if tasks else ''}")
    return _concat_common(parts)


def _concat_common(parts: list[dict]) -> dict[str, np.ndarray]:
    """The rows of several shard tables, concatenated over the arrays every one of them holds (datasets
    of an older label version lack the label fields added since)."""
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if all(k in p for p in parts)}


def split_dataset_arg(arg: str) -> tuple[str, tuple[str, ...] | None]:
    """'DIR' -> (DIR, None); 'DIR:TASK[,TASK...]' -> (DIR, the tasks to take from that folder). A folder
    whose own name contains ':' is taken whole when it exists. Unknown task names are refused."""
    if os.path.isdir(arg) or ":" not in arg:
        return arg, None
    folder, spec = arg.rsplit(":", 1)
    names = tuple(t.strip() for t in spec.split(","))
    unknown = [t for t in names if t not in TASK_KINDS]
    if not folder or unknown:
        raise InputError(f"dataset {arg!r}: give a folder, or FOLDER:TASKS with TASKS among {', '.join(TASK_KINDS)} "
                         f"separated by commas{' (unknown: ' + ', '.join(map(repr, unknown)) + ')' if unknown else ''}")
    return folder, names


def load_datasets(out_dirs: Sequence[str], *, valid_only: bool = True,
                  tasks: Sequence[str] | None = None) -> tuple[dict[str, np.ndarray], list[dict]]:
    """Several datasets (e.g. `itup generate` runs with different seeds, whose procedural tools differ)
    as one: rows concatenated, plus the manifests. An entry 'DIR:TASK,TASK' takes only those tasks'
    shards from DIR (`split_dataset_arg`), e.g. one task's rows from a newer dataset and the other
    tasks' from an older one; `tasks` filters every folder. Refused: a folder given twice (its rows would count
    twice), datasets whose features were made with different `FeatureSpec`s (their columns would
    mean different things) and datasets whose rows of one task were simulated at different timesteps
    (their labels measure different integrations; `dataset_timesteps`). Tasks at different steps mix. A
    shard found in two folders by its checksum (the built-in tool's shard of one seed in both tool
    families, or a task regenerated with a seed already used) is read once, from the first folder, with
    a warning: its rows would otherwise count twice and fall on both sides of a split by tool.
    `tool_id` is renumbered so that it names one tool across the datasets (the first keeps its ids; a
    tool name seen before, such as a built-in tool, keeps its id; every other tool gets a new one), so a
    split by tool stays a split by tool."""
    if not out_dirs:
        raise InputError("load_datasets: no dataset folder given")
    split = [split_dataset_arg(a) for a in out_dirs]
    out_dirs = [d for d, _ in split]
    # per folder: the tasks to take (None: all it holds), its own filter within `tasks`
    picks = [tasks if own is None else tuple(t for t in own if tasks is None or t in tasks) for _, own in split]
    real = [os.path.realpath(d) for d in out_dirs]
    if len(set(real)) != len(real):
        raise InputError(f"datasets {list(out_dirs)}: a folder is given twice; its rows would count twice")
    manifests = [read_manifest(d) for d in out_dirs]
    first: dict[str, tuple[float, str]] = {}  # task -> (step, the first folder holding it)
    for d, m, pick in zip(out_dirs, manifests, picks):
        if m["config"]["feature_spec"] != manifests[0]["config"]["feature_spec"]:
            raise InputError(f"dataset {d!r}: features made with {m['config']['feature_spec']}, but "
                             f"{out_dirs[0]!r} with {manifests[0]['config']['feature_spec']}; they cannot be mixed")
        for t, step in dataset_timesteps(m).items():
            if pick is not None and t not in pick:
                continue
            step0, d0 = first.setdefault(t, (step, d))
            if step != step0:
                raise InputError(f"dataset {d!r}: its {t} rows simulated at a {step} s timestep, but those of "
                                 f"{d0!r} at {step0} s; their labels cannot be mixed")
    seen: dict[str, tuple[str, str]] = {}  # shard checksum -> (folder, file) where it is read
    parts = []
    for d, m, pick in zip(out_dirs, manifests, picks):
        skip, read = set(), 0  # this folder's shards already read from an earlier folder; those left to read
        for entry in m["shards"]:
            if pick is not None and entry["task"] not in pick:
                continue
            d0, f0 = seen.setdefault(entry["sha256"], (d, entry["file"]))
            if d0 == d:
                read += 1
                continue
            skip.add(entry["file"])
            warnings.warn(f"dataset {d!r}: shard {entry['file']} is byte for byte {f0} of {d0!r} (the same seed, "
                          f"task and tool, e.g. the built-in tool in two families of one seed); read once",
                          stacklevel=2)
        if read or not skip:  # a folder with no shards at all still gets load_dataset's refusal
            parts.append(load_dataset(d, valid_only=valid_only, tasks=pick, manifest=m, skip=skip))
    ids: dict[tuple[str, str], int] = {}
    for p in parts:
        new_ids = p["tool_id"].copy()
        for key in dict.fromkeys(zip(p["task"].tolist(), p["tool"].tolist())):
            rows = (p["task"] == key[0]) & (p["tool"] == key[1])
            if key not in ids:
                ids[key] = int(p["tool_id"][rows][0]) if p is parts[0] else max(ids.values(), default=-1) + 1
            new_ids[rows] = ids[key]
        p["tool_id"] = new_ids
    return _concat_common(parts), manifests
