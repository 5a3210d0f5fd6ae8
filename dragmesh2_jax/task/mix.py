"""Several objects in one batch: :class:`ObjectMix` is an env of ``task/protocol.py`` over the tasks of several
objects (each with its own trajectory). Every reset draws one of them for the world, which keeps it for the episode;
``data`` stacks the objects' task data on a leading object axis (each world reads its object's entry), so one
compiled program trains on all of them at once.

What can mix: every object's scene has the same hand layout (51 DoFs, the same sensors) and its task the same config
and start bank. On the C engine anything else may differ (meshes, masses, joint types: each world steps its own
object's host model; fields indexed by geom are padded to the largest object). On MJX (JAX or Warp) the model itself
is stacked, so objects mix only when their models have the same structure: one object at other dampings, frictions
or masses, or procedural objects of any category built on the one-structure template (``scene.build_scene(...,
slots=n)``: a run's MJX mix is, ``runs/build.template_slots``), whose target joint sits at either of two addresses
(``Layout``: data). Objects of other structures are one clear error. Their MJX buffers are one budget, the most any
of them needs (``ContactBudget.joined``), and MJX-Warp's contact buffer, which the whole batch shares, is one.

The object curriculum (``TaskConfig.object_curriculum`` = beta > 0, beyond the paper): the draw follows the policy's
failures instead of being uniform, P(object i) = (1 - beta) / n + beta w_i / sum_j w_j with w_i = 1 - s_i +
``CURRICULUM_FLOOR``, where s_i is object i's success rate, an exponential average over epochs of the episodes that
ended on it (``CURRICULUM_RATE``). Like the reward's adaptive weights, the trainer keeps the rates
(``adaptive_weights``), binds the draw into each epoch's rollout (``bind_weights``) and moves them after it from the
episodes' ends (``update_weights``); the hooks are the same, the rule is this module's. At beta = 0 the draw is
uniform as without it (the same random stream).
"""

from __future__ import annotations

import copy

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics.batch import map_batched, shared
from dragmesh2_jax.physics.contacts import ContactBudget
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import ResetNoise, TaskConfig
from dragmesh2_jax.task.env import PullTask, TaskData
from dragmesh2_jax.task.protocol import State
from dragmesh2_jax.trajectory.schema import Trajectory

#: The success rates' exponential average per epoch (an object meets a few episodes per epoch in a large mix).
CURRICULUM_RATE = 0.1
#: Every object keeps this weight in the prioritised draw when it always succeeds (none drops out of the batch).
CURRICULUM_FLOOR = 0.05
#: A new run's success rate of every object (no evidence either way).
CURRICULUM_PRIOR = 0.5
#: The per-step metric that names the object whose episode ended there (-1: none ended), for the curriculum's rates.
OBJECT_END = "object_end"


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
    # the leaves a whole batch shares (MJX-Warp's contact buffer) are one for every object too
    return jax.tree_util.tree_map_with_path(lambda path, *xs: xs[0] if shared(path) else jnp.stack(xs), *datas)


