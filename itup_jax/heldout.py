"""Held-out label datasets as experiments read them: the rows of one tool, their grasps, their labels
under further physics draws, and tiny datasets for quick runs.

    folder, manifest, config, steps = held_out_dataset("data/val")      # checked; InputError if not one
    rows = unit_rows(data, "hammer", 3)                                   # a loaded dataset's rows of a tool
    extra = cached_redraws("data/test", k=2, cache="out/redraws.npz")     # k more draws of every shard

A held-out dataset is one `itup generate` made with a seed no training set used (docs/results.md, "Data"):
its variant 0 is the task's built-in tool and variants >= 1 are tools no network saw. The scripts in
`experiments/` and `fidelity` (rankings and picks on these rows) build on this module.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import shutil
import sys
import tempfile
import warnings
import zipfile

import numpy as np

from itup_jax.atomic import atomic_write
from itup_jax.dataset import GenerateConfig, generate, unit_tool
from itup_jax.dataset_load import MANIFEST, dataset_timesteps, load_shard
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, make_grasps
from itup_jax.rotations import quat_to_matrix
from itup_jax.sim.physics import Randomization
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import build_scene
from itup_jax.stats import spearman
from itup_jax.task import TASK_KINDS

#: The measured label rankings and picks are judged on (the paper's measure: the full induced peak wrist
#: torque, no projection), as a dataset column.
HEADLINE = "label_peak_torque_induced"
#: The quick runs' tiny datasets: the hammer (its built-in tool and one variant, 12 grasps each, seed 1)
#: and the reach (24 grasps each, seed 6).
QUICK_HAMMER = GenerateConfig(tasks=("hammer",), tools_per_task=2, grasps=12, seed=1)
QUICK_REACH = GenerateConfig(tasks=("reach",), tools_per_task=2, grasps=24, seed=6)
#: The labels `redraw_labels` keeps.
REDRAWN = ("torque", "success", "failed")
#: Seed of the rollouts that measure a pick (`measure_pick`): the same physics draws for every pick.
ROLLOUT_SEED = 777
#: What `measure_pick` measures of a pick: the headline torque and beside it the raw peak, the projected
#: part (the paper objective's C_tau) and the part about the jaw's closure axis (N m), the grip demand (N
#: per pad), task success and grip failure (rates), slip (m) and alignment drift (rad).
MEASURES = {"torque": "peak_torque_induced", "torque_raw": "peak_torque", "torque_projected": "peak_torque_projected",
            "torque_closure": "peak_torque_closure", "grip_demand": "grip_demand", "success": "success",
            "failed": "failed", "slip": "slip_translation", "drift": "alignment_drift"}
#: The measures reported beside the headline torque.
BESIDE = tuple(k for k in MEASURES if k != "torque")
#: Seed of fresh candidates of a held-out tool (+ its variant): never the shard's own (seeded by the run).
SAMPLE_SEED = 1000
#: Seeds of a tool family's calibration and test draws (`family_tools`; the default tool joins calibration).
CAL_SEED, TEST_SEED = 100, 200


def held_out_dataset(folder: str | None, quick_dir: str | None = None, flag: str = "--data", *,
                     error=None) -> tuple[str, dict, GenerateConfig, dict[str, float]]:
    """(folder, manifest, GenerateConfig, {task: step}) of the held-out dataset in `folder`; with `quick_dir`,
    `QUICK_HAMMER` is made there first and read instead. When the folder holds no manifest: InputError
    naming `flag`, or `error(message)` when given (an experiment's `ArgumentParser.error`, exit 2)."""
    if quick_dir is not None:
        folder = quick_dir
        generate(folder, QUICK_HAMMER, progress=False)
    if not folder or not os.path.exists(os.path.join(folder, MANIFEST)):
        message = (f"{flag} {folder!r} holds no dataset manifest (make one with `itup generate`: "
                   "docs/results.md, \"Data\")")
        if error is not None:
            error(message)
        raise InputError(message)
    with open(os.path.join(folder, MANIFEST)) as fh:
        manifest = json.load(fh)
    return folder, manifest, GenerateConfig.from_json(manifest["config"]), dataset_timesteps(manifest)


@contextlib.contextmanager
def quick_dataset(prefix: str = "itup_quick_", config: GenerateConfig = QUICK_REACH):
    """A tiny labelled dataset (`config`, default `QUICK_REACH`) made in a temporary folder and removed
    afterwards: what an experiment's --quick run reads."""
    tmp = tempfile.mkdtemp(prefix=prefix)
    try:
        generate(tmp, config, progress=False)
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def unseen_units(data: dict) -> list[tuple[str, int]]:
    """(task, variant) of every unseen tool (variant >= 1) with rows in a loaded dataset, sorted."""
    return sorted({(str(t), int(v)) for t, v in zip(data["task"], data["tool_id"]) if int(v) >= 1})


def unit_rows(data: dict, task: str, variant: int) -> np.ndarray:
    """Indices of a loaded dataset's rows of one tool (task, variant)."""
    return np.nonzero((np.asarray(data["task"]) == task) & (np.asarray(data["tool_id"]) == variant))[0]


def dataset_grasps(data: dict, idx: np.ndarray) -> Grasps:
    """The `Grasps` of a loaded dataset's (or a shard's) rows `idx`."""
    return make_grasps(np.asarray(data["grasp_p"])[idx], width=np.asarray(data["grasp_width"])[idx],
                       q_tool_grasp=np.asarray(data["grasp_q"])[idx])


def shard_key(entry: dict) -> str:
    """A shard's name among a dataset's redraws: '<task>_<variant>'."""
    return f"{entry['task']}_{entry['variant']}"


def redraw_labels(config: GenerateConfig, entry: dict, a: dict, k: int, timestep: float) -> dict[str, np.ndarray]:
    """{torque, success, failed}: each [k, N], the measured full induced peak torque (N m), task success (1/0)
    and grasp failure (1/0: slip or rotation over the thresholds, or the tool lost) of a shard's N
    grasps under k further physics draws (NaN where a rollout is not valid): the same grasps, tool and
    task, one simulate call, a new seed, at `timestep` s (the dataset's step for the task,
    `dataset_timesteps`)."""
    tool, task = unit_tool(config, entry["task"], entry["variant"])
    n = len(a["grasp_width"])
    reps = Grasps(*(np.tile(a[f], (k,) + (1,) * (a[f].ndim - 1)) for f in ("grasp_p", "grasp_q", "grasp_width")))
    seed = json.loads(bytes(a["meta_json"]))["seed"] + 1
    L = simulate(tool, task, reps, seed=seed, backend=config.backend,
                 scene=build_scene(tool, task, timestep=timestep)).labels
    return {"torque": np.where(L.valid, L.peak_torque_induced, np.nan).reshape(k, n),
            "success": np.where(L.valid, L.success.astype(float), np.nan).reshape(k, n),
            "failed": np.where(L.valid, L.failed.astype(float), np.nan).reshape(k, n)}


def cached_redraws(test_dir: str, k: int, cache: str | None) -> dict[str, dict[str, np.ndarray]]:
    """{shard key: redraw_labels(...)} for every shard of the dataset, read from `cache` (an npz) when it
    was made from this very manifest with this k and the same redrawn labels (`REDRAWN`, the torque being
    `HEADLINE`), else simulated and written there atomically."""
    with open(os.path.join(test_dir, MANIFEST), "rb") as fh:
        raw = fh.read()
    key = f"{hashlib.sha256(raw).hexdigest()}:{k}:{','.join(REDRAWN)}:{HEADLINE}"
    if cache and os.path.exists(cache):
        try:
            with np.load(cache, allow_pickle=False) as z:
                if str(z["key"]) == key:
                    return {n[: -len("/torque")]: {f: z[n[: -len("torque")] + f] for f in REDRAWN}
                            for n in z.files if n.endswith("/torque")}
        except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:  # unreadable: simulate again
            print(f"redraws: ignoring the cache {cache!r} ({exc})", file=sys.stderr)
    manifest = json.loads(raw)
    config = GenerateConfig.from_json(manifest["config"])
    steps = dataset_timesteps(manifest)
    out = {shard_key(e): redraw_labels(config, e, load_shard(test_dir, e), k, steps[e["task"]])
           for e in manifest["shards"]}
    if cache:
        buf = io.BytesIO()
        np.savez(buf, key=np.array(key), **{f"{n}/{f}": v for n, d in out.items() for f, v in d.items()})
        atomic_write(cache, buf.getvalue())
    return out


def oracle_index(tau, ok) -> int:
    """The candidate with the lowest measured torque `tau` [N] among those that did the task and held
    (`ok` [N] bool): what a perfect predictor of those measurements would pick; InputError when none did."""
    tau, ok = np.asarray(tau, float), np.asarray(ok, bool)
    if not ok.any():
        raise InputError("oracle_index: no candidate did the task and held")
    return int(np.argmin(np.where(ok, tau, np.inf)))


def measure_pick(tool, task, scene, grasps: Grasps, i: int, draws: int) -> dict[str, float]:
    """`MEASURES` of grasps[i], each the mean over `draws` rollouts (NaN where none is valid). The draws are
    the same for every pick (`ROLLOUT_SEED`), so picks are compared under the same physics."""
    L = simulate(tool, task, grasps[np.full(draws, i)], seed=ROLLOUT_SEED, scene=scene,
                 randomize=Randomization()).labels
    f = lambda x: float(np.nanmean(np.where(L.valid, np.asarray(x, float), np.nan)))  # noqa: E731
    with warnings.catch_warnings():  # a pick with no valid rollout gives NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        return {k: f(getattr(L, label)) for k, label in MEASURES.items()}


def moved(p: np.ndarray, R: np.ndarray, move: float, turn: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Positions [N, 3] and rotations [N, 3, 3] (tool frame) of N grasps moved by `move` m along a random
    unit direction in each grasp's x-z plane and turned by +-`turn` rad about its y (jaw) axis."""
    n = len(p)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    step = move * (np.cos(phi)[:, None] * R[:, :, 0] + np.sin(phi)[:, None] * R[:, :, 2])
    a = turn * rng.choice([-1.0, 1.0], n)
    c, s = np.cos(a), np.sin(a)
    Ry = np.zeros((n, 3, 3))
    Ry[:, 0, 0], Ry[:, 0, 2], Ry[:, 1, 1], Ry[:, 2, 0], Ry[:, 2, 2] = c, s, 1.0, -s, c
    return p + step, R @ Ry


def with_moved_copies(a: dict, task_kind: str, variant: int, move: float, turn: float, seed: int) -> Grasps:
    """[2N] grasps: a shard's N grasps `a`, then each of them `moved`. The moves are drawn from `seed`,
    the task and the variant alone, so a tool's moves do not depend on which other tools are run."""
    rng = np.random.default_rng([seed, TASK_KINDS.index(task_kind), variant])
    R = np.stack([np.asarray(quat_to_matrix(q), float) for q in a["grasp_q"]])
    p1, R1 = moved(a["grasp_p"], R, move, turn, rng)
    return make_grasps(np.concatenate([a["grasp_p"], p1]), np.concatenate([R, R1]),
                       np.concatenate([a["grasp_width"]] * 2))


def rho(a: np.ndarray, b: np.ndarray) -> float | None:
    """Spearman of a and b, or None (null in a JSON) with fewer than 3 pairs."""
    return spearman(a, b) if len(a) >= 3 else None


def mean_or_none(values) -> float | None:
    """The mean of the values that are not None, or None if there is none."""
    v = np.array([x for x in values if x is not None], float)
    return float(v.mean()) if len(v) else None


def family_tools(name: str, set_name: str, tools: int) -> list[tuple]:
    """[(tool, seed)] of tool family `name`'s calibration set (its default tool, planned with seed 0, and
    `tools` draws from CAL_SEED) or test set (`tools` draws from TEST_SEED, each planned with its seed):
    the out-of-distribution guard's tool sets."""
    from itup_jax.tools import families

    base = CAL_SEED if set_name == "calibration" else TEST_SEED
    seeds = ([None] if set_name == "calibration" else []) + [base + i for i in range(tools)]
    return [(families.get(name).build(), 0) if s is None else (families.draw(name, s), s) for s in seeds]
