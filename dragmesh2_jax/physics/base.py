"""The physics backend interface the task is written against (one world; the task ``vmap``s it).

A backend owns an opaque per-world physics state (a pytree) and offers:
  * ``reset_state()``   the post-settle expert grasp state (identical on every backend: it is computed once
                        on the host with the C engine, see :func:`settled_reset`);
  * ``step(ps, ctrl, damping, friction)``  n substeps with hand PD targets ``ctrl`` (51,), the target joint's
                        viscous damping (absolute) and a friction scale for object geoms;
  * ``kinematics(ps)``  the few quantities the task reads: hand q/qd (51), target-joint q/qd, palm centre,
                        handle centre and handle axes (long, normal), world frame. Positions are those MuJoCo
                        computed at the start of the last substep (as ``mj_step`` leaves ``site_xpos``).
"""

from __future__ import annotations

from typing import Any, Protocol

import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct

from dragmesh2_jax.scene import Scene


@struct.dataclass
class Kinematics:
    hand_q: jnp.ndarray  # (51,)
    hand_qd: jnp.ndarray  # (51,)
    obj_q: jnp.ndarray  # ()
    obj_qd: jnp.ndarray  # ()
    palm: jnp.ndarray  # (3,) m
    handle_pos: jnp.ndarray  # (3,) m
    handle_rot: jnp.ndarray  # (6,) handle long axis and outward normal (unit vectors)


class Backend(Protocol):
    name: str
    scene: Scene
    substeps: int

    def reset_state(self) -> Any: ...

    def step(self, ps: Any, ctrl: jnp.ndarray, damping: jnp.ndarray, friction: jnp.ndarray) -> Any: ...

    def kinematics(self, ps: Any) -> Kinematics: ...


def settled_reset(scene: Scene, hand_q: np.ndarray, obj_q: float, settle_substeps: int) -> mujoco.MjData:
    """The expert grasp state after ``settle_substeps`` physics steps from rest with PD target = hand pose
    (facts §4: 4 settle steps), at nominal damping. Returned MjData is what every backend resets to."""
    m, ids = scene.model, scene.ids
    d = mujoco.MjData(m)
    d.qpos[ids.hand_qpos] = np.clip(hand_q, ids.hand_range[:, 0], ids.hand_range[:, 1])
    d.qpos[ids.target_qpos] = obj_q
    d.ctrl[ids.hand_actuators] = d.qpos[ids.hand_qpos]
    mujoco.mj_forward(m, d)
    for _ in range(settle_substeps):
        mujoco.mj_step(m, d)
    return d


def kinematics_from_mjdata(scene: Scene, d: mujoco.MjData) -> dict[str, np.ndarray]:
    ids = scene.ids
    R = d.site_xmat[ids.handle_site].reshape(3, 3)
    return {"hand_q": d.qpos[ids.hand_qpos].copy(), "hand_qd": d.qvel[ids.hand_dof].copy(),
            "obj_q": np.asarray(d.qpos[ids.target_qpos]), "obj_qd": np.asarray(d.qvel[ids.target_dof]),
            "palm": d.site_xpos[ids.palm_site].copy(), "handle_pos": d.site_xpos[ids.handle_site].copy(),
            "handle_rot": np.concatenate([R[:, 0], R[:, 1]])}