class ObjectMix:
    """The tasks of several objects as one env; ``info["object"]`` is each world's object (its index)."""

    def __init__(self, tasks: list[PullTask]):
        if not tasks:
            raise DragMeshError("an object mix needs at least one task")
        base = tasks[0]
        for t in tasks[1:]:
            if t.signature() != base.signature() or t.num_starts != base.num_starts:
                raise DragMeshError(f"object {t.scene.obj.object_id} does not share the first object's task config, "
                                    "effector or engine")
            ids, b = t.scene.ids, base.scene.ids
            if not (np.array_equal(ids.hand_qpos, b.hand_qpos) and np.array_equal(ids.hand_dof, b.hand_dof)):
                raise DragMeshError(f"object {t.scene.obj.object_id}: another state layout than the first object's")
        budgets = [t.budget for t in tasks]
        if base.budget is not None and any(b != budgets[0] for b in budgets):  # MJX: one set of buffers for all
            budget = ContactBudget.joined(budgets)
            tasks = [t.with_budget(budget) for t in tasks]
        self.tasks, self.base = tuple(tasks), tasks[0]
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
    def active(self) -> jnp.ndarray:
        return self.base.active  # one hand for every object

    @property
    def scene(self) -> Scene:
        """The first object's scene (what a picture of the mix draws)."""
        return self.base.scene

    @property
    def trajectories(self) -> tuple[Trajectory, ...]:
        return tuple(t.traj for t in self.tasks)

    def with_starts(self, starts: ResetNoise | None, costs: bool = False) -> ObjectMix:
        return ObjectMix([t.with_starts(starts, costs) for t in self.tasks])

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
        return self.base.bind(map_batched(lambda x: x[index], self.data))

    def kinematics(self, state: State):
        """A world's quantities, read through its own object's layout (a template's target joint has two addresses)."""
        return self.task(state.info["object"]).kinematics(state)

    @property
    def curriculum(self) -> float:
        return self.config.object_curriculum

    def adaptive_weights(self) -> dict[str, jnp.ndarray]:
        """The reward's (every object has the same task config: checked) and, with the curriculum, each object's
        success rate (``object_success``)."""
        weights = self.base.adaptive_weights()
        if self.curriculum:
            weights["object_success"] = jnp.full(self.num_objects, CURRICULUM_PRIOR, jnp.float32)
        return weights

    def draw(self, success: jnp.ndarray) -> jnp.ndarray:
        """Each object's probability of being drawn at a reset, from its success rate (the module's rule)."""
        w = 1.0 - success + CURRICULUM_FLOOR
        return (1.0 - self.curriculum) / self.num_objects + self.curriculum * w / w.sum()

    def bind_weights(self, data: TaskData, weights: dict) -> TaskData:
        """``data`` with ``weights`` bound for every object (one set of reward weights for the whole mix) and, with
        the curriculum, the draw its success rates give."""
        weights = dict(weights)
        success = weights.pop("object_success", None)
        stacked = jax.tree.map(lambda w: jnp.broadcast_to(w, (self.num_objects, *jnp.shape(w))), weights)
        data = self.base.bind_weights(data, stacked)
        if self.curriculum:
            data = data.replace(params=data.params.replace(draw_weight=self.draw(success)))
        return data

    def update_weights(self, weights: dict, metrics: dict, steps: dict) -> tuple[dict, dict]:
        """The reward's weights moved by its rules and, with the curriculum, each object's success rate by the
        episodes that ended on it this epoch (``steps``: the rollout's per-step metrics); ``draw_peak`` (the
        most drawn object's probability x the number of objects: 1 is uniform) is logged."""
        success = weights.get("object_success")
        weights, metrics = self.base.update_weights(weights, metrics, steps)
        if self.curriculum:
            ended = steps[OBJECT_END][..., None] == jnp.arange(self.num_objects)  # (steps, worlds, objects)
            episodes = ended.sum((0, 1))
            wins = (ended * steps["success"][..., None]).sum((0, 1))
            rate = wins / jnp.maximum(episodes, 1)
            success = jnp.where(episodes > 0, success + CURRICULUM_RATE * (rate - success), success)
            weights["object_success"] = success
            metrics["draw_peak"] = self.draw(success).max() * self.num_objects
        return weights, metrics

    def _pick(self, key: jax.Array) -> jax.Array:
        if self.curriculum:
            return jax.random.categorical(key, jnp.log(self.data.params.draw_weight))
        return jax.random.randint(key, (), 0, self.num_objects)

    def _with_object(self, state: State, index) -> State:
        return self._mark_end(state.replace(info={**state.info, "object": jnp.asarray(index, jnp.int32)}))

    def _mark_end(self, state: State) -> State:
        """``state`` with the curriculum's per-step metric (its object where its episode ended, else -1); as it is
        without the curriculum."""
        if not self.curriculum:
            return state
        end = jnp.where(state.done, state.info["object"], -1).astype(jnp.float32)
        return state.replace(metrics={**state.metrics, OBJECT_END: end})

    def reset(self, key: jax.Array, damping_scale=None, start=None) -> State:
        key, pick = jax.random.split(key)
        index = self._pick(pick)
        return self._with_object(self.task(index).reset(key, damping_scale, start), index)

    def restart(self, state: State) -> State:
        """The world's next episode, on an object drawn anew from the world's rng."""
        rng, pick = jax.random.split(state.info["rng"])
        index = self._pick(pick)
        fresh = self.task(index).restart(state.replace(info={**state.info, "rng": rng}))
        return self._with_object(fresh, index)

    def step(self, state: State, action: jnp.ndarray) -> State:
        return self._mark_end(self.task(state.info["object"]).step(state, action))

    def step_target(self, state: State, target: jnp.ndarray) -> State:
        return self._mark_end(self.task(state.info["object"]).step_target(state, target))
