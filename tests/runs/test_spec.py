"""What a run is: the spec written once into the run record and read back whole; a run trained with non-default
task and scene settings is evaluated, resumed and fine-tuned with them, not with the defaults; a malformed record
is one error line; records of earlier formats are read; a method is one entry of overrides, and a config field
reaches the record and the command line with no other edit."""

import dataclasses
import json
import typing
from pathlib import Path

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object, packaged_object
from dragmesh2_jax.cli.flags import NOT_FLAGS, flag_value
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.train import epoch_jit, init_jit
from dragmesh2_jax.runs.build import program_of
from dragmesh2_jax.runs.commands import load_run, on_object
from dragmesh2_jax.runs.finetunes import FINETUNES, catalogue
from dragmesh2_jax.runs.overrides import RECIPE_DAMPINGS
from dragmesh2_jax.runs.presets import METHODS, RECOMMENDED, Method, get_method
from dragmesh2_jax.runs.record import config_from_dict, config_to_dict
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.runs.spec import (
    RECORD_FORMAT,
    SECTIONS,
    RunSpec,
    Schedule,
    apply_overrides,
    finetune_spec,
    method_defaults,
    method_spec,
)
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import AramConfig, ResetNoise, RewardConfig, TaskConfig
from tests.conftest import TINY_NET, installed_command, tiny_spec
from tests.test_cli import flag_of, tree_help

dragmesh2 = installed_command()


def test_configs_round_trip_through_json():
    task = TaskConfig(alpha=0.03, damping_range=(1.0, 3.0), reset_noise=ResetNoise(bank=4),
                      reward=RewardConfig(w_load=2.0, aram=AramConfig()))
    scene = SceneConfig(damping=25.0, friction=1.0, object_pos=(0.6, 0.1, 0.5))
    for config in (task, scene, PPOConfig(aux_warmup=(5, 20), num_envs=8), TaskConfig(), NetworkConfig(),
                   TINY_NET, NetworkConfig(encoder="none", critic="privileged"), Schedule(),
                   Schedule(epochs=300, seed=3, checkpoint="final", dampings=RECIPE_DAMPINGS)):
        back = config_from_dict(type(config), json.loads(json.dumps(config_to_dict(config))))
        assert back == config  # tuples, optional and nested configs included
    with pytest.raises(DragMeshError, match="unknown TaskConfig fields"):
        config_from_dict(TaskConfig, {"alpha": 0.05, "not_a_field": 1})
    plausible = finetune_spec(RunSpec("pica", "obj"), "plausible", "ck", 1).task
    assert config_from_dict(TaskConfig, json.loads(json.dumps(config_to_dict(plausible)))) == plausible


def test_a_record_from_before_the_constraints_reads_its_single_load_constraint():
    """Records written with ``load_constraint`` (null, or hold_cmdp's) read as the load constraint it was."""
    assert config_from_dict(RewardConfig, {"w_task": 250.0, "load_constraint": None}) == RewardConfig()
    old = {"load_constraint": {"f_limit": 100.0, "budget": 0.01, "lr": 50.0, "lambda_max": 20.0}}
    assert config_from_dict(RewardConfig, old).constraints == method_defaults("hold_cmdp").task.reward.constraints


def test_non_default_task_and_scene_settings_are_what_evaluation_and_finetunes_use(tmp_path):
    spec = tiny_spec(task={"alpha": 0.03, "episode_length": 40}, scene={"damping": 25.0, "friction": 1.0},
                     schedule={"epochs": 1, "robust_every": 0}, update_epochs=1)
    run = RunDir(tmp_path / "run")
    start_or_resume(spec, [run], resume=False, progress=False)
    record = run.record()
    assert record["format"] == RECORD_FORMAT and record["scene"]["damping"] == 25.0
    assert record["task"]["alpha"] == 0.03 and {"jax", "mujoco", "python"} <= set(record["versions"])
    assert run.spec() == spec  # read back whole (the network, the schedule)

    program, ts, _, _ = load_run(run.path)
    assert program.task.config.alpha == 0.03 and program.task.config.episode_length == 40
    assert program.task.scene.config.damping == 25.0 and program.task.scene.config.friction == 1.0
    assert program.network == TINY_NET
    evaluation = PAPER.task(program.task)  # the evaluation protocol's task keeps the run's settings
    assert evaluation.config.alpha == 0.03 and evaluation.scene.config.damping == 25.0
    assert float(evaluation.data.params.damping) == 25.0  # the nominal damping the cells multiply

    ft = program_of(finetune_spec(run.spec(), "aram", "ck", 2), run.trajectory())
    assert ft.task.config.alpha == 0.03 and ft.task.scene.config.damping == 25.0
    assert ft.task.config.reward.aram is not None  # the recipe on top of the recorded task


