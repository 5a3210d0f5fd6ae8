"""PPO for the pulling task, PureJaxRL style: ``Trainer.epoch`` is ONE jitted function = rollout
(``lax.scan`` over the vmapped env) + GAE + ``update_epochs`` x minibatch updates. Python only loops over
epochs (``train``) for logging and checkpoints.

Programs are compiled once per *signature* (method, network, PPO and task config, hand variant, backend), with the
object's data (``task.data``: the model, start states, task boundary) an argument: a second object of the same
structure reuses the compiled epoch. ``Trainer.epoch_runs`` is the same epoch ``vmap``ped over a leading run
axis (seeds), one program for a table's column of seeds; with a device mesh the run axis is sharded over the
devices (``shard_map``; several hosts each train their own seeds, see the README).

Loss (paper eq. opt): L = L_PPO + c_v L_V + c_b L_bounds + w_aux L_aux, w_aux warmed up 0 -> 0.01.
Time-limit truncations bootstrap from V(final observation); terminations (success, detachment) do not.
"""

from __future__ import annotations

import collections
import copy
import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optax
from flax import struct

from dragmesh2_jax.policies.methods import Method
from dragmesh2_jax.policies.networks import ActorCritic
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.normalize import RunningStats
from dragmesh2_jax.task.env import Obs, PullTask, State, TaskData, make_batched

LOG2PI = float(np.log(2 * np.pi))
CLIP_LEVEL = 0.99  # clip099: a step whose max |a_i| exceeds this counts as saturated (facts §8)
RUN_AXIS = "runs"  # the mesh axis the run (seed) axis is sharded over
PROGRAM_CACHE_SIZE = 8  # compiled programs kept (each holds its executables)
_PROGRAMS: collections.OrderedDict[tuple, Any] = collections.OrderedDict()


@struct.dataclass
class TrainState:
    params: Any
    opt_state: Any
    env_state: State
    state_stats: RunningStats
    token_stats: RunningStats
    aux_stats: RunningStats
    privileged_stats: RunningStats
    value_stats: RunningStats
    rng: jax.Array
    epoch: jnp.ndarray
    lr: jnp.ndarray


@struct.dataclass
class Batch:
    state: jnp.ndarray
    history: jnp.ndarray
    aux: jnp.ndarray
    privileged: jnp.ndarray
    action: jnp.ndarray
    logp: jnp.ndarray
    mu: jnp.ndarray  # rollout-time action mean (for the exact KL)
    log_std: jnp.ndarray
    value: jnp.ndarray  # normalised value prediction at rollout time
    advantage: jnp.ndarray
    target: jnp.ndarray  # normalised return target


def gaussian_logp(a, mu, log_std):
    return jnp.sum(-0.5 * ((a - mu) / jnp.exp(log_std)) ** 2 - log_std - 0.5 * LOG2PI, axis=-1)


def gae(rewards, values, dones, last_value, gamma, lam):
    """Generalised advantage estimation over (T, N) arrays; ``dones[t]`` ends the episode after step t."""

    def body(carry, x):
        adv_next, v_next = carry
        r, v, d = x
        nonterminal = 1.0 - d
        delta = r + gamma * v_next * nonterminal - v
        adv = delta + gamma * lam * nonterminal * adv_next
        return (adv, v), adv

    _, adv = jax.lax.scan(body, (jnp.zeros_like(last_value), last_value), (rewards, values, dones), reverse=True)
    return adv, adv + values


