"""PPO for the pulling task as pure programs (PureJaxRL / Brax style).

``make_train(task, network, config, name)`` gives a :class:`TrainProgram`: what one epoch is (the env without its
data, the network config, the PPO config; the name is the method's, for display). It is hashable by what a compiled
program depends on, so the jitted functions below take it as a static argument and jax's own cache compiles each
program once: a second object of the same structure (``task.data``, an argument) or another seed reuses it.

  ``init(program, data, key) -> TrainState``             a new run's parameters, optimiser, worlds, normalisers
  ``epoch(program, data, ts) -> (ts, metrics)``          rollout (``lax.scan`` over the vmapped, auto-resetting
                                                          env) + GAE + ``update_epochs`` x minibatch updates
  ``init_runs`` / ``epoch_runs``                         the same over a leading run axis (seeds), one program,
                                                          split over a device mesh when given (``shard_map``)
  ``epoch(..., axis=WORLD_AXIS)``                        one run's worlds split over a mesh axis (inside
                                                          ``shard_map``: ``ppo/distributed.py``): every reduction
                                                          over the batch a collective over the axis

Python loops over epochs (``train`` with callbacks: logs, checkpoints and robustness checks are the caller's).
Time-limit truncations bootstrap from V(final observation); terminations (success, detachment) do not. The
reward's adaptive weights are the task's (``task.adaptive_weights``): the train state keeps them, the task binds
them into each epoch's rollout (``task.bind_weights``) and moves them after it (``task.update_weights``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics.batch import map_batched
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.policies.gla import TokenWindows
from dragmesh2_jax.policies.networks import ActorCritic, NetworkConfig, make_inference_fn
from dragmesh2_jax.policies.normalize import RunningStats
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.distill import Teachers, world_objects
from dragmesh2_jax.ppo.losses import Batch, compute_gae, compute_ppo_loss, gaussian_logp
from dragmesh2_jax.task.env import TaskData
from dragmesh2_jax.task.protocol import CLIP_LEVEL, Env, Obs
from dragmesh2_jax.task.rewards import COST_PREFIX, TERM_PREFIX
from dragmesh2_jax.task.wrappers import AutoReset

RUN_AXIS = "runs"  # the mesh axis the run (seed) axis is sharded over
WORLD_AXIS = "worlds"  # the mesh axis one run's worlds are sharded over (data-parallel PPO)


@struct.dataclass
class TrainState:
    params: Any
    opt_state: Any
    env_state: Any
    state_stats: RunningStats
    token_stats: RunningStats
    aux_stats: RunningStats
    privileged_stats: RunningStats
    value_stats: RunningStats
    rng: jax.Array
    epoch: jnp.ndarray
    lr: jnp.ndarray
    # the task's adaptive reward weights (``task.adaptive_weights``), each under its own name (checkpoints store it;
    # a task without one leaves its default): ARAM's weight, the constraints' Lagrange multipliers in their order,
    # an object mix's success rate per object (its curriculum's draw: task/mix.py)
    aram_lambda: jnp.ndarray = struct.field(default_factory=lambda: jnp.float32(0.0))
    multipliers: jnp.ndarray = struct.field(default_factory=lambda: jnp.zeros(0, jnp.float32))
    object_success: jnp.ndarray = struct.field(default_factory=lambda: jnp.zeros(0, jnp.float32))

    @property
    def weights(self) -> dict:
        """The task's adaptive weights, by name (``replace(**weights)`` stores them back); a task's own rules move
        them (those of a task without the field stay empty)."""
        weights = {"aram_lambda": self.aram_lambda, "multipliers": self.multipliers}
        return weights | ({"object_success": self.object_success} if self.object_success.size else {})


@dataclass(frozen=True, eq=False)
class TrainProgram:
    """The static part of training: ``task`` (its data is an argument of every program), ``network``, ``config``