GOOD = RunSpec("pica", "obj").record("mujoco")


@pytest.mark.parametrize("record, fragment", [
    ({"format": 2}, "has no method, object, ppo, task"),
    ({"format": 1, **{k: v for k, v in GOOD.items() if k != "format"}}, "record format 1"),
    ([1, 2], "not a JSON object"),
    ({**GOOD, "method": "pica_typo"}, "unknown method"),
    ({**GOOD, "method": 3}, "method must be a string"),
    ({**GOOD, "ppo": {"num_envs": "many"}}, "expected a number"),
    ({**GOOD, "ppo": {"num_envs": 0}}, "must be >= 1"),
    ({**GOOD, "task": {"damping_range": [1.0]}}, "expected 2 values"),
    ({**GOOD, "task": {"reward": 5}}, "RewardConfig must be an object"),
    ({**GOOD, "scene": {"collide": "some"}}, "collide"),
    ({**GOOD, "finetune": "nope"}, "unknown fine-tune"),
    ({**GOOD, "network": {"heads": 2.5}}, "whole number"),
    ({**GOOD, "network": {"encoder": "lstm"}}, "unknown temporal encoder"),
    ({**GOOD, "schedule": {"checkpoint": "best"}}, "checkpoint must be one of"),
    ({**GOOD, "schedule": [150]}, "Schedule must be an object"),
    ({**GOOD, "ppo": {**GOOD["ppo"], "epochs": 150}}, "unknown PPOConfig fields"),  # format 4 keeps it in schedule
    ({**GOOD, "format": 3, "ppo": 5}, "PPOConfig must be an object"),
])
def test_a_malformed_record_is_one_error_line(record, fragment):
    with pytest.raises(DragMeshError, match=fragment) as e:
        RunSpec.from_record(record)
    assert "\n" not in str(e.value)
    assert RunSpec.from_record(GOOD) == RunSpec("pica", str(Path("obj").resolve()))


def test_a_packaged_object_recorded_by_another_checkout_reads_as_this_install_s():
    """A record names its object folder absolutely: a packaged object recorded where another checkout or install
    kept the package is this install's (the run reads after the checkout moves); any other folder, found or not,
    stands as recorded."""
    elsewhere = "/gone/checkout/dragmesh2_jax/data/objects"
    record = {**GOOD, "object": f"{elsewhere}/door_cabinet_0000",
              "objects": [{"folder": f"{elsewhere}/door_cabinet_0000", "hash": ""},
                          {"folder": f"{elsewhere}/drawer_cabinet_0000", "hash": ""}]}
    spec = RunSpec.from_record(record)
    assert spec.object == str(packaged_object("door_cabinet_0000"))
    assert spec.objects == (spec.object, str(packaged_object("drawer_cabinet_0000")))
    for other in ("/gone/objects/door_cabinet_0000", f"{elsewhere}/no_such_object"):
        assert RunSpec.from_record({**GOOD, "object": other}).object == other


def test_a_recorded_fixed_damping_reads_as_a_range_of_one_value():
    """Records from before the damping was fixed one way (``reset(key, damping_scale)``) held ``damping_fixed``."""
    assert config_from_dict(TaskConfig, {"damping_fixed": None}) == TaskConfig()
    assert config_from_dict(TaskConfig, {"damping_fixed": 2.0}).damping_range == (2.0, 2.0)


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize("group, field, value", [
    ("ppo", "lr", NAN), ("ppo", "num_envs", 0), ("task", "alpha", NAN), ("task", "rho", NAN),
    ("task", "damping_range", [1.0, INF]), ("scene", "scale", NAN), ("scene", "timestep", NAN),
    ("scene", "friction", INF),
    ("ppo", "lr", INF), ("ppo", "gamma", NAN), ("ppo", "gamma", 1e9), ("ppo", "gae_lambda", NAN),
    ("ppo", "clip_eps", NAN), ("task", "alpha", INF), ("task", "alpha", 1e9), ("task", "control_dt", NAN),
    ("task", "d_detach", NAN), ("scene", "scale", INF), ("scene", "object_pos", [NAN, 0.0, 0.6]),
    ("scene", "armature", NAN), ("scene", "collision_radius", NAN), ("network", "log_std_init", NAN),
    ("network", "heads", 0), ("schedule", "epochs", 0), ("schedule", "save_every", 0),
    ("schedule", "epochs", INF), ("schedule", "dampings", [NAN]), ("schedule", "dampings", [0.0]),
])
def test_a_non_finite_or_absurd_recorded_number_is_one_error_line(group, field, value):
    """A config number in run.json that is NaN, infinite, 1e9 or 0 where the field needs a finite value in its range
    (JSON's NaN and Infinity read back as Python's json reads run.json) is refused with one error line naming the
    field: no run is trained, resumed, evaluated or fine-tuned with it."""
    record = json.loads(json.dumps({**GOOD, group: {**GOOD[group], field: value}}))
    with pytest.raises(DragMeshError) as e:
        RunSpec.from_record(record)
    assert "\n" not in str(e.value) and str(e.value).startswith("run record:")
    assert field.split("_")[0] in str(e.value)


