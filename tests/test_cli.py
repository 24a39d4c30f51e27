"""The `itup` CLI end to end at tiny sizes; JSON outputs checked against their documented schema."""

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from itup_jax.cli import main

PLAN_KEYS = {"schema", "task", "tool", "regime", "n_candidates", "sampling", "guard", "seed", "scorer", "weights", "best", "top", "summary",
             "status"}
GRASP_KEYS = {"reachable", "index", "p_tool_grasp_m", "q_tool_grasp_wxyz", "width_m", "graspnet_rotation_matrix", "costs"}
BENCH_KEYS = {"n", "t", "compile_s", "warm_ms", "numpy_ms", "speedup_vs_numpy", "machine", "max_rel_diff_vs_numpy"}


def test_plan_writes_the_best_grasp_as_json(tmp_path, capsys):
    out = tmp_path / "best.json"
    # the seeded random scorer: its ranking has no ties and does not move when the shipped checkpoint is
    # retrained, so the premise below (the scorer's first grasp is unreachable) holds whatever the checkpoint
    assert main(["plan", "--task", "reach", "--n", "40", "--top", "3", "--scorer", "random", "--sampling", "all",
                 "--no-verify", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert set(res) == PLAN_KEYS and res["schema"] == "itup.plan/8" and res["status"] == "ok"
    assert res["sampling"]["mode"] == "all" and res["sampling"]["drawn"] == res["n_candidates"] == 40
    assert set(res["best"]) == GRASP_KEYS | {"rank"} and len(res["top"]) == 3
    totals = [r["costs"]["total"] for r in res["top"]]
    assert totals == sorted(totals) and res["regime"] == "quasi_static"
    # the pick is the best-scored grasp the arm can reach: here (the reach task's L-stick) the scorer's
    # first ones are not, so it lies further down the ranking, every grasp above it unreachable
    import itup_jax as itup
    from itup_jax.sim.arm import reachable
    from itup_jax.task import DEFAULT_TOOL

    tool = itup.load_tool(DEFAULT_TOOL["reach"])
    task = itup.make_task("reach", tool)
    g = itup.sample_grasps(tool, 40, seed=0)
    order = np.argsort(np.asarray(itup.score(tool, task, g, "random").total), kind="stable")
    ok = reachable(task, g[order])
    best = res["best"]
    assert best["reachable"] and best["rank"] == int(np.argmax(ok)) + 1 > 1 and best["index"] == order[best["rank"] - 1]
    assert [r["reachable"] for r in res["top"]] == ok[:3].tolist()
    assert best["costs"]["total"] >= res["summary"]["total"]["min"]
    out_text = capsys.readouterr().out
    assert "<- pick" in out_text and f"the pick is the best-scored reachable grasp (rank {best['rank']})" in out_text


def test_plan_scores_only_reachable_candidates_by_default(tmp_path, capsys):
    """The default sampling draws until --n candidates are ones the arm can carry: the scorer's first is
    the pick, every listed row is reachable, and the JSON says how many were drawn for them."""
    out = tmp_path / "best.json"
    assert main(["plan", "--task", "reach", "--n", "40", "--top", "3", "--scorer", "random", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    sm = res["sampling"]
    assert sm["mode"] == "reachable" and sm["requested"] == sm["reachable"] == res["n_candidates"] == 40
    assert sm["complete"] and sm["drawn"] > 40 and sm["budget"] == 40 * 40
    assert res["best"]["rank"] == 1 and all(r["reachable"] for r in res["top"])
    assert f"40 reachable of {sm['drawn']} drawn" in capsys.readouterr().out
    # a budget that cannot be met: a warning, what was found is scored
    assert main(["plan", "--task", "reach", "--n", "200", "--budget", "256", "--scorer", "random",
                 "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert not res["sampling"]["complete"] and res["n_candidates"] == res["sampling"]["reachable"] < 200
    assert "fewer than the 200 asked for (--budget 256 spent)" in capsys.readouterr().out
    assert main(["plan", "--task", "reach", "--n", "40", "--budget", "10"]) == 2
    assert "--budget (the most candidates drawn)" in capsys.readouterr().err


@pytest.mark.slow
def test_plan_marks_no_pick_when_no_candidate_is_reachable(tmp_path, capsys, monkeypatch):
    import importlib

    sim = importlib.import_module("itup_jax.sim.arm")
    monkeypatch.setattr(sim, "reachable", lambda task, g: np.zeros(len(g), bool))
    out = tmp_path / "none.json"
    assert main(["plan", "--task", "knock", "--n", "20", "--top", "2", "--sampling", "all", "--json", str(out)]) == 3
    res = json.loads(out.read_text())
    assert res["best"] is None and res["status"] == "no_reachable_candidate" and res["advice"]
    text = capsys.readouterr().out
    assert "no pick: none of the 20 candidates is reachable" in text and "<- pick" not in text
    # the default sampling draws its whole budget, scores nothing and says so
    assert main(["plan", "--task", "knock", "--n", "20", "--json", str(out)]) == 3
    res = json.loads(out.read_text())
    assert res["status"] == "no_reachable_candidate" and res["best"] is None and res["n_candidates"] == 0
    why = res["sampling"].pop("unreachable")  # under 10 % reachable: the plan says why (IK itself is not patched)
    assert why["checked"] == 256
    assert res["sampling"] == {"mode": "reachable", "requested": 20, "reachable": 0, "drawn": 800, "budget": 800,
                               "complete": False}
    assert res["summary"] is None and res["top"] == []
    from jsonschema import validate

    from itup_jax.schemas import load_schema

    validate(res, load_schema("plan"))
    text = capsys.readouterr().out
    assert "no pick: none of the 800 drawn candidates is reachable" in text and "<- pick" not in text
    assert "note: the arm can carry 0.0 % of the drawn candidates through the task; of 256 candidates checked" in text


@pytest.mark.slow
def test_plan_weights_reach_the_scorer_that_uses_them(tmp_path, capsys):
    """--w-* flags weigh the analytic cost (CostParams) or SDG-Net's total (ScoreWeights) and are recorded
    as used; a baseline has no weights, the analytic cost no task term: both refused."""
    runs = {}
    for name, extra in (("default", []), ("align", ["--w-align", "50", "--w-task", "0", "--w-fail", "0", "--w-weak", "7", "--w-grip", "0.02"])):
        out = tmp_path / f"{name}.json"
        assert main(["plan", "--task", "knock", "--n", "40", "--top", "40", "--json", str(out)] + extra) == 0
        runs[name] = json.loads(out.read_text())
    from itup_jax.scoring import ScoreWeights

    assert runs["default"]["weights"] == dataclasses.asdict(ScoreWeights())
    assert runs["align"]["weights"]["w_align"] == 50 and runs["align"]["weights"]["w_task"] == 0
    assert runs["align"]["weights"]["w_fail"] == 0 and runs["align"]["weights"]["w_weak"] == 7
    for r in runs["align"]["top"]:  # the total is the weighted sum with the given weights
        c = r["costs"]
        grip = 0.02 * c["grip"]  # the shipped network predicts the grip demand too
        weak = 7 * c["p_failed_weak"]  # and the probability of failing in the grip at 25 N per pad
        assert c["total"] == pytest.approx(c["tau"] + 100 * c["slip"] + 50 * c["align"] + grip + weak, rel=1e-4, abs=1e-4)
    out = tmp_path / "a.json"
    assert main(["plan", "--task", "knock", "--n", "8", "--scorer", "analytic", "--w-slip", "3", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["weights"] == {"w_tau": 1.0, "w_slip": 3.0, "w_align": 1.0}
    assert main(["plan", "--task", "knock", "--n", "8", "--scorer", "random", "--w-tau", "2"]) == 2
    assert "no weights" in capsys.readouterr().err
    assert main(["plan", "--task", "knock", "--n", "8", "--scorer", "analytic", "--w-task", "2"]) == 2
    assert "w-task" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:.*joint-speed limit")  # a short stick swings faster for the same tip speed
def test_plan_verifies_its_best_grasps_in_mujoco(tmp_path, capsys):
    out = tmp_path / "v.json"
    assert main(["plan", "--task", "sweep", "--n", "30", "--verify", "2", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    ver = res["verified"]
    assert ver["backend"] == "native" and ver["physics"] == "nominal" and ver["k"] == 2
    # unreachable grasps are skipped: 2 reachable ones are rolled out
    assert sum(r["valid"] for r in ver["labels"]) == 2 and not {r["index"] for r in ver["labels"]} & set(ver["unreachable"])
    assert {"valid", "peak_torque_induced", "slip_translation", "failed", "weak_failed", "measured_total"} <= set(ver["labels"][0])
    assert ver["weak_grip"] == 25.0
    # the pick is the tried grasp with the lowest measured total
    tried = [r for r in ver["labels"] if r["measured_total"] is not None]
    assert ver["pick"]["index"] == min(tried, key=lambda r: r["measured_total"])["index"]
    assert "MuJoCo" in capsys.readouterr().out


@pytest.mark.filterwarnings("ignore:.*joint-speed limit")
def test_plan_verifies_over_draws_with_the_torque_first_weights(tmp_path, capsys):
    """--verify 2 --verify-draws 2 --torque-first: random physics, two rollouts per grasp, and the pick is the
    grasp with the lowest mean measured total (torque, task and grip penalties; the shipped network's
    objective measures the full induced torque, and torque-first weighs no grip demand)."""
    out = tmp_path / "v.json"
    assert main(["plan", "--task", "sweep", "--n", "30", "--verify", "2", "--verify-draws", "2", "--torque-first",
                 "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    ver = res["verified"]
    assert ver["physics"] == "random" and ver["draws"] == 2 and res["weights"]["w_slip"] == 0.0
    assert ver["weak_grip"] == 25.0 and res["weights"]["w_weak"] == 30.0
    assert res["weights"]["w_align"] == 0.0 and res["weights"]["w_task"] > 0 and ver["weights"] == res["weights"]
    assert res["weights"]["w_grip"] == 0.0
    assert len(ver["labels"]) == 2 * len(ver["candidates"]) and [r["draw"] for r in ver["labels"][:2]] == [0, 1]
    for c in ver["candidates"]:
        rows = [r for r in ver["labels"] if r["index"] == c["index"]]
        # each rollout repeated at 25 N per pad: a failure there weighs w_weak (30)
        mean = sum(r["peak_torque_induced"] + 10.0 * (not r["success"]) + 10.0 * r["failed"] + 30.0 * r["weak_failed"]
                   for r in rows) / 2
        assert c["measured_total"] == pytest.approx(mean, rel=1e-9)
    assert ver["pick"]["index"] == min(ver["candidates"], key=lambda c: c["measured_total"])["index"]
    assert "2 draws per grasp" in capsys.readouterr().out


def test_plan_with_a_user_mesh_tool(tmp_path):
    import trimesh

    trimesh.creation.box((0.03, 0.025, 0.30)).export(tmp_path / "stick.stl")
    (tmp_path / "stick.toml").write_text(
        'name = "stick"\ncategory = "mallet"\ncontact_point = [0.0, 0.0, 0.15]\ncontact_normal = [1.0, 0.0, 0.0]\n'
        "grasp_region = { min = [-0.02, -0.02, -0.15], max = [0.02, 0.02, 0.0] }\n")
    out = tmp_path / "p.json"
    assert main(["plan", "--task", "knock", "--tool", str(tmp_path / "stick.stl"), "--tool-spec",
                 str(tmp_path / "stick.toml"), "--n", "20", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["tool"]["name"] == "stick"


@pytest.mark.slow
def test_bench_costs_prints_one_json_object():
    proc = subprocess.run([sys.executable, "-m", "itup_jax.cli", "bench", "costs", "--n", "500", "--t", "16",
                           "--repeats", "2", "--json"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    res = json.loads(proc.stdout)  # stdout is the JSON object and nothing else
    assert BENCH_KEYS <= set(res) and res["n"] == 500 and res["t"] == 16
    assert res["max_rel_diff_vs_numpy"] < 1e-3 and res["warm_ms"] > 0


def test_importing_mjx_prints_nothing_to_stdout():
    """MJX's import reports a missing optional Warp backend on stdout; `import_mjx` keeps stdout clean for
    `itup bench rollout --json` and the other JSON printers."""
    proc = subprocess.run([sys.executable, "-c", "from itup_jax.sim.mjx import import_mjx; import_mjx()"],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == ""


@pytest.mark.parametrize("argv,match", [
    (["plan", "--task", "hammer", "--n", "0"], "--n must be an integer in 1..100,000, got 0"),
    (["plan", "--top", "0"], "--top must be an integer >= 1"),
    (["plan", "--verify", "-1"], "--verify K rolls the K best grasps out and must be >= 1, got -1"),
    (["plan", "--verify", "0"], "--no-verify picks by the score alone"),
    (["plan", "--n", "10000000"], "--n must be an integer in 1..100,000, got 10,000,000"),
    (["evaluate", "--n", "200000"], "--n must be an integer in 1..100,000"),
    (["run", "drive the nail", "--samples", "0"], "--samples must be an integer in 1..100,000"),
    (["plan", "--verify", "2", "--verify-draws", "0"], "--verify-draws must be an integer >= 1"),
    (["plan", "--no-verify", "--verify-draws", "3"], "--verify-draws applies to the verified pick, and verification is off"),
    (["plan", "--verify", "2", "--verify-weak-grip", "300"], "--verify-weak-grip: grip force must be in (0, 235"),
    (["plan", "--verify", "2", "--verify-draws", "3", "--verify-physics", "nominal"], "needs --verify-physics 'random'"),
    (["plan", "--torque-first", "--w-slip", "1"], "cannot be combined with --w-slip"),
    (["plan", "--torque-first", "--scorer", "analytic"], "not the 'analytic' scorer's"),
    (["plan", "--guard-threshold", "-1"], "--guard-threshold must be a finite number > 0, got -1.0"),
    (["plan", "--guard-threshold", "1.3", "--scorer", "geometric"], "--guard-threshold applies to the SDG-Net"),
    (["bench", "verify", "--draws", "0"], "bench verify: --draws must be an integer >= 1, got 0"),
    (["plan", "--n", "5", "--seed", "-1"], "seed must be an integer >= 0, got -1"),
    (["plan", "--tool", "spoon"], "not a built-in tool"),
    (["plan", "--tool-spec", "x.toml"], "--tool-spec needs --tool"),
    (["plan", "--n", "5", "--json", "/no/such/folder/out.json"], "does not exist"),
])
def test_bad_input_exits_non_zero_with_a_message(argv, match, capsys, tmp_path):
    assert main(argv) == 2
    assert match in capsys.readouterr().err


@pytest.mark.parametrize("flags,match", [
    (["--epochs", "0"], "epochs must be an integer >= 1, got 0"),
    (["--batch", "0"], "batch must be an integer >= 1, got 0"),
    (["--patience", "0"], "patience must be an integer >= 1, got 0"),
    (["--lr", "-1"], "lr must be a finite number > 0, got -1.0"),
    (["--weight-decay", "-0.1"], "weight_decay must be a finite number >= 0"),
    (["--hidden", "128,x"], "--hidden: comma-separated layer widths"),
    (["--hidden", "128,0"], "hidden must be a tuple of layer widths >= 1"),
    (["--seed", "-1"], "seed must be an integer >= 0"),
    (["--rank-weight", "-1"], "rank_weight must be a finite number >= 0"),
    (["--rank-temperature", "0"], "rank_temperature must be a finite number > 0"),
    (["--val-fraction", "1"], "val_fraction (the share of tools held out) must be in (0, 1), got 1.0"),
    (["--val-fraction", "0"], "val_fraction (the share of tools held out) must be in (0, 1), got 0.0"),
])
def test_bad_training_recipe_is_refused_before_anything_is_read_or_written(flags, match, capsys, tmp_path):
    out = tmp_path / "m.npz"
    assert main(["train", "--data", str(tmp_path / "no-such-dataset"), "--out", str(out), *flags]) == 2
    assert match in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("argv", [["plan", "--task", "drill"], ["bench", "walk"], ["bench", "score", "--threads", "2"]])
def test_unknown_choices_and_flags_are_refused_by_the_parser(capsys, argv):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and ("invalid choice" in err or "unrecognized arguments: --threads" in err)


def test_cli_defaults_are_the_librarys():
    """Every default the CLI shows is read from the library's own defaults."""
    from itup_jax.cli import build_parser
    from itup_jax.dataset import GenerateConfig
    from itup_jax.evaluate import DEFAULT_METHODS
    from itup_jax.planning import DEFAULT_N, DEFAULT_TOP, DEFAULT_VERIFY
    from itup_jax.sdgnet.config import TrainConfig

    p = build_parser()
    plan = p.parse_args(["plan"])
    assert (plan.n, plan.top, plan.verify, plan.verify_draws, plan.scorer) == (DEFAULT_N, DEFAULT_TOP, DEFAULT_VERIFY, 1,
                                                                               "sdgnet")
    assert not plan.no_verify and plan.verify_weak_grip == 25.0
    assert p.parse_args(["evaluate"]).methods == ",".join(DEFAULT_METHODS)
    gen, cfg = p.parse_args(["generate", "--out", "x"]), GenerateConfig()
    assert (gen.tools_per_task, gen.grasps, gen.seed, gen.variants, gen.contact, gen.weak_grip) == (
        cfg.tools_per_task, cfg.grasps, cfg.seed, cfg.variants, cfg.contact, cfg.weak_grip)
    tr, tc = p.parse_args(["train", "--data", "d", "--out", "m.npz"]), TrainConfig()
    assert (tr.epochs, tr.batch, tr.lr, tr.patience, tr.seed) == (tc.epochs, tc.batch, tc.lr, tc.patience, tc.seed)
    assert p.parse_args(["bench", "score"]).n == 10_000 and p.parse_args(["bench", "costs"]).n == 100_000


def test_failed_json_write_leaves_nothing_behind(tmp_path, monkeypatch):
    import itup_jax.atomic as atomic

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(atomic.os, "fsync", boom)  # fails after the temporary file is written
    with pytest.raises(RuntimeError):
        main(["plan", "--task", "reach", "--n", "5", "--json", str(tmp_path / "x.json")])
    assert list(tmp_path.iterdir()) == []


def test_atomic_write_gives_the_mode_open_would(tmp_path):
    import os

    from itup_jax.atomic import atomic_write

    p = tmp_path / "f.bin"
    atomic_write(str(p), b"x")
    umask = os.umask(0)
    os.umask(umask)
    assert p.read_bytes() == b"x" and (p.stat().st_mode & 0o777) == (0o666 & ~umask)


def test_atomic_write_json_is_strict_json(tmp_path):
    import json

    import numpy as np

    from itup_jax.atomic import atomic_write_json

    p = tmp_path / "f.json"
    atomic_write_json(str(p), {"a": float("nan"), "b": [1.5, np.float32(np.inf), np.int64(3)], "c": (np.nan,)})
    text = p.read_text()
    assert "NaN" not in text and "Infinity" not in text
    assert json.loads(text) == {"a": None, "b": [1.5, None, 3], "c": [None]}


@pytest.mark.slow
def test_bench_sample_reports_both_kernels(capsys):
    assert main(["bench", "sample", "--n", "64", "--repeats", "3", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["benchmark"] == "sample" and res["n"] == 64 and len(res["tasks"]) == 4
    for r in res["tasks"]:
        # the kernel and the batched-dot form it replaced give the same hits on a chunk of sampled grasps
        assert r["kernels_agree"] and r["warm_s"] > 0 and r["kernel_chunk_ms"] > 0 and r["dot_kernel_chunk_ms"] > 0


def test_bench_reachable_reports_each_family_and_task(capsys):
    assert main(["bench", "reachable", "--n", "16", "--repeats", "1", "--families", "spanner", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["benchmark"] == "reachable" and [(r["family"], r["task"]) for r in res["families"]] == [
        ("spanner", "hammer"), ("spanner", "knock")]
    for r in res["families"]:
        assert r["reachable"] == 16 and r["drawn"] >= 16 and 0 < r["reachable_share"] <= 1 and r["warm_s"] > 0
    assert main(["bench", "reachable", "--families", "wrench"]) == 2
    assert "tool family 'wrench'" in capsys.readouterr().err


def test_cli_asks_xla_for_deterministic_gpu_scatters(monkeypatch):
    import os

    from itup_jax.sim.mjx import DETERMINISTIC_GPU_FLAG

    monkeypatch.setenv("XLA_FLAGS", "")  # restored after the test
    assert main(["plan", "--tool-spec", "x.toml"]) == 2  # a bad input, refused once the flags are set
    assert os.environ["XLA_FLAGS"] == DETERMINISTIC_GPU_FLAG


def test_importing_the_cli_does_not_start_jax():
    """XLA reads XLA_FLAGS when JAX starts its backend: `main` can set the GPU determinism flag only if
    importing the package started nothing."""
    code = "import itup_jax.cli\nfrom jax._src import xla_bridge\nprint(len(xla_bridge._backends))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "0"


@pytest.mark.slow
def test_evaluate_says_when_a_verified_method_found_no_grasp_that_works(tmp_path, capsys, monkeypatch):
    """When none of a verified method's rolled-out grasps did the task and held, evaluate says so, records
    it in the JSON and exits 3 (here every check is made to fail)."""
    from itup_jax.verify import Verified

    out = tmp_path / "e.json"
    assert main(["evaluate", "--task", "hammer", "--methods", "sdgnet_verified,force_closure", "--n", "8",
                 "--seeds", "1", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["methods"]["sdgnet_verified"]["verified"]["succeeded"] is True
    capsys.readouterr()
    monkeypatch.setattr(Verified, "succeeded", property(lambda self: False))
    assert main(["evaluate", "--task", "hammer", "--methods", "sdgnet_verified,force_closure", "--n", "8",
                 "--seeds", "1", "--json", str(out)]) == 3
    res = json.loads(out.read_text())
    assert res["methods"]["sdgnet_verified"]["verified"]["succeeded"] is False
    assert "verified" not in res["methods"]["force_closure"]
    assert "no verified pick for sdgnet_verified: none of the" in capsys.readouterr().out


def test_the_top_level_help_imports_neither_jax_nor_mujoco():
    """`itup --help` builds only the list of commands: no library import, so it starts in well under a second."""
    code = ("import sys; from itup_jax.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "assert 'jax' not in sys.modules and 'mujoco' not in sys.modules, sorted(sys.modules)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    for command in ("demo", "plan", "run", "evaluate", "generate", "train", "ensemble", "bench", "tools"):
        assert command in proc.stdout


@pytest.mark.parametrize("command", ["demo", "plan", "run", "evaluate", "generate", "train", "ensemble", "bench",
                                     "tools"])
def test_each_command_has_its_own_examples_and_shows_its_defaults(command, capsys):
    from itup_jax.cli_args import EXAMPLES

    with pytest.raises(SystemExit) as e:
        main([command, "--help"])
    out = capsys.readouterr().out
    assert e.value.code == 0 and "examples:" in out
    own = [line.strip() for line in EXAMPLES[command].splitlines()[1:]]
    assert own and all(line in out for line in own)  # its own examples, not a shared block
    assert all(line.split("#")[0].split()[1] == command for line in own)
    if command not in ("ensemble", "tools", "bench"):  # every flag with a default says it (bench: its benchmarks do)
        assert "(default" in out
