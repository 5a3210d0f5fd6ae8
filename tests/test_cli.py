"""The command line: inspect on real folders, the demo main job."""

import argparse
import contextlib
import dataclasses
import importlib.util
import io
import json
import re

import pytest
from PIL import Image

from dragmesh2_jax import render
from dragmesh2_jax.assets.procedural import default_object, packaged_object
from dragmesh2_jax.cli.flags import GROUPS, NOT_FLAGS, RENAMED, SHORT_FLAGS, parse_tree, print_tree_help
from dragmesh2_jax.cli.parser import build_parser
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.ppo.checkpoint import is_checkpoint
from dragmesh2_jax.runs.build import program_of
from dragmesh2_jax.runs.commands import train_defaults
from dragmesh2_jax.runs.finetunes import FINETUNES
from dragmesh2_jax.runs.presets import DEFAULT_METHOD, METHODS, OFFERED, RECOMMENDED, STATUSES
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.spec import RunSpec, method_defaults, on_objects
from dragmesh2_jax.task.config import AramConfig, Constraint, ResetNoise
from tests.conftest import installed_command

dragmesh2 = installed_command()


def test_inspect_json_on_a_real_object(gapartnet_dir, capsys):
    assert dragmesh2(["inspect", str(gapartnet_dir / "45261"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["category"] == "StorageFurniture"
    assert info["target_joint"]["type"] == "prismatic" and info["target_joint"]["range"] == [0.0, 0.87]
    assert info["handle"]["source"] == "handle"
    assert info["scene"]["collision_pieces"] >= 1 and 4 <= info["scene"]["max_hull_vertices"] <= 32
    # every hand geom against every colliding piece, and MJX's buffers from the expert drag's probe
    c = info["contacts"]
    assert len(c["pairs"]) == info["scene"]["contact_pairs"] and all(a.startswith("R_") for a, _ in c["pairs"])
    b = c["budget"]
    assert 0 < b["probed_contacts"] < b["contacts"] < b["candidates"] and b["constraints"] >= 4 * b["contacts"]


def test_demo_trains_evaluates_and_reports(tmp_path):
    """The main job end to end: the project's recipe with a 2-epoch preset (the real one is 60 epochs on a CPU) and 2
    episodes per cell (the real one: the paper's 20)."""
    demo = ["demo", "--out", str(tmp_path), "--epochs", "2", "--quiet", "--video-every", "100", "--episodes", "2"]
    assert dragmesh2(demo) == 0
    run = RunDir(tmp_path)
    # the recipe's runs are read at their final checkpoint
    res = run.evaluation(run.checkpoint("final"), dataclasses.replace(PAPER, episodes=2))
    assert run.spec().method == RECOMMENDED and run.policy_checkpoint().name == "final"
    assert res["checkpoint"].endswith("final") and res["protocol"]["starts"]["bank"] >= 1  # perturbed starts
    assert sorted((c["damping"], c["mode"]) for c in res["cells"]) == sorted(
        (d, m) for d in (1.0, 2.0, 4.0) for m in ("det", "stoch"))
    assert all(c["episodes"] == 2 and len(c["success_ci95"]) == 2 for c in res["cells"])
    assert (tmp_path / "robust.csv").is_file()
    report = (tmp_path / "report.md").read_text()
    assert "| x1 | det |" in report and "success_vs_damping.png" in report and "(2 episodes per cell" in report
    for png in ("success_vs_damping.png", "grasp.png"):
        assert (tmp_path / png).read_bytes()[:4] == b"\x89PNG"
    assert is_checkpoint(tmp_path / "checkpoints" / "final")
    frames, width, height = _gif(tmp_path / "policy.gif")
    assert "policy.gif" in report and frames >= 2 and width == 3 * height * 4 // 3  # three panels: x1, x2, x4
    # MuJoCo's renderer where it runs (CI installs libosmesa6), else the fallback
    assert f"({'matplotlib' if render.gl_problem() else 'mujoco'} renderer)" in report
    # a second demo into the folder resumes the run there (nothing more to train) and reports again; a demo of
    # another method is refused, never overwriting the run
    assert dragmesh2(demo) == 0
    assert RunDir(tmp_path).trained_epochs() == 2
    assert dragmesh2(["demo", "--out", str(tmp_path), "--epochs", "2", "--method", "state_only"]) == 2


def _gif(path) -> tuple[int, int, int]:
    """(frames, width, height) of a GIF file."""
    with Image.open(path) as im:
        assert im.format == "GIF"
        return im.n_frames, *im.size


def test_a_controller_evaluates_through_the_same_protocol(capsys):
    """The tracking baseline: the evaluator's cells and metric names, from the protocol's perturbed starts."""
    assert dragmesh2(["evaluate", "--method", "tracking", "--object", str(default_object()), "--damping", "1",
                      "--mode", "det", "--episodes", "3", "--backend", "mujoco", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    (cell,) = res["cells"]
    assert res["method"] == "tracking" and isinstance(res["protocol"]["starts"], dict)
    assert cell["episodes"] == 3 and cell["success_rate"] == 1.0 and 0 <= cell["clip099"] <= 1
    # --exact-reset: the paper's noise-free start, the same episode repeated
    assert dragmesh2(["evaluate", "--method", "tracking", "--object", str(default_object()), "--damping", "1",
                      "--mode", "det", "--episodes", "2", "--backend", "mujoco", "--exact-reset", "--json"]) == 0
    exact = json.loads(capsys.readouterr().out)
    assert exact["protocol"]["starts"] is None and exact["cells"][0]["success_rate"] == 1.0


BAD_INPUT = [
    ["train", "--out", "{tmp}/x"],  # no object
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--task.damping-range=-1,2"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--task.friction-range", "nan,1"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--task.damping-fixed", "inf"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--scene.friction", "-1"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--scene.damping", "nan"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--task.object-curriculum", "0.5"],  # one object: no mix
    # a distilled run without its teachers, and a teacher that is no run
    ["train", "--method", "pica", "--num-envs", "2", "--object", "{obj}", "--out", "{tmp}/x",
     "--ppo.distill-coef", "1"],
    ["train", "--method", "pica", "--num-envs", "2", "--object", "{obj}", "--out", "{tmp}/x",
     "--ppo.distill-coef", "1", "--teachers", "{tmp}/none"],
    ["evaluate", "--method", "tracking", "--object", "{obj}", "--damping", "-1"],
    ["evaluate", "--method", "tracking", "--object", "{obj}", "--damping", "inf"],
    ["evaluate", "--method", "teleport", "--object", "{obj}"],
    ["evaluate", "--method", "prior", "--object", "{obj}"],  # an object's task has no expert prior
    ["evaluate", "--object", "{obj}"],  # neither a run nor a controller
    ["video", "--checkpoint", "{tmp}/none"],
    ["bench", "soak", "--damping=1,-2"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--task.alpha", "fast"],  # a usage error
    ["train", "--out", "{tmp}/run_without_configs", "--resume"],  # run.json = {"format": 2}
    ["evaluate", "--checkpoint", "{tmp}/run_without_configs"],
    ["spin"],
    # numbers refused when parsed, before anything runs
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--ppo.num-minibatches", "0"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--save-every", "0"],
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--seeds", ""],  # not seed 42
    ["train", "--object", "{obj}", "--out", "{tmp}/x", "--epochs", "0"],
    ["evaluate", "--method", "tracking", "--object", "{obj}", "--damping", "0"],  # not an x0 row
    ["evaluate", "--method", "tracking", "--object", "{obj}", "--episodes", "-3"],
    ["view", "--object", "{obj}", "--damping", "0"],
    ["reproduce", "main", "--out", "{tmp}/x", "--video-every", "-1"],
    # flags a recorded comparison would ignore
    ["bench", "learning", "--against", "{tmp}/curves.json", "--epochs", "2", "--seeds", "0"],
]


@pytest.mark.parametrize("argv", BAD_INPUT, ids=lambda a: " ".join(a[:1] + a[-2:]))
def test_bad_input_is_one_error_line_and_status_2(argv, tmp_path, capsys):
    argv = [a.format(tmp=tmp_path, obj=default_object()) for a in argv]
    (tmp_path / "run_without_configs").mkdir()
    (tmp_path / "run_without_configs" / "run.json").write_text('{"format": 2}')
    (tmp_path / "curves.json").write_text('{"method": "pica", "epochs": 40, "seeds": [0, 1, 2], "curves": {}}')
    assert dragmesh2(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    assert not (tmp_path / "x").exists()  # nothing was written


#: A valid value, not the default, for every config flag of ``train`` that is not a nested config (valid together).
FLAG_VALUES = {
    "schedule": {"epochs": 3, "seed": 5, "save_every": 2, "robust_every": 0, "robust_episodes": 12,
                 "checkpoint": "final", "dampings": (1.0, 8.0)},
    "task": {"alpha": 0.04, "control_dt": 1 / 30, "episode_length": 200, "history_len": 8, "aux_window": 3,
             "rho": 0.6, "d_detach": 0.12, "settle_substeps": 2, "damping_range": (1.0, 3.0), "damping_log": True,
             "friction_range": (0.8, 1.2), "force_obs": True, "observation": "handle",
             "nthread": 1, "contacts": 48, "object_curriculum": 0.5, "expert_prior": True,
             "expert_load_unit": "start", "residual_scale": 0.5, "residual_scope": "translation",
             "reset_noise": ResetNoise(wrist_pos=0.004, bank=8), "expert_grasp": "seated", "grip_closure": 0.03,
             "expert_rest": True, "expert_wrap": True, "expert_placement": "holds", "expert_depth": 0.0015,
             "expert_choice_starts": 24, "prior_lead": 0.2, "prior_floor": True, "prior_from_start": True,
             "residual_ramp": 5, "expert_plan_contact": "mujoco", "residual_on": "target"},
    "scene": {"scale": 0.45, "object_pos": (0.55, 0.0, 0.6), "timestep": 1 / 120, "damping": 20.0, "armature": 0.01,
              "link_areal_density": 4.0, "friction": 1.2, "collide": "all", "collision_radius": 0.3,
              "gravity": False, "solver_iterations": 5, "ls_iterations": 6, "object_contact": "hand"},
    "ppo": {"num_envs": 8, "rollout_len": 16, "gamma": 0.98, "gae_lambda": 0.9, "lr": 1e-4, "lr_schedule": "adaptive",
            "kl_threshold": 0.01, "clip_eps": 0.1, "update_epochs": 2, "num_minibatches": 2, "value_coef": 0.5,
            "clip_value": False, "entropy_coef": 1e-3, "bounds_coef": 0.02, "bounds_at": 0.9, "aux_weight": 0.02,
            "aux_warmup": (2, 4),
            "aux_channel_weights": (1.0, 1.0, 1.0, 1.0), "max_grad_norm": 0.5, "normalize_obs": False,
            "normalize_advantage": False, "smooth_coef": 0.5, "mean_share": 0.25, "distill_coef": 0.5,
            "distill_epochs": 4},
    "network": {"encoder": "gru", "critic": "privileged", "state_sizes": (64, 64), "hist_dim": 32, "heads": 2,
                "log_std_init": -1.5, "critic_sizes": (64,)},
}


def flag_of(path: str) -> str:
    """The flag of a field of the tree by its dotted path: ``--task.reward.w-bound``, the schedule's ``--epochs``,
    the batch's ``--num-envs``."""
    group, _, rest = path.partition(".")
    config = type(getattr(RunSpec("m", "o"), group))
    rest = RENAMED.get(config, {}).get(rest, rest)
    short = group == "schedule" or rest in SHORT_FLAGS.get(config, ())
    return "--" + (rest if short else f"{group}.{rest}").replace("_", "-")


def flag_args(path: str, value) -> list[str]:
    """A field's flag with this value: a boolean as ``--flag`` or ``--no-flag``, an optional config as its changed
    fields (``KEY=VALUE,...``), a tuple comma-separated."""
    flag = flag_of(path)
    if isinstance(value, bool):
        head, _, name = flag.rpartition(".")
        return [flag if value else (f"{head}.no-{name}" if head else f"--no-{name[2:]}")]
    if dataclasses.is_dataclass(value):
        return [flag, ",".join(f"{f.name}={json.dumps(v) if isinstance(v := getattr(value, f.name), bool) else v}"
                               for f in dataclasses.fields(value))]
    return [flag, ",".join(str(v) for v in value) if isinstance(value, tuple) else str(value)]


def tree_help(default: RunSpec, head: bool = True) -> dict[str, str]:
    """What ``train --help-tree`` says of each configuration flag under ``default``: flag -> its help, on one line
    (``head``: after the flag's own line, its name and type; without: the help alone)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        print_tree_help(default, "dragmesh2 train")
    entries, flag = {}, None
    for line in out.getvalue().splitlines():
        text = line.strip(" \u2502\u256d\u256e\u2570\u256f\u2500")
        if m := re.match(r"(--[a-z][\w.-]*)", text):
            flag = m.group(1)
            entries[flag] = text if head else ""
        elif flag and text and set(text) - set("-"):
            entries[flag] = f"{entries[flag]} {text}".strip()
        else:
            flag = None
    return entries


def test_every_config_flag_reaches_the_run_record_and_the_built_task_trainer_and_scene():
    """Over two objects, where every flag (the object curriculum too) has something to act on."""
    objects = [str(default_object()), str(packaged_object("door_cabinet_0000"))]
    argv = ["train", "--objects", *objects, "--out", "x"]
    for prefix, values in FLAG_VALUES.items():
        argv += [a for f, v in values.items() for a in flag_args(f"{prefix}.{f}", v)]
    args, rest = build_parser().parse_known_args(argv)
    default = method_defaults("pica")
    tree = parse_tree(rest, default, "dragmesh2 train")  # the parsed tree, passed to the run whole
    assert tree.overrides(default) == {f"{g}.{f}": v for g, values in FLAG_VALUES.items() for f, v in values.items()}
    assert args.objects == objects
    spec = on_objects(tree.on("mujoco"), args.objects)
    record = spec.record("mujoco")
    assert RunSpec.from_record(record) == spec  # the record holds every flag
    assert record["overrides"] == json.loads(json.dumps({**tree.overrides(default), "task.backend": "mujoco"},
                                                        default=dataclasses.asdict))
    program = program_of(spec)
    assert program.task.num_objects == 2
    built = {"task": program.task.config, "scene": program.task.scene.config, "ppo": program.config,
             "network": program.network, "schedule": spec.schedule}
    for prefix, values in FLAG_VALUES.items():
        for f, v in values.items():
            assert getattr(built[prefix], f) == v, f"{prefix}.{f}"
    first = program.task.tasks[0]
    assert float(first.params.q_done) == pytest.approx(first.traj.q_done_at(0.6))  # rho is live
    # and no flag is left out of this table: tyro offers exactly these, and the nested configs' fields
    offered = {f for f in tree_help(default) if f.count(".") < 2}
    nested = {f"--{g}.{f.name}".replace("_", "-") for g in GROUPS for f in dataclasses.fields(getattr(default, g))
              if dataclasses.is_dataclass(getattr(getattr(default, g), f.name))}
    assert {f for f in offered if not any(f.startswith(n + ".") for n in nested)} == {
        flag_of(f"{p}.{f}") for p, values in FLAG_VALUES.items() for f in values}
    assert not {flag_of(f"{g}.{n}") for cls, names in NOT_FLAGS.items() for n in names
                for g in GROUPS if isinstance(getattr(default, g), cls)} & set(offered)


def test_a_nested_field_is_a_flag_under_every_method_and_a_flag_tyro_refuses_is_one_line(capsys, tmp_path):
    """The same flags whatever the method's default: an optional config (reset noise, ARAM, Reconfig) and the
    constraints are one value each (``off``/``on``/``KEY=VALUE,...``; ``none``/``MEASURE:LIMIT[:...]``), booleans
    ``--flag``/``--no-flag``."""
    flags = ["--task.reward.constraints", "load:80", "--scene.hand.friction", "1.2", "--task.reset-noise",
             "wrist_pos=0.004", "--task.reward.aram", "on", "--ppo.no-clip-value"]
    for method in ("hold_blind_cmdp", "pica", "recommended"):
        default = method_defaults(method)
        spec = parse_tree(flags, default, "dragmesh2 train")
        assert spec.task.reward.constraints == (Constraint(limit=80.0),) and spec.scene.hand.friction == 1.2
        assert spec.task.reset_noise == ResetNoise(wrist_pos=0.004) and spec.task.reward.aram == AramConfig()
        assert not spec.ppo.clip_value
        moved = ("task.reward.constraints", "scene.hand.friction", "task.reset_noise", "task.reward.aram",
                 "ppo.clip_value")
        assert all(k.startswith(moved) for k in spec.overrides(default))  # nothing else moved
    off = parse_tree(["--task.reset-noise", "off", "--task.reward.constraints", "none"], default, "dragmesh2 train")
    assert off.task.reset_noise is None and off.task.reward.constraints == ()
    for bad in (["--ppo.lr", "fast"], ["--epoch", "3"], ["--task.force-obs", "maybe"], ["--network.state-sizes", "a"],
                ["--scene.object-pos", "1,2"], ["--task.alpha", "-1"], ["--num-envs"], ["--task.reset-noise", "bank=x"],
                ["--task.reset-noise", "banks=8"], ["--task.reward.constraints", "load:fast"],
                ["--task.reward.constraints", "force:100"]):
        assert dragmesh2(["train", "--object", str(default_object()), "--out", str(tmp_path / "x"), *bad]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: "), (bad, err)
    assert not (tmp_path / "x").exists()


def train_parser():
    sub = next(a for a in build_parser()._actions if a.dest == "cmd")
    return sub.choices["train"]


def test_bench_env_checks_every_engine_before_it_measures(monkeypatch, capsys):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "warp" else real(name, *a))
    assert dragmesh2(["bench", "env", "--backend", "mujoco,mjx", "--impl", "jax,warp", "--num-envs", "1",
                      "--steps", "1"]) == 2
    *before, line = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("error: MJX's Warp implementation needs warp-lang")
    assert not [ln for ln in before if "control" in ln and "physics" in ln]  # no row was measured first


def _subparsers(parser: argparse.ArgumentParser):
    """Every (sub)command's parser, by its prog."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):
                yield sub
                yield from _subparsers(sub)


def test_help_shows_every_default():
    """Each option that takes a value and has a default says it in --help, and so do the ones whose default depends
    on the method or the run (the issue's examples)."""
    named = {"dragmesh2 train": {"--method"}, "dragmesh2 evaluate": {"--damping", "--mode", "--episodes"}}
    for sub in _subparsers(build_parser()):
        formatter = sub._get_formatter()
        for a in sub._actions:
            if not a.option_strings or a.nargs == 0:
                continue
            shown = formatter._format_action(a)  # what --help prints for it
            if a.default is not None or set(a.option_strings) & named.get(sub.prog, set()):
                assert "default" in shown, (sub.prog, a.option_strings)
    assert "(default: auto)" in train_parser().format_help()
    flags = tree_help(method_defaults("hold_blind"))  # the configuration's, under the method given
    assert "(default: 300)" in flags["--epochs"] and "(default: 0.05)" in flags["--task.alpha"]
    assert "(default: 64)" in flags["--num-envs"] and "(default: 42)" in flags["--seed"]
    assert "(default: 100.0)" in tree_help(method_defaults("recommended"))["--ppo.smooth-coef"]


def _flag_helps(default: RunSpec) -> dict[str, str]:
    """Each configuration flag's own help text under ``default`` (its name, type and default left out)."""
    return {f: re.sub(r"\s*\(default: [^)]*\)$", "", h) for f, h in tree_help(default, head=False).items()}


def test_train_help_is_one_short_page_and_names_the_offered_methods(capsys):
    assert dragmesh2(["train", "--help"]) == 0
    text = capsys.readouterr().out
    assert len(text.splitlines()) < 150 and text.count("usage:") == 1
    assert "--task.reward.NAME:" in text and "w-bound" in text and "--help-tree" in text
    options = text[text.index("options:"):]
    method_help = options[options.index("--method METHOD"):options.index("--list-methods")]
    for m in METHODS.values():  # the paper's, the recommended and the generalist are named; the others listed apart
        assert bool(re.search(rf"\b{m.name}\b", method_help)) == (m.status in OFFERED), m.name
    assert dragmesh2(["train", "--list-methods"]) == 0
    listed = capsys.readouterr().out.splitlines()
    assert len(listed) == len(METHODS) + len(FINETUNES)
    assert all(line.split()[1 if not line.startswith("finetune") else 2] in STATUSES for line in listed)


def test_every_flag_shows_its_own_fields_help():
    """No flag shows another field's text (tyro reads each field's docstring), under methods with the nested groups
    on and off; choice fields show their values."""
    for method in ("pica", "recommended", "hold_blind_cmdp"):
        helps = _flag_helps(method_defaults(method))
        assert all(helps.values()), [f for f, h in helps.items() if not h]
        by_text = {}
        for flag, text in helps.items():
            by_text.setdefault(text, set()).add(flag.rsplit(".", 1)[-1])
        assert not {t: names for t, names in by_text.items() if len(names) > 1}, method
    shown = tree_help(method_defaults("recommended"))
    for flag, values in (("--task.reward.lagrangian", "{plain,normalized}"), ("--network.encoder", "gla"),
                         ("--ppo.lr-schedule", "{fixed,adaptive}"), ("--scene.hand.side", "{right,left}")):
        assert values in shown[flag], shown[flag]


def test_every_command_spells_a_flag_one_way():
    """One spelling per meaning on every subcommand: damping cells ``--damping``, video frequency ``--video-every``,
    several objects ``--objects A B`` (one object ``--object``), several seeds ``--seeds``, and ``--checkpoint``
    always a checkpoint (a run, one of its checkpoints or a packaged name), a checkpoint rule ``--checkpoint-rule``."""
    spelled = {}
    for sub in _subparsers(build_parser()):
        for a in sub._actions:
            for flag in a.option_strings:
                spelled.setdefault(flag, []).append((sub.prog, a))
    assert not {"--dampings", "--every", "--seed-list", "--object-list"} & set(spelled)
    for prog, a in spelled.get("--checkpoint", []):
        assert a.choices is None and "rule" not in (a.help or ""), prog
    for prog, a in spelled.get("--object", []):
        assert "comma" not in (a.help or "") and a.nargs is None, prog
    for prog, a in spelled.get("--objects", []):
        assert a.nargs in ("+", "*"), prog  # a list of folders, space-separated
    for flag in ("--damping", "--video-every"):
        assert len({a.dest for _, a in spelled[flag]}) == 1, flag
    assert "--damping" in _flag_helps(method_defaults("recommended")) and "--checkpoint-rule" in _flag_helps(
        method_defaults("recommended"))


def test_train_without_a_method_trains_the_recipe():
    assert train_defaults(None, None, False, None).method == RECOMMENDED == DEFAULT_METHOD


def test_envelope_prints_the_cells_and_rejects_a_bad_pace(capsys):
    obj = str(default_object())
    assert dragmesh2(["envelope", "--object", obj, "--paces", "1", "--damping", "1", "--backend", "mujoco",
                      "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["pace"] == 1.0 and row["damping"] == 1.0 and row["opened"]
    for bad in (["--paces", "0"], ["--paces", "fast"], ["--damping", "-1"]):
        assert dragmesh2(["envelope", "--object", obj, "--backend", "mujoco", *bad]) == 2
    assert capsys.readouterr().err.count("error:") == 3


def test_several_objects_are_given_one_way_and_checked_before_anything_trains(tmp_path, capsys):
    obj = str(default_object())
    for bad in (["--object", obj, "--objects", obj, obj], ["--dataset", str(tmp_path)],
                ["--objects", obj, obj, "--holdout", "2"]):
        assert dragmesh2(["train", "--out", str(tmp_path / "x"), "--backend", "mujoco", *bad]) == 2
    err = capsys.readouterr().err
    assert "not both" in err and "not a dataset folder" in err and "--holdout 2" in err
