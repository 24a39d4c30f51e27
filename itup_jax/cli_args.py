"""The `itup` command line's arguments: every subcommand's flags, their help, defaults and examples.

Each `add_<command>(parser)` adds one subcommand's flags. Their defaults are read from the library (a
signature's default, a config dataclass, a named constant), so the help shows what the library does; the
library modules are imported inside these functions, so `itup --help` (which adds none of them) starts
without JAX or MuJoCo.
"""

from __future__ import annotations

import argparse
import inspect
import textwrap

#: Per subcommand, the examples its `--help` ends with.
EXAMPLES = {
    "demo": """examples:
  itup demo                                   # the hammer: SDG-Net vs force closure, verified in MuJoCo
  itup demo --task reach --out reach-demo/
  itup demo --quick                           # a smoke run: 32 candidates, 2 draws per pick
  itup demo --tool my.stl --tool-spec my.toml --task knock""",
    "plan": """examples:
  itup plan                                   # hammer, built-in claw hammer, 1000 candidates, SDG-Net, 5 verified
  itup plan --scorer analytic                 # the analytic wrench cost instead
  itup plan --task reach --n 2000 --json best.json
  itup plan --task hammer --no-verify         # the best-scored grasp, no MuJoCo rollout
  itup plan --task hammer --verify 10 --verify-draws 3   # the 10 best, 3 random draws each
  itup plan --task hammer --tool my.stl --tool-spec my.toml
  itup plan --task knock --tool spanner@3     # a drawn tool of a family (itup tools lists them)""",
    "evaluate": """examples:
  itup evaluate --task hammer --methods sdgnet,force_closure,geometric,random --seeds 5 --json eval.json
  itup evaluate --task sweep --methods sdgnet,force_closure --grip-force 25   # a weak fixed grip""",
    "run": """examples:
  itup run "drive the nail with the hammer"
  itup run "knock over the tower" --clutter 4 --seed 3
  itup run "drive the nail with my_hammer" --add-tool my_hammer.stl my_hammer.toml
  itup run "drive the nail with tool 5" --add-tool my_hammer.stl my_hammer.toml   # by its number on the table
  itup run "pull the block closer" --grounder vlm --vlm-url http://localhost:8000/v1 --vlm-model qwen""",
    "generate": """examples:
  itup generate --out data/ --tasks hammer,reach --tools-per-task 4 --grasps 128
  itup generate --out data/ --tasks hammer --tools-per-task 2 --grasps 64 --mcap logs/
  itup generate --out data/ --tools-per-task 64 --process-index 0 --process-count 2   # and --process-index 1
  itup generate --out fam/ --family spanner --tasks hammer,knock --tools-per-task 8""",
    "train": """examples:
  itup train --data data/ --out model.npz
  itup train --data data/ data2/ --out model.npz --seed 1
  itup train --data data/ --teacher ens.npz --out student.npz   # distil an ensemble into one network
  itup train --init model.npz --data new/ --out adapted.npz     # continue a checkpoint on new data""",
    "ensemble": """examples:
  itup ensemble --models m0.npz m1.npz m2.npz --out ens.npz   # average seeds (itup train --seed S)""",
    "bench": """examples:
  itup bench costs --n 100000 --t 64 --json
  itup bench rollout --json
  itup bench score --n 10000 --json
  itup bench verify --json
  itup bench sample --json
  itup bench reachable --families hammer,spanner
  itup bench startup --json                   # wall time of plan and demo from a shell, first and repeated""",
    "tools": """examples:
  itup tools""",
}


def default(fn, name: str):
    """The default of `fn`'s keyword `name`: every CLI default is the library's."""
    return inspect.signature(fn).parameters[name].default


def _sub(sub, name: str, help_text: str, description: str | None = None) -> argparse.ArgumentParser:
    return sub.add_parser(name, help=help_text, description=textwrap.fill(description or help_text, 100),
                          epilog=EXAMPLES.get(name), formatter_class=argparse.RawDescriptionHelpFormatter)


