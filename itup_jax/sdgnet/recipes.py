"""Training recipes on datasets from `itup generate`: from scratch, distilled from a teacher, adapted
from a checkpoint, and ensembles. `itup train` and `itup ensemble` are these functions and a printout.

    model = train_on_datasets(["data/"], TrainConfig())                  # from scratch
    model = train_on_datasets(["data/"], TrainConfig(), teacher="E.npz")  # distil an ensemble
    model = adapt_on_datasets("M.npz", ["data/"], keep=("tau", "align"))  # continue a checkpoint
    model = ensemble_of(["m0.npz", "m1.npz"])

Each returned model's spec records the datasets it saw (`spec["datasets"]`) and, when there was one,
its teacher and the checkpoint it was adapted from. Host-side orchestration: the training steps jit
themselves (`training.train`, `training.adapt`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from itup_jax.errors import InputError


def load_training_data(paths: Sequence[str]) -> tuple[dict, list[dict]]:
    """The rows of the datasets in `paths` as one table, and their manifests (`dataset_load.load_datasets`;
    a folder may be `DIR:TASK,TASK` to take only those tasks' rows)."""
    from itup_jax.dataset_load import load_datasets

    return load_datasets(list(paths))


def datasets_record(paths: Sequence[str], manifests: list[dict]) -> list[dict]:
    """What a checkpoint records of the datasets it was trained on."""
    from itup_jax.dataset_load import dataset_timesteps, split_dataset_arg

    split = [split_dataset_arg(a) for a in paths]
    return [{"folder": os.path.abspath(d), "tasks": list(t) if t else None, "config": m["config"],
             "timesteps": dataset_timesteps(m), "totals": m.get("totals"), "code_version": m["code_version"]}
            for (d, t), m in zip(split, manifests)]


def predicted_targets(what: str, model, data: dict, feature_spec: dict, outputs=None) -> dict:
    """`data` with `model`'s predictions of the rows as the targets (`sdgnet.training.teacher_targets`, all outputs
    or `outputs`), after refusing a checkpoint whose features were made with another `FeatureSpec` than
    the datasets' (`what` names it in the message)."""
    from itup_jax.sdgnet.training import teacher_targets

    if model.spec["feature_spec"] != feature_spec:
        raise InputError(f"{what}: its features were made with {model.spec['feature_spec']}, "
                         f"the datasets' with {feature_spec}")
    return teacher_targets(data, model, outputs=outputs)


def _teacher_record(path: str, teacher) -> dict:
    """What a distilled checkpoint's spec keeps of its teacher (`spec["teacher"]`)."""
    return {"file": os.path.abspath(path), "ensemble_size": teacher.ensemble_size, "command": teacher.spec.get("command")}


def train_on_datasets(paths: Sequence[str], config, *, teacher: str | None = None, progress: bool = False,
                      command: str | None = None, guard_reference: str | None = None):
    """A new SDG-Net trained on the datasets' rows with `config` (`sdgnet.config.TrainConfig`); with `teacher`
    (a checkpoint, e.g. an ensemble), on its predictions of the rows instead of their labels. The
    teacher is loaded, and so checked, before any data is read. With `guard_reference` (a path,
    `ood.reference_path` of the checkpoint), the out-of-distribution guard's reference of the rows is
    written there (`write_guard_reference`)."""
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.training import train

    teacher_model = load_model(teacher) if teacher is not None else None
    data, manifests = load_training_data(paths)
    fs = manifests[0]["config"]["feature_spec"]  # load_datasets refuses datasets of different specs
    if teacher_model is not None:
        data = predicted_targets(f"teacher {teacher!r}", teacher_model, data, fs)
    model = train(data, config, feature_spec=fs, progress=progress)
    if teacher_model is not None:
        model.spec["teacher"] = _teacher_record(teacher, teacher_model)
    model.spec["datasets"] = datasets_record(paths, manifests)
    model.spec["command"] = command
    if guard_reference is not None:
        write_guard_reference(guard_reference, data)
    return model


def adapt_on_datasets(init: str, paths: Sequence[str], *, epochs: int | None = None, lr: float | None = None,
                      seed: int = 0, patience: int = 25, ema: float | None = None,
                      keep: Sequence[str] | None = None, teacher: str | None = None, progress: bool = False,
                      command: str | None = None, guard_reference: str | None = None):
    """The checkpoint `init` adapted to the datasets' rows (`training.adapt`): each of its networks continues
    from its weights and normalisation for `epochs` (default: its recipe's fine-tuning epochs, or 60)
    and is kept unless an epoch beats it on the data's held-out tools.

    keep: outputs of the checkpoint (`Model.output_names`, e.g. tau, slip, align for the paper's
      objective, tau_third ... grip for the wrench objective; and p_success, p_failed) trained towards
      its own predictions of the rows, so the others adapt to a changed label while these stay.
    teacher: a checkpoint whose predictions replace every label (distil while adapting).
    guard_reference: a path: the out-of-distribution guard's reference of the new rows, with `init`'s
      reference rows when it has one, is written there (`write_guard_reference`).
    """
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.training import adapt

    model = load_model(init)  # checked before any data is read
    if teacher is not None and keep is not None:
        raise InputError("adapt: teacher and keep both replace the rows' labels with a checkpoint's predictions; "
                         "give one")
    teacher_model = load_model(teacher) if teacher is not None else None
    if keep is not None:
        keep = tuple(keep)
        heads = tuple(model.output_names) + tuple(model.head_names)
        if not keep or set(keep) - set(heads):
            raise InputError(f"adapt: keep {list(keep)}: outputs of {init!r}, some of {', '.join(heads)}")
    epochs = epochs if epochs is not None else (model.train_config.finetune_epochs or 60)
    data, manifests = load_training_data(paths)
    fs = manifests[0]["config"]["feature_spec"]
    if keep is not None:  # these outputs are held at the checkpoint's own predictions
        data = predicted_targets(f"checkpoint {init!r}", model, data, fs, outputs=keep)
    if teacher_model is not None:  # every output towards the teacher's predictions of the rows
        data = predicted_targets(f"teacher {teacher!r}", teacher_model, data, fs)
    out = adapt(model, data, epochs=epochs, lr=lr, seed=seed, patience=patience, ema=ema, feature_spec=fs,
                progress=progress)
    out.spec["adapted_from"]["file"] = os.path.abspath(init)
    if keep is not None:
        out.spec["adapted_from"]["kept"] = list(keep)
    if teacher_model is not None:
        out.spec["teacher"] = _teacher_record(teacher, teacher_model)
    out.spec["datasets"] = datasets_record(paths, manifests)
    out.spec["command"] = command
    if guard_reference is not None:
        write_guard_reference(guard_reference, data, init=init)
    return out


def ensemble_of(paths: Sequence[str], *, command: str | None = None):
    """One checkpoint that averages the checkpoints in `paths` (`sdgnet.model.ensemble`: their log costs and
    probabilities), recording their files."""
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.model import ensemble

    model = ensemble([load_model(m) for m in paths])
    model.spec["ensemble"]["files"] = [os.path.abspath(m) for m in paths]
    model.spec["command"] = command
    return model


def write_guard_reference(path: str, data: dict, *, init: str | None = None) -> None:
    """Write the out-of-distribution guard's reference of the training rows `data` (a loaded dataset
    table: its "features" and "task") to `path`: a sample of the rows' features per task; for a
    checkpoint adapted from `init`, `init`'s reference rows (when it has one) join the new rows."""
    import numpy as np

    from itup_jax import ood

    feats, tasks = np.asarray(data["features"], np.float32), np.asarray(data["task"])
    old = ood.reference_path_of(init) if init is not None else None
    if old is not None:
        ref = ood.load_reference(old)
        feats = np.concatenate([feats] + list(ref.features.values()))
        tasks = np.concatenate([tasks] + [np.full(len(v), k) for k, v in ref.features.items()])
    ood.save_reference(path, ood.sample_reference(feats, tasks))
