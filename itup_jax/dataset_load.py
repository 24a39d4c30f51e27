"""Reading label datasets: manifests, verified shards, and several datasets as one.

    manifest = read_manifest("data/val")                       # checked; InputError naming what is wrong
    data = load_dataset("data/val")                            # every valid row, with `task` and `tool`
    data, manifests = load_datasets(["data/a", "data/b:hammer"])   # several folders as one (`itup train`)

A dataset is what `itup generate` writes (`dataset.generate`): shards of arrays and a manifest with each
shard's SHA-256; every shard read here is checked against it first.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from itup_jax.errors import InputError
from itup_jax.sim.scene import TIMESTEP, task_timestep
from itup_jax.task import TASK_KINDS

MANIFEST = "manifest.json"


def sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


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


def parse_manifest(mpath: str) -> dict[str, Any]:
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
    """The manifest of the dataset in `out_dir`, checked (`parse_manifest`); InputError if there is none."""
    mpath = os.path.join(out_dir, MANIFEST)
    if not os.path.exists(mpath):
        raise InputError(f"dataset {out_dir!r}: no {MANIFEST} there (make one with `itup generate`)")
    return parse_manifest(mpath)


def dataset_timesteps(manifest: dict[str, Any]) -> dict[str, float]:
    """{task: s} the integration step of each task's rows in a dataset, from its manifest: recorded per
    task since per-task steps; before, the config's one step for all (2 ms when it records none, each
    task's own when it records None: what `dataset.GenerateConfig.from_json` reads)."""
    if "timesteps" in manifest:
        return {t: float(v) for t, v in manifest["timesteps"].items()}
    config = manifest["config"]
    step = config.get("timestep", TIMESTEP)
    return {t: task_timestep(t) if step is None else float(step) for t in config.get("tasks", TASK_KINDS)}


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