def test_recommended_is_the_projects_recipe_and_trains_on_the_c_engine():
    """``--method recommended`` resolves to the recipe, recorded by its own name; one tiny epoch on the C engine
    (tests/physics/test_mjx_backend.py trains it on MJX). The recipe observes what the paper's policy does (no
    force or touch sensing) and acts as a smooth residual over the expert drag, its pull narrowed to a quarter of the
    action range and its wrist load relative to the object's expert's a CMDP constraint charged to the horizon, over
    the expert grasp that holds the most load; only its critic sees damping, friction and contact load. It trains
    the paper's 150 epochs and is read at its final checkpoint over x1-x8 and x16."""
    spec = tiny_spec("recommended")
    assert spec.method == RECOMMENDED and get_method("recommended").name == "hold_blind_residual_seated"
    assert spec.task.expert_grasp == "seated" and spec.task.expert_placement == "holds"
    assert spec.task.damping_range == (1.0, 8.0) and not spec.task.force_obs and spec.task.reset_noise is not None
    assert spec.task.expert_prior and [c.measure for c in spec.task.reward.constraints] == ["relative_load"]
    assert spec.task.residual_scale == 0.25 and spec.task.residual_scope == "translation"
    assert spec.ppo.smooth_coef > 0 and spec.network.critic == "privileged"
    assert method_spec("recommended", "obj").schedule.epochs == 150 and spec.schedule.checkpoint == "final"
    assert spec.schedule.dampings == RECIPE_DAMPINGS
    program = program_of(spec)
    ts, m = epoch_jit(program, program.data(), init_jit(program, program.data(), jax.random.PRNGKey(0)))
    assert int(ts.epoch) == 1 and np.isfinite(float(m["loss"])) and float(ts.privileged_stats.count) > 1
    with pytest.raises(DragMeshError, match="choose from recommended"):
        get_method("recomended")


def test_overrides_are_dotted_paths_into_the_tree_and_an_unknown_one_is_named():
    spec = RunSpec("pica", "obj")
    changed = apply_overrides(spec, {"task.reward.w_load": 2.0, "network.encoder": "gru", "schedule.seed": 3})
    assert (changed.task.reward.w_load, changed.network.encoder, changed.schedule.seed) == (2.0, "gru", 3)
    assert dataclasses.replace(changed.task, reward=spec.task.reward) == spec.task  # nothing else moved
    refined = apply_overrides(spec, {"task.reward": RewardConfig(w_bound=0.0), "task.reward.w_load": 1.0})
    assert refined.task.reward == RewardConfig(w_bound=0.0, w_load=1.0)
    for bad, named in (({"task.reward.w_bond": 0.0}, "task.reward.w_bond"), ({"netwrok.heads": 2}, "netwrok"),
                       ({"task.alpha.x": 1}, "task.alpha.x"), ({"network.encoder": "lstm"}, "lstm")):
        with pytest.raises(DragMeshError, match=named) as e:
            apply_overrides(spec, bad)
        assert "\n" not in str(e.value)
    for name in METHODS:  # every method is a valid set of overrides
        assert method_defaults(name).method == name


def test_the_object_curriculum_needs_two_training_objects_and_a_policy_carried_onto_one_drops_it():
    drawer, door = "drawer_cabinet_0000", "door_cabinet_0000"
    spec = method_spec("pica", [drawer, door], task={"object_curriculum": 0.5})
    assert spec.task.object_curriculum == 0.5
    carried = on_object(spec, door)  # a zero-shot evaluation or a fine-tune onto one object
    assert carried.task.object_curriculum == 0 and dataclasses.replace(carried.task, object_curriculum=0.5) == spec.task
    for objects, holdout in ((drawer, 0), ([drawer, door], 1)):  # one object to train on: nothing to draw among
        with pytest.raises(DragMeshError, match="--task.object-curriculum"):
            method_spec("pica", objects, holdout=holdout, task={"object_curriculum": 0.5})


