"""C-engine backend: MuJoCo's multithreaded ``rollout`` over all worlds, called from inside the jitted step
through ``jax.pure_callback`` (``vmap_method="broadcast_all"``), so a vmapped step makes **one host call per
control step for the whole batch**. Each world has its own ``MjModel`` copy whose ``dof_damping`` and object
``geom_friction`` are written before the call (no recompilation, nothing shared between worlds).

The per-world state carried in JAX is (qpos, qvel, sensors): the callback is a pure function of its inputs,
so the same seed and thread count give the same results. (MuJoCo's solver warm start is not carried across
control steps; it changes iteration counts, not the converged contact solution.)
"""

from __future__ import annotations

import copy
import math
import os

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import rollout

from dragmesh2_jax.physics.base import Kinematics, Start, settled_reset, stack_states, take_state
from dragmesh2_jax.scene import FORCE_SIZE, SENSORS, Scene


@struct.dataclass
class CState:
    qpos: jnp.ndarray
    qvel: jnp.ndarray
    sensors: jnp.ndarray  # palm (3), handle pos (3), handle x axis (3), handle y axis (3), contact load (22)


class _HostStepper:
    """Host side: per-world models, one MjData per thread, state packing for ``rollout``."""

    def __init__(self, scene: Scene, substeps: int, nthread: int):
        self.scene, self.substeps = scene, substeps
        self.base = scene.model
        self.models: list[mujoco.MjModel] = []
        self.datas = [mujoco.MjData(self.base) for _ in range(max(1, nthread))]
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.nstate = mujoco.mj_stateSize(self.base, self.spec)
        m = self.base
        self.qpos_sl = slice(1, 1 + m.nq)  # FULLPHYSICS = time | qpos | qvel | act | ...
        self.qvel_sl = slice(1 + m.nq, 1 + m.nq + m.nv)
        self.friction0 = self.base.geom_friction[scene.ids.object_collision_geoms, 0].copy()

    def _world_models(self, n: int) -> list[mujoco.MjModel]:
        while len(self.models) < n:
            self.models.append(copy.copy(self.base))
        return self.models[:n]

    def __call__(self, qpos, qvel, ctrl, damping, friction):
        batch = qpos.shape[:-1]
        n = math.prod(batch)
        qpos, qvel = qpos.reshape(n, -1), qvel.reshape(n, -1)
        ctrl = ctrl.reshape(n, -1)
        damping, friction = np.broadcast_to(damping, batch).reshape(n), np.broadcast_to(friction, batch).reshape(n)
        ids = self.scene.ids
        models = self._world_models(n)
        og = ids.object_collision_geoms
        for i, m in enumerate(models):
            m.dof_damping[ids.target_dof] = damping[i]
            m.geom_friction[og, 0] = self.friction0 * friction[i]
        init = np.zeros((n, self.nstate))
        init[:, self.qpos_sl], init[:, self.qvel_sl] = qpos, qvel
        control = np.zeros((n, self.substeps, self.base.nu))
        control[:, :, ids.hand_actuators] = ctrl[:, None, :]
        state = np.empty((n, self.substeps, self.nstate))
        sensors = np.empty((n, self.substeps, self.base.nsensordata))
        rollout.rollout(models, self.datas, init, control, nstep=self.substeps, skip_checks=True, state=state,
                        sensordata=sensors)
        last = state[:, -1]
        out = (last[:, self.qpos_sl], last[:, self.qvel_sl], sensors[:, -1])
        return tuple(o.reshape(*batch, -1) for o in out)


class MujocoBackend:
    name = "mujoco"

    def __init__(self, scene: Scene, substeps: int, starts: list[Start], settle_substeps: int = 4,
                 nthread: int | None = None):
        self.scene, self.substeps = scene, substeps
        self.nthread = nthread or os.cpu_count() or 1
        self._host = _HostStepper(scene, substeps, self.nthread)
        ds = [settled_reset(scene, hand_q, obj_q, settle_substeps) for hand_q, obj_q in starts]
        self._bank = stack_states([CState(qpos=jnp.asarray(d.qpos), qvel=jnp.asarray(d.qvel),
                                          sensors=jnp.asarray(d.sensordata)) for d in ds])
        self._hand_qpos = jnp.asarray(scene.ids.hand_qpos)
        self._hand_dof = jnp.asarray(scene.ids.hand_dof)

    def reset_state(self, index) -> CState:
        return take_state(self._bank, index)

    def step(self, ps: CState, ctrl, damping, friction) -> CState:
        dt = ps.qpos.dtype
        shapes = (jax.ShapeDtypeStruct(ps.qpos.shape, dt), jax.ShapeDtypeStruct(ps.qvel.shape, dt),
                  jax.ShapeDtypeStruct(ps.sensors.shape, dt))

        def host(qpos, qvel, c, damp, fr):
            out = self._host(np.asarray(qpos, np.float64), np.asarray(qvel, np.float64), np.asarray(c, np.float64),
                             np.asarray(damp, np.float64), np.asarray(fr, np.float64))
            return tuple(np.asarray(o, dtype=dt) for o in out)

        qpos, qvel, sensors = jax.pure_callback(host, shapes, ps.qpos, ps.qvel, ctrl.astype(dt),
                                                jnp.asarray(damping, dt), jnp.asarray(friction, dt),
                                                vmap_method="broadcast_all")
        return CState(qpos=qpos, qvel=qvel, sensors=sensors)

    def kinematics(self, ps: CState) -> Kinematics:
        ids = self.scene.ids
        s, n = ps.sensors, 3 * len(SENSORS)
        return Kinematics(hand_q=ps.qpos[self._hand_qpos], hand_qd=ps.qvel[self._hand_dof],
                          obj_q=ps.qpos[ids.target_qpos], obj_qd=ps.qvel[ids.target_dof],
                          palm=s[0:3], handle_pos=s[3:6], handle_rot=s[6:12], force=s[n:n + FORCE_SIZE])