def _tool_task(p: argparse.ArgumentParser) -> None:
    """--task, --tool, --tool-spec: the tool and task of plan, evaluate and demo."""
    from itup_jax.task import DEFAULT_TOOL, TASK_KINDS

    p.add_argument("--task", default=TASK_KINDS[0], choices=TASK_KINDS, help="task kind (default %(default)s)")
    p.add_argument("--tool", default=None,
                   help="a built-in tool or family name ('spanner', 'spanner@3': a drawn one), or a mesh file (STL, "
                   "OBJ, PLY) with --tool-spec (default: the task's built-in tool, "
                   + ", ".join(f"{k} {v}" for k, v in DEFAULT_TOOL.items()) + ")")
    p.add_argument("--tool-spec", default=None, help="the TOML spec of a mesh --tool")


def add_plan(p: argparse.ArgumentParser) -> None:
    from itup_jax.grasp_sampler import MAX_CANDIDATES, MAX_DRAWN, REACHABLE_BUDGET_FACTOR
    from itup_jax.planning import SAMPLING_MODES, plan_grasp
    from itup_jax.scoring import SCORERS, W_ALIGN, W_FAIL, W_GRIP, W_TASK, W_WEAK, ScoreWeights
    from itup_jax.sdgnet.config import DEFAULT_MODEL

    _tool_task(p)
    p.add_argument("--n", type=int, default=default(plan_grasp, "n"),
                   help=f"grasp candidates scored, at most {MAX_CANDIDATES:,}: with --sampling reachable, grasps the "
                   "arm can carry through the task (default %(default)s)")
    p.add_argument("--sampling", choices=SAMPLING_MODES, default=default(plan_grasp, "sampling"),
                   help="reachable: draw until --n candidates the arm can carry through the task are found (closed-form "
                   "IK along the trajectory) or --budget are drawn; all: draw --n and walk the ranking to the best "
                   "reachable one (default %(default)s)")
    p.add_argument("--budget", type=int, default=None,
                   help=f"--sampling reachable: the most candidates drawn, --n to {MAX_DRAWN:,} (default "
                   f"{REACHABLE_BUDGET_FACTOR} x --n, at most {MAX_DRAWN:,})")
    p.add_argument("--seed", type=int, default=default(plan_grasp, "seed"), help="sampling seed (default %(default)s)")
    p.add_argument("--top", type=int, default=default(plan_grasp, "top"),
                   help="rows of the ranking to print; the pick, the best-scored reachable grasp, is printed too when "
                   "it lies below them (default %(default)s)")
    w = ScoreWeights()
    p.add_argument("--w-tau", type=float, default=None, help=f"weight of C_tau, 1/(N m) (default {w.w_tau:g})")
    p.add_argument("--w-slip", type=float, default=None,
                   help=f"weight of C_s: 1/N for --scorer analytic (default 1), 1/m for sdgnet (default {w.w_slip:g})")
    p.add_argument("--w-align", type=float, default=None,
                   help=f"weight of C_alpha, 1/rad (default: analytic 1, sdgnet {W_ALIGN:g})")
    p.add_argument("--w-task", type=float, default=None,
                   help=f"sdgnet: weight of the predicted probability of missing the task (default {W_TASK:g})")
    p.add_argument("--w-fail", type=float, default=None,
                   help=f"sdgnet: weight of the predicted probability of failing in the grip (default {W_FAIL:g})")
    p.add_argument("--w-weak", type=float, default=None,
                   help="sdgnet (a network with the weak-grip head): weight of the predicted probability of failing in "
                   f"the grip at 25 N per pad (default {W_WEAK:g})")
    p.add_argument("--w-grip", type=float, default=None,
                   help="sdgnet (wrench objective): weight of the predicted grip demand, N m per N of normal force "
                   f"per pad (default {W_GRIP:g})")
    p.add_argument("--verify", type=int, default=default(plan_grasp, "verify"), metavar="K",
                   help="roll the K >= 1 best reachable grasps out in MuJoCo and pick the lowest measured total "
                   "(default %(default)s; 20 carried less torque on the sealed rounds' tools, ~1 s more on 2 cores)")
    p.add_argument("--no-verify", action="store_true",
                   help="no rollouts: the best-scored reachable grasp is the pick (unless the out-of-distribution "
                   "guard fires: it then verifies --guard-verify; --no-guard stops it)")
    p.add_argument("--guard-verify", type=int, default=default(plan_grasp, "guard_verify"), metavar="K",
                   help="sdgnet: where the out-of-distribution guard fires, roll out max(--verify, K) grasps, the "
                   "analytic wrench cost's best among them (default %(default)s)")
    p.add_argument("--verify-physics", choices=("nominal", "random"), default=None,
                   help="physics of the --verify rollouts: the priors' nominal values (the default for one draw) or one "
                   "draw each from --seed (the default with --verify-draws > 1)")
    p.add_argument("--verify-draws", type=int, default=default(plan_grasp, "verify_draws"), metavar="R",
                   help="roll each of the K grasps out R times under random physics; the pick has the lowest mean "
                   "measured total (default %(default)s)")
    p.add_argument("--verify-weak-grip", type=float, default=default(plan_grasp, "verify_weak_grip"), metavar="N",
                   help="repeat every verification rollout at N per pad on the same physics draw; a failure there adds "
                   "--w-weak to the grasp's measured total (default %(default)g; 0: verify at the default grip alone)")
    p.add_argument("--torque-first", action="store_true",
                   help="sdgnet: weigh torque alone, with the task and grip penalties kept (ScoreWeights.torque_first)")
    p.add_argument("--no-guard", action="store_true",
                   help="sdgnet: when the tool lies outside the network's training data (the out-of-distribution "
                   "guard, itup_jax/ood.py; it still reports), neither mix the analytic wrench cost's best into the "
                   "verified grasps nor verify --guard-verify of them")
    p.add_argument("--guard-threshold", type=float, default=None, metavar="X",
                   help="sdgnet: the guard's threshold (default: ood.GUARD_THRESHOLD, calibrated for the shipped "
                   "checkpoint; for a checkpoint of your own, calibrate it with experiments/ood_guard.py)")
    p.add_argument("--scorer", default=default(plan_grasp, "scorer"), choices=SCORERS,
                   help="sdgnet (the shipped checkpoint), sdgnet_paper (the paper objective's checkpoint), analytic "
                   "(the paper's cost), analytic_wrench (its grip-demand form), or a baseline (default %(default)s)")
    p.add_argument("--model", default=None, help=f"SDG-Net checkpoint for --scorer sdgnet (default: the shipped "
                   f"{DEFAULT_MODEL.rsplit('/', 1)[-1]})")
    p.add_argument("--json", default=None, help="write the result as JSON (schema itup.plan/8)")


