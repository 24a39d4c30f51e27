"""The `itup` command line.

  itup demo [--task hammer] [--out itup-demo/]
  itup evaluate --task T [--tool MESH --tool-spec SPEC] --methods sdgnet,force_closure,... --seeds K --json OUT
  itup plan  --task hammer [--tool NAME | --tool MESH --tool-spec SPEC] [--n 1000] [--verify 5] [--json OUT]
  itup bench costs [--n 100000] [--t 64] [--json]
  itup bench rollout [--n 64] [--threads 1,2] [--mjx-batches 1,16,64] [--json]
  itup bench score [--n 10000] [--json]
  itup bench verify [--n 1000] [--k 5] [--json]
  itup bench sample [--n 4096] [--json]
  itup bench reachable [--n 256] [--families F,...] [--json]
  itup bench startup [--repeats 5] [--json]
  itup ensemble --models M.npz M.npz ... --out E.npz
  itup tools

Exit status: 0 done; 2 bad input (a message names the input and the problem, before any long work;
nothing is half-written); 3 no acceptable grasp (`plan`: no candidate the arm can carry, or, with
--verify (or the out-of-distribution guard's verification), none of the verified grasps did the task
and held; `evaluate`: a verified method's grasps did not; the message says what to try).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
from typing import Any

import numpy as np

#: Exit status when planning finds no grasp it can recommend (documented in `itup --help`).
EXIT_NO_PICK = 3
#: `itup demo --quick`: candidates, randomised-physics draws per pick.
QUICK_DEMO = (32, 2)

EXAMPLES = """examples:
  itup demo                                   # the main job: SDG-Net vs force closure, verified in MuJoCo
  itup demo --task reach --out reach-demo/
  itup evaluate --task hammer --methods sdgnet,force_closure,geometric,random --seeds 5 --json eval.json
  itup plan                                   # hammer task, built-in claw hammer, 1000 candidates, SDG-Net
  itup plan --scorer analytic                 # the analytic wrench cost instead
  itup plan --task reach --n 2000 --json best.json
  itup plan --task hammer --verify 5           # roll the 5 best out in MuJoCo, pick the best measured
  itup plan --task hammer --tool my.stl --tool-spec my.toml
  itup bench costs --n 100000 --t 64 --json
  itup bench rollout --json
  itup bench score --n 10000 --json
  itup bench verify --json
  itup bench sample --json
  itup bench startup --json                   # wall time of plan and demo from a shell, first and repeated
  itup generate --out data/ --tasks hammer,reach --tools-per-task 4 --grasps 128
  itup generate --out data/ --tasks hammer --tools-per-task 2 --grasps 64 --mcap logs/
  itup generate --out data/ --tools-per-task 64 --process-index 0 --process-count 2   # and --process-index 1, elsewhere
  itup train --data data/ --out model.npz
  itup ensemble --models m0.npz m1.npz m2.npz --out ens.npz   # average seeds (itup train --seed S)
  itup train --data data/ --teacher ens.npz --out student.npz   # one network trained on the ensemble's predictions
  itup tools
