"""C-engine backend: MuJoCo's ``rollout`` over all worlds on a pool of worker threads, called from inside the jitted
step through ``jax.pure_callback`` (``vmap_method="broadcast_all"``), so a vmapped step makes **one host call per
control step for the whole batch**. Each world has its own ``MjModel`` copy whose model fields (``WorldFields``:
damping, friction, any other) are written before the call (no recompilation, nothing shared between worlds).

The model is data here too: the program carries an integer handle to the object's host models (a registry
entry), so objects of the same structure share one compiled program, and a batch may even mix objects.

The per-world state carried in JAX is (qpos, qvel, sensors): the callback is a pure function of its inputs,
so the same seed and thread count give the same results. (MuJoCo's solver warm start is not carried across
control steps; it changes iteration counts, not the converged contact solution.)
"""

from __future__ import annotations

import copy
import itertools
import math
import os
import threading
import weakref
from concurrent.futures import ThreadPoolExecutor

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct
from mujoco import rollout

from dragmesh2_jax.physics.base import (
    Kinematics,
    Layout,
    Start,
    WorldFields,
    penetration,
    stack_states,
    take_state,
)
from dragmesh2_jax.scene import CONTACT_SLICE, FORCE_SLICE, Scene


@struct.dataclass
class CState:
    qpos: jnp.ndarray
    qvel: jnp.ndarray
    sensors: jnp.ndarray  # palm (3), handle pos (3), handle x, y axes (3 + 3), deepest contact (2), load (22)


@struct.dataclass
class CData:
    host: jnp.ndarray  # () int32: the object's entry in the host registry
    bank: CState  # the start states, stacked
    layout: Layout


class _HostStepper:
    """Host side of one object: per-world models, one MjData per worker thread, state packing for ``rollout``."""

    def __init__(self, scene: Scene, substeps: int, nthread: int):
        self.substeps, self.base, self.nthread = substeps, scene.model, nthread
        self.actuators = scene.ids.hand_actuators
        self.models: list[mujoco.MjModel] = []
        self.datas: dict[int, mujoco.MjData] = {}  # by worker: an MjData fits one model structure only
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.nstate = mujoco.mj_stateSize(self.base, self.spec)
        m = self.base
        self.qpos_sl = slice(1, 1 + m.nq)  # FULLPHYSICS = time | qpos | qvel | act | ...
        self.qvel_sl = slice(1 + m.nq, 1 + m.nq + m.nv)

    def world_models(self, n: int, fields: dict[str, np.ndarray]) -> list[mujoco.MjModel]:
        """This call's ``n`` worlds' models, their fields written (an object of a mix may have fewer geoms than the
        padded field)."""
        while len(self.models) < n:
            self.models.append(copy.copy(self.base))
        models = self.models[:n]
        for name, values in fields.items():
            for m, v in zip(models, values, strict=True):
                field = getattr(m, name)
                field[...] = v[tuple(slice(0, k) for k in field.shape)]
        return models

    def data(self, worker: int) -> mujoco.MjData:
        """Worker ``worker``'s MjData for this object."""
        if worker not in self.datas:
            self.datas[worker] = mujoco.MjData(self.base)
        return self.datas[worker]

    def run(self, runner: rollout.Rollout, datas: list[mujoco.MjData], models: list[mujoco.MjModel], qpos, qvel,
            ctrl):
        """Step these worlds with ``runner`` (its threads, one of ``datas`` each)."""
        n = qpos.shape[0]
        init = np.zeros((n, self.nstate))
        init[:, self.qpos_sl], init[:, self.qvel_sl] = qpos, qvel
        control = np.zeros((n, self.substeps, self.base.nu))
        control[:, :, self.actuators] = ctrl[:, None, :]
        state = np.empty((n, self.substeps, self.nstate))
        sensors = np.empty((n, self.substeps, self.base.nsensordata))
        runner.rollout(models, datas, init, control, nstep=self.substeps, skip_checks=True, state=state,
                       sensordata=sensors)
        last = state[:, -1]
        return last[:, self.qpos_sl], last[:, self.qvel_sl], sensors[:, -1]


_HOSTS: dict[int, _HostStepper] = {}  # the registry CData.host points into; an entry lives as long as its backend
_NEXT_HOST = itertools.count()
_LOCK = threading.Lock()  # shards of a sharded program may call in at once; the models are written per call

#: The process's CPUs at import: the callback may run on an XLA pool thread started on fewer (see
#: ``engines.avoid_lapack_deadlock``), and the workers must not inherit that.
_CPUS = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
#: Chunks per worker thread a mixed batch is cut into, so that objects of unequal cost balance across the threads.
CHUNKS_PER_THREAD = 4

_WORKER = threading.local()  # a worker's index and its single-threaded rollout
_WORKER_IDS = itertools.count()
_POOLS: dict[int, ThreadPoolExecutor] = {}
_ROLLOUTS: dict[int, rollout.Rollout] = {}


def _start_worker() -> None:
    if _CPUS is not None:
        os.sched_setaffinity(0, _CPUS)
    _WORKER.index, _WORKER.rollout = next(_WORKER_IDS), rollout.Rollout(nthread=0)


def _rollout(nthread: int) -> rollout.Rollout:
    """MuJoCo's threaded rollout over one object's worlds, its thread pool kept (started once, not on every call)."""
    if nthread not in _ROLLOUTS:
        _ROLLOUTS[nthread] = rollout.Rollout(nthread=nthread if nthread > 1 else 0)
    return _ROLLOUTS[nthread]