def _verify_args(p: argparse.ArgumentParser) -> None:
    """evaluate's and demo's: the tool and task, candidates, seeds, model."""
    from itup_jax.evaluate import evaluate

    _tool_task(p)
    p.add_argument("--n", type=int, default=default(evaluate, "n"),
                   help="reachable candidates every method chooses from (default %(default)s)")
    p.add_argument("--seeds", type=int, default=default(evaluate, "seeds"),
                   help="randomised-physics rollouts per pick (default %(default)s)")
    p.add_argument("--seed", type=int, default=default(evaluate, "seed"),
                   help="sampling and physics seed (default %(default)s)")
    p.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")


def add_evaluate(p: argparse.ArgumentParser) -> None:
    from itup_jax.evaluate import DEFAULT_METHODS, METHODS, VERIFY_K, VERIFY_TORQUE_DRAWS, VERIFY_TORQUE_K
    from itup_jax.robot import GRIP_FORCE

    _verify_args(p)
    p.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                   help=f"comma-separated, from {','.join(METHODS)} (sdgnet_verified: SDG-Net's {VERIFY_K} best rolled "
                   f"out under nominal physics, the best measured kept; sdgnet_verified_torque: its {VERIFY_TORQUE_K} "
                   f"best by the torque-first total, each under {VERIFY_TORQUE_DRAWS} draws of the priors), or "
                   "the network under other weights, e.g. sdgnet@w_align=100,w_grip=0.05 (default %(default)s)")
    p.add_argument("--grip-force", type=float, default=None, metavar="N",
                   help=f"N per pad, fixed, for the measured rollouts (default: {GRIP_FORCE:g}, randomised with the "
                   "priors); below the 2F-85's 20 N a labelled robustness probe")
    p.add_argument("--json", default=None, help="write the result (schema itup.evaluate/1)")