"""


def _atomic_write_json(path: str, obj: Any) -> None:
    """Write strict JSON atomically (`atomic.atomic_write_json`): never half-written, NaN as null."""
    from itup_jax.atomic import atomic_write_json

    _check_out_folder("--json", path)
    atomic_write_json(path, obj, indent=2)


def raise_input(msg: str) -> None:
    from itup_jax.errors import InputError

    raise InputError(msg)


def _command_line() -> str | None:
    """The `itup ...` command being run, recorded in the checkpoints it writes (None when not run as `itup`)."""
    return "itup " + " ".join(sys.argv[1:]) if sys.argv and "itup" in sys.argv[0] else None


def _check_model_arg(args) -> Any:
    """A given --model loaded before any work, so a missing, foreign or corrupt checkpoint is refused before
    sampling and rollouts; the `Model` is what the command scores with (None: the shipped one)."""
    if getattr(args, "model", None):
        from itup_jax.sdgnet import load_model

        return load_model(args.model)
    return None


def _load_tool_arg(args) -> Any:
    import itup_jax as itup
    from itup_jax.task import DEFAULT_TOOL

    if args.tool_spec and not args.tool:
        raise_input("--tool-spec needs --tool MESH")
    if args.tool is None:
        return itup.load_tool(DEFAULT_TOOL[args.task])
    return itup.load_tool(args.tool, spec=args.tool_spec)


def _make_task(args, tool) -> Any:
    """The task of `--task` for `tool`: from the task cache kept between runs when the compile cache is on
    (`task_cache`: the same arrays, without their ~0.5 s of op-by-op dispatch in a fresh process)."""
    from itup_jax import compile_cache, task_cache
    from itup_jax.task import make_task

    if compile_cache.wanted(args.no_compile_cache):
        return task_cache.make_task(args.task, tool)
    return make_task(args.task, tool)


def cmd_plan(args) -> int:
    """`itup plan`: `planning.plan_grasp` and a printout."""
    import itup_jax as itup
    from itup_jax.planning import plan_grasp

    if args.json:
        _check_out_folder("--json", args.json)
    model = _check_model_arg(args) if args.scorer == "sdgnet" else args.model
    given = {k: getattr(args, k) for k in ("w_tau", "w_slip", "w_align", "w_task", "w_fail", "w_weak", "w_grip")
             if getattr(args, k) is not None}
    tool = _load_tool_arg(args)
    task = _make_task(args, tool)
    try:
        plan = plan_grasp(tool, task, n=args.n, seed=args.seed, scorer=args.scorer, model=model, weights=given,
                          torque_first=args.torque_first, top=args.top, verify=args.verify,
                          verify_draws=args.verify_draws, verify_physics=args.verify_physics, sampling=args.sampling,
                          budget=args.budget, guard=not args.no_guard)
    except itup.InputError as exc:  # the library's names for the options, written as the flags that set them
        raise_input(_as_flags(str(exc).replace("plan_grasp: ", "")))
    _print_plan(args, plan)
    result = plan.to_json()
    if args.json:
        _atomic_write_json(args.json, result)
        print(f"wrote {args.json}")
    return 0 if plan.status == "ok" else EXIT_NO_PICK


#: `plan_grasp`'s keyword options, as `itup plan` names them in a message (longest first).
PLAN_OPTIONS = ("verify_draws", "verify_physics", "torque_first", "w_tau", "w_slip", "w_align", "w_task", "w_fail",
                "w_weak", "w_grip",
                "verify", "top", "sampling", "budget", "n")


def _as_flags(message: str, names=PLAN_OPTIONS) -> str:
    """A library message about keyword options, with each option in `names` written as the CLI flag that
    sets it (`verify_draws` -> `--verify-draws`; `weights ['w_slip']` -> `--w-slip`)."""
    message = re.sub(r"weights \[([^\]]*)\]", lambda m: ", ".join(w.strip(" '") for w in m.group(1).split(",")), message)
    pattern = re.compile(r"(?<![\w-])(" + "|".join(map(re.escape, names)) + r")(?![\w])")
    return pattern.sub(lambda m: "--" + m.group(1).replace("_", "-"), message)


def _print_plan(args, plan) -> None:
    """The ranking, the pick, the verification rollouts and what to try when there is no pick."""
    from itup_jax.planning import GUARD_ANALYTIC_SHARE

    tool, grasps, costs = plan.tool, plan.grasps, plan.scores
    sm = plan.sampling
    drawn = (f"{sm['reachable']} reachable of {sm['drawn']} drawn" if sm["mode"] == "reachable"
             else f"{args.n} drawn")
    print(f"task {args.task} | tool {tool.name} ({tool.mass:.3f} kg) | regime {plan.regime} | "
          f"{plan.n} antipodal candidates ({drawn}, seed {args.seed}) | scorer {args.scorer}")
    if sm["mode"] == "reachable" and not sm["complete"]:
        print(f"warning: the arm can carry {sm['reachable']} of {sm['drawn']} drawn candidates through the task, "
              f"fewer than the {sm['requested']} asked for (--budget {sm['budget']} spent)")
    g = plan.guard
    if g is not None and g.fired:
        if plan.guard_verified:
            what = (f"{plan.verify_k} grasps are rolled out in MuJoCo and the pick is the best measured (--no-guard: "
                    "trust the learned score)")
        else:
            what = ("the --verify rollouts decide the pick" if plan.verified is not None
                    else "--no-guard: the learned score decides the pick")
        if plan.shortlist_rule == "guard_mixed":
            m = int(GUARD_ANALYTIC_SHARE * plan.verify_k)
            what += (f"; the grasps verified are SDG-Net's {plan.verify_k - m} best and the analytic wrench cost's "
                     f"{m} best")
        print("warning: " + g.message(tool.name, plan.task.kind) + "; " + what)
    if costs is None:  # the reachable sampler found none: nothing was scored
        print(f"no pick: none of the {sm['drawn']} drawn candidates is reachable for the arm along the task "
              "(closed-form IK); " + "; ".join(plan.advice))
        return
    # analytic costs are wrench components (N m, N, rad); SDG-Net predicts measured torque, slip, drift
    # (N m, m, rad); the baselines' scores are dimensionless
    units = {"analytic": ("N·m", "N", "rad"), "analytic_wrench": ("N·m", "N", "rad"), "sdgnet": ("N·m", "m", "rad"),
             "sdgnet_paper": ("N·m", "m", "rad")}.get(args.scorer, ("", "", ""))
    grip = getattr(costs, "grip", None) is not None  # a wrench-objective SDG-Net: predicted grip demand (N per pad)
    p_task = getattr(costs, "p_success", None) is not None  # SDG-Net with a success head: P(task achieved)
    p_fail = getattr(costs, "p_failed", None) is not None  # and with a failure head: P(fails in the grip)
    p_weak = getattr(costs, "p_failed_weak", None) is not None  # and with a weak-grip head: P(fails at 25 N)
    print(f"{'rank':>4} {'idx':>5} {'C_tau ' + units[0]:>10} {'C_s ' + units[1]:>9} {'C_alpha ' + units[2]:>11} "
          + (f"{'grip N':>7} " if grip else "")
          + (f"{'P(task)':>7} " if p_task else "") + (f"{'P(fail)':>7} " if p_fail else "")
          + (f"{'P(f@25)':>7} " if p_weak else "")
          + f"{'C':>9} {'reach':>5}  grasp origin (tool frame, m)")
    listed = [(rank, int(i)) for rank, i in enumerate(plan.top)]
    pick_rank, best = plan.pick_rank, plan.best_index
    if pick_rank >= len(plan.top):  # the pick lies below the listed ones: its row follows them
        listed.append((pick_rank, best))
    marked = plan.status == "ok" and plan.verified is None
    for rank, i in listed:
        c = plan.row(i)["costs"]
        if rank > len(plan.top):  # a gap between the listed rows and the pick
            print(f"{'...':>4}")
        print(f"{rank + 1:>4} {i:>5} {c['tau']:>10.3f} {c['slip']:>9.3f} {c['align']:>11.3f} "
              + (f"{c['grip']:>7.1f} " if grip else "")
              + (f"{c['p_success']:>7.2f} " if p_task else "") + (f"{c['p_failed']:>7.2f} " if p_fail else "")
              + (f"{c['p_failed_weak']:>7.2f} " if p_weak else "")
              + f"{c['total']:>9.3f} {'yes' if plan.reachable[i] else 'no':>5}  "
              f"{np.asarray(grasps.p_tool_grasp)[i].astype(float).round(4).tolist()}"
              f"{' <- pick' if i == best and marked else ''}")
    if plan.status == "no_reachable_candidate":
        print(f"no pick: none of the {plan.n} candidates is reachable for the arm along the task (closed-form IK); "
              + "; ".join(plan.advice))
    elif pick_rank > 0:
        print(f"reach: whether the arm can follow the task trajectory with the grasp (closed-form IK); the pick is "
              f"the best-scored reachable grasp (rank {pick_rank + 1}); --verify K rolls out the K best reachable ones")
    total = np.asarray(costs.total)
    print(f"all candidates: C {total.min():.3f}..{total.max():.3f} (median {float(np.median(total)):.3f})")
    v = plan.verified
    if v is None:
        return
    draws = plan.verify_draws
    print(f"MuJoCo ({plan.physics} physics{', seed ' + str(args.seed) if plan.physics == 'random' else ''}"
          f"{f', {draws} draws per grasp' if draws > 1 else ''}) for the {len(v.shortlist)} best reachable grasps "
          + ("by the scorer" if plan.shortlist_rule == "scorer" else "by SDG-Net and by the analytic wrench cost")
          + f": the pick is the lowest measured total{' (mean over the draws)' if draws > 1 else ''} (*)")
    print(f"{'rank':>4} {'idx':>5} {'rollout':>8} {'tau_ind N·m':>11} {'tau_perp N·m':>12} {'slip mm':>8} {'rot deg':>7} "
          f"{'failed':>6} {'success':>7} {'measured C':>10}")
    for j, row in enumerate(plan.verify_rows):
        r, d = divmod(j, draws)
        i = row["index"]
        status = "ok" if row["valid"] else "diverged"
        mean = (f"{v.measured_total[r]:>10.3f}{' *' if i == v.index else ''}" if d == draws - 1 else "")
        print(f"{(str(r + 1) if d == 0 else ''):>4} {(str(i) if d == 0 else ''):>5} {status:>8} "
              f"{row['peak_torque_induced']:>11.3f} {row['peak_torque_projected']:>12.3f} "
              f"{1e3 * row['slip_translation']:>8.2f} {np.degrees(row['slip_rotation']):>7.2f} "
              f"{str(row['failed']):>6} {str(row['success']):>7} {mean}")
    ahead = (int(np.sum(total[v.unreachable] <= total[v.shortlist].max())) if len(v.shortlist)
             else len(v.unreachable))
    if ahead:
        print(f"({ahead} grasp(s) scored among these are unreachable for the arm along the task (IK) and were skipped)")
    if v.chosen_by == "score":
        print("no rollout was valid: the scorer's pick stands (it may be unreachable)")
    if plan.status == "no_verified_success":
        print(f"no pick: none of the {len(v.shortlist)} verified grasps did the task and held in MuJoCo; "
              + "; ".join(plan.advice))


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
    m = generate(args.out, cfg, progress=not args.quiet, mcap_dir=args.mcap, mcap_per_shard=args.mcap_per_shard,
                 process_index=args.process_index, process_count=args.process_count, nthread=args.threads)
    t = m["totals"]
    units = len(cfg.tasks) * cfg.tools_per_task
    done = f"{len(m['shards'])} shards" if len(m["shards"]) == units else f"{len(m['shards'])} of {units} shards"
    print(f"{args.out}: {done}, {t['n']} rollouts: {t['valid']} valid, "
          f"{t['infeasible']} infeasible, {t['diverged']} diverged (see {args.out}/manifest.json)")
    if len(m["shards"]) < units and args.process_count > 1:
        print(f"this process (--process-index {args.process_index} of {args.process_count}) has made its shards; "
              f"the rest are the other processes' (the manifest lists every finished shard)")
    return 0


def _library_warnings_on_stderr(fn, *args, **kwargs):
    """Call fn; its own UserWarnings (e.g. a shard found in two dataset folders, read once) printed as one
    line each on stderr instead of Python's warning format; any other warning shown as Python would."""
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UserWarning)
        out = fn(*args, **kwargs)
    for w in caught:
        if w.category is UserWarning:
            print(f"itup train: note: {w.message}", file=sys.stderr)
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    return out


