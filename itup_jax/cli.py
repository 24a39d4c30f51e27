"""The `itup` command line: it parses (`cli_args`), calls the library and prints.

  itup demo [--task hammer] [--out itup-demo/]
  itup plan  --task hammer [--tool NAME | --tool MESH --tool-spec SPEC] [--n 1000] [--verify K | --no-verify] [--json OUT]
  itup run "drive the nail with the hammer" [--add-tool MESH SPEC] [--clutter N]
  itup evaluate --task T --methods sdgnet,force_closure,... --seeds K --json OUT
  itup generate --out DIR ...;  itup train --data DIR --out M.npz;  itup ensemble --models ... --out E.npz
  itup bench costs|rollout|score|verify|sample|reachable|startup [--json];  itup tools

`itup CMD --help` has each command's flags, defaults and examples. Exit status: 0 done; 2 bad input (a
message names the input and the problem, before any long work; nothing is half-written); 3 no acceptable
grasp (`plan`: no candidate the arm can carry, or none of the verified grasps did the task and held;
`evaluate`: a verified method's grasps did not) or `run`'s chain ended short of the task. The library is
imported inside each command, so `itup --help` starts without JAX or MuJoCo.
"""

from __future__ import annotations

import json
import os
import re
import sys
from typing import Any

from itup_jax.cli_args import COMMANDS, build_parser

#: Exit status when planning finds no grasp it can recommend, or a run ends short of the task.
EXIT_NO_PICK = 3


# ---------------------------------------------------------------------------------------------------
# Checks of the arguments shared by several commands (before any long work)
# ---------------------------------------------------------------------------------------------------
def raise_input(msg: str) -> None:
    from itup_jax.errors import InputError

    raise InputError(msg)


def _check_out_folder(flag: str, path: str) -> None:
    """An output file's path: its folder must exist, and the path must not be a folder."""
    folder = os.path.dirname(os.path.abspath(path)) or "."
    if not os.path.isdir(folder):
        what = "is a file, not a folder" if os.path.exists(folder) else "does not exist"
        raise_input(f"{flag} {path!r}: folder {folder!r} {what}")
    if os.path.isdir(path):
        raise_input(f"{flag} {path!r} is a folder; give a file name")


def _check_out_dir(flag: str, path: str) -> None:
    """An output folder (made if missing): neither it nor any folder above it may be a file."""
    p = os.path.abspath(path)
    if os.path.exists(p) and not os.path.isdir(p):
        raise_input(f"{flag} {path!r} exists and is not a folder")
    parent = os.path.dirname(p)
    while parent and not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if parent and not os.path.isdir(parent):
        raise_input(f"{flag} {path!r}: {parent!r} above it is a file, not a folder")


def _write_json(path: str, obj: Any) -> None:
    """Strict JSON written atomically (never half-written; NaN as null)."""
    from itup_jax.atomic import atomic_write_json

    _check_out_folder("--json", path)
    atomic_write_json(path, obj, indent=2)


def _command_line() -> str | None:
    """The `itup ...` command being run, recorded in the checkpoints it writes (None when not run as `itup`)."""
    return "itup " + " ".join(sys.argv[1:]) if sys.argv and "itup" in sys.argv[0] else None


def _check_model_arg(args) -> Any:
    """A given --model loaded before any work (a missing, foreign or corrupt checkpoint is refused before
    sampling and rollouts); the `Model` is what the command scores with (None: the shipped one)."""
    if getattr(args, "model", None):
        from itup_jax.sdgnet.checkpoint import load_model

        return load_model(args.model)
    return None


def _check_count(flag: str, value: int, lowest: int, highest: int | None = None, why: str = "") -> None:
    """An integer flag within [lowest, highest], refused before any work with its bounds and why."""
    if value < lowest or (highest is not None and value > highest):
        bound = f">= {lowest}" if highest is None else f"in {lowest}..{highest:,}"
        raise_input(f"{flag} must be an integer {bound}, got {value:,}{'; ' + why if why else ''}")


def _load_tool_arg(args) -> Any:
    from itup_jax.task import DEFAULT_TOOL
    from itup_jax.tools import load_tool

    if args.tool_spec and not args.tool:
        raise_input("--tool-spec needs --tool MESH")
    if args.tool is None:
        return load_tool(DEFAULT_TOOL[args.task])
    return load_tool(args.tool, spec=args.tool_spec)


