"""The policy's state vector s_t, one per ``TaskConfig.observation`` (both float32, of a fixed size per config).

``paper`` (120, the paper's s_t): hand q (51), hand qd (51), handle position (3), handle long axis and outward normal
(6), palm-to-handle vector (3), distance d (1), object q and qd (2), phi = [progress, (q_done - q) / Delta, Delta] (3).
Its world positions and raw joint values tie a policy to the object it was trained on.

``handle`` (110: an observation that transfers across objects): everything in the handle's current frame
(columns: long axis, outward normal, their cross product; it moves with the part) or in task units, nothing that
identifies the object. A bar's long axis is a line, not a direction: an importer may give it either way (GAPartNet's
doors point it up, the procedural ones down), and the policy, which acts along the world's axes, would read one door as
another turned half a turn about the handle's normal (hinged on the other side). So its direction is the object's
(``long_axis_sign``, fixed at the closed pose: it does not flip as the part turns): away from ``LONG_AXIS_AWAY``, i.e.
down for an upright bar, along -y for a level one. The vector: finger q and qd (45 + 45, already in the hand's own
frame), the palm centre relative to the handle centre (3), the wrist rotation as its x and y axes (6), the palm's
linear velocity (3), the joint axis (3), the hinge radius (1, 0 for a slide), the joint type (1: revolute) and the
part's state [progress, (q_done - q) / Delta, qd / Delta] (3). No force or touch sensing (``TaskConfig.force_obs``
appends the contact load to either).
"""

from __future__ import annotations

from typing import Protocol

import jax.numpy as jnp
import mujoco
import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL
from dragmesh2_jax.physics.base import Kinematics
from dragmesh2_jax.scene import FORCE_SIZE, Scene
from dragmesh2_jax.task.config import TaskConfig


class TaskParams(Protocol):
    """What the state vectors read of ``env.TaskParams`` (env imports this module, so not that class itself)."""

    q_start: jnp.ndarray
    q_goal: jnp.ndarray
    q_done: jnp.ndarray
    revolute: jnp.ndarray
    joint_axis: jnp.ndarray
    hinge_radius: jnp.ndarray
    long_sign: jnp.ndarray

#: s_t's size per observation, without the contact load (the hand's 51 DoFs: 6 wrist + 45 finger).
STATE_SIZES = {"paper": 120, "handle": 110}
STATE_SIZE = STATE_SIZES["paper"]
#: A handle's long axis points away from this world direction (an upright bar down, a level one along -y).
LONG_AXIS_AWAY = np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0)


def state_size(config: TaskConfig) -> int:
    """The size of s_t under ``config`` (its observation, plus the contact load with ``force_obs``)."""
    return STATE_SIZES[config.observation] + (FORCE_SIZE if config.force_obs else 0)


def long_axis_sign(long: np.ndarray) -> float:
    """+1 or -1: the direction of a handle's long axis ``long`` (world frame) that points away from
    ``LONG_AXIS_AWAY`` (kept when perpendicular to it)."""
    return -1.0 if float(np.asarray(long) @ LONG_AXIS_AWAY) > 0 else 1.0


def joint_geometry(scene: Scene) -> tuple[np.ndarray, float, float]:
    """The target joint's axis in the handle's frame (unit), the hinge radius (m, the handle centre's distance from
    the axis line; 0 for a slide) and the long axis's sign (``long_axis_sign``), at the closed pose. They stay
    constant as the part moves: the handle turns about the hinge axis or slides along the slide's, so the host
    computes them once per object."""
    m, d = scene.model, mujoco.MjData(scene.model)
    mujoco.mj_kinematics(m, d)
    joint = m.dof_jntid[scene.ids.target_dof]
    axis, anchor = d.xaxis[joint], d.xanchor[joint]
    centre, frame = d.site_xpos[scene.ids.handle_site], d.site_xmat[scene.ids.handle_site].reshape(3, 3)
    arm = centre - anchor
    radius = float(np.linalg.norm(arm - (arm @ axis) * axis)) if scene.ids.target_is_revolute else 0.0
    sign = long_axis_sign(frame[:, 0])
    return frame.T @ axis * np.array([sign, 1.0, sign]), radius, sign  # the long axis and the third turn with it


def phi(params: TaskParams, q: jnp.ndarray) -> jnp.ndarray:
    """[progress p_t = max(0, (q - q_start) / Delta) (paper eq. progress), (q_done - q) / Delta, Delta]."""
    delta = jnp.maximum(params.q_goal - params.q_start, 1e-6)
    return jnp.stack([jnp.maximum(0.0, (q - params.q_start) / delta), (params.q_done - q) / delta, delta])


def load(k: Kinematics) -> jnp.ndarray:
    """f_t: the contact-load sensors, signed log1p (N, N m), so that a grip and a yank fit one scale."""
    return (jnp.sign(k.force) * jnp.log1p(jnp.abs(k.force))).astype(jnp.float32)


def _rot(axis: int, angle: jnp.ndarray) -> jnp.ndarray:
    c, s = jnp.cos(angle), jnp.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    return jnp.eye(3).at[i, i].set(c).at[j, j].set(c).at[i, j].set(-s).at[j, i].set(s)


def _wrist(k: Kinematics) -> tuple[jnp.ndarray, jnp.ndarray]:
    """The wrist's rotation R = Rx(q3) Ry(q4) Rz(q5) (``assets/hand.py``) and the palm centre's linear velocity, both
    in the world frame. The virtual joints are chained on the wrist body, so each hinge turns about its axis as
    rotated by the hinges before it, and the palm moves with the slides plus omega x (palm - wrist origin)."""
    q, qd = k.hand_q[:NUM_VIRTUAL], k.hand_qd[:NUM_VIRTUAL]
    rx, ry = _rot(0, q[3]), _rot(1, q[4])
    rxy = rx @ ry
    omega = qd[3] * jnp.eye(3)[0] + qd[4] * rx[:, 1] + qd[5] * rxy[:, 2]
    return rxy @ _rot(2, q[5]), qd[:3] + jnp.cross(omega, k.palm - q[:3])


def paper_state(k: Kinematics, params: TaskParams) -> jnp.ndarray:
    rel = k.handle_pos - k.palm
    return jnp.concatenate([k.hand_q, k.hand_qd, k.handle_pos, k.handle_rot, rel, jnp.linalg.norm(rel)[None],
                            k.obj_q[None], k.obj_qd[None], phi(params, k.obj_q)])


def handle_state(k: Kinematics, params: TaskParams) -> jnp.ndarray:
    long, normal = params.long_sign * k.handle_rot[:3], k.handle_rot[3:]
    frame = jnp.stack([long, normal, jnp.cross(long, normal)])  # rows: world -> handle frame
    rot, palm_v = _wrist(k)
    progress, left, delta = phi(params, k.obj_q)
    part = jnp.stack([progress, left, k.obj_qd / delta])
    return jnp.concatenate([k.hand_q[NUM_VIRTUAL:], k.hand_qd[NUM_VIRTUAL:], frame @ (k.palm - k.handle_pos),
                            (frame @ rot[:, :2]).T.reshape(6), frame @ palm_v, params.joint_axis,
                            params.hinge_radius[None], params.revolute.astype(jnp.float32)[None], part])


def state_obs(config: TaskConfig, k: Kinematics, params: TaskParams) -> jnp.ndarray:
    """s_t under ``config``: its observation's vector, then the contact load with ``force_obs``."""
    state = (handle_state if config.observation == "handle" else paper_state)(k, params)
    parts = [state, load(k)] if config.force_obs else [state]
    return jnp.concatenate(parts).astype(jnp.float32)
