"""MJX backend: ``mjx.step`` under ``lax.scan`` for the substeps; per-world damping and friction are written
into the (per-world) model's ``dof_damping`` / ``geom_friction`` inside the step, so nothing recompiles."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from mujoco import mjx

from dragmesh2_jax.physics.base import Kinematics, Start, settled_reset, stack_states, take_state
from dragmesh2_jax.scene import FORCE_SIZE, SENSORS, Scene


def warn_cpu_batch(num_worlds: int) -> None:
    """MJX on a CPU deadlocked inside XLA for >= 16 vmapped worlds on the development machine (jax 0.10.2, 2 cores;
    RESULTS.md §1). Say so before it happens; the C-engine backend is the right one on a CPU anyway."""
    import sys

    if num_worlds >= 16 and jax.default_backend() == "cpu":
        print(f"warning: MJX with {num_worlds} worlds on a CPU has hung inside XLA on some machines (RESULTS.md); "
              "use --backend mujoco on a CPU", file=sys.stderr)


class MjxBackend:
    name = "mjx"

    def __init__(self, scene: Scene, substeps: int, starts: list[Start], settle_substeps: int = 4,
                 impl: str = "jax"):
        self.scene, self.substeps, self.impl = scene, substeps, impl
        self.model = mjx.put_model(scene.model, impl=impl)
        self._bank = stack_states([mjx.put_data(scene.model, settled_reset(scene, hand_q, obj_q, settle_substeps),
                                                impl=impl) for hand_q, obj_q in starts])
        ids = scene.ids
        self._hand_qpos, self._hand_dof = jnp.asarray(ids.hand_qpos), jnp.asarray(ids.hand_dof)
        self._act = jnp.asarray(ids.hand_actuators)
        self._obj_geoms = jnp.asarray(ids.object_collision_geoms)
        self._friction0 = jnp.asarray(scene.model.geom_friction)
        self._force = slice(3 * len(SENSORS), 3 * len(SENSORS) + FORCE_SIZE)

    def reset_state(self, index) -> mjx.Data:
        return take_state(self._bank, index)

    def step(self, ps: mjx.Data, ctrl, damping, friction) -> mjx.Data:
        ids = self.scene.ids
        m = self.model
        fr = self._friction0.at[self._obj_geoms, 0].multiply(friction)
        m = m.replace(dof_damping=m.dof_damping.at[ids.target_dof].set(damping), geom_friction=fr)
        ps = ps.replace(ctrl=ps.ctrl.at[self._act].set(ctrl))

        def body(d, _):
            return mjx.step(m, d), None

        ps, _ = jax.lax.scan(body, ps, None, length=self.substeps)
        return ps

    def kinematics(self, ps: mjx.Data) -> Kinematics:
        ids = self.scene.ids
        R = ps.site_xmat[ids.handle_site]
        return Kinematics(hand_q=ps.qpos[self._hand_qpos], hand_qd=ps.qvel[self._hand_dof],
                          obj_q=ps.qpos[ids.target_qpos], obj_qd=ps.qvel[ids.target_dof],
                          palm=ps.site_xpos[ids.palm_site], handle_pos=ps.site_xpos[ids.handle_site],
                          handle_rot=jnp.concatenate([R[:, 0], R[:, 1]]),
                          force=ps.sensordata[self._force])