def _make_task(args, tool) -> Any:
    """The task of `--task` for `tool`: from the task cache kept between runs when the compile cache is on
    (`task_cache`: the same arrays, without their ~0.5 s of op-by-op dispatch in a fresh process), and
    then the contact calibration tables its rollouts use kept beside it (`sim.restitution.keep_tables`:
    0.05-0.2 s per contact duration drawn)."""
    from itup_jax import compile_cache, task_cache
    from itup_jax.sim import restitution
    from itup_jax.task import make_task

    if compile_cache.wanted(args.no_compile_cache):
        restitution.keep_tables(task_cache.restitution_dir())
        return task_cache.make_task(args.task, tool)
    return make_task(args.task, tool)


#: `plan_grasp`'s keyword options, as `itup plan` names them in a message (longest first).
PLAN_OPTIONS = ("guard_threshold", "guard_verify", "verify_weak_grip", "verify_draws", "verify_physics", "torque_first", "w_tau",
                "w_slip", "w_align", "w_task", "w_fail", "w_weak", "w_grip", "verify", "top", "sampling", "budget", "n")


def _as_flags(message: str, names=PLAN_OPTIONS) -> str:
    """A library message about keyword options, with each option in `names` written as the CLI flag that
    sets it (`verify_draws` -> `--verify-draws`; `weights ['w_slip']` -> `--w-slip`)."""
    message = re.sub(r"weights \[([^\]]*)\]", lambda m: ", ".join(w.strip(" '") for w in m.group(1).split(",")), message)
    pattern = re.compile(r"(?<![\w-])(" + "|".join(map(re.escape, names)) + r")(?![\w])")
    return pattern.sub(lambda m: "--" + m.group(1).replace("_", "-"), message)


# ---------------------------------------------------------------------------------------------------
# Commands
# ---------------------------------------------------------------------------------------------------
def cmd_demo(args) -> int:
    """The main job (`demo.run_demo`) and its table."""
    from itup_jax.demo import METHODS, QUICK, run_demo
    from itup_jax.evaluate import table

    if args.quick:  # a smoke run: few candidates, two draws per pick
        args.n, args.seeds = min(args.n, QUICK[0]), min(args.seeds, QUICK[1])
    _check_count("--n", args.n, 2)
    _check_count("--seeds", args.seeds, 1)
    _check_out_dir("--out", args.out)
    model = _check_model_arg(args)
    tool = _load_tool_arg(args)
    res = run_demo(args.task, tool=tool, task=_make_task(args, tool), n=args.n, seeds=args.seeds, seed=args.seed,
                   model=model, out=args.out)
    c = res["candidates"]
    print(f"scored {c['used']} candidates ({c['feasible']} of {c['sampled']} sampled were reachable); each pick rolled "
          f"out {args.seeds}x in native MuJoCo with randomised physics (mean ± std):")
    print(table(res))
    s, f = (res["methods"][m]["measured"] for m in METHODS)
    print(res["verdict"] + f" Beside it: raw peak {s['peak_torque']['mean']:.2f} vs {f['peak_torque']['mean']:.2f} "
          f"N·m; projected (C_tau's component) {s['peak_torque_projected']['mean']:.2f} vs "
          f"{f['peak_torque_projected']['mean']:.2f} N·m; slip {1e3 * s['slip_translation']['mean']:.1f} vs "
          f"{1e3 * f['slip_translation']['mean']:.1f} mm (the planner vs force closure)")
    print(f"wrote {', '.join(res['files'].values())} ({res['wall_s']:.0f} s)")
    return 0