def test_a_new_method_is_one_entry_that_reaches_the_record_and_the_command_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(METHODS, "pica_wide", Method("pica_wide", "PICA with a wider history feature and a gentler "
                                                     "reward shaping", {"network.hist_dim": 48, "task.alpha": 0.04}))
    spec = method_spec("pica_wide", str(default_object()), backend="mujoco")
    assert spec.network.hist_dim == 48 and spec.task.alpha == 0.04 and spec.method == "pica_wide"
    record = json.loads(json.dumps(spec.record("mujoco")))
    assert record["method"] == "pica_wide" and record["network"]["hist_dim"] == 48 and record["task"]["alpha"] == 0.04
    assert RunSpec.from_record(record) == dataclasses.replace(spec, object=str(Path(spec.object).resolve()))
    assert "pica_wide" in catalogue() and "experimental" in catalogue().splitlines()[-len(FINETUNES) - 1]
    # the command line takes it: a recorded run of it resumes by its name, refusing only what differs
    run = RunDir(tmp_path / "run")
    atomic_write_json(run.record_path, record)
    assert dragmesh2(["train", "--out", str(run.path), "--resume", "--method", "pica_wide", "--task.alpha",
                      "0.05"]) == 2
    err = capsys.readouterr().err
    assert "task.alpha 0.05 (recorded 0.04)" in err and "method pica_wide" not in err


def _leaves(tree, path: str = ""):
    """Every field of a config tree that is a flag, by dotted path: a config nested in it by its fields, an optional
    config or a tuple of configs (the constraints) as one value."""
    hints = typing.get_type_hints(type(tree))
    for f in dataclasses.fields(tree):
        value, where = getattr(tree, f.name), f"{path}{f.name}"
        if dataclasses.is_dataclass(value) and type(None) not in typing.get_args(hints[f.name]):
            yield from _leaves(value, where + ".")
        else:
            yield where, value, hints[f.name]


def _shown(value, hint) -> str:
    """A default as ``--help`` shows it: a flag's value, a tuple of tuples as several values, an optional config as
    ``off`` or its fields, the constraints as ``none`` or their fields, colon-separated."""
    configs = [t for t in typing.get_args(hint) if dataclasses.is_dataclass(t)]
    if configs and value in (None, ()):
        return "off" if value is None else "none"
    if isinstance(value, bool):
        return str(value)
    if dataclasses.is_dataclass(value):
        return ",".join(f"{f.name}={flag_value(getattr(value, f.name))}" for f in dataclasses.fields(value))
    if isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
        return ",".join(":".join(flag_value(getattr(c, f.name)) for f in dataclasses.fields(c)) for c in value)
    if isinstance(value, tuple) and value and isinstance(value[0], tuple):
        return " ".join(map(flag_value, value))
    return flag_value(value)


def test_every_config_field_reaches_the_record_and_a_train_flag_with_its_default():
    """Every field of the schedule and of the PPO, task, scene and network configs, nested ones too, is in the run
    record and is a ``train`` flag (generated by tyro) whose help shows its docstring and its default under the
    method given: a new field reaches both. Only the engine's (``--backend``, ``--impl``, every command's) and the
    parallel-jaw primitive's effector are not tree flags."""
    for method in ("pica", "hold_blind_cmdp"):
        default = method_defaults(method)
        record, helps = default.record("mujoco"), tree_help(default)
        for group in SECTIONS:
            for path, value, hint in _leaves(getattr(default, group), f"{group}."):
                field = path.split(".")[1]
                assert field in record[group], f"{path} not recorded"
                if field in NOT_FLAGS.get(type(getattr(default, group)), ()):
                    assert flag_of(path) not in helps
                    continue
                assert flag_of(path) in helps, f"{path}: no {flag_of(path)}"
                shown = helps[flag_of(path)]
                # (a long default wraps in the help: compared without its spaces)
                assert f"(default:{_shown(value, hint)})".replace(" ", "") in shown.replace(" ", ""), (path, shown)
                assert shown.split(maxsplit=2)[2].partition("(default:")[0].strip(), f"{path}: no docstring"


