"""The C engine's host step (physics/mujoco_backend.py): one object's worlds on rollout's threads, a batch that mixes
objects on a pool of workers; either way each world steps exactly as it would alone."""

import jax
import numpy as np

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.physics.mujoco_backend import _host_step
from dragmesh2_jax.runs.build import load_task

WORLDS = 10


def test_a_mixed_batch_steps_each_world_as_its_object_alone_would():
    tasks = [load_task(str(packaged_object(n)), None, backend="mujoco")
             for n in ("drawer_cabinet_0000", "door_cabinet_0000")]
    which = np.arange(WORLDS) % 2  # the worlds alternate between the two objects
    starts = [jax.tree.map(lambda x: np.asarray(x[0]), t.data.physics.bank) for t in tasks]
    host = np.array([int(tasks[w].data.physics.host) for w in which])
    qpos = np.stack([starts[w].qpos for w in which])
    qvel = np.stack([starts[w].qvel for w in which])
    ctrl = np.random.default_rng(0).uniform(-1, 1, (WORLDS, tasks[0].action_size))
    mixed = _host_step(host, qpos, qvel, ctrl, {})
    for w in (0, 1):
        mine = which == w
        alone = _host_step(host[mine], qpos[mine], qvel[mine], ctrl[mine], {})
        for m, a in zip(mixed, alone, strict=True):
            np.testing.assert_array_equal(m[mine], a)
    assert not np.array_equal(mixed[0][0], qpos[0])  # and they did step