def cmd_plan(args) -> int:
    """`planning.plan_grasp` and its report."""
    from itup_jax.errors import InputError
    from itup_jax.grasp_sampler import MAX_CANDIDATES
    from itup_jax.planning import plan_grasp

    if args.json:
        _check_out_folder("--json", args.json)
    _check_count("--n", args.n, 1, MAX_CANDIDATES, why=f"{MAX_CANDIDATES:,} candidates take ~45 s to sample, check "
                 "for reach and score on a 2-core CPU")
    if args.verify < 1:
        raise_input(f"--verify K rolls the K best grasps out and must be >= 1, got {args.verify}; --no-verify picks "
                    "by the score alone (the out-of-distribution guard may still verify; --no-guard stops it)")
    model = _check_model_arg(args) if args.scorer == "sdgnet" else args.model
    given = {k: getattr(args, k) for k in ("w_tau", "w_slip", "w_align", "w_task", "w_fail", "w_weak", "w_grip")
             if getattr(args, k) is not None}
    tool = _load_tool_arg(args)
    task = _make_task(args, tool)
    try:
        plan = plan_grasp(tool, task, n=args.n, seed=args.seed, scorer=args.scorer, model=model, weights=given,
                          torque_first=args.torque_first, top=args.top, verify=0 if args.no_verify else args.verify,
                          verify_draws=args.verify_draws, verify_physics=args.verify_physics, sampling=args.sampling,
                          budget=args.budget, guard=not args.no_guard, guard_threshold=args.guard_threshold,
                          verify_weak_grip=args.verify_weak_grip or None, guard_verify=args.guard_verify)
    except InputError as exc:  # the library's names for the options, written as the flags that set them
        raise_input(_as_flags(str(exc).replace("plan_grasp: ", "")))
    print(plan.report())
    if args.json:
        _write_json(args.json, plan.to_json())
        print(f"wrote {args.json}")
    return 0 if plan.status == "ok" else EXIT_NO_PICK


def cmd_run(args) -> int:
    """The whole chain from an instruction (`pipeline.run`), its printout and files."""
    import itup_jax as itup
    from itup_jax import pipeline, tabletop
    from itup_jax.grasp_sampler import MAX_CANDIDATES
    from itup_jax.grounding import GroundingError
    from itup_jax.render import RenderUnavailable
    from itup_jax.tools import load_tool

    _check_out_dir("--out", args.out)
    _check_count("--attempts", args.attempts, 1, why="picks tried")
    _check_count("--verify", args.verify, 1, why="the grasps checked in MuJoCo; --no-verify picks by the score alone")
    _check_count("--guard-verify", args.guard_verify, 0, why="the grasps checked where the out-of-distribution guard fires")
    _check_count("--samples", args.samples, 1, MAX_CANDIDATES, why="grasps sampled per round")
    model = _check_model_arg(args)
    grounder = "rule"
    if args.grounder == "vlm":
        from itup_jax.vlm import VLMGrounder

        kw = dict(timeout=args.vlm_timeout, fallback="rule" if args.vlm_fallback else None, view=args.view)
        if args.vlm_key_env:
            kw["api_key_env"] = args.vlm_key_env
        grounder = (VLMGrounder(url=args.vlm_url, model=args.vlm_model, **kw) if args.vlm_url or args.vlm_model
                    else VLMGrounder.from_env(**kw))
    elif any((args.vlm_url, args.vlm_model, args.vlm_key_env, args.vlm_fallback)):
        raise_input("--vlm-url/--vlm-model/--vlm-key-env/--vlm-fallback apply to --grounder vlm")
    try:
        view = tabletop.resolve_view(args.view)
    except RenderUnavailable as e:
        raise_input(f"--view camera: {e}")
    tools = ([load_tool(n) for n in (args.tools or tabletop.DEFAULT_TOOLS)]
             + [load_tool(mesh, spec=spec) for mesh, spec in (args.add_tool or [])]) if args.tools or args.add_tool else None
    top = tabletop.make_tabletop(tools, clutter=args.clutter, seed=args.seed)
    print(f"itup run: {args.instruction!r}; table seed {args.seed}: {len(top.tools)} tools ("
          + ", ".join(f"{i + 1} {t.name}" for i, t in enumerate(top.tools)) + f"), method {args.method}", flush=True)
    r = itup.run(args.instruction, tabletop=top, seed=args.seed, method=args.method, samples=args.samples,
                 grip_force=args.grip_force, randomize=not args.nominal, model=model, traces=True, grounder=grounder,
                 max_attempts=args.attempts, verify=0 if args.no_verify else args.verify, guard_verify=args.guard_verify)
    if r.stage == "grounding":
        raise GroundingError(r.message)
    print(r.report())
    files = pipeline.write_outputs(r, args.out, view=view)
    print(f"wrote {', '.join(files.values())} ({r.wall_s:.1f} s)")
    return 0 if r.success else EXIT_NO_PICK


