"""Compiled programs at scale: the object is data (objects of one structure share a compiled epoch), seeds train
as one vmapped program that equals separate runs, the run axis shards over devices, and a multi-seed run
resumes exactly."""

import json
import os
import subprocess
import sys
import textwrap

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object, synthesize
from dragmesh2_jax.policies.methods import get_method
from dragmesh2_jax.ppo import train as train_lib
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.runner import RobustSelection, take_run, train_seeds
from dragmesh2_jax.ppo.train import Trainer
from dragmesh2_jax.runs import load_task
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.trajectory.generator import generate

TINY = PPOConfig(num_envs=2, rollout_len=4, update_epochs=1, epochs=2)
OBJ = str(default_object())


def _close(a, b, tol=2e-3):
    """Equal within float tolerance: a batched matmul may round differently from an unbatched one."""
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_allclose(np.asarray(x, np.float64), np.asarray(y, np.float64), rtol=tol, atol=tol)


def _cache_size(name: str, trainer: Trainer) -> int:
    return train_lib._PROGRAMS[(name, trainer.signature())]._cache_size()


def test_objects_of_the_same_structure_share_one_compiled_epoch(tmp_path):
    """Two procedural doors of different sizes (other meshes, other joint limits) and one PPO epoch program."""
    a, b = synthesize("door_cabinet", 2, 0, tmp_path)
    trainers = [Trainer(load_task(str(p), None, backend="mujoco"), get_method("pica"), TINY) for p in (a, b)]
    assert trainers[0].signature() == trainers[1].signature()
    states = []
    for t in trainers:
        ts, m = t.epoch(t.init())
        states.append(ts)
        assert np.isfinite(float(m["loss"]))
    assert _cache_size("epoch", trainers[0]) == 1  # compiled once, run for both objects
    # each ran on its own object: the handle the observation reports is that object's
    for t, ts in zip(trainers, states, strict=True):
        k = jax.vmap(t.task.kinematics)(ts.env_state.physics)
        np.testing.assert_allclose(np.asarray(ts.env_state.obs.state[:, 102:105]), np.asarray(k.handle_pos),
                                   atol=1e-5)
    h0, h1 = (np.asarray(ts.env_state.obs.state[0, 102:105]) for ts in states)
    assert np.linalg.norm(h0 - h1) > 1e-3


def test_seed_vmapped_training_equals_separate_runs():
    trainer = Trainer(load_task(OBJ, None, backend="mujoco"), get_method("pica"), TINY)
    runs = trainer.init_runs([0, 1])
    for _ in range(2):
        runs, m_runs = trainer.epoch_runs(runs)
    for i, seed in enumerate((0, 1)):
        ts = trainer.init(seed)
        for _ in range(2):
            ts, m = trainer.epoch(ts)
        _close(take_run(runs, i).params, ts.params)
        np.testing.assert_allclose(float(m_runs["loss"][i]), float(m["loss"]), rtol=2e-3)
    assert not np.allclose(np.asarray(m_runs["loss"][0]), np.asarray(m_runs["loss"][1]))  # seeds differ


SHARDED = textwrap.dedent("""
    import json, sys
    import jax, numpy as np
    from dragmesh2_jax.policies.methods import get_method
    from dragmesh2_jax.ppo.config import PPOConfig
    from dragmesh2_jax.ppo.runner import run_mesh
    from dragmesh2_jax.ppo.train import Trainer
    from dragmesh2_jax.runs import load_task

    trainer = Trainer(load_task(sys.argv[1], None, backend="mujoco"), get_method("pica"),
                      PPOConfig(num_envs=2, rollout_len=4, update_epochs=1))
    mesh = run_mesh(4)
    one = sharded = trainer.init_runs([0, 1, 2, 3])
    one, m1 = trainer.epoch_runs(one)
    sharded, m4 = trainer.epoch_runs(sharded, mesh)
    diff = max(float(np.max(np.abs(np.asarray(a) - np.asarray(b))))
               for a, b in zip(jax.tree.leaves(one.params), jax.tree.leaves(sharded.params)))
    leaf = jax.tree.leaves(sharded.params)[0]
    print(json.dumps({"devices": jax.device_count(), "mesh": None if mesh is None else mesh.size, "diff": diff,
                      "shards": len(leaf.sharding.device_set), "loss1": np.asarray(m1["loss"]).tolist(),
                      "loss4": np.asarray(m4["loss"]).tolist()}))
""")


def test_runs_sharded_over_four_devices_equal_one_device():
    env = {**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=4"}
    out = subprocess.run([sys.executable, "-c", SHARDED, OBJ], env=env, capture_output=True, text=True, timeout=900)
    assert out.returncode == 0, out.stderr[-3000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["devices"] == 4 and r["mesh"] == 4 and r["shards"] == 4  # the run axis lives on four devices
    assert r["diff"] < 2e-3
    np.testing.assert_allclose(r["loss1"], r["loss4"], rtol=2e-3)


def test_multi_seed_run_writes_a_folder_per_seed_and_resumes_exactly(tmp_path):
    trainer = Trainer(load_task(OBJ, None, backend="mujoco"), get_method("pica"), TINY)
    quiet = {"progress": False, "save_every": 1, "selection": RobustSelection(every=0)}
    full, rows = train_seeds(trainer, tmp_path / "full", [3, 4], OBJ, **quiet)
    assert [len(r) for r in rows] == [2, 2]
    for seed in (3, 4):
        run = tmp_path / "full" / f"seed_{seed}"
        assert json.loads((run / "run.json").read_text())["ppo"]["seed"] == seed
        assert (run / "checkpoints" / "final" / "env").is_dir()
    one = Trainer(trainer.task, trainer.method, PPOConfig(**{**TINY.__dict__, "epochs": 1}))
    train_seeds(one, tmp_path / "cut", [3, 4], OBJ, **quiet)  # "interrupted" after one epoch
    resumed, rows2 = train_seeds(trainer, tmp_path / "cut", [3, 4], OBJ, resume=True, **quiet)
    for x, y in zip(jax.tree.leaves(full.params), jax.tree.leaves(resumed.params), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert [r["epoch"] for r in rows2[0]] == [1, 2]


@pytest.mark.mjx
def test_mjx_model_is_data_same_object_other_damping_shares_the_program():
    """On MJX the model's static fields (geometry included) fix the program; the nominal damping is data."""
    obj = load_gapartnet(OBJ)
    config = TaskConfig(backend="mjx")
    tasks = []
    for damping in (10.0, 40.0):
        scene = build_scene(obj, SceneConfig(damping=damping))
        tasks.append(PullTask(scene, generate(obj, scene=scene), config))
    tiny = PPOConfig(num_envs=1, rollout_len=2, update_epochs=1)
    trainers = [Trainer(t, get_method("state_only"), tiny) for t in tasks]
    for t in trainers:
        ts, m = t.epoch(t.init())
        assert np.isfinite(float(m["loss"]))
    assert _cache_size("epoch", trainers[0]) == 1
    damping = [float(t.task.data.physics.model.dof_damping[t.task.scene.ids.target_dof]) for t in trainers]
    assert damping == [10.0, 40.0]
