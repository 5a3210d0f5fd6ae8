"""The contact-driven pulling task (paper §3.1-3.2, Appendix A) as pure functions of one world's ``State``.

:class:`PullTask` is an env of ``task/protocol.py``: ``reset(key) -> State`` and ``step(state, action) -> State``
act on one world; batch them with ``jax.vmap`` (:func:`make_batched`); ``wrappers.AutoReset`` restarts finished
worlds. A step is physics -> events -> reward -> observation (:meth:`PullTask.step`).

Units: world frame, metres, radians, seconds; a step = ``control_dt`` (1/60 s) = ``substeps`` physics steps. The
policy acts only on the hand (target = clip(q_hand + alpha a, limits)); the object's joint moves only by contact.

Observation (kept as separate fields, so each policy takes what it may):
  obs.state    s_t (``task/observation.py``): the paper's (120: hand q and qd, handle pose, palm-to-handle vector and
               distance, object q and qd, phi) or, with ``TaskConfig.observation = "handle"``, one that transfers
               across objects (110: the hand and the joint in the handle's frame, the part's state in task units).
  obs.history  H_t (L=16, 102): tokens h = [e_t, a_{t-1}], e_t = PD target - hand q, oldest first; zeros at
               reset except the newest token [e_0, 0].
  obs.aux      y_t (4): [q_t - q_{t-K}, max_{t-K..t} d, 1(max d > d_detach), max_{t-K..t} ||e||], K = 5: a target.
  obs.privileged (2 + 22): [damping multiplier, friction multiplier, contact load f_t]: an asymmetric critic's only.
  obs.step     the control step within the episode (0 at reset): what a time-indexed controller reads (the
               tracking baseline's replay, the parallel-jaw primitive's phases); no network input.
With ``TaskConfig.force_obs`` (beyond the paper) the contact load f_t (22) is appended to s_t (-> 142, or 132) and to
every history token (-> 124): signed log1p of [wrist force (3, N), wrist torque (3, N m), normal contact force on
the palm and each of the 15 phalanges (16, N)], so that a grip and a yank fit one scale.

The object is data: everything object-specific (the backend's model and start bank, the task boundary, the nominal
model fields, the adaptive ARAM weight) is ``task.data`` (:class:`TaskData`); :meth:`PullTask.bind` gives the same
task over other data, as Playground's randomisation wrapper swaps the model inside a traced function, so a program
written against ``task.bind(data)`` compiles once for every object of the same structure (``ppo/train.py``).

Success: q >= q_done = q_min + rho (q_max - q_min) over the trajectory (``TaskConfig.rho``; design §4). Reset: at
the expert grasp (drag-start frame, settled), or with ``TaskConfig.reset_noise`` a seeded perturbation of it.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
from types import ModuleType

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dragmesh2_jax.assets.hand import NUM_DOFS, NUM_VIRTUAL
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.physics.base import Backend, Kinematics, Start, WorldFields
from dragmesh2_jax.physics.contacts import ContactBudget
from dragmesh2_jax.physics.mujoco_backend import MujocoBackend
from dragmesh2_jax.scene import FORCE_SIZE, Scene
from dragmesh2_jax.task import expert, randomize
from dragmesh2_jax.task.config import PEAK_COSTS, ResetNoise, TaskConfig
from dragmesh2_jax.task.observation import joint_geometry, load, phi, state_obs
from dragmesh2_jax.task.protocol import METRICS, START_STEPS, Obs, State
from dragmesh2_jax.task.rewards import (
    TERM_PREFIX,
    aram_penalty,
    bound_weights,
    constraint_cost,
    cost_metric,
    ended_early_charge,
    initial_weights,
    reconfig_bonus,
    reward_terms,
    term_names,
    update_weights,
)
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.schema import Trajectory

TOKEN_SIZE = 2 * NUM_DOFS
AUX_SIZE = 4
PRIVILEGED_SIZE = len(randomize.RANDOMIZERS) + FORCE_SIZE


def applied_action(obs: Obs, action_size: int) -> jnp.ndarray:
    """a_{t-1} of the newest history token [e_t, a_{t-1}, ...]: the action the last step applied (prior included)."""
    return obs.history[..., -1, action_size:2 * action_size]


@struct.dataclass
class TaskParams:
    """Per-object task boundary from the reference trajectory (paper eq. done/progress), and the reward's
    adaptive weights, set by the trainer once per epoch: ARAM's and the constraints' multipliers (one per
    ``RewardConfig.constraints``, in its order; 0 until the trainer moves them)."""

    q_start: jnp.ndarray
    q_goal: jnp.ndarray
    q_done: jnp.ndarray
    damping: jnp.ndarray  # nominal target-joint damping
    hand_lo: jnp.ndarray
    hand_hi: jnp.ndarray
    revolute: jnp.ndarray  # the target joint is a hinge (bool)
    joint_axis: jnp.ndarray  # (3,) the target joint's axis in the handle's frame (task/observation.py)
    hinge_radius: jnp.ndarray  # m, the handle centre's distance from the hinge axis (0 for a slide)
    long_sign: jnp.ndarray  # +-1: the handle's long axis as the observation reads it (task/observation.py)
    schedule: jnp.ndarray  # (episode_length,) the target joint after each step of the expert drag at its own pace
    drag: jnp.ndarray  # (episode_length, 51) the expert drag's hand targets per step (TaskConfig.expert_prior), or (0,)
    expert_load: jnp.ndarray  # (bank, 4) N, the expert's peak wrist load per start at x1-x8, relative_load's unit
    expert_pace: jnp.ndarray  # (bank,) m/s, the expert's settled palm peak per start at x1, relative_palm_speed's unit
    aram_lambda: jnp.ndarray = struct.field(default_factory=lambda: jnp.float32(0.0))
    multipliers: jnp.ndarray = struct.field(default_factory=lambda: jnp.zeros(0, jnp.float32))
    # the object's probability of being drawn at a reset of an object mix (task/mix.py; set there by the trainer)
    draw_weight: jnp.ndarray = struct.field(default_factory=lambda: jnp.float32(1.0))


@struct.dataclass
class TaskData:
    """Everything object-specific the task's functions read: an argument of a compiled program, not a constant."""

    physics: object  # the backend's data (model or host handle, start bank, layout)
    params: TaskParams
    start_ctrl: jnp.ndarray  # (bank, 51) the PD target each start was settled with
    fields: WorldFields  # nominal values of the randomised fields (randomize.FIELDS)