def cmd_evaluate(args) -> int:
    """`evaluate.evaluate` on one tool and task, its table and JSON."""
    from itup_jax.evaluate import evaluate, parse_methods, table
    from itup_jax.grasp_sampler import MAX_CANDIDATES

    methods = parse_methods(args.methods, "--methods")
    _check_count("--seeds", args.seeds, 1)
    _check_count("--n", args.n, 1, MAX_CANDIDATES)
    if args.json:
        _check_out_folder("--json", args.json)
    model = _check_model_arg(args)
    tool = _load_tool_arg(args)
    task = _make_task(args, tool)
    res = evaluate(tool, task, methods, n=args.n, seeds=args.seeds, seed=args.seed, model=model,
                   grip_force=args.grip_force)
    res = {"schema": "itup.evaluate/1", **res}
    c = res["candidates"]
    grip = ("" if args.grip_force is None else f" | grip fixed at {args.grip_force:g} N per pad"
            + (" (a robustness probe: below the 2F-85's 20 N)" if res["grip_probe"] else ""))
    print(f"task {args.task} | tool {tool.name} | {c.get('used')} reachable candidates of {c.get('sampled')} sampled | "
          f"{args.seeds} randomised-physics rollouts per pick (native MuJoCo){grip}: mean ± std")
    print(table(res))
    unverified = [m for m, r in res["methods"].items() if r.get("verified") and not r["verified"]["succeeded"]]
    for m in unverified:
        v = res["methods"][m]["verified"]
        print(f"no verified pick for {m}: none of the {len(v['tried'])} grasps it rolled out did the task and held in "
              f"MuJoCo (its row is the least bad of them); try more candidates (--n, now {args.n}), another grasp "
              "region in the tool's spec (grasp_region), a stronger grip, or another tool")
    if args.json:
        _write_json(args.json, res)
        print(f"wrote {args.json}")
    return EXIT_NO_PICK if unverified else 0


def cmd_generate(args) -> int:
    from itup_jax.dataset import GenerateConfig, generate

    _check_out_dir("--out", args.out)
    if args.mcap:
        _check_out_dir("--mcap", args.mcap)
    tasks = tuple(t for t in args.tasks.split(",") if t)
    cfg = GenerateConfig(tasks=tasks, tools_per_task=args.tools_per_task, grasps=args.grasps, seed=args.seed,
                         backend=args.backend, randomize=not args.nominal, timestep=args.timestep,
                         variants=args.variants, contact=args.contact, family=args.family,
                         weak_grip=args.weak_grip or None)
    m = _library_warnings_on_stderr(
        "generate", generate, args.out, cfg, progress=not args.quiet, mcap_dir=args.mcap,
        mcap_per_shard=args.mcap_per_shard, process_index=args.process_index, process_count=args.process_count,
        nthread=args.threads)
    t = m["totals"]
    units = len(cfg.tasks) * cfg.tools_per_task
    done = f"{len(m['shards'])} shards" if len(m["shards"]) == units else f"{len(m['shards'])} of {units} shards"
    print(f"{args.out}: {done}, {t['n']} rollouts: {t['valid']} valid, "
          f"{t['infeasible']} infeasible, {t['diverged']} diverged (see {args.out}/manifest.json)")
    if len(m["shards"]) < units and args.process_count > 1:
        print(f"this process (--process-index {args.process_index} of {args.process_count}) has made its shards; "
              f"the rest are the other processes' (the manifest lists every finished shard)")
    return 0


