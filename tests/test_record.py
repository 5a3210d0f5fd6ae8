"""The run record: written once, read back whole; a run trained with non-default task and scene settings is
evaluated, resumed and fine-tuned with them, not with the defaults."""

import dataclasses
import json

import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.methods import get_method, task_overrides
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.runner import RobustSelection, train
from dragmesh2_jax.record import RECORD_FORMAT, config_from_dict, config_to_dict
from dragmesh2_jax.runs import eval_task, load_run, make_finetune, make_trainer, trainer_from_record
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import AramConfig, ResetNoise, RewardConfig, TaskConfig

OBJ = str(default_object())


def test_configs_round_trip_through_json():
    task = TaskConfig(alpha=0.03, damping_range=(1.0, 3.0), damping_fixed=2.0, reset_noise=ResetNoise(bank=4),
                      reward=RewardConfig(w_load=2.0, aram=AramConfig()))
    scene = SceneConfig(damping=25.0, friction=1.0, object_pos=(0.6, 0.1, 0.5))
    for config in (task, scene, PPOConfig(aux_warmup=(5, 20), num_envs=8), TaskConfig()):
        back = config_from_dict(type(config), json.loads(json.dumps(config_to_dict(config))))
        assert back == config  # tuples, optional and nested configs included
    with pytest.raises(DragMeshError, match="unknown TaskConfig fields"):
        config_from_dict(TaskConfig, {"alpha": 0.05, "not_a_field": 1})


def test_non_default_task_and_scene_settings_are_what_evaluation_and_finetunes_use(tmp_path):
    task = dataclasses.replace(TaskConfig(**task_overrides(get_method("pica"))), alpha=0.03, episode_length=40)
    scene = SceneConfig(damping=25.0, friction=1.0)
    trainer = make_trainer(OBJ, None, "pica", "mujoco", task_config=task, scene_config=scene, num_envs=2,
                           rollout_len=4, epochs=1, update_epochs=1)
    run = tmp_path / "run"
    train(trainer, run, OBJ, progress=False, selection=RobustSelection(every=0))
    record = json.loads((run / "run.json").read_text())
    assert record["format"] == RECORD_FORMAT and record["scene"]["damping"] == 25.0
    assert record["task"]["alpha"] == 0.03 and {"jax", "mujoco", "python"} <= set(record["versions"])

    loaded, ts, _, _ = load_run(run, backend="mujoco")
    assert loaded.task.config.alpha == 0.03 and loaded.task.config.episode_length == 40
    assert loaded.task.scene.config.damping == 25.0 and loaded.task.scene.config.friction == 1.0
    evaluation = eval_task(loaded.task)  # the evaluation protocol's task keeps the run's settings
    assert evaluation.config.alpha == 0.03 and evaluation.scene.config.damping == 25.0
    assert float(evaluation.data.params.damping) == 25.0  # the nominal damping the cells multiply

    resumed = trainer_from_record(run, "mujoco", epochs=3)
    assert resumed.config.epochs == 3 and resumed.config.num_envs == 2 and resumed.task.config.alpha == 0.03
    ft, _, _ = make_finetune(run, "aram", backend="mujoco", epochs=1)
    assert ft.task.config.alpha == 0.03 and ft.task.scene.config.damping == 25.0
    assert ft.task.config.reward.aram is not None  # the recipe on top of the recorded task