def _cmd_adapt(args) -> int:
    """`itup train --init M.npz`: continue training a checkpoint on new data (`training.adapt_on_datasets`)."""
    from itup_jax.errors import InputError
    from itup_jax.ood import reference_path
    from itup_jax.sdgnet import save_model
    from itup_jax.training import adapt_on_datasets

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
            adapt_on_datasets, args.init, args.data, epochs=args.finetune_epochs, lr=args.finetune_lr,
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
    """`itup train`: `training.train_on_datasets` (or, with --init, `adapt_on_datasets`) and a printout."""
    from itup_jax.ood import reference_path
    from itup_jax.sdgnet import TrainConfig, save_model
    from itup_jax.training import train_on_datasets

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
                                    objective=args.objective,
                                    success_weight=args.success_weight,
                                    failure_weight=args.failure_weight, weak_failure_weight=args.weak_failure_weight,
                                    finetune_epochs=args.finetune_epochs,
                                    finetune_lr=args.finetune_lr, rank_weight=args.rank_weight,
                                    rank_temperature=args.rank_temperature, ema=args.ema,
                                    val_fraction=args.val_fraction).items() if v is not None}
    if args.per_task:  # from scratch per task: nothing shared to fine-tune
        recipe.setdefault("finetune_epochs", 0)
    cfg = TrainConfig(epochs=args.epochs, batch=args.batch, lr=args.lr, seed=args.seed, patience=args.patience,
                      per_task=args.per_task, **recipe)
    from itup_jax.errors import InputError

    try:
        model = _library_warnings_on_stderr(train_on_datasets, args.data, cfg, teacher=args.teacher,
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
    """`itup ensemble`: `training.ensemble_of` and a printout."""
    from itup_jax.sdgnet import save_model
    from itup_jax.training import ensemble_of

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


def cmd_bench_costs(args) -> int:
    from itup_jax.bench import bench_costs

    if args.n < 1 or args.t < 8:
        raise_input(f"bench costs: need --n >= 1 and --t >= 8, got --n {args.n} --t {args.t}")
    res = bench_costs(n=args.n, t=args.t, repeats=args.repeats, task_kind=args.task)
    print(json.dumps(res) if args.json else
          f"costs: n={res['n']} t={res['t']} compile {res['compile_s']:.2f} s, warm {res['warm_ms']:.1f} ms "
          f"(numpy {res['numpy_ms']:.1f} ms, x{res['speedup_vs_numpy']}) on {res['machine']['cpu']}")
    return 0


def cmd_bench_rollout(args) -> int:
    from itup_jax.bench import bench_rollout

    batches = _ints("bench rollout: --mjx-batches", args.mjx_batches, 1) if args.mjx_batches else ()
    threads = _ints("bench rollout: --threads", args.threads, 1)
    if not 1 <= args.n <= 256:
        raise_input(f"bench rollout: --n must be in 1..256, got {args.n}")
    res = bench_rollout(n=args.n, threads=threads, mjx_batches=batches, mjx_steps=args.mjx_steps, repeats=args.repeats)
    nt = threads[-1]
    print(json.dumps(res) if args.json else
          f"rollout: raw {res[f'raw_steps_per_s_threads{nt}']} steps/s, labels "
          f"{res[f'label_steps_per_s_threads{nt}']} steps/s (x{res[f'label_over_raw_threads{nt}']}) on {nt} "
          f"threads; mjx {res['mjx']}")
    return 0


def cmd_bench_score(args) -> int:
    from itup_jax.bench import bench_score

    if args.n < 1 or args.repeats < 1:
        raise_input(f"bench score: --n and --repeats must be >= 1, got --n {args.n} --repeats {args.repeats}")
    _check_model_arg(args)
    res = bench_score(n=args.n, repeats=args.repeats, task_kind=args.task, model=args.model)
    print(json.dumps(res) if args.json else
          f"score: n={res['n']} compile {res['compile_s']:.2f} s, warm {res['warm_ms']:.2f} ms "
          f"({res['candidates_per_s']} candidates/s; {res['flops_per_s'] or 0:.3g} flop/s vs matmul "
          f"{res['matmul_flops_per_s']:.3g}) on {res['machine']['cpu']}")
    return 0


def cmd_bench_verify(args) -> int:
    from itup_jax.bench import bench_verify

    if args.n < 1 or args.k < 1 or args.draws < 1 or args.repeats < 1:
        raise_input(f"bench verify: need --n, --k, --draws and --repeats >= 1, got --n {args.n} --k {args.k} "
                    f"--draws {args.draws} --repeats {args.repeats}")
    _check_model_arg(args)
    res = bench_verify(n=args.n, k=args.k, repeats=args.repeats, model=args.model, draws=args.draws,
                       torque_first=args.torque_first)
    print(json.dumps(res) if args.json else "\n".join(
        f"verify {r['task']:6s}: {r['rollouts']} rollouts ({r['valid_rollouts']} valid) {r['verify_ms']:.0f} ms vs "
        f"scoring {args.n} candidates {r['score_warm_ms']:.1f} ms (x{r['verify_over_score']}); scene built in "
        f"{r['scene_build_s']:.2f} s" for r in res["tasks"]))
    return 0


def cmd_bench_sample(args) -> int:
    from itup_jax.bench import bench_sample

    if args.n < 1 or args.repeats < 1:
        raise_input(f"bench sample: --n and --repeats must be >= 1, got --n {args.n} --repeats {args.repeats}")
    res = bench_sample(n=args.n, repeats=args.repeats)
    print(json.dumps(res) if args.json else "\n".join(
        f"sample {r['task']:6s}: {args.n} grasps in {r['warm_s']:.2f} s warm ({r['grasps_per_s']} grasps/s; first call "
        f"{r['first_call_s']:.2f} s); collision kernel {r['kernel_chunk_ms']:.1f} ms per {res['chunk']} candidates x "
        f"{r['surface_points']} points vs {r['dot_kernel_chunk_ms']:.1f} ms as a batched dot (x{r['kernel_speedup']}, "
        f"{'same' if r['kernels_agree'] else 'DIFFERENT'} hits)" for r in res["tasks"]))
    return 0


def cmd_bench_reachable(args) -> int:
    from itup_jax.bench import bench_reachable

    if args.n < 1 or args.repeats < 1:
        raise_input(f"bench reachable: --n and --repeats must be >= 1, got --n {args.n} --repeats {args.repeats}")
    from itup_jax import families

    names = tuple(f for f in args.families.split(",") if f) if args.families else None
    for f in names or ():
        families.get(f)  # an unknown family: a clear message before any work
    res = bench_reachable(n=args.n, repeats=args.repeats, families=names)
    print(json.dumps(res) if args.json else "\n".join(
        f"reachable {r['family']:11s} {r['task']:6s}: {r['reachable']} reachable of {r['drawn']} drawn "
        f"({r['reachable_share']:.0%}) in {r['warm_s']:.2f} s warm (first call {r['first_call_s']:.2f} s; sampling "
        f"alone {r['sample_only_s']:.2f} s, IK {r['ik_share']:.0%})" for r in res["families"]))
    return 0


def cmd_bench_startup(args) -> int:
    from itup_jax.bench import bench_startup

    if args.repeats < 1:
        raise_input(f"bench startup: --repeats must be >= 1, got {args.repeats}")
    res = bench_startup(repeats=args.repeats, task_kind=args.task)
    c = res["commands"]
    lines = [f"startup itup --help: {c['help']['median_s']:.2f} s (Python, JAX and the package imported: the floor)"]
    for name in ("plan", "demo"):
        r = c[name]
        lines.append(f"startup itup {name} --task {res['task']}: repeated {r['median_s']:.2f} s (median of {res['repeats']}, "
                     f"{r['min_s']:.2f}-{r['max_s']:.2f}; goal {r['goal_s']:g} s), first run {r['first_s']:.2f} s, "
                     f"without the caches {r['no_cache_s']:.2f} s; {r['over_import_floor_s']:.2f} s over the floor")
    print(json.dumps(res) if args.json else "\n".join(lines))
    return 0


def _print_eval_table(res: dict) -> None:
    """Per method, mean ± std over its rollouts: the full induced peak wrist torque (the headline), the raw
    peak, the induced torque's grasp-frame components at its peak (about the jaw's closure axis, the
    approach axis, the third axis), the projected torque (the C_tau component), slip, turn in the pads,
    alignment drift, grip failure and task success."""
    print(f"{'method':>22} {'tau_ind N·m':>12} {'tau_raw N·m':>12} {'closure':>8} {'approach':>8} {'third':>8} "
          f"{'tau_proj':>9} {'grip N':>7} {'slip mm':>10} {'turn deg':>9} {'drift deg':>9} {'fail':>5} {'task':>5}  "
          "grasp (tool frame, m)")
    for name, r in res["methods"].items():
        m = r["measured"]

        def ms(k, scale=1.0, w=5, p=2):
            return f"{scale * m[k]['mean']:{w}.{p}f}±{scale * m[k]['std']:<{w}.{p}f}"

        def mean(k, scale=1.0, w=8, p=2):
            return f"{scale * m[k]['mean']:>{w}.{p}f}"
        print(f"{name:>22} {ms('peak_torque_induced', w=5)} {ms('peak_torque', w=5)} "
              f"{mean('peak_induced_closure')} {mean('peak_induced_approach')} {mean('peak_induced_third')} "
              f"{mean('peak_torque_projected', w=9)} {mean('grip_demand', w=7, p=0)} {ms('slip_translation', 1e3, 4, 1)} "
              f"{mean('slip_rotation', 180 / np.pi, 9, 1)} {mean('alignment_drift', 180 / np.pi, 9, 1)} "
              f"{m['failed']['mean']:>5.2f} {m['success']['mean']:>5.2f}  {r['grasp']['p_tool_grasp_m']}")
    print("tau_ind: full peak induced wrist torque (static holding torque removed, all axes; the headline); "
          "closure/approach/third: its grasp-frame components at that peak (N·m); tau_proj: the part off the "
          "closure axis, the paper's C_tau component (N·m); grip: the normal force per pad the induced wrench "
          "needs (N); turn: the tool's turn in the pads")


def cmd_evaluate(args) -> int:
    from itup_jax.evaluate import METHODS, evaluate

    methods = tuple(m for m in args.methods.split(",") if m)
    bad = [m for m in methods if m not in METHODS]
    if bad or not methods:
        raise_input(f"--methods: unknown {bad or 'empty list'}; choose from {','.join(METHODS)}")
    if args.seeds < 1 or args.n < 1:
        raise_input(f"--seeds and --n must be >= 1, got --seeds {args.seeds} --n {args.n}")
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
    _print_eval_table(res)
    unverified = [m for m, r in res["methods"].items() if r.get("verified") and not r["verified"]["succeeded"]]
    for m in unverified:
        v = res["methods"][m]["verified"]
        print(f"no verified pick for {m}: none of the {len(v['tried'])} grasps it rolled out did the task and held in "
              f"MuJoCo (its row is the least bad of them); try more candidates (--n, now {args.n}), another grasp "
              "region in the tool's spec (grasp_region), a stronger grip, or another tool")
    if args.json:
        _atomic_write_json(args.json, res)
        print(f"wrote {args.json}")
    return EXIT_NO_PICK if unverified else 0


def _check_out_folder(flag: str, path: str) -> None:
    """An output file's path: its folder must exist, and the path must not be a folder (checked before work)."""
    folder = os.path.dirname(os.path.abspath(path)) or "."
    if not os.path.isdir(folder):
        what = "is a file, not a folder" if os.path.exists(folder) else "does not exist"
        raise_input(f"{flag} {path!r}: folder {folder!r} {what}")
    if os.path.isdir(path):
        raise_input(f"{flag} {path!r} is a folder; give a file name")


def _check_out_dir(flag: str, path: str) -> None:
    """An output folder (made if missing): neither it nor any folder above it may be a file (checked before work)."""
    p = os.path.abspath(path)
    if os.path.exists(p) and not os.path.isdir(p):
        raise_input(f"{flag} {path!r} exists and is not a folder")
    parent = os.path.dirname(p)
    while parent and not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if parent and not os.path.isdir(parent):
        raise_input(f"{flag} {path!r}: {parent!r} above it is a file, not a folder")


def cmd_demo(args) -> int:
    """The main job: hammer + shipped SDG-Net vs force closure, verified in MuJoCo, PNG + MCAP."""
    import time

    import itup_jax as itup
    from itup_jax.evaluate import HEADLINE, evaluate, feasible_candidates, reduction
    from itup_jax.mcap_log import write_rollout_mcap
    from itup_jax.plotting import plot_picks
    from itup_jax.scene import build_scene
    from itup_jax.simulate import induced
    from itup_jax.task import contact_motion

    t_start = time.perf_counter()
    if args.quick:  # a smoke run: few candidates, two draws per pick
        args.n, args.seeds = min(args.n, QUICK_DEMO[0]), min(args.seeds, QUICK_DEMO[1])
    if args.n < 2 or args.seeds < 1:
        raise_input(f"--n must be >= 2 and --seeds >= 1, got --n {args.n} --seeds {args.seeds}")
    _check_out_dir("--out", args.out)
    model = _check_model_arg(args)
    os.makedirs(args.out, exist_ok=True)
    tool = _load_tool_arg(args)
    task = _make_task(args, tool)
    scene = build_scene(tool, task)
    print(f"itup demo: task {args.task}, tool {tool.name} ({tool.mass:.3f} kg); sampling {args.n} reachable "
          "antipodal candidates ...", flush=True)
    cands, counts = feasible_candidates(tool, task, args.n, seed=args.seed)
    methods = ("sdgnet", "force_closure")
    res = evaluate(tool, task, methods, seeds=args.seeds, seed=args.seed, scene=scene, candidates=cands, model=model)
    res["candidates"] = counts
    print(f"scored {counts['used']} candidates ({counts['feasible']} of {counts['sampled']} sampled were reachable); "
          f"each pick rolled out {args.seeds}x in native MuJoCo with randomised physics (mean ± std):")
    _print_eval_table(res)
    s, f = (res["methods"][m]["measured"] for m in methods)
    red = reduction(s[HEADLINE]["mean"], f[HEADLINE]["mean"])
    word = "lower" if red >= 0 else "higher"
    print(f"SDG-Net's pick vs force closure's: full induced peak wrist torque {s[HEADLINE]['mean']:.2f} vs "
          f"{f[HEADLINE]['mean']:.2f} N·m ({abs(red):.0f}% {word}); raw peak {s['peak_torque']['mean']:.2f} vs "
          f"{f['peak_torque']['mean']:.2f} N·m; projected (C_tau's component) {s['peak_torque_projected']['mean']:.2f} vs "
          f"{f['peak_torque_projected']['mean']:.2f} N·m; slip {1e3 * s['slip_translation']['mean']:.1f} vs "
          f"{1e3 * f['slip_translation']['mean']:.1f} mm")
    # one nominal-physics rollout of each pick with traces: the PNG and the MCAP logs
    picks = {m: cands[res["methods"][m]["index"]] for m in methods}
    both = itup.Grasps(*(np.stack([np.asarray(getattr(picks[m], k)) for m in methods])
                         for k in ("p_tool_grasp", "q_tool_grasp", "width")))
    tr = itup.simulate(tool, task, both, scene=scene, randomize=None, traces=True)
    files = {}
    for k, m in enumerate(methods):
        files[f"mcap_{m}"] = write_rollout_mcap(os.path.join(args.out, f"{m}.mcap"), scene, task, tr, k, grasp=picks[m])
    # the labels' window, the motion: the settling transient is not plotted. The full induced torque is
    # what the table's headline compares; the raw norm (holding torque included) is drawn beside it
    tau = tr.traces["gripper/wrist_torque"]
    d_tau, _ = induced(scene, tr.plan, tau)
    t_motion = tr.traces["t"][tr.plan.n_settle:]
    traces = {m: (t_motion, np.linalg.norm(d_tau[k], axis=-1), np.linalg.norm(tau[k, tr.plan.n_settle:], axis=-1))
              for k, m in enumerate(methods)}
    files["png"] = plot_picks(tool, picks, os.path.join(args.out, "picks.png"), traces=traces,
                              title=f"{tool.name}, {args.task}: SDG-Net (red) vs force closure (blue)",
                              motion=contact_motion(task))
    out = {"schema": "itup.demo/1", **res, "headline": HEADLINE, "torque_reduction_vs_force_closure_pct": red,
           "files": files,
           "wall_s": round(time.perf_counter() - t_start, 2)}
    files["json"] = os.path.join(args.out, "demo.json")
    _atomic_write_json(files["json"], out)
    print(f"wrote {', '.join(files.values())} ({out['wall_s']:.0f} s)")
    return 0


def cmd_run(args) -> int:
    """The whole chain from an instruction: grounding, pick from the table, the task (`pipeline.run`)."""
    import itup_jax as itup
    from itup_jax import pickup, pipeline, tabletop
    from itup_jax.grounding import GroundingError

    _check_out_dir("--out", args.out)
    if args.attempts < 1:
        raise_input(f"--attempts must be at least 1 (picks tried), got {args.attempts}")
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
    from itup_jax.render import RenderUnavailable

    try:
        view = tabletop.resolve_view(args.view)
    except RenderUnavailable as e:
        raise_input(f"--view camera: {e}")
    tools = None
    if args.tools or args.add_tool:
        if any(len(pair) != 2 for pair in args.add_tool or []):
            raise_input("--add-tool takes a mesh file and its spec: --add-tool MESH SPEC")
        tools = [itup.load_tool(n) for n in (args.tools or tabletop.DEFAULT_TOOLS)]
        tools += [itup.load_tool(mesh, spec=spec) for mesh, spec in (args.add_tool or [])]
    top = tabletop.make_tabletop(tools, clutter=args.clutter, seed=args.seed)
    print(f"itup run: {args.instruction!r}; table seed {args.seed}: {len(top.tools)} tools "
          f"({', '.join(t.name for t in top.tools)}), method {args.method}", flush=True)
    r = itup.run(args.instruction, tabletop=top, seed=args.seed, method=args.method, samples=args.samples,
                 grip_force=args.grip_force, randomize=not args.nominal, model=model, traces=True, grounder=grounder,
                 max_attempts=args.attempts)
    if r.stage == "grounding":
        raise GroundingError(r.message)
    g = r.grounding
    print(f"grounded: task {g.task} (target: the {g.target}), tool {g.tool_index + 1} {g.tool_name}, "
          f"strike with the {g.work_part}, hold the {g.grasp_part}" + "".join(f"; {n}" for n in g.notes))
    c = r.counts
    if c:
        print(f"grasps: {c['sampled']} sampled, {c.get('pick_reachable', 0)} can be picked from the rest pose, "
              f"{c.get('task_reachable', 0)} of those can be carried through the task, {c.get('lift_within_share', 0)} "
              f"of those the pads' torsional grip holds through the lift (its load at most "
              f"{pickup.LIFT_TORQUE_SHARE:.0%} of the grip's capacity)")
        if c.get("scored") and not c.get("lift_within_share"):
            print(f"  none does: scored the {c['scored']} least-loaded lifts (within {pipeline.LIFT_FALLBACK_SPREAD:.0%} "
                  f"of the grip's capacity of the least; the tool may turn in the pads)")
    for k, a in enumerate(r.attempts):
        print(f"pick {k + 1}: {a['why']}; " + ("turned the tool over" if a["action"] == "turn_over" else
                                               "put the tool back down") + ", planned again")
    if r.pick is not None:
        p = r.pick
        print(f"pick{'' if not r.attempts else f' {len(r.attempts) + 1}'}: {'lifted' if p.lifted else 'failed'} (rose {p.rise * 1000:.0f} mm); achieved grasp "
              f"{p.position_error * 1000:.1f} mm and {np.degrees(p.angle_error):.1f} deg from the planned one")
    if r.labels is not None:
        L = r.labels
        print(f"task: metric {L['task_metric']:.4g}, success {L['success']}, grip failure {L['failed']}; full "
              f"induced peak wrist torque {L['peak_torque_induced']:.2f} N·m (raw {L['peak_torque']:.2f})")
    print(f"{'done' if r.success else 'ended at ' + r.stage}: {r.message}")
    os.makedirs(args.out, exist_ok=True)
    files = {}
    if r.pick is not None and r.pick.trace is not None:
        from itup_jax.atomic import atomic_write
        from itup_jax.mcap_log import bodies_mcap_bytes

        tr = r.pick.trace
        files["pick_mcap"] = os.path.join(args.out, "pick.mcap")
        atomic_write(files["pick_mcap"], bodies_mcap_bytes(tr["model"], tr["t"], tr["pos"], tr["quat"], tr["bodies"],
                                                           {"tool": g.tool_name, "instruction": args.instruction}))
    if r.sim is not None:
        from itup_jax.mcap_log import write_rollout_mcap
        from itup_jax.scene import build_scene

        files["mcap"] = write_rollout_mcap(os.path.join(args.out, "task.mcap"), build_scene(r.tool, r.task), r.task,
                                           r.sim, 0, grasp=r.pick.achieved[0])
    files["png"] = os.path.join(args.out, "scene.png")
    tabletop.picture(top, files["png"], highlight=g.tool_index, view=view,
                     title=f"{args.instruction!r}: tool {g.tool_index + 1} ({g.tool_name}); {r.stage}")
    out = {**r.to_json(), "files": files, "picture_view": view}
    files["json"] = os.path.join(args.out, "run.json")
    _atomic_write_json(files["json"], out)
    print(f"wrote {', '.join(files.values())} ({r.wall_s:.1f} s)")
    return 0 if r.success else 3


def cmd_tools(args) -> int:
    import itup_jax as itup
    from itup_jax import priors
    from itup_jax.tool import BUILTIN_TOOLS

    for name in BUILTIN_TOOLS:
        t = itup.load_tool(name)
        p = t.params
        lo, hi = t.mesh.bounds
        size = np.round(np.asarray(hi - lo, float), 3).tolist()
        com = np.round(np.asarray(p.com, float), 3).tolist()
        print(f"{name:8s} category {t.category:8s} mass {float(p.mass):.3f} kg  size {size} m  com {com} m  "
              f"e {float(p.restitution):.2f}  mu {float(p.mu):.2f}  dt {float(p.contact_duration) * 1e3:.0f} ms")
        print(f"{'':8s} parts {list(t.parts)}")
    from itup_jax import families

    print("tool families (itup.load_tool('<family>') is the default, '<family>@<seed>' a drawn one):")
    for name in families.names():
        fam = families.get(name)
        t = itup.load_tool(name)
        lo, hi = t.mesh.bounds
        print(f"  {name:12s} tasks {','.join(fam.tasks):12s} default {t.mass:.3f} kg, {float(np.max(hi - lo)):.2f} m long: "
              f"{fam.summary}")
    print("category priors:")
    for cat, pr in priors.CATEGORY_PRIORS.items():
        for field in ("density", "restitution", "mu", "contact_duration"):
            q = getattr(pr, field)
            print(f"  {cat:11s} {field:16s} {q.value:<8g} {q.unit:7s} {q.source}")
    return 0


def _add_verify_args(p: argparse.ArgumentParser, task_kinds) -> None:
    """Arguments shared by `evaluate` and `demo`: the tool and task, candidates, seeds, model."""
    from itup_jax.evaluate import evaluate

    p.add_argument("--task", default=task_kinds[0], choices=task_kinds)
    p.add_argument("--tool", default=None, help="built-in tool name, or a mesh file (with --tool-spec)")
    p.add_argument("--tool-spec", default=None)
    p.add_argument("--n", type=int, default=_default(evaluate, "n"),
                   help="reachable candidates every method chooses from (default %(default)s)")
    p.add_argument("--seeds", type=int, default=_default(evaluate, "seeds"),
                   help="randomised-physics rollouts per pick (default %(default)s)")
    p.add_argument("--seed", type=int, default=_default(evaluate, "seed"))
    p.add_argument("--model", default=None, help="SDG-Net checkpoint (default: shipped)")


def _default(fn, name: str):
    """The default of `fn`'s keyword `name`: every CLI default is the library's."""
    import inspect

    return inspect.signature(fn).parameters[name].default


def build_parser() -> argparse.ArgumentParser:
    from itup_jax import bench, families
    from itup_jax.dataset import GenerateConfig, generate
    from itup_jax.evaluate import DEFAULT_METHODS, METHODS, VERIFY_K, VERIFY_TORQUE_DRAWS, VERIFY_TORQUE_K
    from itup_jax.grasp_sampler import REACHABLE_BUDGET_FACTOR
    from itup_jax.objective import OBJECTIVES
    from itup_jax.planning import SAMPLING_MODES, plan_grasp
    from itup_jax.sdgnet import TrainConfig

    gen_defaults, train_defaults = GenerateConfig(), TrainConfig()
    from itup_jax.scene import TASK_TIMESTEP
    from itup_jax.scoring import SCORERS
    from itup_jax.task import TASK_KINDS

    ap = argparse.ArgumentParser(prog="itup", description="inverse Tool-use Planning (iTuP) in JAX. Exit status: "
                                 "0 done, 2 bad input, 3 no acceptable grasp (plan; evaluate's verified methods)",
                                 epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-compile-cache", action="store_true",
                    help="do not keep compiled kernels and built tasks between runs (default: kept in "
                    "~/.cache/itup-jax/jax and ~/.cache/itup-jax/tasks, or $ITUP_COMPILE_CACHE_DIR and "
                    "$ITUP_TASK_CACHE_DIR; ITUP_COMPILE_CACHE=0 also turns them off)")
    sub = ap.add_subparsers(dest="cmd", required=True)

    p = sub.add_parser("plan", help="best reachable grasp for a task (SDG-Net by default)", epilog=EXAMPLES,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--task", default=TASK_KINDS[0], choices=TASK_KINDS)
    p.add_argument("--tool", default=None, help="built-in tool name, or a mesh file (with --tool-spec)")
    p.add_argument("--tool-spec", default=None, help="TOML spec of a mesh tool")
    p.add_argument("--n", type=int, default=_default(plan_grasp, "n"),
                   help="grasp candidates scored: with --sampling reachable, grasps the arm can carry through the task "
                   "(default %(default)s)")
    p.add_argument("--sampling", choices=SAMPLING_MODES, default=_default(plan_grasp, "sampling"),
                   help="reachable: draw until --n candidates the arm can carry through the task are found (closed-form "
                   "IK along the trajectory) or --budget are drawn; all: draw --n and walk the ranking to the best "
                   "reachable one (default %(default)s)")
    p.add_argument("--budget", type=int, default=None,
                   help="--sampling reachable: the most candidates drawn (default "
                   f"{REACHABLE_BUDGET_FACTOR} x --n)")
    p.add_argument("--seed", type=int, default=_default(plan_grasp, "seed"))
    p.add_argument("--top", type=int, default=_default(plan_grasp, "top"), help="rows of the ranking to print (the pick, the best-scored reachable "
                   "grasp, is printed too when it lies below them)")
    p.add_argument("--w-tau", type=float, default=None, help="weight of C_tau, 1/(N m) (default 1)")
    p.add_argument("--w-slip", type=float, default=None,
                   help="weight of C_s: 1/N for --scorer analytic (default 1), 1/m for sdgnet (default 100)")
    p.add_argument("--w-align", type=float, default=None,
                   help="weight of C_alpha, 1/rad (defaults: analytic 1, sdgnet scoring.ScoreWeights)")
    p.add_argument("--w-task", type=float, default=None,
                   help="sdgnet: weight of the predicted probability of missing the task (default scoring.W_TASK)")
    p.add_argument("--w-fail", type=float, default=None,
                   help="sdgnet: weight of the predicted probability of failing in the grip (default scoring.W_FAIL)")
    p.add_argument("--w-weak", type=float, default=None,
                   help="sdgnet (a network with the weak-grip head): weight of the predicted probability of failing in "
                   "the grip at 25 N per pad (default scoring.W_WEAK)")
    p.add_argument("--w-grip", type=float, default=None,
                   help="sdgnet (wrench objective): weight of the predicted grip demand, N m per N of normal force "
                   "per pad (default scoring.W_GRIP)")
    p.add_argument("--verify", type=int, default=_default(plan_grasp, "verify"), metavar="K",
                   help="roll the K best grasps out in MuJoCo and pick the lowest measured total (5 is a good choice)")
    p.add_argument("--verify-physics", choices=("nominal", "random"), default=None,
                   help="physics of the --verify rollouts: the priors' nominal values (the default for one draw) or one "
                   "draw each from --seed (the default with --verify-draws > 1)")
    p.add_argument("--verify-draws", type=int, default=_default(plan_grasp, "verify_draws"), metavar="R",
                   help="roll each of the K grasps out R times under random physics; the pick has the lowest mean "
                   "measured total (default 1)")
    p.add_argument("--torque-first", action="store_true",
                   help="sdgnet: weigh torque alone, with the task and grip penalties kept (ScoreWeights.torque_first)")
    p.add_argument("--no-guard", action="store_true",
                   help="sdgnet: do not switch to verified picking when the tool lies outside the network's training "
                   "data (the out-of-distribution guard, itup_jax/ood.py; it still reports)")
    p.add_argument("--scorer", default=_default(plan_grasp, "scorer"), choices=SCORERS,
                   help="sdgnet (the shipped checkpoint, default), sdgnet_paper (the paper objective's checkpoint), "
                   "analytic (the paper's cost), analytic_wrench (its grip-demand form), or a baseline")
    p.add_argument("--model", default=None, help="SDG-Net checkpoint for --scorer sdgnet (default: shipped)")
    p.add_argument("--json", default=None, help="write the result as JSON (schema itup.plan/6)")
    p.set_defaults(fn=cmd_plan)

    b = sub.add_parser("bench", help="benchmarks, each with its own flags: costs, rollout, score, verify, sample")
    bsub = b.add_subparsers(dest="bench", required=True, metavar="BENCHMARK")

    def bench_parser(name, fn, cmd, help_text):
        bp = bsub.add_parser(name, help=help_text)
        bp.add_argument("--json", action="store_true", help="print one JSON object")
        bp.set_defaults(fn=cmd, _bench_fn=fn)
        return bp

    bp = bench_parser("costs", bench.bench_costs, cmd_bench_costs, "the analytic costs (one jit) against NumPy")
    bp.add_argument("--n", type=int, default=_default(bench.bench_costs, "n"), help="grasps (default %(default)s)")
    bp.add_argument("--t", type=int, default=_default(bench.bench_costs, "t"), help="time steps (default %(default)s)")
    bp.add_argument("--task", default=_default(bench.bench_costs, "task_kind"), choices=TASK_KINDS)
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_costs, "repeats"))
    bp = bench_parser("rollout", bench.bench_rollout, cmd_bench_rollout,
                      "hammer scene: raw native stepping, label generation, MJX")
    bp.add_argument("--n", type=int, default=_default(bench.bench_rollout, "n"), help="rollouts (default %(default)s)")
    bp.add_argument("--threads", default=",".join(map(str, _default(bench.bench_rollout, "threads"))),
                    help="native stepping threads to time, comma-separated (default %(default)s)")
    bp.add_argument("--mjx-batches", default=",".join(map(str, _default(bench.bench_rollout, "mjx_batches"))),
                    help="MJX batch sizes, comma-separated ('' for none; default %(default)s)")
    bp.add_argument("--mjx-steps", type=int, default=_default(bench.bench_rollout, "mjx_steps"),
                    help="MJX steps timed per batch (default %(default)s)")
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_rollout, "repeats"))
    bp = bench_parser("score", bench.bench_score, cmd_bench_score, "SDG-Net scoring of n candidates (one jit)")
    bp.add_argument("--n", type=int, default=_default(bench.bench_score, "n"), help="candidates (default %(default)s)")
    bp.add_argument("--task", default=_default(bench.bench_score, "task_kind"), choices=TASK_KINDS)
    bp.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_score, "repeats"))
    bp = bench_parser("verify", bench.bench_verify, cmd_bench_verify, "the verified pick's rollouts against scoring")
    bp.add_argument("--n", type=int, default=_default(bench.bench_verify, "n"), help="candidates (default %(default)s)")
    bp.add_argument("--k", type=int, default=_default(bench.bench_verify, "k"),
                    help="verified grasps per pick (default %(default)s)")
    bp.add_argument("--draws", type=int, default=_default(bench.bench_verify, "draws"),
                    help="rollouts per verified grasp (> 1: random physics; default %(default)s)")
    bp.add_argument("--torque-first", action="store_true",
                    help="the torque-first weights (ScoreWeights.torque_first; `itup plan --torque-first`)")
    bp.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_verify, "repeats"))
    bp = bench_parser("sample", bench.bench_sample, cmd_bench_sample, "the flat-pad sampler and its collision kernel")
    bp.add_argument("--n", type=int, default=_default(bench.bench_sample, "n"), help="grasps (default %(default)s)")
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_sample, "repeats"))
    bp = bench_parser("reachable", bench.bench_reachable, cmd_bench_reachable,
                      "reachable candidates per tool family: sampling with the arm's IK")
    bp.add_argument("--n", type=int, default=_default(bench.bench_reachable, "n"),
                    help="reachable candidates per tool (default %(default)s)")
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_reachable, "repeats"))
    bp.add_argument("--families", default=None, help="comma-separated tool families (default: every one)")

    bp = bench_parser("startup", bench.bench_startup, cmd_bench_startup,
                      "wall time of itup plan and itup demo from a shell, first and repeated")
    bp.add_argument("--task", default=_default(bench.bench_startup, "task_kind"), choices=TASK_KINDS)
    bp.add_argument("--repeats", type=int, default=_default(bench.bench_startup, "repeats"),
                    help="repeated runs per command (default %(default)s)")

    gen = sub.add_parser("generate", help="label dataset: shards + manifest; resumes after a kill")
    gen.add_argument("--out", required=True, help="dataset folder (created; resumed if it holds a manifest)")
    gen.add_argument("--tasks", default=",".join(TASK_KINDS), help="comma-separated task kinds")
    gen.add_argument("--tools-per-task", type=int, default=gen_defaults.tools_per_task,
                     help="built-in tool + procedural variants (default %(default)s)")
    gen.add_argument("--grasps", type=int, default=gen_defaults.grasps, help="grasps (rollouts) per tool (default %(default)s)")
    gen.add_argument("--seed", type=int, default=gen_defaults.seed)
    gen.add_argument("--backend", default=None, choices=["native", "mjx"],
                     help="default: mjx on an accelerator, native on a CPU. On a GPU machine native MuJoCo on its CPU "
                     "cores was faster for these scenes, and gives the CPU's labels (docs/benchmarks.md, GPU)")
    gen.add_argument("--nominal", action="store_true", help="no domain randomisation")
    gen.add_argument("--timestep", type=float, default=None,
                     help="s, the simulator's integration step for every task (default: each task's, "
                     + ", ".join(f"{k} {v * 1e3:g} ms" for k, v in TASK_TIMESTEP.items())
                     + ": the coarsest whose labels rank like 0.25 ms's, experiments/timestep_convergence.py)")
    gen.add_argument("--variants", default=gen_defaults.variants, choices=["stretch", "parts"],
                     help="procedural tools: 'stretch' scales the whole built-in tool, 'parts' varies the handle and "
                     "the head independently (dataset.part_variant)")
    gen.add_argument("--family", default=None, choices=families.names(),
                     help="draw every shard's tool from this tool family (itup tools lists them; --tasks must be ones it "
                     "can do) instead of the task's built-in tool and its --variants")
    gen.add_argument("--contact", default=gen_defaults.contact, choices=["flat", "point"],
                     help="grasp sampler: 'flat' (the pads lie flat on the tool; grasp_sampler.py) or 'point' (antipodal "
                     "point contacts in the friction cone, every dataset up to code 0.5.0)")
    gen.add_argument("--weak-grip", type=float, default=gen_defaults.weak_grip, metavar="N",
                     help="N per pad: also roll every candidate out at this fixed grip, same physics draw otherwise "
                     "(labels label_weak_*, which SDG-Net's weak-grip head learns; about doubles the time); 0: no "
                     "second rollout (default %(default)s)")
    gen.add_argument("--quiet", action="store_true", help="no progress bar")
    gen.add_argument("--mcap", default=None, metavar="DIR",
                     help="also log rollouts as MCAP (Foxglove schemas) into DIR")
    gen.add_argument("--mcap-per-shard", type=int, default=_default(generate, "mcap_per_shard"),
                     help="rollouts logged per shard with --mcap (default %(default)s)")
    gen.add_argument("--process-index", type=int, default=_default(generate, "process_index"), metavar="I",
                     help="with --process-count N: this process makes shards I, I+N, I+2N, ... (0-based)")
    gen.add_argument("--process-count", type=int, default=_default(generate, "process_count"), metavar="N",
                     help="processes that make the dataset together, on one machine or several sharing --out; "
                     "each adds its shards to the one manifest (file lock); start N of them with I = 0..N-1")
    gen.add_argument("--threads", type=int, default=None,
                     help="native stepping threads of this process (default: every core; with N processes on one "
                     "machine, cores / N); the labels do not depend on it")
    gen.set_defaults(fn=cmd_generate)

    tr = sub.add_parser("train", help="train SDG-Net on a dataset from `itup generate`")
    tr.add_argument("--data", required=True, nargs="+", metavar="DIR",
                    help="dataset folder(s); several (e.g. generated with different seeds) are trained on as one; "
                         "DIR:TASK,TASK takes only those tasks' rows from DIR")
    tr.add_argument("--out", required=True, help="checkpoint to write (.npz, arrays only)")
    tr.add_argument("--hidden", default=None, help="hidden layer widths, e.g. 128,128,128 (default: TrainConfig's)")
    tr.add_argument("--weight-decay", type=float, default=None,
                    help="AdamW's decoupled weight decay, per step w -= lr * wd * w (default: TrainConfig's)")
    tr.add_argument("--objective", default=None, choices=tuple(OBJECTIVES),
                    help="what the network regresses: wrench (the induced torque's grasp-frame components and the "
                    "grip demand) or paper (the projected torque) (default: TrainConfig's)")
    tr.add_argument("--torque-scale", type=float, default=None,
                    help="N m; the torque target is log1p(tau / scale) (default: TrainConfig's)")
    tr.add_argument("--success-weight", type=float, default=None,
                    help="weight of the task-success head's cross-entropy; 0: no success head (default: TrainConfig's)")
    tr.add_argument("--failure-weight", type=float, default=None,
                    help="weight of the grip-failure head's cross-entropy; 0: no failure head (default: TrainConfig's)")
    tr.add_argument("--weak-failure-weight", type=float, default=None,
                    help="weight of the weak-grip failure head's cross-entropy (label_weak_failed, from itup generate's "
                    "--weak-grip rollouts); 0: no such head, for data without them (default: TrainConfig's)")
    tr.add_argument("--epochs", type=int, default=train_defaults.epochs, help="(default %(default)s)")
    tr.add_argument("--batch", type=int, default=train_defaults.batch, help="(default %(default)s)")
    tr.add_argument("--lr", type=float, default=train_defaults.lr, help="peak learning rate (default %(default)s)")
    tr.add_argument("--patience", type=int, default=train_defaults.patience,
                    help="epochs without a better validation loss before stopping (default %(default)s)")
    tr.add_argument("--val-fraction", type=float, default=None,
                    help="share of the data's tools held out for validation and early stopping, in (0, 1) "
                         "(default: TrainConfig's, 0.25); the rest are trained on")
    tr.add_argument("--seed", type=int, default=train_defaults.seed)
    tr.add_argument("--finetune-epochs", type=int, default=None,
                    help="epochs of fine-tuning a copy of the shared network on each task's rows, one network per "
                         "task in the checkpoint; 0: the shared network alone (default: TrainConfig's, 0)")
    tr.add_argument("--finetune-lr", type=float, default=None, help="fine-tuning's peak learning rate (default: TrainConfig's)")
    tr.add_argument("--rank-weight", type=float, default=None,
                    help="weight of the within-tool listwise loss on the torque output (the top-1 pick of each "
                         "tool's grasps); 0: the paper's loss alone (default: TrainConfig's, 0)")
    tr.add_argument("--rank-temperature", type=float, default=None,
                    help="temperature of that loss on the normalised log-torque scale; smaller weighs a tool's "
                         "lowest grasps more (default: TrainConfig's)")
    tr.add_argument("--ema", type=float, default=None,
                    help="decay per step of an exponential moving average of the weights, validated and kept "
                         "instead of the last step's (e.g. 0.999); 0: off (default: TrainConfig's, 0; with --init "
                         "the checkpoint's recipe's)")
    tr.add_argument("--per-task", action="store_true",
                    help="one MLP per task trained from scratch (own normalisation, split and early stopping), "
                         "one checkpoint; no fine-tuning")
    tr.add_argument("--teacher", default=None, metavar="E.npz",
                    help="distil: train on this checkpoint's predictions (costs and probabilities) of the rows "
                         "instead of their labels, e.g. an `itup ensemble` that scores M times slower; with --init, "
                         "adapt that checkpoint towards them (how the shipped checkpoint was made)")
    tr.add_argument("--init", default=None, metavar="M.npz",
                    help="adapt this checkpoint to --data instead of training from scratch: each of its networks "
                         "continues from its weights and normalisation for --finetune-epochs epochs (default: its "
                         "recipe's) at --finetune-lr, kept unless an epoch beats it on the data's held-out tools; "
                         "--epochs, --lr and --batch (training from scratch) do not apply")
    tr.add_argument("--keep", default=None, metavar="OUT,OUT",
                    help="with --init: train these outputs of the checkpoint (its objective's: tau, slip, align for paper; "
                         "tau_third, tau_closure, tau_approach, grip, slip, align for wrench; and p_success, p_failed) towards the "
                         "checkpoint's own predictions of the rows instead of their labels, so that the others "
                         "adapt to a changed label while these stay where they were (e.g. tau,align,p_success "
                         "after the slip label changed)")
    tr.add_argument("--quiet", action="store_true")
    tr.set_defaults(fn=cmd_train)

    en = sub.add_parser("ensemble", help="combine trained SDG-Net checkpoints into one that averages them",
                        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    en.add_argument("--models", nargs="+", required=True, metavar="M.npz",
                    help=">= 2 checkpoints of one recipe (e.g. `itup train ... --seed S` for several S)")
    en.add_argument("--out", required=True, help="checkpoint to write (.npz, arrays only); --model M for plan, "
                    "evaluate, bench score")
    en.set_defaults(fn=cmd_ensemble)

    ev = sub.add_parser("evaluate", help="each method's pick, measured in MuJoCo over randomised physics",
                        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_verify_args(ev, TASK_KINDS)
    ev.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                    help=f"comma-separated, from {','.join(METHODS)} (sdgnet_verified: SDG-Net's "
                    f"{VERIFY_K} best rolled out under nominal physics, the best measured kept; sdgnet_verified_torque: its "
                    f"{VERIFY_TORQUE_K} best by the torque-first total, each under {VERIFY_TORQUE_DRAWS} draws of the priors)")
    ev.add_argument("--grip-force", type=float, default=None, metavar="N",
                    help="N per pad, fixed, for the measured rollouts (default: 100, randomised with the priors); "
                    "below the 2F-85's 20 N a labelled robustness probe")
    ev.add_argument("--json", default=None, help="write the result (schema itup.evaluate/1)")
    ev.set_defaults(fn=cmd_evaluate)

    dm = sub.add_parser("demo", help="the main job: SDG-Net vs force closure on the hammer, verified in MuJoCo",
                        epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    _add_verify_args(dm, TASK_KINDS)
    dm.add_argument("--out", default="itup-demo", help="output folder (default ./itup-demo/)")
    dm.add_argument("--quick", action="store_true",
                    help=f"a smoke run: at most {QUICK_DEMO[0]} candidates and {QUICK_DEMO[1]} draws per pick")
    dm.set_defaults(fn=cmd_demo)

    from itup_jax.pipeline import DEFAULT_GRIP_FORCE, DEFAULT_SAMPLES, MAX_PICK_ATTEMPTS, METHODS
    from itup_jax.tabletop import MAX_CLUTTER

    rn = sub.add_parser("run", help="the whole chain from an instruction: ground it, pick the tool up, do the task",
                        description="Ground the instruction in a table of tools (the four built-in ones, plus "
                        "--clutter procedural ones), pick the grounded tool up from where it lies and do the task "
                        "in MuJoCo. Exit 0: done; 3: the chain ran and the task was not done (the stage it ended "
                        "at is printed and in run.json); 2: bad input or an instruction it cannot ground.")
    rn.add_argument("instruction", help='plain words, e.g. "drive the nail with the hammer"')
    rn.add_argument("--tools", nargs="+", default=None, metavar="NAME",
                    help="the tools laid apart on the table: built-in or family names ('spanner@3'); default "
                    "hammer broom mallet l_stick")
    rn.add_argument("--add-tool", nargs=2, action="append", default=None, metavar=("MESH", "SPEC"),
                    help="add your own tool (a mesh file and its TOML spec, as for plan --tool); repeatable")
    rn.add_argument("--clutter", type=int, default=0, help=f"procedural tools dropped among the others (0-{MAX_CLUTTER})")
    rn.add_argument("--seed", type=int, default=0, help="the table's layout, the sampling and the physics draw")
    rn.add_argument("--method", choices=tuple(METHODS), default="itup",
                    help="itup (default) or an ablation: no_sdgnet, object_level, copa, no_grounding")
    rn.add_argument("--samples", type=int, default=DEFAULT_SAMPLES, help="grasps sampled before the pick and reach filters")
    rn.add_argument("--grip-force", type=float, default=DEFAULT_GRIP_FORCE, metavar="N", help="N per pad, pick and task")
    rn.add_argument("--attempts", type=int, default=MAX_PICK_ATTEMPTS, metavar="K",
                    help=f"picks made at most (default {MAX_PICK_ATTEMPTS}): a pick that does not bring the tool up in a "
                    "grasp the task can use puts it back down, one where no such grasp is pickable turns the tool "
                    "over, and the table is planned again away from the grasps tried")
    rn.add_argument("--nominal", action="store_true", help="nominal physics for the task (default: drawn around the priors)")
    rn.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    rn.add_argument("--grounder", choices=("rule", "vlm"), default="rule",
                    help="rule: the lexicon grounder (default); vlm: a vision-language model behind an "
                    "OpenAI-compatible endpoint (--vlm-url and --vlm-model, or $ITUP_VLM_URL and $ITUP_VLM_MODEL)")
    rn.add_argument("--vlm-url", default=None, help="the endpoint's base URL, e.g. http://localhost:8000/v1")
    rn.add_argument("--vlm-model", default=None, help="the model's name on the endpoint")
    rn.add_argument("--vlm-key-env", default=None, help="environment variable holding the API key (default OPENAI_API_KEY)")
    rn.add_argument("--vlm-timeout", type=float, default=60.0, help="s to wait for the model's answer (default 60)")
    rn.add_argument("--vlm-fallback", action="store_true", help="on a failed or invalid answer, ground with the rules")
    rn.add_argument("--view", choices=("auto", "camera", "top"), default="auto",
                    help="scene.png's view (and the picture a vision-language model gets): camera, MuJoCo's "
                    "offscreen rendering (OpenGL: EGL or OSMesa); top, a drawing from above; auto (default): the "
                    "camera where OpenGL works, else the top view")
    rn.add_argument("--out", default="itup-run",
                    help="output folder: run.json, scene.png, pick.mcap (every pick and put-back), task.mcap (default ./itup-run/)")
    rn.set_defaults(fn=cmd_run)

    t = sub.add_parser("tools", help="list the built-in tools, the tool families and the category priors")
    t.set_defaults(fn=cmd_tools)
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    # before JAX starts its backend: reproducible MJX labels on a GPU (simulate.DETERMINISTIC_GPU_FLAG);
    # an XLA_FLAGS that already chooses is left as it is
    from itup_jax.simulate import request_deterministic_gpu

    request_deterministic_gpu()
    from itup_jax import compile_cache

    if compile_cache.wanted(args.no_compile_cache):
        compile_cache.enable()
    from itup_jax.errors import InputError
    from itup_jax.grasp_sampler import SamplingError

    try:
        return args.fn(args)
    except (InputError, SamplingError) as exc:
        print(f"itup: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