def _library_warnings_on_stderr(cmd_name: str, fn, *args, **kwargs):
    """Call fn; its own UserWarnings (a shard read once, a corrupt shard made again) printed as one line each
    on stderr instead of Python's warning format; any other warning shown as Python would."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        out = fn(*args, **kwargs)
    for w in caught:
        if w.category is UserWarning:
            print(f"itup {cmd_name}: note: {w.message}", file=sys.stderr)
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    return out


def _cmd_adapt(args) -> int:
    """`itup train --init M.npz`: continue training a checkpoint on new data (`recipes.adapt_on_datasets`)."""
    from itup_jax.errors import InputError
    from itup_jax.ood import reference_path
    from itup_jax.sdgnet.checkpoint import save_model
    from itup_jax.sdgnet.recipes import adapt_on_datasets

    fixed = [f for f, v in (("--hidden", args.hidden), ("--weight-decay", args.weight_decay),
                            ("--torque-scale", args.torque_scale), ("--success-weight", args.success_weight),
                            ("--failure-weight", args.failure_weight),
                            ("--weak-failure-weight", args.weak_failure_weight), ("--rank-weight", args.rank_weight),
                            ("--rank-temperature", args.rank_temperature), ("--per-task", args.per_task or None),
                            ("--val-fraction", args.val_fraction))
             if v is not None]
    if fixed:
        raise_input(f"--init: the recipe is the checkpoint's own; {', '.join(fixed)} cannot change it "
                    f"(--finetune-epochs, --finetune-lr, --patience, --ema and --seed set the adaptation)")
    keep = None if args.keep is None else tuple(k.strip() for k in args.keep.split(",") if k.strip())
    try:
        out = _library_warnings_on_stderr(
            "train", adapt_on_datasets, args.init, args.data, epochs=args.finetune_epochs, lr=args.finetune_lr,
            seed=args.seed, patience=args.patience, ema=args.ema, keep=keep, teacher=args.teacher,
            progress=not args.quiet, command=_command_line(), guard_reference=reference_path(args.out))
    except InputError as exc:
        raise_input(_as_flags(str(exc).replace("adapt: ", ""), names=("keep", "teacher")))
    save_model(args.out, out)
    epochs = out.spec["adapted_from"].get("epochs", args.finetune_epochs)
    kept = [k for k, e in out.spec.get("by_task", {"all": out.spec}).items() if e.get("best_epoch", 0) < 0]
    print(f"wrote {args.out}: {args.init} adapted (up to {epochs} epochs per network, early stopping); best "
          f"validation loss {out.spec['best_val_loss']:.4f} on the new data's held-out tools"
          + (f"; kept the checkpoint's network for {', '.join(kept)} (no epoch beat it)" if kept else ""))
    return 0


def cmd_train(args) -> int:
    """`recipes.train_on_datasets` (or, with --init, `adapt_on_datasets`) and a printout."""
    from itup_jax.errors import InputError
    from itup_jax.ood import reference_path
    from itup_jax.sdgnet.checkpoint import save_model
    from itup_jax.sdgnet.config import TrainConfig
    from itup_jax.sdgnet.recipes import train_on_datasets

    _check_out_folder("--out", args.out)  # before training, not after
    if args.init:
        return _cmd_adapt(args)
    if args.keep is not None:
        raise_input("--keep holds outputs of the checkpoint being adapted: it needs --init M.npz")
    try:
        hidden = None if args.hidden is None else tuple(int(h) for h in args.hidden.split(",") if h.strip())
    except ValueError:
        raise_input(f"--hidden: comma-separated layer widths, e.g. 128,128,128; got {args.hidden!r}")
    # flags left out keep TrainConfig's defaults (the shipped recipe); the config is checked before any data is read
    recipe = {k: v for k, v in dict(hidden=hidden, weight_decay=args.weight_decay, torque_scale=args.torque_scale,
                                    objective=args.objective, success_weight=args.success_weight,
                                    failure_weight=args.failure_weight, weak_failure_weight=args.weak_failure_weight,
                                    finetune_epochs=args.finetune_epochs, finetune_lr=args.finetune_lr,
                                    rank_weight=args.rank_weight, rank_temperature=args.rank_temperature, ema=args.ema,
                                    val_fraction=args.val_fraction).items() if v is not None}
    if args.per_task:  # from scratch per task: nothing shared to fine-tune
        recipe.setdefault("finetune_epochs", 0)
    cfg = TrainConfig(epochs=args.epochs, batch=args.batch, lr=args.lr, seed=args.seed, patience=args.patience,
                      per_task=args.per_task, **recipe)
    try:
        model = _library_warnings_on_stderr("train", train_on_datasets, args.data, cfg, teacher=args.teacher,
                                            progress=not args.quiet, command=_command_line(),
                                            guard_reference=reference_path(args.out))
    except InputError as exc:
        raise_input(_as_flags(str(exc), names=("teacher",)))
    save_model(args.out, model)
    print(f"wrote {args.out} (and the out-of-distribution guard's reference {reference_path(args.out)}): best "
          f"validation loss {model.spec['best_val_loss']:.4f} (normalised SSE"
          f"{' + weighted cross-entropy of ' + ', '.join(model.class_heads) if model.class_heads else ''}), "
          f"{model.spec['n_train']} train / {model.spec['n_val']} held-out-tool examples")
    return 0


def cmd_ensemble(args) -> int:
    """`recipes.ensemble_of` and a printout."""
    from itup_jax.sdgnet.checkpoint import save_model
    from itup_jax.sdgnet.recipes import ensemble_of

    _check_out_folder("--out", args.out)
    if os.path.abspath(args.out) in {os.path.abspath(m) for m in args.models}:
        raise_input(f"--out {args.out!r} is one of the --models; write the ensemble to a new file")
    model = ensemble_of(args.models, command=_command_line())
    save_model(args.out, model)
    print(f"wrote {args.out}: an ensemble of {model.ensemble_size} SDG-Nets (their log costs and probabilities "
          f"averaged; {model.ensemble_size}x the MLP's cost per candidate)")
    return 0


def _ints(flag: str, text: str, lowest: int) -> tuple[int, ...]:
    """Comma-separated integers >= lowest, or a clear error naming the flag."""
    try:
        values = tuple(int(t) for t in text.split(",") if t.strip())
    except ValueError:
        values = ()
    if not values or min(values) < lowest:
        raise_input(f"{flag} must be comma-separated integers >= {lowest}, got {text!r}")
    return values


def cmd_bench(args) -> int:
    """`itup bench NAME`: one of `bench.bench_*`, printed as JSON or in a few lines (`bench.describe`)."""
    from itup_jax import bench

    name, flag = args.bench, f"bench {args.bench}:"
    _check_count(f"{flag} --repeats", args.repeats, 1)
    kw: dict[str, Any] = {"repeats": args.repeats}
    if name == "costs":
        if args.n < 1 or args.t < 8:
            raise_input(f"{flag} need --n >= 1 and --t >= 8, got --n {args.n} --t {args.t}")
        kw.update(n=args.n, t=args.t, task_kind=args.task)
    elif name == "rollout":
        _check_count(f"{flag} --n", args.n, 1, 256)
        kw.update(n=args.n, threads=_ints(f"{flag} --threads", args.threads, 1), mjx_steps=args.mjx_steps,
                  mjx_batches=_ints(f"{flag} --mjx-batches", args.mjx_batches, 1) if args.mjx_batches else ())
    elif name in ("score", "verify"):
        _check_count(f"{flag} --n", args.n, 1)
        _check_model_arg(args)
        kw.update(n=args.n, model=args.model)
        if name == "score":
            kw.update(task_kind=args.task)
        else:
            _check_count(f"{flag} --k", args.k, 1)
            _check_count(f"{flag} --draws", args.draws, 1)
            kw.update(k=args.k, draws=args.draws, torque_first=args.torque_first, weak_grip=args.weak_grip or None)
    elif name in ("sample", "reachable"):
        _check_count(f"{flag} --n", args.n, 1)
        kw.update(n=args.n)
        if name == "reachable":
            from itup_jax.tools import families

            names = tuple(f for f in args.families.split(",") if f) if args.families else None
            for f in names or ():
                families.get(f)  # an unknown family: a clear message before any work
            kw.update(families=names)
    elif name == "startup":
        kw.update(task_kind=args.task)
    res = getattr(bench, f"bench_{name}")(**kw)
    threads = kw["threads"][-1] if name == "rollout" else None
    print(json.dumps(res) if args.json else bench.describe(res, threads=threads))
    return 0


def cmd_tools(args) -> int:
    from itup_jax.tools.catalogue import catalogue

    print(catalogue())
    return 0


# ---------------------------------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------------------------------
def _command_of(argv: list[str]) -> str | None:
    """The subcommand named on the command line (its first word that is one), or None."""
    return next((a for a in argv if a in COMMANDS), None)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    command = _command_of(argv)
    args = build_parser(command, full=False).parse_args(argv)
    # before JAX starts its backend: reproducible MJX labels on a GPU (sim.mjx.DETERMINISTIC_GPU_FLAG);
    # an XLA_FLAGS that already chooses is left as it is
    from itup_jax.sim.mjx import request_deterministic_gpu

    request_deterministic_gpu()
    from itup_jax import compile_cache

    if compile_cache.wanted(args.no_compile_cache):
        compile_cache.enable()
    from itup_jax.errors import InputError
    from itup_jax.grasp_sampler import SamplingError

    try:
        return globals()[f"cmd_{args.cmd}"](args)
    except (InputError, SamplingError) as exc:
        print(f"itup: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