def _format_3(method: str) -> dict:
    """A record as format 3 wrote it: the epochs and the seed in ``ppo``, the network's sizes without its encoder
    and critic (the method's), the schedule's intervals and checkpoint rule."""
    ppo = {**config_to_dict(PPOConfig()), "epochs": 120, "seed": 7}
    network = {k: v for k, v in config_to_dict(NetworkConfig()).items() if k not in ("encoder", "critic")}
    rule = method_defaults(method).schedule.checkpoint
    return {"format": 3, "method": method, "object": "/objects/door", "objects": [], "holdout": 0, "finetune": None,
            "parent": None, "backend": "mujoco", "buffers": None,
            "schedule": {"save_every": 5, "robust_every": 10, "checkpoint": rule},
            "ppo": ppo, "task": config_to_dict(method_defaults(method).task), "scene": config_to_dict(SceneConfig()),
            "network": network, "versions": {"python": "3.11"}}


def test_a_format_3_record_reads_its_epochs_and_seed_into_the_schedule_and_the_network_from_its_method(tmp_path):
    recipe = RunSpec.from_record(_format_3(RECOMMENDED))
    assert recipe.schedule == Schedule(epochs=120, seed=7, save_every=5, checkpoint="final", dampings=RECIPE_DAMPINGS)
    assert recipe.network == NetworkConfig(critic="privileged") and recipe.ppo == PPOConfig()
    blind = RunSpec.from_record(_format_3("state_only"))  # its recorded aux weight went unused: none now
    assert blind.network.encoder == "none" and blind.ppo.aux_weight == 0.0
    old = {k: v for k, v in _format_3(RECOMMENDED).items() if k not in ("network", "schedule")}  # format 2
    assert RunSpec.from_record({**old, "format": 2}).schedule == dataclasses.replace(recipe.schedule, save_every=10)
    # a resume that extends it writes the record in the current format
    run = RunDir(tmp_path / "run")
    atomic_write_json(run.record_path, _format_3(RECOMMENDED))
    run.revise(dataclasses.replace(recipe, schedule=dataclasses.replace(recipe.schedule, epochs=200)))
    record = run.record()
    assert record["format"] == RECORD_FORMAT and "epochs" not in record["ppo"] and record["schedule"]["epochs"] == 200
    assert record["network"]["critic"] == "privileged" and record["versions"] == {"python": "3.11"}
    assert run.spec() == dataclasses.replace(recipe, schedule=dataclasses.replace(recipe.schedule, epochs=200))


def test_a_format_4_record_reads_with_the_contacts_and_the_grasp_it_was_made_with():
    """Runs recorded before the object's contacts and the expert's grasp were choices were made with MuJoCo's object
    contacts and the planned grasp: they read back so, whatever the defaults become; a value recorded wins."""
    record = {**RunSpec.from_record(_format_3(RECOMMENDED)).record("mujoco"), "format": 4}
    record["scene"] = {k: v for k, v in record["scene"].items() if k != "object_contact"}
    record["task"] = {k: v for k, v in record["task"].items() if k != "expert_grasp"}
    old = RunSpec.from_record(record)
    assert old.scene.object_contact == "mujoco" and old.task.expert_grasp == "planned"
    seated = RunSpec.from_record({**record, "task": {**record["task"], "expert_grasp": "seated"}})
    assert seated.task.expert_grasp == "seated"
    assert RunSpec.from_record(old.record("mujoco")) == old  # written in the current format, read back whole


def test_records_before_formats_6_and_7_read_with_the_starts_they_were_made_with():
    """Runs recorded before perturbed starts were kept clear of the part (format 5) trained and selected on starts as
    drawn, and those before the grasp was seated (format 6) on starts kept clear around the grasp as written: they read
    back so, and keep it when written again; a record of the current format keeps its seated, clear starts."""
    record = {**RunSpec.from_record(_format_3(RECOMMENDED)).record("mujoco")}
    noise = record["task"]["reset_noise"]
    assert noise is not None and {"clear", "seat"} <= set(noise)
    record["task"] = {**record["task"], "reset_noise": {k: v for k, v in noise.items() if k not in ("clear", "seat")}}
    for fmt, clear in ((5, False), (6, True)):
        old = RunSpec.from_record({**record, "format": fmt})
        assert (old.task.reset_noise.clear, old.task.reset_noise.seat) == (clear, False)
        again = RunSpec.from_record(old.record("mujoco")).task.reset_noise  # written now, read back whole
        assert (again.clear, again.seat) == (clear, False)
    now = RunSpec.from_record({**record, "format": RECORD_FORMAT}).task.reset_noise
    assert now.clear is True and now.seat is True
