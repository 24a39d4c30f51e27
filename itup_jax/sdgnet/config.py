"""SDG-Net's training recipe (`TrainConfig`) and the names of its outputs.

The network regresses its objective's targets (`objective.py`: the paper's projected torque, slip and
drift, or the wrench objective's torque components and grip demand) and, as binary heads, the
probabilities of task success and of grip failure at the default and at a weak grip (`CLASS_TARGETS`).
"""

from __future__ import annotations

import dataclasses
import importlib.resources

import numpy as np

from itup_jax.errors import InputError, check_seed
from itup_jax.sdgnet import objective

#: The paper objective's targets (`objective.PAPER`; the wrench objective's: `objective.WRENCH`).
TARGETS = objective.PAPER.targets


#: Targets are learned as log1p(y / scale): slip is heavy-tailed (a lost tool "slips" metres), torque
#: spans decades; the scales (`objective.Objective.scales`) are 0.02 N m (`TrainConfig.torque_scale`),
#: 1 mm, 0.1 rad, and the wrench objective's grip demand 1 N. They are stored in the checkpoint and its
#: predictions are mapped back with them by scale * expm1.
#: The labels of the binary heads (bool per rollout; `sim.labels.Labels.success` / `.failed`, and `.failed`
#: of the weak-grip rollout, `dataset.weak_rollouts`), in the order of their outputs after the costs, and
#: the names their probabilities go by.
CLASS_TARGETS = ("label_success", "label_failed", "label_weak_failed")


CLASS_NAMES = ("p_success", "p_failed", "p_failed_weak")


SUCCESS_TARGET = CLASS_TARGETS[0]


WEAK_TARGET = CLASS_TARGETS[2]


#: The shipped checkpoint, inside the installed package (model card: `itup_jax/models/MODEL_CARD.md`).
DEFAULT_MODEL = str(importlib.resources.files("itup_jax") / "models" / "sdgnet_default.npz")


#: The paper objective's checkpoint, trained on the same data (`itup train --objective paper`): the
#: paper's model reproduced, one option away (scorer "sdgnet_paper").
PAPER_MODEL = str(importlib.resources.files("itup_jax") / "models" / "sdgnet_paper.npz")