def add_demo(p: argparse.ArgumentParser) -> None:
    from itup_jax.demo import QUICK

    _verify_args(p)
    p.add_argument("--out", default="itup-demo", help="output folder (default ./%(default)s/)")
    p.add_argument("--quick", action="store_true",
                   help=f"a smoke run: at most {QUICK[0]} candidates and {QUICK[1]} draws per pick")


def add_run(p: argparse.ArgumentParser) -> None:
    from itup_jax.pipeline import DEFAULT_SAMPLES, MAX_PICK_ATTEMPTS, METHODS
    from itup_jax.planning import DEFAULT_VERIFY, GUARD_VERIFY_K
    from itup_jax.robot import GRIP_FORCE
    from itup_jax.tabletop import DEFAULT_TOOLS, MAX_CLUTTER

    p.add_argument("instruction", help='plain words, e.g. "drive the nail with the hammer"; a tool is named by its '
                   "name, its category, 'my <name>' or its number in the table's listing ('tool 5')")
    p.add_argument("--tools", nargs="+", default=None, metavar="NAME",
                   help="the tools laid apart on the table: built-in or family names ('spanner@3') (default "
                   f"{' '.join(DEFAULT_TOOLS)})")
    p.add_argument("--add-tool", nargs=2, action="append", default=None, metavar=("MESH", "SPEC"),
                   help="add your own tool (a mesh file and its TOML spec, as for plan --tool); repeatable")
    p.add_argument("--clutter", type=int, default=0,
                   help=f"procedural tools dropped among the others, 0-{MAX_CLUTTER} (default %(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="the table's layout, the sampling and the physics draw (default %(default)s)")
    p.add_argument("--method", choices=tuple(METHODS), default="itup",
                   help="itup or an ablation: no_sdgnet, object_level, copa, no_grounding (default %(default)s)")
    p.add_argument("--samples", type=int, default=DEFAULT_SAMPLES,
                   help="grasps sampled before the pick and reach filters (default %(default)s)")
    p.add_argument("--grip-force", type=float, default=GRIP_FORCE, metavar="N",
                   help="N per pad, pick and task (default %(default)g)")
    p.add_argument("--attempts", type=int, default=MAX_PICK_ATTEMPTS, metavar="K",
                   help="picks made at most: a pick that does not bring the tool up in a grasp the task can use puts it "
                   "back down, one where no such grasp is pickable turns the tool over, and the table is planned again "
                   "away from the grasps tried (default %(default)s)")
    p.add_argument("--verify", type=int, default=DEFAULT_VERIFY, metavar="K",
                   help="SDG-Net's methods: roll the K >= 1 best grasps out in MuJoCo (nominal physics, again at 25 N per pad) "
                   "and pick the lowest measured total, as itup plan does (default %(default)s)")
    p.add_argument("--no-verify", action="store_true",
                   help="SDG-Net's methods: the best-scored grasp, no rollout (unless the out-of-distribution guard fires)")
    p.add_argument("--guard-verify", type=int, default=GUARD_VERIFY_K, metavar="K",
                   help="SDG-Net's methods: where the out-of-distribution guard fires, roll out max(--verify, K) grasps, "
                   "as itup plan does (default %(default)s)")
    p.add_argument("--nominal", action="store_true", help="nominal physics for the task (default: drawn around the priors)")
    p.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    p.add_argument("--grounder", choices=("rule", "vlm"), default="rule",
                   help="rule: the lexicon grounder; vlm: a vision-language model behind an OpenAI-compatible endpoint "
                   "(--vlm-url and --vlm-model, or $ITUP_VLM_URL and $ITUP_VLM_MODEL) (default %(default)s)")
    p.add_argument("--vlm-url", default=None, help="the endpoint's base URL, e.g. http://localhost:8000/v1")
    p.add_argument("--vlm-model", default=None, help="the model's name on the endpoint")
    p.add_argument("--vlm-key-env", default=None,
                   help="environment variable holding the API key (default OPENAI_API_KEY)")
    p.add_argument("--vlm-timeout", type=float, default=60.0, help="s to wait for the model's answer (default %(default)g)")
    p.add_argument("--vlm-fallback", action="store_true", help="on a failed or invalid answer, ground with the rules")
    p.add_argument("--view", choices=("auto", "camera", "top"), default="auto",
                   help="scene.png's view (and the picture a vision-language model gets): camera, MuJoCo's offscreen "
                   "rendering (OpenGL: EGL or OSMesa); top, a drawing from above; auto: the camera where OpenGL works, "
                   "else the top view (default %(default)s)")
    p.add_argument("--out", default="itup-run",
                   help="output folder: run.json, scene.png, pick.mcap (every pick and put-back), task.mcap "
                   "(default ./%(default)s/)")


def add_generate(p: argparse.ArgumentParser) -> None:
    from itup_jax.dataset import GenerateConfig, generate
    from itup_jax.sim.scene import TASK_TIMESTEP
    from itup_jax.task import TASK_KINDS
    from itup_jax.tools import families
    from itup_jax.tools.variants import VARIANT_FAMILIES

    d = GenerateConfig()
    p.add_argument("--out", required=True, help="dataset folder (created; resumed if it holds a manifest)")
    p.add_argument("--tasks", default=",".join(TASK_KINDS), help="comma-separated task kinds (default %(default)s)")
    p.add_argument("--tools-per-task", type=int, default=d.tools_per_task,
                   help="built-in tool + procedural variants (default %(default)s)")
    p.add_argument("--grasps", type=int, default=d.grasps, help="grasps (rollouts) per tool (default %(default)s)")
    p.add_argument("--seed", type=int, default=d.seed, help="(default %(default)s)")
    p.add_argument("--backend", default=None, choices=["native", "mjx"],
                   help="default: mjx on an accelerator, native on a CPU. On a GPU machine native MuJoCo on its CPU "
                   "cores was faster for these scenes, and gives the CPU's labels (docs/benchmarks.md, GPU)")
    p.add_argument("--nominal", action="store_true", help="no domain randomisation")
    p.add_argument("--timestep", type=float, default=None,
                   help="s, the simulator's integration step for every task (default: each task's, "
                   + ", ".join(f"{k} {v * 1e3:g} ms" for k, v in TASK_TIMESTEP.items())
                   + ": the coarsest whose labels rank like 0.25 ms's, experiments/timestep_convergence.py)")
    p.add_argument("--variants", default=d.variants, choices=VARIANT_FAMILIES,
                   help="procedural tools: 'stretch' scales the whole built-in tool, 'parts' varies the handle and "
                   "the head independently (tools.variants) (default %(default)s)")
    p.add_argument("--family", default=None, choices=families.names(),
                   help="draw every shard's tool from this tool family (itup tools lists them; --tasks must be ones it "
                   "can do) instead of the task's built-in tool and its --variants")
    p.add_argument("--contact", default=d.contact, choices=["flat", "point"],
                   help="grasp sampler: 'flat' (the pads lie flat on the tool; grasp_sampler.py) or 'point' (antipodal "
                   "point contacts in the friction cone, every dataset up to code 0.5.0) (default %(default)s)")
    p.add_argument("--weak-grip", type=float, default=d.weak_grip, metavar="N",
                   help="N per pad: also roll every candidate out at this fixed grip, same physics draw otherwise "
                   "(labels label_weak_*, which SDG-Net's weak-grip head learns; about doubles the time); 0: no "
                   "second rollout (default %(default)s)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--mcap", default=None, metavar="DIR", help="also log rollouts as MCAP (Foxglove schemas) into DIR")
    p.add_argument("--mcap-per-shard", type=int, default=default(generate, "mcap_per_shard"),
                   help="rollouts logged per shard with --mcap (default %(default)s)")
    p.add_argument("--process-index", type=int, default=default(generate, "process_index"), metavar="I",
                   help="with --process-count N: this process makes shards I, I+N, I+2N, ... (0-based; default "
                   "%(default)s)")
    p.add_argument("--process-count", type=int, default=default(generate, "process_count"), metavar="N",
                   help="processes that make the dataset together, on one machine or several sharing --out; each adds "
                   "its shards to the one manifest (file lock); start N of them with I = 0..N-1 (default %(default)s)")
    p.add_argument("--threads", type=int, default=None,
                   help="native stepping threads of this process (default: every core; with N processes on one "
                   "machine, cores / N); the labels do not depend on it")


def add_train(p: argparse.ArgumentParser) -> None:
    from itup_jax.sdgnet.config import TrainConfig
    from itup_jax.sdgnet.objective import OBJECTIVES

    c = TrainConfig()
    p.add_argument("--data", required=True, nargs="+", metavar="DIR",
                   help="dataset folder(s); several (e.g. generated with different seeds) are trained on as one; "
                   "DIR:TASK,TASK takes only those tasks' rows from DIR")
    p.add_argument("--out", required=True, help="checkpoint to write (.npz, arrays only)")
    p.add_argument("--hidden", default=None,
                   help=f"hidden layer widths, e.g. 128,128,128 (default {','.join(map(str, c.hidden))})")
    p.add_argument("--weight-decay", type=float, default=None,
                   help=f"AdamW's decoupled weight decay, per step w -= lr * wd * w (default {c.weight_decay:g})")
    p.add_argument("--objective", default=None, choices=tuple(OBJECTIVES),
                   help="what the network regresses: wrench (the induced torque's grasp-frame components and the grip "
                   f"demand) or paper (the projected torque) (default {c.objective})")
    p.add_argument("--torque-scale", type=float, default=None,
                   help=f"N m; the torque target is log1p(tau / scale) (default {c.torque_scale:g})")
    p.add_argument("--success-weight", type=float, default=None,
                   help=f"weight of the task-success head's cross-entropy; 0: no success head (default {c.success_weight:g})")
    p.add_argument("--failure-weight", type=float, default=None,
                   help=f"weight of the grip-failure head's cross-entropy; 0: no failure head (default {c.failure_weight:g})")
    p.add_argument("--weak-failure-weight", type=float, default=None,
                   help="weight of the weak-grip failure head's cross-entropy (label_weak_failed, from itup generate's "
                   f"--weak-grip rollouts); 0: no such head, for data without them (default {c.weak_failure_weight:g})")
    p.add_argument("--epochs", type=int, default=c.epochs, help="(default %(default)s)")
    p.add_argument("--batch", type=int, default=c.batch, help="(default %(default)s)")
    p.add_argument("--lr", type=float, default=c.lr, help="peak learning rate (default %(default)s)")
    p.add_argument("--patience", type=int, default=c.patience,
                   help="epochs without a better validation loss before stopping (default %(default)s)")
    p.add_argument("--val-fraction", type=float, default=None,
                   help="share of the data's tools held out for validation and early stopping, in (0, 1); the rest are "
                   f"trained on (default {c.val_fraction:g})")
    p.add_argument("--seed", type=int, default=c.seed, help="(default %(default)s)")
    p.add_argument("--finetune-epochs", type=int, default=None,
                   help="epochs of fine-tuning a copy of the shared network on each task's rows, one network per task "
                   f"in the checkpoint; 0: the shared network alone (default {c.finetune_epochs})")
    p.add_argument("--finetune-lr", type=float, default=None,
                   help=f"fine-tuning's peak learning rate (default {c.finetune_lr:g})")
    p.add_argument("--rank-weight", type=float, default=None,
                   help="weight of the within-tool listwise loss on the torque output (the top-1 pick of each tool's "
                   f"grasps); 0: the paper's loss alone (default {c.rank_weight:g})")
    p.add_argument("--rank-temperature", type=float, default=None,
                   help="temperature of that loss on the normalised log-torque scale; smaller weighs a tool's lowest "
                   f"grasps more (default {c.rank_temperature:g})")
    p.add_argument("--ema", type=float, default=None,
                   help="decay per step of an exponential moving average of the weights, validated and kept instead of "
                   f"the last step's (e.g. 0.999); 0: off (default {c.ema:g}; with --init the checkpoint's recipe's)")
    p.add_argument("--per-task", action="store_true",
                   help="one MLP per task trained from scratch (own normalisation, split and early stopping), one "
                   "checkpoint; no fine-tuning")
    p.add_argument("--teacher", default=None, metavar="E.npz",
                   help="distil: train on this checkpoint's predictions (costs and probabilities) of the rows instead of "
                   "their labels, e.g. an `itup ensemble` that scores M times slower; with --init, adapt that checkpoint "
                   "towards them (how the shipped checkpoint was made)")
    p.add_argument("--init", default=None, metavar="M.npz",
                   help="adapt this checkpoint to --data instead of training from scratch: each of its networks continues "
                   "from its weights and normalisation for --finetune-epochs epochs (default: its recipe's) at "
                   "--finetune-lr, kept unless an epoch beats it on the data's held-out tools; --epochs, --lr and "
                   "--batch (training from scratch) do not apply")
    p.add_argument("--keep", default=None, metavar="OUT,OUT",
                   help="with --init: train these outputs of the checkpoint (its objective's: tau, slip, align for "
                   "paper; tau_third, tau_closure, tau_approach, grip, slip, align for wrench; and p_success, p_failed) "
                   "towards the checkpoint's own predictions of the rows instead of their labels, so that the others "
                   "adapt to a changed label while these stay where they were (e.g. tau,align,p_success after the slip "
                   "label changed)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_ensemble(p: argparse.ArgumentParser) -> None:
    p.add_argument("--models", nargs="+", required=True, metavar="M.npz",
                   help=">= 2 checkpoints of one recipe (e.g. `itup train ... --seed S` for several S)")
    p.add_argument("--out", required=True,
                   help="checkpoint to write (.npz, arrays only); --model M for plan, evaluate, bench score")


def add_bench(p: argparse.ArgumentParser) -> None:
    from itup_jax import bench
    from itup_jax.task import TASK_KINDS

    bsub = p.add_subparsers(dest="bench", required=True, metavar="BENCHMARK")

    def bench_parser(name, fn, help_text):
        bp = bsub.add_parser(name, help=help_text, description=help_text)
        bp.add_argument("--json", action="store_true", help="print one JSON object")
        bp.set_defaults(bench_name=name)
        bp.add_argument("--repeats", type=int, default=default(fn, "repeats"), help="timed repeats (default %(default)s)")
        return bp

    bp = bench_parser("costs", bench.bench_costs, "the analytic costs (one jit) against NumPy")
    bp.add_argument("--n", type=int, default=default(bench.bench_costs, "n"), help="grasps (default %(default)s)")
    bp.add_argument("--t", type=int, default=default(bench.bench_costs, "t"), help="time steps (default %(default)s)")
    bp.add_argument("--task", default=default(bench.bench_costs, "task_kind"), choices=TASK_KINDS,
                    help="(default %(default)s)")
    bp = bench_parser("rollout", bench.bench_rollout, "hammer scene: raw native stepping, label generation, MJX")
    bp.add_argument("--n", type=int, default=default(bench.bench_rollout, "n"), help="rollouts, 1-256 (default %(default)s)")
    bp.add_argument("--threads", default=",".join(map(str, default(bench.bench_rollout, "threads"))),
                    help="native stepping threads to time, comma-separated (default %(default)s)")
    bp.add_argument("--mjx-batches", default=",".join(map(str, default(bench.bench_rollout, "mjx_batches"))),
                    help="MJX batch sizes, comma-separated ('' for none; default %(default)s)")
    bp.add_argument("--mjx-steps", type=int, default=default(bench.bench_rollout, "mjx_steps"),
                    help="MJX steps timed per batch (default %(default)s)")
    bp = bench_parser("score", bench.bench_score, "SDG-Net scoring of n candidates (one jit)")
    bp.add_argument("--n", type=int, default=default(bench.bench_score, "n"), help="candidates (default %(default)s)")
    bp.add_argument("--task", default=default(bench.bench_score, "task_kind"), choices=TASK_KINDS,
                    help="(default %(default)s)")
    bp.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    bp = bench_parser("verify", bench.bench_verify, "the verified pick's rollouts against scoring")
    bp.add_argument("--n", type=int, default=default(bench.bench_verify, "n"), help="candidates (default %(default)s)")
    bp.add_argument("--k", type=int, default=default(bench.bench_verify, "k"),
                    help="verified grasps per pick (default %(default)s)")
    bp.add_argument("--draws", type=int, default=default(bench.bench_verify, "draws"),
                    help="rollouts per verified grasp (> 1: random physics; default %(default)s)")
    bp.add_argument("--torque-first", action="store_true",
                    help="the torque-first weights (ScoreWeights.torque_first; `itup plan --torque-first`)")
    bp.add_argument("--weak-grip", type=float, default=default(bench.bench_verify, "weak_grip"), metavar="N",
                    help="each rollout repeated at N per pad, as `itup plan` verifies (default %(default)g; 0: none)")
    bp.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    bp = bench_parser("sample", bench.bench_sample, "the flat-pad sampler and its collision kernel")
    bp.add_argument("--n", type=int, default=default(bench.bench_sample, "n"), help="grasps (default %(default)s)")
    bp = bench_parser("reachable", bench.bench_reachable, "reachable candidates per tool family: sampling with the arm's IK")
    bp.add_argument("--n", type=int, default=default(bench.bench_reachable, "n"),
                    help="reachable candidates per tool (default %(default)s)")
    bp.add_argument("--families", default=None, help="comma-separated tool families (default: every one)")
    bp = bench_parser("startup", bench.bench_startup, "wall time of itup plan and itup demo from a shell, first and repeated")
    bp.add_argument("--task", default=default(bench.bench_startup, "task_kind"), choices=TASK_KINDS,
                    help="(default %(default)s)")


def add_tools(p: argparse.ArgumentParser) -> None:
    """`itup tools` takes no flags."""


#: Subcommand -> (one line for `itup --help`, the function that adds its flags). The order is the help's.
COMMANDS = {
    "demo": ("the main job: SDG-Net vs force closure on one task, verified in MuJoCo", add_demo),
    "plan": ("the best reachable grasp for a task (SDG-Net by default)", add_plan),
    "run": ("the whole chain from an instruction: ground it, pick the tool up, do the task", add_run),
    "evaluate": ("each method's pick, measured in MuJoCo over randomised physics", add_evaluate),
    "generate": ("a label dataset: shards and a manifest; resumes after a kill", add_generate),
    "train": ("train SDG-Net on datasets from `itup generate`", add_train),
    "ensemble": ("combine trained SDG-Net checkpoints into one that averages them", add_ensemble),
    "bench": ("benchmarks: costs, rollout, score, verify, sample, reachable, startup", add_bench),
    "tools": ("the built-in tools, the tool families and the category priors", add_tools),
}
#: Longer descriptions where the one line is not enough.
DESCRIPTIONS = {
    "run": "Ground the instruction in a table of tools (the four built-in ones, your --add-tool ones, plus --clutter "
           "procedural ones; the listing numbers them), pick the grounded tool up from where it lies and do the task "
           "in MuJoCo. Exit 0: done; 3: the chain ran and the task was not done (the stage it ended at is printed and "
           "in run.json); 2: bad input or an instruction it cannot ground.",
}


def build_parser(command: str | None = None, *, full: bool = True) -> argparse.ArgumentParser:
    """The `itup` parser. Every subcommand is listed; its flags are added for `command` alone, or for every
    subcommand when `full` (importing the library to read the defaults). `itup --help` adds none."""
    ap = argparse.ArgumentParser(
        prog="itup", description=textwrap.fill(
            "inverse Tool-use Planning (iTuP) in JAX. Exit status: 0 done; 2 bad input (the message names the input "
            "and the problem, before any long work; nothing is half-written); 3 no acceptable grasp (plan, evaluate's "
            "verified methods) or the chain ended short of the task (run). `itup CMD --help` has each command's "
            "flags, defaults and examples.", 100), formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-compile-cache", action="store_true",
                    help="do not keep compiled kernels and built tasks between runs (default: kept in "
                    "~/.cache/itup-jax/jax and ~/.cache/itup-jax/tasks, or $ITUP_COMPILE_CACHE_DIR and "
                    "$ITUP_TASK_CACHE_DIR; ITUP_COMPILE_CACHE=0 also turns them off)")
    sub = ap.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    for name, (help_text, add) in COMMANDS.items():
        p = _sub(sub, name, help_text, DESCRIPTIONS.get(name))
        if full or name == command:
            add(p)
    return ap
