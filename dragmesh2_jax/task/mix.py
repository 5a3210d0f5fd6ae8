"""Several objects in one batch: :class:`ObjectMix` is an env of ``task/protocol.py`` over the tasks of several
objects (each with its own trajectory). Every reset draws one of them for the world, which keeps it for the episode;
``data`` stacks the objects' task data on a leading object axis (each world reads its object's entry), so one
compiled program trains on all of them at once.

What can mix: every object's scene has the same state layout (51 hand DoFs and the target joint, the same sensors)
and its task the same config and start bank. On the C engine anything else may differ (meshes, masses, joint types:
each world steps its own object's host model; fields indexed by geom are padded to the largest object). On MJX the
model itself is stacked, so objects mix only when their models have the same structure (the same geoms, meshes and
static fields: one object at other dampings, frictions or masses, or procedural objects built from the same
pieces); objects of other structures are one clear error (train them as separate runs, or group them by structure).
MJX-Warp does not mix objects: its contact buffer belongs to the whole batch, not to a world.
"""

from __future__ import annotations

import copy

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics.contacts import ContactBudget
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import ResetNoise, TaskConfig
from dragmesh2_jax.task.env import PullTask, TaskData
from dragmesh2_jax.task.protocol import State
from dragmesh2_jax.trajectory.schema import Trajectory


def _pad(x, n: int, axis: int):
    """``x`` padded with zeros (False) to length ``n`` along ``axis``."""
    x = jnp.asarray(x)
    width = [(0, 0)] * x.ndim
    width[axis] = (0, n - x.shape[axis])
    return jnp.pad(x, width)


def stack_data(tasks: list[PullTask]) -> TaskData:
    """The tasks' data on a leading object axis; the geom-indexed fields padded to the largest object's geoms."""
    ngeom = max(t.scene.model.ngeom for t in tasks)
    datas = []
    for t in tasks:
        d = t.data
        layout = d.physics.layout.replace(object_geoms=_pad(d.physics.layout.object_geoms, ngeom, 0))
        fields = {k: _pad(v, ngeom, 0) if k.startswith("geom_") else v for k, v in d.fields.items()}
        datas.append(d.replace(physics=d.physics.replace(layout=layout), fields=fields))
    structures = {jax.tree.structure(d) for d in datas}
    shapes = {tuple(np.shape(x) for x in jax.tree.leaves(d)) for d in datas}
    if len(structures) > 1 or len(shapes) > 1:
        raise DragMeshError("these objects cannot share one batch on this engine: their task data differ in "
                            "structure (on MJX the model's geoms, meshes and static fields must match; mix them "
                            "on the C engine, or train one run per structure)")
    return jax.tree.map(lambda *xs: jnp.stack(xs), *datas)


class ObjectMix:
    """The tasks of several objects as one env; ``info["object"]`` is each world's object (its index)."""

    def __init__(self, tasks: list[PullTask]):
        if not tasks:
            raise DragMeshError("an object mix needs at least one task")
        base = tasks[0]
        if getattr(base.backend, "impl", None) == "warp" and len(tasks) > 1:
            raise DragMeshError("MJX-Warp trains one object per run (its contact buffer is the batch's, not a "
                                "world's); mix objects on the C engine or on MJX-JAX")
        for t in tasks[1:]:
            if t.signature() != base.signature() or t.num_starts != base.num_starts:
                raise DragMeshError(f"object {t.scene.obj.object_id} does not share the first object's task config, "
                                    "effector or engine")
            ids, b = t.scene.ids, base.scene.ids
            if (ids.target_qpos, ids.target_dof) != (b.target_qpos, b.target_dof) or not (
                    np.array_equal(ids.hand_qpos, b.hand_qpos) and np.array_equal(ids.hand_dof, b.hand_dof)):
                raise DragMeshError(f"object {t.scene.obj.object_id}: another state layout than the first object's")
        self.tasks, self.base = tuple(tasks), base
        self.data = stack_data(tasks)

    @property
    def num_objects(self) -> int:
        return len(self.tasks)

    # what every object shares (checked above), read from the first
    @property
    def config(self) -> TaskConfig:
        return self.base.config

    @property
    def action_size(self) -> int:
        return self.base.action_size

    @property
    def substeps(self) -> int:
        return self.base.substeps

    @property
    def num_starts(self) -> int:
        return self.base.num_starts

    @property
    def engine(self) -> str:
        return self.base.engine

    @property
    def budget(self) -> ContactBudget | None:
        return self.base.budget

    @property
    def buffers(self) -> dict:
        return self.base.buffers

    @property
    def object_id(self) -> str:
        """The first object's (a mix is named by it, with ``num_objects``)."""
        return self.base.object_id

    @property
    def scene(self) -> Scene:
        """The first object's scene (what a picture of the mix draws)."""
        return self.base.scene

    @property
    def trajectories(self) -> tuple[Trajectory, ...]:
        return tuple(t.traj for t in self.tasks)

    def with_starts(self, starts: ResetNoise | None) -> ObjectMix:
        return ObjectMix([t.with_starts(starts) for t in self.tasks])

    def bind(self, data: TaskData) -> ObjectMix:
        mix = copy.copy(self)
        mix.data = data
        return mix

    def signature(self) -> tuple:
        return "object_mix", self.num_objects, self.base.signature()

    def sized(self, worlds: int) -> ObjectMix:
        """The mix for a batch of ``worlds`` worlds (each object's engine buffers sized for all of them)."""
        return self.bind(stack_data([t.sized(worlds) for t in self.tasks]))

    def check_overflow(self, count: int, where: str) -> None:
        self.base.check_overflow(count, where)

    def task(self, index) -> PullTask:
        """The task of object ``index`` (a traced index inside a world) over this mix's data."""
        return self.base.bind(jax.tree.map(lambda x: x[index], self.data))

    def kinematics(self, ps):
        return self.base.kinematics(ps)  # every object has the same state layout (checked)

    def adaptive_weights(self) -> dict[str, jnp.ndarray]:
        return self.base.adaptive_weights()  # every object has the same task config (checked)

    def bind_weights(self, data: TaskData, weights: dict) -> TaskData:
        """``data`` with ``weights`` bound for every object (one set of weights for the whole mix)."""
        stacked = jax.tree.map(lambda w: jnp.broadcast_to(w, (self.num_objects, *jnp.shape(w))), weights)
        return self.base.bind_weights(data, stacked)

    def update_weights(self, weights: dict, metrics: dict, steps: dict) -> tuple[dict, dict]:
        return self.base.update_weights(weights, metrics, steps)

    def _with_object(self, state: State, index) -> State:
        return state.replace(info={**state.info, "object": jnp.asarray(index, jnp.int32)})

    def reset(self, key: jax.Array, damping_scale=None, start=None) -> State:
        key, pick = jax.random.split(key)
        index = jax.random.randint(pick, (), 0, self.num_objects)
        return self._with_object(self.task(index).reset(key, damping_scale, start), index)

    def restart(self, state: State) -> State:
        """The world's next episode, on an object drawn anew from the world's rng."""
        rng, pick = jax.random.split(state.info["rng"])
        index = jax.random.randint(pick, (), 0, self.num_objects)
        fresh = self.task(index).restart(state.replace(info={**state.info, "rng": rng}))
        return self._with_object(fresh, index)

    def step(self, state: State, action: jnp.ndarray) -> State:
        return self.task(state.info["object"]).step(state, action)

    def step_target(self, state: State, target: jnp.ndarray) -> State:
        return self.task(state.info["object"]).step_target(state, target)