def trajectory_joint(obj, traj: Trajectory) -> str:
    """The name of the object joint ``traj`` moves (its target); a clear error if ``traj`` is not ``obj``'s."""
    h = traj.header
    if h.get("object_id") not in (None, obj.object_id):
        raise DragMeshError(f"trajectory is for object {h['object_id']}, not {obj.object_id}")
    n = len(traj.frames[0].joint_positions)
    if n != len(obj.movable_joints):
        raise DragMeshError(f"trajectory has {n} object joints but object {obj.object_id} has "
                            f"{len(obj.movable_joints)} movable joints")
    return obj.movable_joints[traj.target_index].name


def check_trajectory_matches(scene: Scene, traj: Trajectory) -> None:
    """A clear error if ``traj`` was not made for ``scene``'s object and target (before anything compiles)."""
    obj = scene.obj
    moved = trajectory_joint(obj, traj)
    if moved != obj.target.joint.name:
        raise DragMeshError(f"trajectory moves joint {moved} but the target of object {obj.object_id} is "
                            f"{obj.target.joint.name} (build the scene from obj.with_target({moved!r}); "
                            "runs.build.load_task does)")
    if not traj.q_max - traj.q_min > 1e-6:
        raise DragMeshError("trajectory never moves its target joint (zero motion range)")