class Trainer:
    """Holds the static pieces (task, network, optimiser); every function of ``TrainState`` is pure."""

    def __init__(self, task: PullTask, method: Method, config: PPOConfig = PPOConfig()):
        self.task, self.method, self.config = task, method, config
        self.net = ActorCritic(encoder=method.encoder, action_size=task.action_size, critic=method.critic)
        self.use_aux = method.physical_signals and method.encoder != "none"
        self.aram = task.config.reward.aram
        self.reset, self.step = make_batched(task)
        self.tx = optax.chain(optax.clip_by_global_norm(config.max_grad_norm),
                              optax.inject_hyperparams(optax.adam)(learning_rate=config.lr))
        self._placed: dict = {}  # the object's data replicated on each mesh's devices

    # ---------------------------------------------------------------------------- compiled programs
    def signature(self) -> tuple:
        """What a compiled program depends on besides the object's data (the seed and the epoch count are
        inputs or Python-side, so they are not part of it)."""
        return self.method, self.net, dataclasses.replace(self.config, seed=0, epochs=1), self.task.signature()

    def bind(self, data: TaskData) -> Trainer:
        """This trainer over another object's data (or over the tracers of a compiled program)."""
        t = copy.copy(self)
        t.task = self.task.bind(data)
        t.reset, t.step = make_batched(t.task)
        t._placed = {}
        return t

    def _program(self, name: str, build):
        """The compiled program ``name`` for this signature, built by ``build(template_trainer)`` on first use."""
        key = (name, self.signature())
        if key not in _PROGRAMS:
            _PROGRAMS[key] = build(self)
            while len(_PROGRAMS) > PROGRAM_CACHE_SIZE:
                _PROGRAMS.popitem(last=False)
        _PROGRAMS.move_to_end(key)
        return _PROGRAMS[key]

    def epoch(self, ts: TrainState) -> tuple[TrainState, dict]:
        """One epoch: rollout, GAE, PPO update (one compiled program per signature)."""
        run = self._program("epoch", lambda t: jax.jit(lambda data, ts: t.bind(data)._epoch(ts)))
        return run(self.task.data, ts)

    def epoch_runs(self, ts: TrainState, mesh: jax.sharding.Mesh | None = None) -> tuple[TrainState, dict]:
        """One epoch of R runs at once: every leaf of ``ts`` (and of the metrics) has a leading run axis. With
        ``mesh`` (one axis, ``RUN_AXIS``) the runs are split over its devices, R a multiple of its size."""
        def build(t):  # the vmapped epoch, and its compiled forms by mesh
            return {"epoch": jax.vmap(lambda data, ts: t.bind(data)._epoch(ts), in_axes=(None, 0))}

        if mesh is None and ts.epoch.shape[0] == 1:  # one run: the unbatched program (its lax.cond stays a branch)
            return jax.tree.map(lambda x: x[None], self.epoch(jax.tree.map(lambda x: x[0], ts)))
        P = jax.sharding.PartitionSpec
        programs = self._program("epoch_runs", build)
        if mesh not in programs:
            f = programs["epoch"]
            if mesh is not None:
                f = jax.shard_map(f, mesh=mesh, in_specs=(P(), P(RUN_AXIS)), out_specs=P(RUN_AXIS), check_vma=False)
            programs[mesh] = jax.jit(f)
        data = self.task.data
        if mesh is not None:  # runs split over the devices (a no-op once placed), the object's data on every device
            if mesh not in self._placed:
                self._placed[mesh] = jax.device_put(data, jax.sharding.NamedSharding(mesh, P()))
            data = self._placed[mesh]
            ts = jax.device_put(ts, jax.sharding.NamedSharding(mesh, P(RUN_AXIS)))
        return programs[mesh](data, ts)

    def _update_aram_lambda(self, env_state: State, metrics: dict):
        """lambda_ARAM, once per epoch (facts §5): when the epoch's success exceeds the gate,
        lambda <- clip(lambda + lr (clip099 - target), 0, lambda_max). It lives in every world's env info."""
        a = self.aram
        lam = env_state.info["aram_lambda"][0]
        ok = (metrics["success"] > a.success_gate) & (metrics["episodes"] > 0)
        lam = jnp.where(ok, jnp.clip(lam + a.lr * (metrics["clip099"] - a.target), 0.0, a.lambda_max), lam)
        info = {**env_state.info, "aram_lambda": jnp.full_like(env_state.info["aram_lambda"], lam)}
        return env_state.replace(info=info), lam

    # ----------------------------------------------------------------------------------------- helpers
    def inputs(self, ts: TrainState, obs: Obs):
        """Normalised network inputs (state, history, privileged). The aux targets never enter the network;
        the privileged block reaches only a privileged critic."""
        if not self.config.normalize_obs:
            return obs.state, obs.history, obs.privileged
        return (ts.state_stats.normalize(obs.state), ts.token_stats.normalize(obs.history),
                ts.privileged_stats.normalize(obs.privileged))

    def apply(self, params, ts, obs: Obs):
        return self.net.apply(params, *self.inputs(ts, obs))

    # ---------------------------------------------------------------------------------------- the policy
    @staticmethod
    def policy_params(ts: TrainState) -> dict:
        """What the policy needs: network parameters and the observation normalisers."""
        return {"net": ts.params, "state_stats": ts.state_stats, "token_stats": ts.token_stats}

    def make_policy(self, deterministic: bool = True):
        """The policy as a function ``(policy_params, obs, key) -> action`` (Brax's ``make_inference_fn``):
        the Gaussian mean (det) or a sample (stoch). It reads obs.state and obs.history only."""
        normalize = self.config.normalize_obs

        def policy(params, obs: Obs, key):
            s, h = obs.state, obs.history
            if normalize:
                s, h = params["state_stats"].normalize(s), params["token_stats"].normalize(h)
            mu, log_std = self.net.apply(params["net"], s, h, method=ActorCritic.actor)
            if deterministic:
                return mu
            return mu + jnp.exp(log_std) * jax.random.normal(key, mu.shape)

        return policy

    def controller(self, ts: TrainState):
        """The trained policy of ``ts`` as the evaluator's :class:`Controller`."""
        from dragmesh2_jax.evaluation.evaluate import Controller

        return Controller(self.method.name, self.make_policy, self.policy_params(ts), key=self.signature())

    def init(self, seed: int | None = None) -> TrainState:
        """A new run's state (parameters, optimiser, worlds) from ``seed`` (default: the config's)."""
        run = self._program("init", lambda t: jax.jit(lambda data, key: t.bind(data)._init(key)))
        return run(self.task.data, jax.random.PRNGKey(self.config.seed if seed is None else seed))

    def init_runs(self, seeds: list[int]) -> TrainState:
        """The states of runs with these seeds, stacked on a leading run axis (each equals ``init(seed)``)."""
        run = self._program("init_runs", lambda t: jax.jit(jax.vmap(lambda data, key: t.bind(data)._init(key),
                                                                    in_axes=(None, 0))))
        return run(self.task.data, jnp.stack([jax.random.PRNGKey(s) for s in seeds]))

    def _init(self, rng: jax.Array) -> TrainState:
        c = self.config
        rng, k_net, k_env = jax.random.split(rng, 3)
        env_state = self.reset(jax.random.split(k_env, c.num_envs))
        obs = env_state.obs  # sizes come from the env (120, 16 x 102, 4 for the pulling task)
        params = self.net.init(k_net, obs.state[:1], obs.history[:1], obs.privileged[:1], method=ActorCritic.init_all)
        return TrainState(params=params, opt_state=self.tx.init(params), env_state=env_state,
                          state_stats=RunningStats.create(obs.state.shape[-1]),
                          token_stats=RunningStats.create(obs.history.shape[-1]),
                          aux_stats=RunningStats.create(obs.aux.shape[-1]),
                          privileged_stats=RunningStats.create(obs.privileged.shape[-1]),
                          value_stats=RunningStats.create(1),
                          rng=rng, epoch=jnp.int32(0), lr=jnp.float32(c.lr))

    # ------------------------------------------------------------------------------------------- epoch
    def _rollout(self, ts: TrainState):
        c = self.config
        vs = ts.value_stats
        denorm = lambda v: v * jnp.sqrt(vs.var[0] + 1e-5) + vs.mean[0]  # noqa: E731

        def body(carry, _):
            env_state, rng = carry
            rng, k = jax.random.split(rng)
            obs = env_state.obs
            mu, log_std, v, _ = self.apply(ts.params, ts, obs)
            a = mu + jnp.exp(log_std) * jax.random.normal(k, mu.shape)
            nxt = self.step(env_state, a)
            # bootstrap time limits only; the value of the final observations only at a step where one truncates
            v_final = jax.lax.cond(nxt.truncated.any(), lambda o: self.apply(ts.params, ts, o)[2],
                                   lambda o: jnp.zeros_like(v), nxt.final_obs)
            reward = nxt.reward + c.gamma * denorm(v_final) * nxt.truncated
            out = {"state": obs.state, "history": obs.history, "aux": obs.aux, "privileged": obs.privileged,
                   "step": obs.step, "action": a,
                   "logp": gaussian_logp(a, mu, log_std), "mu": mu, "log_std": jnp.broadcast_to(log_std, mu.shape),
                   "value": v, "reward": reward,
                   "done": nxt.done.astype(jnp.float32), "metrics": nxt.metrics, "terminated": nxt.terminated}
            return (nxt, rng), out

        (env_state, rng), traj = jax.lax.scan(body, (ts.env_state, ts.rng), None, length=c.rollout_len)
        _, _, last_v, _ = self.apply(ts.params, ts, env_state.obs)
        adv, ret = gae(traj["reward"], denorm(traj["value"]), traj["done"], denorm(last_v), c.gamma, c.gae_lambda)
        return env_state, rng, traj, adv, ret

    def loss(self, params, ts: TrainState, b: Batch, w_aux):
        c = self.config
        mu, log_std, v, z = self.net.apply(params, b.state, b.history, b.privileged)
        logp = gaussian_logp(b.action, mu, log_std)
        ratio = jnp.exp(logp - b.logp)
        adv = b.advantage
        if c.normalize_advantage:
            adv = (adv - adv.mean()) / (adv.std() + 1e-8)
        pg = -jnp.mean(jnp.minimum(ratio * adv, jnp.clip(ratio, 1 - c.clip_eps, 1 + c.clip_eps) * adv))
        if c.clip_value:
            v_clip = b.value + jnp.clip(v - b.value, -c.clip_eps, c.clip_eps)
            vl = 0.5 * jnp.mean(jnp.maximum((v - b.target) ** 2, (v_clip - b.target) ** 2))
        else:
            vl = 0.5 * jnp.mean((v - b.target) ** 2)
        bounds = jnp.mean(jnp.sum(jnp.maximum(mu - 1.1, 0) ** 2 + jnp.maximum(-1.1 - mu, 0) ** 2, axis=-1))
        entropy = jnp.sum(log_std + 0.5 * (LOG2PI + 1.0))
        aux = jnp.float32(0.0)
        if self.use_aux:
            pred = self.net.apply(params, z, method=ActorCritic.aux)
            target = ts.aux_stats.normalize(b.aux, clip=1e6)  # z-scored targets (facts §6)
            aux = jnp.sum(jnp.asarray(c.aux_channel_weights) * jnp.mean((pred - target) ** 2, axis=0))
        total = pg + c.value_coef * vl + c.bounds_coef * bounds - c.entropy_coef * entropy + w_aux * aux
        kl = jnp.mean(jnp.sum(log_std - b.log_std + (jnp.exp(2 * b.log_std) + (b.mu - mu) ** 2)
                              / (2 * jnp.exp(2 * log_std)) - 0.5, axis=-1))  # KL(old || new), as rl_games
        return total, {"loss": total, "policy_loss": pg, "value_loss": vl, "bounds_loss": bounds, "aux_loss": aux,
                       "kl": kl, "entropy": entropy}

    def _epoch(self, ts: TrainState):
        c = self.config
        env_state, rng, traj, adv, ret = self._rollout(ts)
        vs = ts.value_stats.update(ret[..., None])  # value normalisation (the reference's normalize_value)
        n = c.num_envs * c.rollout_len
        flat = lambda x: x.reshape(n, *x.shape[2:])  # noqa: E731
        obs = Obs(state=flat(traj["state"]), history=flat(traj["history"]), aux=flat(traj["aux"]),
                  privileged=flat(traj["privileged"]), step=flat(traj["step"]))
        s_in, h_in, p_in = self.inputs(ts, obs)
        # values were predicted in the old value normalisation: re-express old predictions and targets in the new
        old_v = flat(traj["value"]) * jnp.sqrt(ts.value_stats.var[0] + 1e-5) + ts.value_stats.mean[0]
        norm = lambda x: (x - vs.mean[0]) / jnp.sqrt(vs.var[0] + 1e-5)  # noqa: E731
        batch = Batch(state=s_in, history=h_in, aux=obs.aux, privileged=p_in, action=flat(traj["action"]),
                      logp=flat(traj["logp"]), mu=flat(traj["mu"]), log_std=flat(traj["log_std"]),
                      value=norm(old_v), advantage=flat(adv), target=norm(flat(ret)))
        ts = ts.replace(value_stats=vs)
        w_aux = c.aux_weight_at(ts.epoch)
        grad_fn = jax.grad(self.loss, has_aux=True)

        def update_epoch(carry, _):
            ts, rng = carry
            rng, k = jax.random.split(rng)
            perm = jax.random.permutation(k, n).reshape(c.num_minibatches, -1)

            def minibatch(ts, idx):
                mb = jax.tree.map(lambda x: x[idx], batch)
                grads, info = grad_fn(ts.params, ts, mb, w_aux)
                clip_state, adam_state = ts.opt_state
                adam_state = adam_state._replace(hyperparams={**adam_state.hyperparams, "learning_rate": ts.lr})
                updates, opt_state = self.tx.update(grads, (clip_state, adam_state), ts.params)
                return ts.replace(params=optax.apply_updates(ts.params, updates), opt_state=opt_state), info

            ts, info = jax.lax.scan(minibatch, ts, perm)
            info = jax.tree.map(lambda x: x[-1], info)
            if c.lr_schedule == "adaptive":  # rl_games: KL-adaptive learning rate
                kl = info["kl"]
                lr = jnp.where(kl > 2 * c.kl_threshold, ts.lr / 1.5,
                               jnp.where(kl < 0.5 * c.kl_threshold, ts.lr * 1.5, ts.lr))
                ts = ts.replace(lr=jnp.clip(lr, 1e-6, 1e-2))
            return (ts, rng), info

        (ts, rng), info = jax.lax.scan(update_epoch, (ts, rng), None, length=c.update_epochs)
        info = jax.tree.map(lambda x: x[-1], info)
        if c.normalize_obs:  # statistics move after the update, so rollout and update saw the same inputs
            ts = ts.replace(state_stats=ts.state_stats.update(obs.state),
                            token_stats=ts.token_stats.update(obs.history), aux_stats=ts.aux_stats.update(obs.aux),
                            privileged_stats=ts.privileged_stats.update(obs.privileged))
        m, done = traj["metrics"], traj["done"]
        episodes = done.sum()
        at_end = lambda x: jnp.sum(x * done) / jnp.maximum(episodes, 1.0)  # noqa: E731
        metrics = {
            **info, "lr": ts.lr, "w_aux": w_aux, "reward": traj["reward"].mean(), "episodes": episodes,
            "success": at_end(m["success"]), "progress": at_end(m["progress"]), "detach": at_end(m["detach"]),
            "episode_return": at_end(m["episode_return"]), "clip099": jnp.mean(m["action_abs_max"] > CLIP_LEVEL),
            "clip099_active": jnp.mean(m["active_abs_max"] > CLIP_LEVEL),
            "action_l2": m["action_l2"].mean(), "nonfinite": m["nonfinite"].sum(),
        }
        if self.aram is not None:
            env_state, metrics["aram_lambda"] = self._update_aram_lambda(env_state, metrics)
        return ts.replace(env_state=env_state, rng=rng, epoch=ts.epoch + 1), metrics