def _pool(nthread: int) -> ThreadPoolExecutor:
    """Worker threads for a batch that mixes objects: rollout's own pool takes one model structure per call, so each
    object's chunks run on a worker of this pool, single-threaded (rollout releases the GIL)."""
    if nthread not in _POOLS:
        _POOLS[nthread] = ThreadPoolExecutor(nthread, thread_name_prefix="mujoco-rollout", initializer=_start_worker)
    return _POOLS[nthread]


def _host_step(host, qpos, qvel, ctrl, fields):
    """The callback: any batch shape. One object's worlds step on rollout's thread pool; a batch that mixes objects is
    grouped by object, each group cut into chunks, all chunks on one pool of worker threads."""
    if _CPUS is not None:
        os.sched_setaffinity(0, _CPUS)  # rollout's threads inherit the calling thread's affinity
    batch = qpos.shape[:-1]
    n = math.prod(batch)
    flat = lambda x: np.asarray(x, np.float64).reshape(n, *x.shape[len(batch):])  # noqa: E731
    host = np.broadcast_to(host, batch).reshape(n)
    qpos, qvel, ctrl = flat(qpos), flat(qvel), flat(ctrl)
    fields = {k: flat(v) for k, v in fields.items()}
    hosts = {int(h): np.flatnonzero(host == h) for h in np.unique(host)}
    nthread = max(_HOSTS[h].nthread for h in hosts)
    with _LOCK:
        models = {h: _HOSTS[h].world_models(len(idx), {k: v[idx] for k, v in fields.items()})
                  for h, idx in hosts.items()}
        if len(hosts) == 1:
            (h, idx), = hosts.items()
            datas = [_HOSTS[h].data(w) for w in range(max(1, nthread))]
            chunks = [(idx, _HOSTS[h].run(_rollout(nthread), datas, models[h], qpos, qvel, ctrl))]
        else:
            size = max(1, -(-n // (nthread * CHUNKS_PER_THREAD)))
            parts = [(h, idx[a:a + size], models[h][a:a + size]) for h, idx in hosts.items()
                     for a in range(0, len(idx), size)]

            def run(part):
                h, idx, ms = part
                return _HOSTS[h].run(_WORKER.rollout, [_HOSTS[h].data(_WORKER.index)], ms, qpos[idx], qvel[idx],
                                     ctrl[idx])

            chunks = list(zip([idx for _, idx, _ in parts], _pool(nthread).map(run, parts), strict=True))
    out = [np.empty((n, r.shape[1])) for r in chunks[0][1]]
    for idx, res in chunks:
        for o, r in zip(out, res, strict=True):
            o[idx] = r
    return tuple(o.reshape(*batch, -1) for o in out)


class MujocoBackend:
    name = "mujoco"
    budget = None  # the C engine sizes its contacts and rows as it goes (its arena holds them)

    def __init__(self, scene: Scene, substeps: int, starts: list[Start], settle_substeps: int = 4,
                 nthread: int | None = None):
        self.scene, self.substeps = scene, substeps
        self.nthread = nthread or os.cpu_count() or 1
        host = next(_NEXT_HOST)
        _HOSTS[host] = _HostStepper(scene, substeps, self.nthread)
        weakref.finalize(self, _HOSTS.pop, host, None)
        ds = [scene.settled_state(hand_q, obj_q, settle_substeps) for hand_q, obj_q in starts]
        bank = stack_states([CState(qpos=jnp.asarray(d.qpos), qvel=jnp.asarray(d.qvel),
                                    sensors=jnp.asarray(d.sensordata)) for d in ds])
        self.data = CData(host=jnp.int32(host), bank=bank, layout=Layout.of(scene))

    def signature(self) -> tuple:
        return self.name, self.substeps, self.nthread

    def reset_state(self, data: CData, index) -> CState:
        return take_state(data.bank, index)

    def step(self, data: CData, ps: CState, ctrl, fields: WorldFields) -> CState:
        dt = ps.qpos.dtype
        shapes = (jax.ShapeDtypeStruct(ps.qpos.shape, dt), jax.ShapeDtypeStruct(ps.qvel.shape, dt),
                  jax.ShapeDtypeStruct(ps.sensors.shape, dt))

        def host(*args):
            return tuple(np.asarray(o, dtype=dt) for o in _host_step(*args))

        qpos, qvel, sensors = jax.pure_callback(host, shapes, data.host, ps.qpos, ps.qvel, ctrl.astype(dt),
                                                {k: jnp.asarray(v, dt) for k, v in fields.items()},
                                                vmap_method="broadcast_all")
        return CState(qpos=qpos, qvel=qvel, sensors=sensors)

    def overflow(self, data: CData, ps: CState) -> jnp.ndarray:
        return jnp.bool_(False)

    def sized(self, data: CData, worlds: int) -> CData:
        return data

    def kinematics(self, data: CData, ps: CState) -> Kinematics:
        L = data.layout
        s = ps.sensors
        return Kinematics(hand_q=ps.qpos[L.hand_qpos], hand_qd=ps.qvel[L.hand_dof],
                          obj_q=ps.qpos[L.target_qpos], obj_qd=ps.qvel[L.target_dof],
                          palm=s[0:3], handle_pos=s[3:6], handle_rot=s[6:12], force=s[FORCE_SLICE],
                          penetration=penetration(s[CONTACT_SLICE]))
