"""Trajectory-tracking baseline (paper Table 2, row 1; Appendix A.2): each next reference hand pose of the
drag phase becomes the hand PD target; the object state is never replayed, so the part opens only if the
replayed hand motion drags it through contact. It is a controller of the evaluator (``controls="targets"``):
the same cells and metric names as every policy. After the drag block it holds the last pose.

``tracking_delta`` is the reference's ``delta_action`` mode of the same replay (design §10): the drag sent through the
learned policies' action interface, a = clip((target - q) / alpha, -1, 1), so the PD target never leads the hand by
more than alpha. It tells apart what the increment interface allows from what a policy learns to do with it.

``prior`` is the expert prior a residual policy is trained over, alone: its residual at zero, so the drag at the
prior's steps (``TaskConfig.prior_lead``, ``prior_floor``) and through its interface (``residual_on``); of a run, the
expert in use as its policy meets it."""

from __future__ import annotations

import functools

import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.task.protocol import Obs

TRACKING = "tracking"
TRACKING_DELTA = "tracking_delta"
PRIOR = "prior"


def drag_targets(task: PullTask, pace: float = 1.0) -> np.ndarray:
    """The task's expert drag as one hand PD target per control step, at ``pace`` (``Trajectory.drag_targets``)."""
    return task.traj.drag_targets(task.config.control_dt, pace)


def replay(targets: jnp.ndarray, obs: Obs, key) -> jnp.ndarray:
    """The PD target of the episode's current step (the last one once the replay is over)."""
    return targets[jnp.minimum(obs.step, targets.shape[0] - 1)]


def tracking_controller(task: PullTask, pace: float = 1.0) -> Controller:
    """The expert drag replayed open-loop (deterministic: det and stoch are the same controller), at ``pace``."""
    return Controller(TRACKING, lambda deterministic: replay, jnp.asarray(drag_targets(task, pace)), controls="targets",
                      key=TRACKING)


def toward(alpha: float, target: jnp.ndarray, obs: Obs) -> jnp.ndarray:
    """The action whose PD target q + alpha a comes nearest ``target``."""
    q = obs.state[..., : target.shape[-1]]  # s_t starts with the hand's joint positions
    return jnp.clip((target - q) / alpha, -1.0, 1.0)


def increments(alpha: float, targets: jnp.ndarray, obs: Obs, key) -> jnp.ndarray:
    """The action whose PD target q + alpha a comes nearest this step's reference pose."""
    return toward(alpha, replay(targets, obs, key), obs)


def tracking_delta_controller(task: PullTask) -> Controller:
    """The expert drag through the action interface (deterministic, like ``tracking``)."""
    policy = functools.partial(increments, task.config.alpha)
    return Controller(TRACKING_DELTA, lambda deterministic: policy, jnp.asarray(drag_targets(task)),
                      key=TRACKING_DELTA)


def zero_residual(size: int, params, obs: Obs, key) -> jnp.ndarray:
    """A residual of zeros for each world of ``obs``."""
    return jnp.zeros(obs.state.shape[:-1] + (size,), jnp.float32)


def prior_controller(task: PullTask) -> Controller:
    """The task's expert prior alone (deterministic): a residual of zeros through the task's own step."""
    if not task.config.expert_prior:
        raise DragMeshError("prior needs a task with an expert prior (task.expert_prior: a residual method's run)")
    policy = functools.partial(zero_residual, task.action_size)
    return Controller(PRIOR, lambda deterministic: policy, jnp.zeros(()), key=(PRIOR, task.action_size))