and ``name`` (the method's, shown in progress and results). Equal (and hashed) by :meth:`signature`."""

    task: Env
    network: NetworkConfig
    config: PPOConfig
    name: str

    @functools.cached_property
    def net(self) -> ActorCritic:
        return ActorCritic(config=self.network, action_size=self.task.action_size)

    @functools.cached_property
    def tx(self) -> optax.GradientTransformation:
        return optax.chain(optax.clip_by_global_norm(self.config.max_grad_norm),
                           optax.inject_hyperparams(optax.adam)(learning_rate=self.config.lr))

    @property
    def use_aux(self) -> bool:
        """The causal-window auxiliary loss: weighted, on a history feature (a state-only network has none)."""
        return self.config.aux_weight > 0 and self.network.encoder != "none"

    @functools.cached_property
    def signature(self) -> tuple:
        """What a compiled program depends on besides the object's data (the seed is an input, the epoch count
        Python-side: neither is in the configs)."""
        return self.name, self.net, self.config, self.task.signature()

    def __hash__(self) -> int:
        return hash(self.signature)

    def __eq__(self, other) -> bool:
        return isinstance(other, TrainProgram) and self.signature == other.signature

    @property
    def make_policy(self) -> Callable:
        """``deterministic -> policy(policy_params(ts), obs, key) -> action`` (Brax's ``make_inference_fn``)."""
        return make_inference_fn(self.net, self.config.normalize_obs)

    def data(self, runs: int = 1) -> TaskData:
        """The task's data for ``runs`` runs of ``config.num_envs`` worlds (an engine whose buffers the batch
        shares sizes them for it)."""
        return self.task.sized(runs * self.config.num_envs).data

    def controller(self, ts: TrainState) -> Controller:
        """The trained policy of ``ts`` as the evaluator's controller."""
        return Controller(self.name, self.make_policy, policy_params(ts), key=self.signature)


def make_train(task: Env, network: NetworkConfig = NetworkConfig(), config: PPOConfig = PPOConfig(),
               name: str = "pica") -> TrainProgram:
    return TrainProgram(task, network, config, name)


def policy_params(ts: TrainState) -> dict:
    """What the policy needs: network parameters and the observation normalisers."""
    return {"net": ts.params, "state_stats": ts.state_stats, "token_stats": ts.token_stats}


def _env(program: TrainProgram, data: TaskData, ts: TrainState | None = None) -> AutoReset:
    """The auto-resetting env over ``data``, the reward's adaptive weights of ``ts`` bound in (``None``: the
    task's own, a new run's)."""
    if ts is not None:
        data = program.task.bind_weights(data, ts.weights)
    return AutoReset(program.task.bind(data))


def _inputs(program: TrainProgram, ts: TrainState, obs: Obs):
    """Normalised network inputs (state, history, privileged). The aux targets never enter the network; the
    privileged block reaches only a privileged critic."""
    if not program.config.normalize_obs:
        return obs.state, obs.history, obs.privileged
    return (ts.state_stats.normalize(obs.state), ts.token_stats.normalize(obs.history),
            ts.privileged_stats.normalize(obs.privileged))


def init(program: TrainProgram, data: TaskData, key: jax.Array) -> TrainState:
    """A new run's state (parameters, optimiser, worlds) from ``key``."""
    c = program.config
    rng, k_net, k_env = jax.random.split(key, 3)
    env = _env(program, data)
    env_state = jax.vmap(env.reset)(jax.random.split(k_env, c.num_envs))
    obs = env_state.obs  # sizes come from the env (120, 16 x 102, 4 for the pulling task)
    params = program.net.init(k_net, obs.state[:1], obs.history[:1], obs.privileged[:1], method=ActorCritic.init_all)
    return TrainState(params=params, opt_state=program.tx.init(params), env_state=env_state,
                      state_stats=RunningStats.create(obs.state.shape[-1]),
                      token_stats=RunningStats.create(obs.history.shape[-1]),
                      aux_stats=RunningStats.create(obs.aux.shape[-1]),
                      privileged_stats=RunningStats.create(obs.privileged.shape[-1]),
                      value_stats=RunningStats.create(1), rng=rng, epoch=jnp.int32(0), lr=jnp.float32(c.lr),
                      **program.task.adaptive_weights())


def _shard_key(key: jax.Array, axis: str | None) -> jax.Array:
    """``key`` as this shard's own stream (``axis`` None: ``key`` itself)."""
    return key if axis is None else jax.random.fold_in(key, jax.lax.axis_index(axis))


def _explore(program: TrainProgram, worlds: int, axis: str | None) -> jnp.ndarray:
    """1 for each of this shard's ``worlds`` that samples its actions, 0 for one of the first ``mean_worlds`` (of
    the run's, counted over the shards in order), which acts on the mean."""
    index = jnp.arange(worlds) + (0 if axis is None else jax.lax.axis_index(axis) * worlds)
    return (index >= program.config.mean_worlds).astype(jnp.float32)


def _rollout(program: TrainProgram, data: TaskData, ts: TrainState, explore: jnp.ndarray, axis: str | None = None,
             teachers: Teachers | None = None):
    """``explore``: this shard's worlds' ``_explore``; ``teachers``: each step labelled by its world's teacher."""
    c, net = program.config, program.net
    teacher_policy = program.make_policy(True) if teachers is not None else None
    env = _env(program, data, ts)
    step = jax.vmap(env.step)
    vs = ts.value_stats
    denorm = lambda v: v * jnp.sqrt(vs.var[0] + 1e-5) + vs.mean[0]  # noqa: E731
    apply = lambda obs: net.apply(ts.params, *_inputs(program, ts, obs))  # noqa: E731

    def body(carry, _):
        env_state, rng = carry
        rng, k = jax.random.split(rng)
        obs = env_state.obs
        mu, log_std, v, _ = apply(obs)
        a = mu + explore[:, None] * jnp.exp(log_std) * jax.random.normal(_shard_key(k, axis), mu.shape)
        nxt = step(env_state, a)
        # bootstrap time limits only; the value of the final observations only at a step where one truncates
        v_final = jax.lax.cond(nxt.truncated.any(), lambda o: apply(o)[2], lambda o: jnp.zeros_like(v),
                               nxt.final_obs)
        reward = nxt.reward + c.gamma * denorm(v_final) * nxt.truncated
        out = {"obs": obs, "action": a, "logp": gaussian_logp(a, mu, log_std), "mu": mu,
               "log_std": jnp.broadcast_to(log_std, mu.shape), "value": v, "reward": reward,
               "done": nxt.done.astype(jnp.float32), "metrics": nxt.metrics}
        if teachers is not None:
            out["teacher_mu"], out["taught"] = teachers.label(teacher_policy, obs,
                                                              world_objects(env_state.info, mu.shape[0]))
        return (nxt, rng), out

    (env_state, rng), traj = jax.lax.scan(body, (ts.env_state, ts.rng), None, length=c.rollout_len)
    last_v = apply(env_state.obs)[2]
    adv, ret = compute_gae(traj["reward"], denorm(traj["value"]), traj["done"], denorm(last_v), c.gamma,
                           c.gae_lambda)
    return env_state, rng, traj, adv, ret


def epoch(program: TrainProgram, data: TaskData, ts: TrainState, axis: str | None = None,
          teachers: Teachers | None = None) -> tuple[TrainState, dict]:
    """One epoch: rollout, GAE, PPO update. Returns the new state and the epoch's metrics (every one is logged).

    ``axis``: a mesh axis the worlds are split over (inside ``shard_map``; ``ts.env_state`` holds this shard's
    worlds, everything else is the same on every shard). Each shard rolls out its worlds on its own random stream
    and samples its own minibatches; gradients, normalisers' statistics, the adaptive learning rate's KL, the
    metrics and the reward's adaptive weights are reduced over the axis, so every shard ends with the same state
    but its worlds. None: the whole batch here (no collective). ``teachers``: the run's (``ppo/distill.py``), when
    its config distils (``distill_coef``); None there: no labels this epoch (past ``distill_epochs``: ``train``)."""
    c, net = program.config, program.net
    _check_teachers(program, teachers)
    if axis is not None and program.task.config.object_curriculum:
        raise DragMeshError("the object curriculum counts each object's episodes in one process: train it without "
                            "splitting the worlds over processes")
    explore = _explore(program, ts.env_state.done.shape[0], axis)
    env_state, rng, traj, adv, ret = _rollout(program, data, ts, explore, axis, teachers)
    explore = jnp.broadcast_to(explore, traj["done"].shape)  # per sample: (steps, worlds)
    vs = ts.value_stats.update(ret[..., None], axis)  # value normalisation (the reference's normalize_value)
    n = traj["reward"].size  # this shard's samples (all of them: num_envs x rollout_len)
    flat = lambda x: x.reshape(n, *x.shape[2:])  # noqa: E731
    obs = jax.tree.map(flat, traj["obs"])
    s_in, h_in, p_in = _inputs(program, ts, obs)
    if program.network.encoder != "none":  # a rollout's windows share their tokens: each held (and projected) once
        norm = ts.token_stats.normalize if c.normalize_obs else (lambda x: x)
        h_in = TokenWindows.of_rollout(traj["obs"].history, traj["done"], norm)
    # values were predicted in the old value normalisation: re-express old predictions and targets in the new
    old_v = flat(traj["value"]) * jnp.sqrt(ts.value_stats.var[0] + 1e-5) + ts.value_stats.mean[0]
    norm = lambda x: (x - vs.mean[0]) / jnp.sqrt(vs.var[0] + 1e-5)  # noqa: E731
    # each step's previous mean: the step before in this rollout, unless an episode ended there
    mu_prev = jnp.concatenate([traj["mu"][:1], traj["mu"][:-1]])
    prev_valid = jnp.concatenate([jnp.zeros_like(traj["done"][:1]), 1.0 - traj["done"][:-1]])
    batch = Batch(state=s_in, history=h_in, privileged=p_in, aux_target=ts.aux_stats.normalize(obs.aux, clip=1e6),
                  action=flat(traj["action"]), logp=flat(traj["logp"]), mu=flat(traj["mu"]),
                  mu_prev=flat(mu_prev), prev_valid=flat(prev_valid),
                  log_std=flat(traj["log_std"]), explore=flat(explore), value=norm(old_v), advantage=flat(adv),
                  target=norm(flat(ret)), teacher_mu=_flat_or_none(traj, "teacher_mu", flat),
                  taught=_flat_or_none(traj, "taught", flat))
    ts = ts.replace(value_stats=vs)
    w_aux = c.aux_weight_at(ts.epoch)
    aux_head = (lambda p, z: net.apply(p, z, method=ActorCritic.aux)) if program.use_aux else None
    w_distill = c.distill_coef_at(ts.epoch)
    grad_fn = jax.grad(functools.partial(compute_ppo_loss, apply=net.apply, aux_head=aux_head, config=c, axis=axis,
                                         w_distill=w_distill, active=program.task.active), has_aux=True)
    mean = (lambda x: x) if axis is None else functools.partial(jax.lax.pmean, axis_name=axis)
    total = (lambda x: x) if axis is None else functools.partial(jax.lax.psum, axis_name=axis)

    def update_epoch(carry, _):
        ts, rng = carry
        rng, k = jax.random.split(rng)
        perm = jax.random.permutation(_shard_key(k, axis), n).reshape(c.num_minibatches, -1)

        def minibatch(ts, idx):
            mb = batch.take(idx)
            grads, info = mean(grad_fn(ts.params, batch=mb, w_aux=w_aux))  # the whole minibatch's
            clip_state, adam_state = ts.opt_state
            adam_state = adam_state._replace(hyperparams={**adam_state.hyperparams, "learning_rate": ts.lr})
            updates, opt_state = program.tx.update(grads, (clip_state, adam_state), ts.params)
            return ts.replace(params=optax.apply_updates(ts.params, updates), opt_state=opt_state), info

        ts, info = jax.lax.scan(minibatch, ts, perm)
        info = jax.tree.map(lambda x: x[-1], info)
        if c.lr_schedule == "adaptive":  # rl_games: KL-adaptive learning rate
            kl = info["kl"]
            lr = jnp.where(kl > 2 * c.kl_threshold, ts.lr / 1.5, jnp.where(kl < 0.5 * c.kl_threshold, ts.lr * 1.5,
                                                                           ts.lr))
            ts = ts.replace(lr=jnp.clip(lr, 1e-6, 1e-2))
        return (ts, rng), info

    (ts, rng), info = jax.lax.scan(update_epoch, (ts, rng), None, length=c.update_epochs)
    info = jax.tree.map(lambda x: x[-1], info)
    if c.normalize_obs:  # statistics move after the update, so rollout and update saw the same inputs
        ts = ts.replace(state_stats=ts.state_stats.update(obs.state, axis),
                        token_stats=ts.token_stats.update(obs.history, axis),
                        aux_stats=ts.aux_stats.update(obs.aux, axis),
                        privileged_stats=ts.privileged_stats.update(obs.privileged, axis))
    m, done = traj["metrics"], traj["done"]
    episodes = total(done.sum())
    at_end = lambda x: total(jnp.sum(x * done)) / jnp.maximum(episodes, 1.0)  # noqa: E731
    metrics = {
        **info, "lr": ts.lr, "w_aux": w_aux, "reward": mean(traj["reward"].mean()), "episodes": episodes,
        "success": at_end(m["success"]), "progress": at_end(m["progress"]), "detach": at_end(m["detach"]),
        "episode_return": at_end(m["episode_return"]), "clip099": mean(jnp.mean(m["action_abs_max"] > CLIP_LEVEL)),
        "clip099_active": mean(jnp.mean(m["active_abs_max"] > CLIP_LEVEL)),
        "clip099_policy_active": mean(jnp.mean(jnp.max(jnp.where(program.task.active, jnp.abs(traj["action"]), 0.0),
                                                         -1) > CLIP_LEVEL)),
        "action_l2": mean(m["action_l2"].mean()), "nonfinite": total(m["nonfinite"].sum()),
        "overflow": total(m["overflow"].sum()),
    }
    if c.distill_coef > 0:  # the same columns every epoch, those without labels (past their epochs) at 0
        labelled = teachers is not None
        metrics |= {"w_distill": w_distill if labelled else jnp.float32(0.0),
                    "taught": mean(traj["taught"].mean()) if labelled else jnp.float32(0.0)}
        metrics.setdefault("distill_loss", jnp.float32(0.0))
    metrics |= {k: mean(v.mean()) for k, v in m.items() if k.startswith(TERM_PREFIX)}  # per step, unnormalised
    steps = m if axis is None else {k: mean(jnp.mean(v)) for k, v in m.items()}  # what the weights' rules read
    if c.mean_worlds:  # the constraints' costs counted on the worlds that act on the mean: the deployed policy's
        counted = 1.0 - explore
        steps = steps | {k: total(jnp.sum(v * counted)) / total(jnp.sum(counted))
                         for k, v in m.items() if k.startswith(COST_PREFIX)}
    weights, metrics = program.task.update_weights(ts.weights, metrics, steps)
    return ts.replace(**weights, env_state=env_state, rng=rng, epoch=ts.epoch + 1), metrics


def _check_teachers(program: TrainProgram, teachers: Teachers | None) -> None:
    """Teachers only where the config distils, one per object of the program's task (at trace time)."""
    if teachers is not None and not program.config.distill_coef:
        raise DragMeshError("teachers label only a run that distils (distill_coef > 0)")
    objects = getattr(program.task, "num_objects", 1)
    if teachers is not None and teachers.num_objects != objects:
        raise DragMeshError(f"{teachers.num_objects} objects' teachers for a run over {objects} objects")


def _flat_or_none(traj: dict, key: str, flat: Callable):
    return flat(traj[key]) if key in traj else None


# ------------------------------------------------------------------------------- compiled programs
# The program is a static argument: jax.jit's own cache holds one executable per program signature (and shapes).
init_jit = jax.jit(init, static_argnums=0)
epoch_jit = jax.jit(epoch, static_argnums=0)


@functools.partial(jax.jit, static_argnums=0)
def init_runs(program: TrainProgram, data: TaskData, keys: jax.Array) -> TrainState:
    """The states of runs from ``keys``, stacked on a leading run axis (each equals ``init`` of its key)."""
    return jax.vmap(lambda k: init(program, data, k))(keys)


@functools.partial(jax.jit, static_argnums=(0, 3))
def _epoch_runs(program: TrainProgram, data: TaskData, ts: TrainState, mesh, teachers: Teachers | None):
    f = lambda data, ts, teachers: jax.vmap(lambda t: epoch(program, data, t, teachers=teachers))(ts)  # noqa: E731
    if mesh is not None:
        P = jax.sharding.PartitionSpec
        f = jax.shard_map(f, mesh=mesh, in_specs=(P(), P(RUN_AXIS), P()), out_specs=P(RUN_AXIS), check_vma=False)
    return f(data, ts, teachers)


def epoch_runs(program: TrainProgram, data: TaskData, ts: TrainState, mesh: jax.sharding.Mesh | None = None,
               teachers: Teachers | None = None) -> tuple[TrainState, dict]:
    """One epoch of R runs at once: every leaf of ``ts`` (and of the metrics) has a leading run axis. With
    ``mesh`` (one axis, ``RUN_AXIS``) the runs are split over its devices, R a multiple of its size. ``teachers``:
    every run's (a distilled run's seeds share them)."""
    if mesh is None and ts.epoch.shape[0] == 1:  # one run: the unbatched program (its lax.cond stays a branch)
        return map_batched(lambda x: x[None], epoch_jit(program, data, map_batched(lambda x: x[0], ts),
                                                        teachers=teachers))
    if mesh is not None:  # runs split over the devices, the object's data on every device (no-ops once placed)
        P = jax.sharding.PartitionSpec
        data = jax.device_put(data, jax.sharding.NamedSharding(mesh, P()))
        ts = jax.device_put(ts, jax.sharding.NamedSharding(mesh, P(RUN_AXIS)))
    return _epoch_runs(program, data, ts, mesh, teachers)


def run_mesh(num_runs: int) -> jax.sharding.Mesh | None:
    """A mesh over this process's devices when there are several and the runs split evenly over them; else None
    (one device runs them all). Several hosts: each process trains its own seeds on its own devices."""
    devices = jax.local_devices()
    n = len(devices)
    return jax.sharding.Mesh(np.asarray(devices), (RUN_AXIS,)) if n > 1 and num_runs % n == 0 else None


def seed_keys(seeds: list[int]) -> jax.Array:
    return jnp.stack([jax.random.PRNGKey(s) for s in seeds])


def take_run(ts: TrainState, i: int) -> TrainState:
    return map_batched(lambda x: x[i], ts)


def stack_runs(states: list[TrainState]) -> TrainState:
    """Runs' states on a leading run axis (what ``init_runs`` gives)."""
    return map_batched(lambda *xs: jnp.stack(xs), *states)


def train(program: TrainProgram, data: TaskData, ts: TrainState, epochs: int, mesh=None,
          on_epoch: Callable[[TrainState, dict], None] | None = None, teachers: Teachers | None = None) -> TrainState:
    """Train the runs of ``ts`` (leading run axis) up to ``epochs``: each epoch's state and host-side metrics (one
    array per metric, one value per run) go to ``on_epoch`` (logs, checkpoints, robustness checks); ``teachers``: a
    distilled run's, labelling its epochs until ``distill_epochs`` (after them nothing reads the labels: none made)."""
    last = program.config.distill_epochs
    for _ in range(int(ts.epoch[0]), epochs):
        labelling = teachers if not last or int(ts.epoch[0]) < last else None
        ts, m = epoch_runs(program, data, ts, mesh, labelling)
        m = {k: np.asarray(v, np.float64) for k, v in jax.device_get(m).items()}
        program.task.check_overflow(int(m["overflow"].sum()), f"epoch {int(ts.epoch[0])}")
        if not (np.all(np.isfinite(m["loss"])) and bool(_finite((ts.params, ts.opt_state)))):
            raise NonFiniteLearning(int(ts.epoch[0]), m["loss"])
        if on_epoch is not None:
            on_epoch(ts, m)
    return ts


class NonFiniteLearning(DragMeshError):
    """The loss or the learner's parameters went non-finite in ``epoch`` (its state is dropped: nothing of it is
    saved); the caller names the last good checkpoint."""

    def __init__(self, epoch: int, loss: np.ndarray):
        super().__init__(f"epoch {epoch}: learning went non-finite (loss {', '.join(f'{x:g}' for x in loss)}, or a "
                         "parameter NaN or inf); training stopped")
        self.epoch = epoch


@jax.jit
def _finite(tree) -> jax.Array:
    """Whether every floating-point number in ``tree`` is finite (one scalar: the check costs one transfer)."""
    leaves = [jnp.all(jnp.isfinite(x)) for x in jax.tree.leaves(tree) if jnp.issubdtype(x.dtype, jnp.inexact)]
    return jnp.all(jnp.stack(leaves))
