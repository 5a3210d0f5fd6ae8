"""MJX backend: ``mjx.step`` under ``lax.scan`` for the substeps. The MJX model is an argument (``data.model``),
not a constant of the program; a world's model fields (damping, friction, ...) are written into its copy of
the model inside the step, so nothing recompiles."""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import sys

import jax
import jax.numpy as jnp
import jaxlib
from flax import struct
from jax._src import xla_bridge

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics.base import Kinematics, Layout, Start, WorldFields, stack_states, take_state
from dragmesh2_jax.scene import SENSORS, Scene

_IMPORT_NOTES = io.StringIO()  # mujoco.mjx prints "Failed to import warp" when warp is absent: shown only for warp
with contextlib.redirect_stdout(_IMPORT_NOTES):
    from mujoco import mjx


FORCE_SLICE = slice(3 * len(SENSORS), None)  # the contact-load sensors: the last ones in sensordata


@struct.dataclass
class MjxData:
    model: mjx.Model
    bank: mjx.Data  # the start states, stacked
    layout: Layout


def avoid_lapack_deadlock() -> None:
    """Start JAX's CPU client with a one-thread intra-op pool when jaxlib < 0.11.

    jaxlib 0.10's CPU LAPACK kernels split a large batched Cholesky (MJX's Newton solver and implicitfast
    integrator, from about 5 worlds of the hand task) into chunks on XLA's intra-op pool and wait for them on a
    pool thread; two such calls at once on a 2-thread pool wait for each other forever (jax-ml/jax#36927, fixed
    in 0.11; RESULTS.md §1). The pool is sized from the CPU affinity when the client starts, so the client is
    started with one CPU and the affinity restored: the C engine's threads and everything else keep every core.
    It must run before anything starts JAX's backends (``MjxBackend`` and the CLI call it); when too late, it
    warns once."""
    version = tuple(int(x) for x in jaxlib.__version__.split(".")[:2])
    if version >= (0, 11) or not hasattr(os, "sched_setaffinity") or _accelerator_plugin():
        return
    cpus = os.sched_getaffinity(0)
    if len(cpus) == 1 or _DONE:
        return
    _DONE.append(True)
    if xla_bridge.backends_are_initialized():
        if jax.default_backend() == "cpu":
            print(f"warning: MJX on a CPU with jaxlib {jaxlib.__version__} can deadlock from about 5 worlds when JAX "
                  "started before the MJX backend was built (RESULTS.md §1); build it first, or run under "
                  "`taskset -c 0`", file=sys.stderr)
        return
    os.sched_setaffinity(0, {min(cpus)})
    try:
        jax.devices()
    finally:
        os.sched_setaffinity(0, cpus)


_DONE: list[bool] = []  # pinned (or warned) once per process


def _accelerator_plugin() -> bool:
    """Whether JAX may start an accelerator client here (a CUDA/ROCm plugin is installed and the platforms are
    not restricted to the CPU): then the pin is not ours to make (an accelerator's host threads need the cores)."""
    platforms = os.environ.get("JAX_PLATFORMS") or jax.config.jax_platforms or ""
    if platforms.strip().lower() == "cpu":
        return False
    return any(importlib.util.find_spec(m) is not None for m in ("jax_cuda12_plugin", "jax_cuda13_plugin",
                                                                "jax_rocm60_plugin", "jax_rocm7_plugin"))


class MjxBackend:
    name = "mjx"

    def __init__(self, scene: Scene, substeps: int, starts: list[Start], settle_substeps: int = 4,
                 impl: str = "jax"):
        avoid_lapack_deadlock()
        if impl == "warp" and importlib.util.find_spec("warp") is None:
            raise DragMeshError("MJX's Warp implementation needs warp-lang (pip install -e \".[warp]\"); "
                                f"mujoco.mjx said: {_IMPORT_NOTES.getvalue().strip() or 'nothing'}")
        self.scene, self.substeps, self.impl = scene, substeps, impl
        bank = stack_states([mjx.put_data(scene.model, scene.settled_state(hand_q, obj_q, settle_substeps),
                                          impl=impl) for hand_q, obj_q in starts])
        self.data = MjxData(model=mjx.put_model(scene.model, impl=impl), bank=bank, layout=Layout.of(scene))

    def signature(self) -> tuple:
        return self.name, self.substeps, self.impl

    def reset_state(self, data: MjxData, index) -> mjx.Data:
        return take_state(data.bank, index)

    def step(self, data: MjxData, ps: mjx.Data, ctrl, fields: WorldFields) -> mjx.Data:
        m = data.model.replace(**fields)
        ps = ps.replace(ctrl=ps.ctrl.at[data.layout.hand_actuators].set(ctrl))

        def body(d, _):
            return mjx.step(m, d), None

        ps, _ = jax.lax.scan(body, ps, None, length=self.substeps)
        return ps

    def kinematics(self, data: MjxData, ps: mjx.Data) -> Kinematics:
        L = data.layout
        R = ps.site_xmat[L.handle_site]
        return Kinematics(hand_q=ps.qpos[L.hand_qpos], hand_qd=ps.qvel[L.hand_dof],
                          obj_q=ps.qpos[L.target_qpos], obj_qd=ps.qvel[L.target_dof],
                          palm=ps.site_xpos[L.palm_site], handle_pos=ps.site_xpos[L.handle_site],
                          handle_rot=jnp.concatenate([R[:, 0], R[:, 1]]), force=ps.sensordata[FORCE_SLICE])