@dataclasses.dataclass(frozen=True)
class TrainConfig:
    hidden: tuple = (128, 128, 128)
    epochs: int = 200
    batch: int = 128
    lr: float = 2e-3
    weight_decay: float = 0.1  # decoupled (AdamW); width, depth and decay chosen by validation loss (models/MODEL_CARD.md)
    patience: int = 25
    val_fraction: float = 0.25  # of the tools (task x variant), held out
    seed: int = 0
    per_task: bool = False  # one MLP per task, each trained (and early-stopped) on its task's rows alone
    # > 0: after the shared network, a copy per task trained on that task's rows for this many more
    # epochs (same held-out tools, same normalisation, AdamW at `finetune_lr`, kept only where it lowers
    # that task's validation loss). The shipped checkpoint uses 60 (`itup train
    # --finetune-epochs 60`: Spearman +0.02 to +0.03 on held-out tools over the shared network alone on the same
    # data; models/MODEL_CARD.md); the default stays 0, one network for every task, the paper's model
    finetune_epochs: int = 0
    finetune_lr: float = 5e-4
    # N m: the torque target is log1p(tau / torque_scale). 0.02 (about the smallest peaks measured) ranks
    # held-out grasps better than 1 N m (Spearman +0.02); its picks need the success head
    torque_scale: float = 0.02
    # weights of the binary heads' cross-entropy in the loss (task success, grasp failure); 0: no such
    # head (both 0: 3 outputs, the paper's loss alone, as the oldest checkpoints). 0.3 ranks
    # torque better than 1.0 at the same success AUC
    success_weight: float = 0.3
    failure_weight: float = 0.3
    # the weak-grip failure head's (label_weak_failed: fails in the grip at `dataset.WEAK_GRIP` N per
    # pad); its rows are those whose weak-grip rollout is valid. Data without weak-grip rollouts (labels
    # before 0.11.0, `itup generate --weak-grip 0`) trains with it at 0
    weak_failure_weight: float = 0.3
    # > 0: adds rank_weight x the within-tool listwise loss (`listwise_loss`) of the torque output to the
    # loss of the network(s) that score: the per-task fine-tuning when finetune_epochs > 0 (the shared
    # network before it keeps the paper's loss: the term there too measured 2.6x slower and no better,
    # models/MODEL_CARD.md), else the one network (or each per_task one). Each step also draws `rank_tools`
    # training tools and `rank_group` of each one's grasps and adds the KL divergence between the top-1
    # distributions softmax(-log torque / rank_temperature) of their labels and of their predictions:
    # the network is spent on which grasp of a tool is lowest (the top-1 regret) rather than on the
    # offsets between tools. 0 (default): the paper's loss alone
    rank_weight: float = 0.0
    rank_temperature: float = 0.3  # on the normalised log-torque scale (1 = the training rows' spread)
    rank_tools: int = 8
    rank_group: int = 32
    # what the network regresses (`objective.OBJECTIVES`): 'wrench' (the induced torque's three
    # grasp-frame components, the grip demand, slip, drift; the default, chosen on validation tools,
    # experiments/objective_selection.py) or 'paper' (projected torque, slip, drift)
    objective: str = "wrench"
    # in [0, 1): > 0 keeps an exponential moving average of the weights, updated after every Adam step
    # (w_avg <- ema w_avg + (1 - ema) w, starting from the first weights), and validates, early-stops and
    # stores the average instead of the last step's weights: Polyak averaging, a cheap ensemble over the
    # end of training at one network's scoring cost. 0 (default): the last step's weights
    ema: float = 0.0

    def __post_init__(self):
        def integer(v):
            return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

        if not (isinstance(self.hidden, tuple) and all(integer(h) and h >= 1 for h in self.hidden)):
            raise InputError(f"train: hidden must be a tuple of layer widths >= 1 (() for a linear model), "
                             f"got {self.hidden!r}")
        for name in ("epochs", "batch", "patience"):
            if not (integer(getattr(self, name)) and getattr(self, name) >= 1):
                raise InputError(f"train: {name} must be an integer >= 1, got {getattr(self, name)!r}")
        if not (np.isfinite(self.lr) and self.lr > 0):
            raise InputError(f"train: lr must be a finite number > 0, got {self.lr!r}")
        if not (np.isfinite(self.weight_decay) and self.weight_decay >= 0):
            raise InputError(f"train: weight_decay must be a finite number >= 0, got {self.weight_decay!r}")
        if not 0 < self.val_fraction < 1:
            raise InputError(f"train: val_fraction (the share of tools held out) must be in (0, 1), "
                             f"got {self.val_fraction!r}")
        check_seed(self.seed, "train")
        if not self.torque_scale > 0:
            raise InputError(f"train: torque_scale must be > 0 N m, got {self.torque_scale!r}")
        for name in ("success_weight", "failure_weight", "weak_failure_weight"):
            if not getattr(self, name) >= 0:
                raise InputError(f"train: {name} must be >= 0, got {getattr(self, name)!r}")
        if not (isinstance(self.finetune_epochs, int) and self.finetune_epochs >= 0):
            raise InputError(f"train: finetune_epochs must be an integer >= 0, got {self.finetune_epochs!r}")
        if not self.finetune_lr > 0:
            raise InputError(f"train: finetune_lr must be > 0, got {self.finetune_lr!r}")
        if not (np.isfinite(self.rank_weight) and self.rank_weight >= 0):
            raise InputError(f"train: rank_weight must be a finite number >= 0, got {self.rank_weight!r}")
        if not (np.isfinite(self.rank_temperature) and self.rank_temperature > 0):
            raise InputError(f"train: rank_temperature must be a finite number > 0, got {self.rank_temperature!r}")
        for name, least in (("rank_tools", 1), ("rank_group", 2)):  # a group of one grasp ranks nothing
            if not (integer(getattr(self, name)) and getattr(self, name) >= least):
                raise InputError(f"train: {name} must be an integer >= {least}, got {getattr(self, name)!r}")
        if not (isinstance(self.ema, (float, int)) and not isinstance(self.ema, bool) and 0 <= self.ema < 1):
            raise InputError(f"train: ema (the weight average's decay per step) must be in [0, 1), got {self.ema!r}")
        objective.get(self.objective, what="train")
        if self.per_task and self.finetune_epochs:
            raise InputError("train: per_task trains each task's network from scratch and finetune_epochs "
                             "fine-tunes a shared one per task; set finetune_epochs=0 with per_task")

    @property
    def class_weights(self) -> dict:
        """{label: cross-entropy weight} of the binary heads the network gets, in output order."""
        w = dict(zip(CLASS_TARGETS, (self.success_weight, self.failure_weight, self.weak_failure_weight)))
        return {k: v for k, v in w.items() if v > 0}

    @property
    def targets(self) -> tuple:
        """The label columns the network regresses, in output order (its objective's)."""
        return objective.get(self.objective).targets

    @property
    def target_scales(self) -> tuple:
        return objective.get(self.objective).target_scales(self.torque_scale)