def substeps_of(scene: Scene, config: TaskConfig) -> int:
    substeps = config.control_dt / scene.config.timestep
    if abs(substeps - round(substeps)) > 1e-6 or round(substeps) < 1:
        raise DragMeshError(f"control_dt {config.control_dt} is not a whole number of timesteps "
                            f"{scene.config.timestep}")
    return int(round(substeps))


MJX_BACKEND = "dragmesh2_jax.physics.mjx_backend"


def _mjx() -> ModuleType:
    """The MJX backend (``physics/mjx_backend.py``), imported when a task chooses it: importing ``mujoco.mjx`` defines
    MuJoCo Warp's kernels when warp-lang is installed, 2.2 s of every process that steps only the C engine (a CLI
    command, CPU training; RESULTS.md §4)."""
    return importlib.import_module(MJX_BACKEND)


def contact_budget(scene: Scene, traj: Trajectory, config: TaskConfig, starts: list[Start]) -> ContactBudget:
    """MJX's buffers for the task: the expert drag probed on the C engine from the first starts, with the budget's
    margin (``config.contacts`` overrides the contact slots)."""
    probed = contacts.probe(scene, starts[:contacts.PROBE_STARTS], traj.drag_targets(config.control_dt),
                            substeps_of(scene, config), config.settle_substeps)
    return ContactBudget.of(*probed, _mjx().candidates(scene.model), contacts.limited_dofs(scene),
                            config.contacts)


def make_backend(scene: Scene, config: TaskConfig, starts: list[Start], traj: Trajectory) -> Backend:
    """The task's physics engine (MJX's buffers from :func:`contact_budget`)."""
    substeps = substeps_of(scene, config)
    if config.resolved_backend() == "mjx":
        budget = contact_budget(scene, traj, config, starts)
        return _mjx().MjxBackend(scene, substeps, starts, budget, config.settle_substeps, impl=config.resolved_impl())
    return MujocoBackend(scene, substeps, starts, config.settle_substeps, nthread=config.nthread)


@struct.dataclass
class Events:
    """What one step's physics meant for the episode."""

    d: jnp.ndarray  # palm-handle distance (m)
    q: jnp.ndarray  # target-joint position
    success: jnp.ndarray
    detach: jnp.ndarray
    terminated: jnp.ndarray
    truncated: jnp.ndarray
    step: jnp.ndarray  # control steps taken in the episode


