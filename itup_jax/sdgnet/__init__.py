"""SDG-Net: the learned scorer, a hand-written JAX MLP trained on MuJoCo's labels.

    from itup_jax.sdgnet import TrainConfig, load_model, train
    model = load_model()                                  # the shipped checkpoint
    model = train(load_dataset("data/"), TrainConfig())   # or one of your own

One module per stage: `features` (a grasp's inputs), `objective` (what it regresses and what the scorer
adds), `mlp` and `optim` (our MLP and AdamW), `config` (the recipe), `model` (a trained network,
prediction, ensembles), `training` (training, adapting, distilling), `checkpoint` (arrays-only files),
`recipes` (`itup train` and `itup ensemble` on datasets). Scoring candidates with it is `scoring.score`.
"""

from itup_jax.sdgnet.checkpoint import load_model, save_model
from itup_jax.sdgnet.config import DEFAULT_MODEL, PAPER_MODEL, TrainConfig
from itup_jax.sdgnet.model import Model, ensemble, predict_costs
from itup_jax.sdgnet.training import adapt, teacher_targets, train

__all__ = ["DEFAULT_MODEL", "Model", "PAPER_MODEL", "TrainConfig", "adapt", "ensemble", "load_model", "predict_costs",
           "save_model", "teacher_targets", "train"]
