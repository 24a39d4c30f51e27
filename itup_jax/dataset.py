"""Label datasets for SDG-Net: shards of arrays plus a manifest (`itup generate`).

    manifest = generate("data/", GenerateConfig(tasks=("hammer",), tools_per_task=4, grasps=256))

One shard per (task, tool variant): the tool (variant 0 is the built-in, the others are procedural
variants of it, `tools.variants`: `vary_tool` stretches the whole tool, `part_variant` varies its handle
and head independently; `GenerateConfig.variants`), `grasps` sampled grasps, their rollouts in MuJoCo with
randomised physics (`simulate`), each grasp's second rollout at a weak grip on the same physics draw
(`weak_rollouts`, labels `label_weak_*`), the SDG-Net features (`sdgnet.features.py`) and the analytic costs. Every shard is a
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
import io
import json
import os
import warnings
import zipfile
from collections.abc import Callable
from typing import Any

import numpy as np

from itup_jax import __version__, robot
from itup_jax.atomic import atomic_write
from itup_jax.costs import CostParams, wrench_costs
from itup_jax.dataset_load import MANIFEST, dataset_timesteps, parse_manifest, sha256_file
from itup_jax.errors import InputError, is_integer
from itup_jax.grasp import Grasps
from itup_jax.grasp_sampler import CONTACT_MODELS, SamplerConfig, sample_grasps
from itup_jax.sdgnet.features import FeatureSpec, batched_features, tool_field
from itup_jax.sim.labels import LABEL_FIELDS
from itup_jax.sim.mjx import DETERMINISTIC_GPU_FLAG, gpu_determinism
from itup_jax.sim.physics import Randomization
from itup_jax.sim.rollout import default_backend, simulate
from itup_jax.sim.scene import TIMESTEP, build_scene, check_timestep, task_timestep
from itup_jax.task import DEFAULT_TOOL, TASK_KINDS, Task, make_task
from itup_jax.tools import Tool, families, load_tool
from itup_jax.tools.variants import VARIANT_FAMILIES, part_variant, vary_tool
from itup_jax.wrench import task_loads

FORMAT = "itup.dataset/1"
#: The version of the labels: what a row's labels mean (scenes, thresholds, measures). It changes only
#: when labels change (CHANGELOG.md lists each change), not with the package's version. A dataset records
#: it, and a folder of another label version refuses to resume (its rows would mean something else).
LABEL_VERSION = "0.12.0"
LOCK = ".manifest.lock"  # the manifest's read-modify-write lock (`_manifest_lock`): an empty file
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)  # fixed timestamps: byte-reproducible shards

#: N per pad: the weak grip at which `generate` rolls every candidate out a second time (`weak_rollouts`;
#: `robot.WEAK_GRIP`). At the default grip (100 N, +-20 %) almost no grasp fails in the grip, and the
#: grasps that fail at a weak grip are not ranked by anything the default rollout measures
#: (docs/results.md, "What fails under a weak grip"): this rollout labels them.
WEAK_GRIP = robot.WEAK_GRIP
#: The labels of the weak-grip rollout, stored per row as `label_weak_<name>` (`sim.labels.Labels`' meaning).
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
    # s, the scenes' integration step for every task; None: each task's own (`sim.scene.TASK_TIMESTEP`).
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
    # a tool family (`tools.families.FAMILIES`) whose tools every shard draws instead of the task's built-in tool
    # and its variants: variant 0 the family's default tool, v >= 1 `tools.families.draw`; None: the built-ins
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
    `family`, that family's default tool and its draws (`tools.families.draw`) instead."""
    seed = _unit_seed(config, task_kind, variant)
    if config.family is not None:
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
    from itup_jax.stress import simulate_at_grip

    L = simulate_at_grip(tool, task, grasps, float(config.weak_grip), seed=seed, scene=scene,
                         randomize=Randomization() if config.randomize else None, backend=config.backend,
                         nthread=nthread)
    return {f"label_weak_{f}": np.asarray(getattr(L, f)) for f in WEAK_FIELDS}


def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """A .npz with fixed timestamps and sorted members: the same arrays give the same bytes."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_STORED) as zf:
        for name in sorted(arrays):
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(arrays[name]), allow_pickle=False)
            zf.writestr(zipfile.ZipInfo(name + ".npy", date_time=_ZIP_TIME), member.getvalue())
    return buf.getvalue()


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
    old = parse_manifest(mpath)
    if old.get("config") != header["config"]:
        was, now = old.get("config") or {}, header["config"]
        diff = [f"{k} {was.get(k, '(unset)')!r} there, {now.get(k, '(unset)')!r} now" for k in sorted(set(was) | set(now))
                if was.get(k, "(unset)") != now.get(k, "(unset)")]
        raise InputError(f"generate: {mpath} was made with another config ({'; '.join(diff)}); resuming would mix "
                         "their shards: run again with its settings, or use a new folder")
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
    XLA_FLAGS leave scatters non-deterministic (`sim.mjx.DETERMINISTIC_GPU_FLAG`; `itup generate` sets it)."""
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

    Resumes: shards already listed in the manifest whose file has the recorded checksum are kept, and a
    listed shard that is missing or fails its checksum is made again with a warning saying so; a manifest
    made with another config (the message names the settings that differ), at other steps or of another
    label version is refused. `after_shard(k)` is called after the k-th shard is written (tests use it
    to interrupt a run).

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
    made = {}  # checksums outside the lock: the other processes go on meanwhile
    for s in listed:
        path = os.path.join(out_dir, s["file"])
        if not os.path.exists(path):
            warnings.warn(f"dataset {out_dir!r}: shard {s['file']} is listed in {MANIFEST} but missing; making it "
                          "again", stacklevel=2)
        elif sha256_file(path) != s["sha256"]:
            warnings.warn(f"dataset {out_dir!r}: shard {s['file']} does not match its checksum in {MANIFEST} "
                          "(corrupted or changed); making it again", stacklevel=2)
        else:
            made[s["file"]] = s
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


