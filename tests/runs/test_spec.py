"""What a run is: the spec written once into the run record and read back whole; a run trained with non-default
task and scene settings is evaluated, resumed and fine-tuned with them, not with the defaults; a malformed record
is one error line."""

import dataclasses
import json
from pathlib import Path

import jax
import numpy as np
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.policies.methods import RECOMMENDED, get_method
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.finetune import get_finetune
from dragmesh2_jax.ppo.train import epoch_jit, init_jit
from dragmesh2_jax.runs.build import program_of
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.runs.record import config_from_dict, config_to_dict
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import Selection, start_or_resume
from dragmesh2_jax.runs.spec import RECORD_FORMAT, RunSpec, finetune_spec
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import AramConfig, ResetNoise, RewardConfig, TaskConfig
from tests.conftest import TINY_NET, tiny_spec


def test_configs_round_trip_through_json():
    task = TaskConfig(alpha=0.03, damping_range=(1.0, 3.0), damping_fixed=2.0, reset_noise=ResetNoise(bank=4),
                      reward=RewardConfig(w_load=2.0, aram=AramConfig()))
    scene = SceneConfig(damping=25.0, friction=1.0, object_pos=(0.6, 0.1, 0.5))
    for config in (task, scene, PPOConfig(aux_warmup=(5, 20), num_envs=8), TaskConfig(), NetworkConfig(),
                   TINY_NET):
        back = config_from_dict(type(config), json.loads(json.dumps(config_to_dict(config))))
        assert back == config  # tuples, optional and nested configs included
    with pytest.raises(DragMeshError, match="unknown TaskConfig fields"):
        config_from_dict(TaskConfig, {"alpha": 0.05, "not_a_field": 1})
    plausible = TaskConfig(**get_finetune("plausible").task_overrides(RewardConfig()))
    assert config_from_dict(TaskConfig, json.loads(json.dumps(config_to_dict(plausible)))) == plausible


def test_a_record_from_before_the_constraints_reads_its_single_load_constraint():
    """Records written with ``load_constraint`` (null, or hold_cmdp's) read as the load constraint it was."""
    assert config_from_dict(RewardConfig, {"w_task": 250.0, "load_constraint": None}) == RewardConfig()
    old = {"load_constraint": {"f_limit": 100.0, "budget": 0.01, "lr": 50.0, "lambda_max": 20.0}}
    assert config_from_dict(RewardConfig, old).constraints == get_method("hold_cmdp").constraints


def test_non_default_task_and_scene_settings_are_what_evaluation_and_finetunes_use(tmp_path):
    spec = tiny_spec(task={"alpha": 0.03, "episode_length": 40}, scene={"damping": 25.0, "friction": 1.0},
                     epochs=1, update_epochs=1)
    run = RunDir(tmp_path / "run")
    start_or_resume(spec, [run], resume=False, selection=Selection(every=0), progress=False)
    record = run.record()
    assert record["format"] == RECORD_FORMAT and record["scene"]["damping"] == 25.0
    assert record["task"]["alpha"] == 0.03 and {"jax", "mujoco", "python"} <= set(record["versions"])
    assert run.spec() == dataclasses.replace(spec, robust_every=0)  # read back whole (the network, the schedule)

    program, ts, _, _ = load_run(run.path)
    assert program.task.config.alpha == 0.03 and program.task.config.episode_length == 40
    assert program.task.scene.config.damping == 25.0 and program.task.scene.config.friction == 1.0
    assert program.method.network == TINY_NET
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
])
def test_a_malformed_record_is_one_error_line(record, fragment):
    with pytest.raises(DragMeshError, match=fragment) as e:
        RunSpec.from_record(record)
    assert "\n" not in str(e.value)
    assert RunSpec.from_record(GOOD) == RunSpec("pica", str(Path("obj").resolve()))


NAN, INF = float("nan"), float("inf")


@pytest.mark.parametrize("group, field, value", [
    ("ppo", "lr", NAN), ("ppo", "num_envs", 0), ("task", "alpha", NAN), ("task", "rho", NAN),
    ("task", "damping_fixed", INF), ("scene", "scale", NAN), ("scene", "timestep", NAN), ("scene", "friction", INF),
    ("ppo", "lr", INF), ("ppo", "gamma", NAN), ("ppo", "gamma", 1e9), ("ppo", "gae_lambda", NAN),
    ("ppo", "clip_eps", NAN), ("task", "alpha", INF), ("task", "alpha", 1e9), ("task", "control_dt", NAN),
    ("task", "d_detach", NAN), ("scene", "scale", INF), ("scene", "object_pos", [NAN, 0.0, 0.6]),
    ("scene", "armature", NAN), ("scene", "collision_radius", NAN), ("network", "log_std_init", NAN),
    ("network", "heads", 0),
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
    force or touch sensing); only its critic sees damping, friction and contact load."""
    spec = tiny_spec("recommended")
    assert spec.method == RECOMMENDED and spec.preset.name == get_method("recommended").name == "hold_blind"
    assert spec.task.damping_range == (1.0, 8.0) and not spec.task.force_obs and spec.task.reset_noise is not None
    program = program_of(spec)
    ts, m = epoch_jit(program, program.data(), init_jit(program, program.data(), jax.random.PRNGKey(0)))
    assert int(ts.epoch) == 1 and np.isfinite(float(m["loss"])) and float(ts.privileged_stats.count) > 1
    with pytest.raises(DragMeshError, match="choose from recommended"):
        get_method("recomended")