class PullTask:
    """One object, one trajectory, one config: the env of ``task/protocol.py`` (no automatic reset: see
    ``wrappers.AutoReset``). ``costs``: False for a task whose constraints' costs count for nothing (an evaluation's:
    its multipliers stay zero), where one probe of the expert's load from the exact grasp stands for every start."""

    def __init__(self, scene: Scene, traj: Trajectory, config: TaskConfig = TaskConfig(), start: Start | None = None,
                 costs: bool = True):
        check_trajectory_matches(scene, traj)
        self.scene, self.traj, self.config = scene, traj, config
        starts = reset_starts(scene, traj, config.reset_noise, start, config.rho)
        self.backend = make_backend(scene, config, starts, traj)
        substeps = self.substeps = self.backend.substeps
        lo, hi = scene.ids.hand_range[:, 0], scene.ids.hand_range[:, 1]
        axis, radius, sign = joint_geometry(scene)
        probe = (scene, traj, config, reset_starts(scene, traj, None, start, config.rho)[0], starts, substeps, costs)
        params = TaskParams(q_start=jnp.float32(traj.q_start), q_goal=jnp.float32(traj.q_goal),
                            q_done=jnp.float32(traj.q_done_at(config.rho)), damping=jnp.float32(scene.config.damping),
                            hand_lo=jnp.asarray(lo, jnp.float32), hand_hi=jnp.asarray(hi, jnp.float32),
                            revolute=jnp.bool_(scene.ids.target_is_revolute), long_sign=jnp.float32(sign),
                            joint_axis=jnp.asarray(axis, jnp.float32), hinge_radius=jnp.float32(radius),
                            schedule=jnp.asarray(traj.drag_schedule(config.control_dt, config.episode_length)),
                            drag=jnp.asarray(expert.expert_drag(scene, traj, config)),
                            expert_load=jnp.asarray(expert.expert_load(*probe)),
                            expert_pace=jnp.asarray(expert.expert_pace(*probe)),
                            multipliers=jnp.zeros(len(config.reward.constraints), jnp.float32))
        start_ctrl = jnp.clip(jnp.asarray(np.stack([h for h, _ in starts]), jnp.float32), lo, hi)
        self.data = TaskData(physics=self.backend.data, params=params, start_ctrl=start_ctrl,
                             fields={f: jnp.asarray(getattr(scene.model, f)) for f in randomize.FIELDS})
        self.action_size = len(scene.ids.hand_qpos)  # 51 for the hand, 8 for the gripper
        self.active = jnp.asarray(scene.config.active_dofs())

    def check_overflow(self, count: int, where: str) -> None:
        """A clear error when ``count`` world-steps overflowed the engine's contact or constraint buffers."""
        if count:
            raise DragMeshError(contacts.overflow_message(self.backend.budget, count, where))

    @property
    def num_starts(self) -> int:
        return self.data.start_ctrl.shape[0]

    def bind(self, data: TaskData) -> PullTask:
        """This task over ``data`` (another object of the same structure, or tracers of a compiled program)."""
        task = copy.copy(self)
        task.data = data
        return task

    def sized(self, worlds: int) -> PullTask:
        """This task for a batch of ``worlds`` worlds (the engine's shared buffers sized for them)."""
        return self.bind(self.data.replace(physics=self.backend.sized(self.data.physics, worlds)))

    def signature(self) -> tuple:
        """What the compiled functions depend on besides ``data`` (and its shapes, and on MJX the model's static
        fields, geometry included): tasks with equal signatures share programs. The scene enters through the
        model (data) but for the effector and the hand variant, which fix the moving DoFs."""
        return self.config, self.scene.config.effector, self.scene.config.hand, self.backend.signature()

    @property
    def params(self) -> TaskParams:
        return self.data.params

    @property
    def object_id(self) -> str:
        return self.scene.obj.object_id

    @property
    def engine(self) -> str:
        """The physics engine: ``mujoco`` (the C engine) or ``mjx`` (``config.resolved_impl()`` says which MJX)."""
        return self.backend.name

    @property
    def budget(self) -> ContactBudget | None:
        """MJX's contact budget (its static buffers); None on the C engine, which sizes its own as it goes."""
        return self.backend.budget

    @property
    def buffers(self) -> dict:
        """Contact slots and constraint rows one world holds (None on the C engine)."""
        return self.backend.buffers if self.budget is not None else {"contact_slots": None, "constraint_rows": None}

    @property
    def trajectories(self) -> tuple[Trajectory, ...]:
        return (self.traj,)

    def with_budget(self, budget: ContactBudget) -> PullTask:
        """This task on MJX with ``budget``'s buffers (a mix's, which holds each of its objects)."""
        task = copy.copy(self)
        task.backend = self.backend.with_budget(budget)
        return task.bind(self.data.replace(physics=task.backend.data))

    def with_starts(self, starts: ResetNoise | None, costs: bool = False) -> PullTask:
        """This object and trajectory from other reset starts (an evaluation protocol's; ``costs``: see the class)."""
        return PullTask(self.scene, self.traj, dataclasses.replace(self.config, reset_noise=starts), costs=costs)

    def kinematics(self, state: State) -> Kinematics:
        return self.backend.kinematics(self.data.physics, state.physics)

    # ------------------------------------------------------------------- the reward's adaptive weights
    def adaptive_weights(self) -> dict[str, jnp.ndarray]:
        """A new run's adaptive reward weights (``rewards.initial_weights``): the trainer keeps them, binds them into
        each epoch's rollout (:meth:`bind_weights`) and moves them after it (:meth:`update_weights`)."""
        return initial_weights(self.config.reward)

    def bind_weights(self, data: TaskData, weights: dict) -> TaskData:
        """``data`` with the adaptive weights its reward reads set to ``weights``."""
        return data.replace(params=data.params.replace(**bound_weights(self.config.reward, weights)))

    def update_weights(self, weights: dict, metrics: dict, steps: dict) -> tuple[dict, dict]:
        """The weights after an epoch of ``metrics`` (per-step ``steps``), and the metrics with theirs added."""
        return update_weights(self.config.reward, weights, metrics, steps)

    # ------------------------------------------------------------------------------------------ helpers
    def progress(self, q):
        """p_t = max(0, (q - q_start) / (q_goal - q_start)) (paper eq. progress)."""
        return phi(self.params, q)[0]

    def _token(self, e, a, k: Kinematics) -> jnp.ndarray:
        """h_t = [e_t, a_{t-1}] (paper), [e_t, a_{t-1}, f_t] with ``force_obs``."""
        return jnp.concatenate([e, a, load(k)] if self.config.force_obs else [e, a]).astype(jnp.float32)

    def _privileged(self, info, k: Kinematics) -> jnp.ndarray:  # and the peak constraints' memory: costs to come
        peak = np.asarray([x.cost in PEAK_COSTS for x in self.config.reward.constraints], bool)
        return jnp.concatenate([randomize.privileged(info["scales"]), load(k), info["passed"][peak] * 1.0])

    def _aux(self, info) -> jnp.ndarray:
        q, dmax = info["q_ring"], info["d_ring"].max()
        return jnp.stack([q[-1] - q[0], dmax, (dmax > self.config.d_detach).astype(jnp.float32),
                          info["e_ring"].max()]).astype(jnp.float32)

    # --------------------------------------------------------------------------------------------- API
    def reset(self, key: jax.Array, damping_scale: jax.Array | float | None = None, start=None) -> State:
        """A new episode at the expert grasp state (post-settle). The randomised multipliers are drawn
        (``randomize.sample``); the damping multiplier is fixed instead by ``damping_scale`` (the one way to fix
        it), and a fixed multiplier is kept by every automatic reset of that world (evaluation cells). ``start``:
        the index of the start state (modulo the bank; an evaluation gives each episode of a cell its own), else
        drawn at random."""
        key, sub = jax.random.split(key)
        scales = randomize.sample(sub, self.config)
        fixed = damping_scale is not None
        if fixed:
            scales[randomize.DAMPING] = jnp.asarray(damping_scale, jnp.float32)
        return self.reset_world(key, scales, jnp.bool_(fixed), start)

    def reset_world(self, key: jax.Array, scales: dict, fixed: jax.Array, start=None) -> State:
        """A new episode with these multipliers (``fixed``: the damping multiplier survives automatic resets) from
        start ``start`` (modulo the bank; None: drawn at random)."""
        c = self.config
        key, k_start = jax.random.split(key)
        start = (jax.random.randint(k_start, (), 0, self.num_starts) if start is None
                 else jnp.asarray(start, jnp.int32) % self.num_starts)
        ps = self.backend.reset_state(self.data.physics, start)
        k = self.backend.kinematics(self.data.physics, ps)
        ctrl = self.data.start_ctrl[start]
        e = (ctrl - k.hand_q).astype(jnp.float32)
        token = self._token(e, jnp.zeros(self.action_size, jnp.float32), k)
        history = jnp.zeros((c.history_len, token.shape[0]), jnp.float32).at[-1].set(token)
        d = jnp.linalg.norm(k.handle_pos - k.palm).astype(jnp.float32)
        K1 = c.aux_window + 1
        info = {
            "rng": key, "step": jnp.int32(0), "scales": {n: jnp.asarray(v, jnp.float32) for n, v in scales.items()},
            "fixed_damping": fixed, "start": start, "armed": d <= c.d_detach, "q_prev": k.obj_q.astype(jnp.float32),
            "ctrl": ctrl, "episode_return": jnp.float32(0.0), "e_ring": jnp.full((K1,), jnp.linalg.norm(e)),
            "d_ring": jnp.full((K1,), d), "q_ring": jnp.full((K1,), k.obj_q, jnp.float32),
            "passed": jnp.zeros(len(c.reward.constraints), bool),  # each constraint's limit passed this episode
            # reward-stage rings of 2K+1 and the ARAM / Reconfig state (design §5)
            "d_long": jnp.full((2 * K1 - 1,), d), "q_long": jnp.full((2 * K1 - 1,), k.obj_q, jnp.float32),
            "stall": jnp.int32(0), "cooldown": jnp.int32(0),
            **({"drag_begun": expert.planned_step(self.params, k.obj_q)} if c.prior_from_start else {}),  # drag_step's
        }
        obs = Obs(state=state_obs(c, k, self.params), history=history, aux=self._aux(info),
                  privileged=self._privileged(info, k), step=info["step"])
        zero = jnp.float32(0.0)
        metrics = ({m: zero for m in METRICS} | {cost_metric(x): zero for x in c.reward.constraints}
                   | {TERM_PREFIX + t: zero for t in term_names(c.reward)} | {"q": k.obj_q.astype(jnp.float32)})
        return State(physics=ps, obs=obs, reward=zero, done=jnp.bool_(False), terminated=jnp.bool_(False),
                     truncated=jnp.bool_(False), final_obs=obs, metrics=metrics, info=info)

    def restart(self, state: State) -> State:
        """The next episode of a world: fresh multipliers from the world's rng, its damping multiplier kept when
        fixed (an evaluation cell)."""
        info = state.info
        key, sub, sub2 = jax.random.split(info["rng"], 3)
        scales = randomize.sample(sub, self.config)
        scales[randomize.DAMPING] = jnp.where(info["fixed_damping"], info["scales"][randomize.DAMPING],
                                              scales[randomize.DAMPING])
        fresh = self.reset_world(sub2, scales, info["fixed_damping"])
        return fresh.replace(info={**fresh.info, "rng": key})

    def step(self, state: State, action: jnp.ndarray) -> State:
        """One control step from a policy action a in [-1, 1]^51: target = clip(q_hand + alpha a, limits) (with
        ``expert_prior``, a the policy's residual over the expert drag: ``expert.residual_step``)."""
        a = jnp.clip(action, -1.0, 1.0).astype(jnp.float32)
        k0 = self.kinematics(state)
        if self.config.expert_prior:
            ctrl, applied, own = expert.residual_step(self.config, self.params, state.info, k0.hand_q, k0.obj_q, a)
            return self._advance(state, ctrl, applied, k0.palm, own)
        ctrl = jnp.clip(k0.hand_q + self.config.alpha * a, self.params.hand_lo, self.params.hand_hi)
        return self._advance(state, ctrl, a, k0.palm)

    def step_target(self, state: State, target: jnp.ndarray) -> State:
        """One control step with the hand PD target given directly (the trajectory-tracking baseline); the
        history token's action part is then (target - q) / alpha clipped to [-1, 1]."""
        k0 = self.kinematics(state)
        ctrl = jnp.clip(target.astype(jnp.float32), self.params.hand_lo, self.params.hand_hi)
        a = jnp.clip((ctrl - k0.hand_q) / self.config.alpha, -1.0, 1.0)
        return self._advance(state, ctrl, a, k0.palm)

    # ----------------------------------------------------------------- the step: physics -> ... -> obs
    def _physics(self, state: State, ctrl: jnp.ndarray):
        """Substeps with PD targets ``ctrl`` in this world's model fields; a non-finite world reads as zeros."""
        info = state.info
        fields = randomize.world_fields(info["scales"], self.data.fields, self.params.damping,
                                        self.data.physics.layout)
        ps = self.backend.step(self.data.physics, state.physics, ctrl, fields)
        k = self.backend.kinematics(self.data.physics, ps)
        finite = jnp.all(jnp.array([jnp.all(jnp.isfinite(x)) for x in jax.tree.leaves(k)]))
        return ps, jax.tree.map(lambda x: jnp.where(finite, x, 0.0), k), finite

    def _events(self, info: dict, k: Kinematics, finite: jnp.ndarray) -> Events:
        """Success, detachment (once armed: paper App. A, design §4), the time limit."""
        c, p = self.config, self.params
        d = jnp.linalg.norm(k.handle_pos - k.palm)
        q = k.obj_q.astype(jnp.float32)
        success = q >= p.q_done
        detach = info["armed"] & (d > c.d_detach) & ~success
        step = info["step"] + 1
        terminated = success | detach | ~finite
        return Events(d=d, q=q, success=success, detach=detach, terminated=terminated,
                      truncated=(step >= c.episode_length) & ~terminated, step=step)

    def _measures(self, palm_before: jnp.ndarray, k: Kinematics, a: jnp.ndarray, a_prev: jnp.ndarray, ev: Events,
                  info: dict, own: jnp.ndarray) -> dict[str, jnp.ndarray]:
        """This step's value of each quantity a constraint can bound (``config.MEASURES``; the relative ones in the
        expert's units at this world's start and damping; the saturations of ``own``)."""
        p, start = self.params, info["start"]
        lag = (p.schedule[ev.step - 1] - ev.q) / (p.q_goal - p.q_start)  # one schedule entry per step
        load, palm_speed = jnp.linalg.norm(k.force[:3]), jnp.linalg.norm(k.palm - palm_before) / self.config.control_dt
        settled = jnp.where(ev.step > START_STEPS, palm_speed, 0.0)
        unit = expert.load_unit(p.expert_load[start], info["scales"][randomize.DAMPING])
        return {"load": load, expert.RELATIVE_LOAD: load / unit, "lag": lag, "lead": -lag, "palm_speed": palm_speed,
                "settled_palm_speed": settled, expert.RELATIVE_PACE: settled / p.expert_pace[start],
                "saturation": jnp.max(jnp.where(self.active, jnp.abs(own), 0.0)),
                "wrist_saturation": jnp.max(jnp.abs(own[:NUM_VIRTUAL])), "penetration": k.penetration,
                "action_change": jnp.where(ev.step > 1, jnp.mean(jnp.abs(a - a_prev)), 0.0)}

    def _reward(self, state: State, a, own, k: Kinematics, ev: Events, finite: jnp.ndarray, costs):
        """r_t (paper eq. totalreward, with the constraints' term, ARAM or Reconfig when configured), its terms
        (zero in a non-finite world), the reward stage's new state; ``costs``: c_t per constraint; ``own``: PICA's."""
        c, p, info = self.config, self.params, state.info
        terms = reward_terms(c.reward, own, ev.d, ev.q - info["q_prev"], ev.success.astype(jnp.float32),
                             ev.detach.astype(jnp.float32), k.force[:3])
        if c.reward.constraints:
            terms["constraints"] = -jnp.dot(p.multipliers, costs) - ended_early_charge(
                c.reward, p.multipliers, costs, ev.detach, ev.success, c.episode_length - ev.step)
        ring = lambda r, x: jnp.concatenate([r[1:], jnp.asarray(x, r.dtype)[None]])  # noqa: E731
        d_long, q_long = ring(info["d_long"], ev.d), ring(info["q_long"], ev.q)
        stall, cooldown = info["stall"], info["cooldown"]
        delta, K = p.q_goal - p.q_start, c.aux_window
        if c.reward.aram is not None:
            terms["aram"], stall = aram_penalty(c.reward.aram, p.aram_lambda, stall, ev.d, a,
                                                ev.q - q_long[-1 - K], delta, p.revolute)
        if c.reward.reconfig is not None:
            prev_a = applied_action(state.obs, self.action_size)
            terms["reconfig"], cooldown = reconfig_bonus(c.reward.reconfig, cooldown, d_long, q_long, a, prev_a,
                                                         k.hand_qd, delta, K)
        reward = sum(terms.values())
        if c.reward.constraints and c.reward.lagrangian == "normalized":
            reward = reward / (1.0 + p.multipliers.sum())
        reward = jnp.where(finite, reward, 0.0).astype(jnp.float32)
        terms = {t: jnp.where(finite, v, 0.0).astype(jnp.float32) for t, v in terms.items()}
        return reward, terms, {"d_long": d_long, "q_long": q_long, "stall": stall, "cooldown": cooldown}

    def _advance(self, state: State, ctrl: jnp.ndarray, a: jnp.ndarray, palm_before: jnp.ndarray,
                 own: jnp.ndarray | None = None) -> State:
        """The step to PD target ``ctrl``; ``own``: what PICA's action terms and saturations read (else ``a``)."""
        c, info, own = self.config, state.info, a if own is None else own
        ps, k, finite = self._physics(state, ctrl)
        overflow = self.backend.overflow(self.data.physics, ps)
        ev = self._events(info, k, finite)
        measures = self._measures(palm_before, k, a, applied_action(state.obs, self.action_size), ev, info, own)
        costs = jnp.asarray([jnp.where(finite, constraint_cost(x, measures[x.measure], info["passed"][i]), 0.0)
                             for i, x in enumerate(c.reward.constraints)], jnp.float32)
        reward, terms, reward_state = self._reward(state, a, own, k, ev, finite, costs)
        # observation
        ring = lambda r, x: jnp.concatenate([r[1:], jnp.asarray(x, r.dtype)[None]])  # noqa: E731
        e = (ctrl - k.hand_q).astype(jnp.float32)
        history = jnp.concatenate([state.obs.history[1:], self._token(e, a, k)[None]], axis=0)
        ep_return = info["episode_return"] + reward
        new_info = {**info, **reward_state, "step": ev.step, "armed": info["armed"] | (ev.d <= c.d_detach),
                    "q_prev": ev.q, "ctrl": ctrl, "d_ring": ring(info["d_ring"], ev.d),
                    "q_ring": ring(info["q_ring"], ev.q), "e_ring": ring(info["e_ring"], jnp.linalg.norm(e)),
                    "episode_return": ep_return, "passed": info["passed"] | (costs > 0)}
        obs = Obs(state=state_obs(self.config, k, self.params), history=history, aux=self._aux(new_info),
                  privileged=self._privileged(new_info, k), step=ev.step)
        metrics = {
            "success": ev.success.astype(jnp.float32), "progress": self.progress(ev.q),
            "detach": ev.detach.astype(jnp.float32), "truncated": ev.truncated.astype(jnp.float32),
            "action_abs_max": jnp.max(jnp.abs(a)), "active_abs_max": jnp.max(jnp.where(self.active, jnp.abs(a), 0.0)),
            "action_l2": jnp.linalg.norm(a), "palm_dist": ev.d.astype(jnp.float32), "reward": reward,
            "nonfinite": (~finite).astype(jnp.float32), "overflow": overflow.astype(jnp.float32),
            "episode_return": ep_return, "episode_length": ev.step.astype(jnp.float32), "q": ev.q,
        } | {cost_metric(x): costs[i] for i, x in enumerate(c.reward.constraints)} | {
            TERM_PREFIX + t: v for t, v in terms.items()}
        return State(physics=ps, obs=obs, reward=reward, done=ev.terminated | ev.truncated, terminated=ev.terminated,
                     truncated=ev.truncated, final_obs=obs, metrics=metrics, info=new_info)


def make_batched(env):
    """(reset, step) over a leading world axis: ``reset(keys[N]) -> State[N]``, ``step(State[N], a[N, 51])``."""
    return jax.vmap(env.reset), jax.vmap(env.step)
