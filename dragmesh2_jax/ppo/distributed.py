"""One run past one machine: data-parallel PPO over JAX's own multi-process runtime (``jax.distributed``).

Every process runs the same program over every device of every process (one global mesh, one axis,
``WORLD_AXIS``): the run's worlds are split over the devices, each device rolling out and learning from its own
worlds, and every reduction over the batch (gradients, the normalisers' statistics, the learning rate's KL, the
metrics, the reward's adaptive weights) is a collective over the axis (``epoch(..., axis=WORLD_AXIS)``), so every
device ends an epoch with the same parameters, as one process holding all the worlds on as many devices would.
No process pool of our own: JAX starts nothing, each host starts its own process (``initialize`` first).

  ``initialize(coordinator, num_processes, process_id)``   join the runtime (on CPU: gloo collectives)
  ``world_mesh()``                                          the global mesh over ``jax.devices()``
  ``place(mesh, data, ts)``                                 the task data and a train state as global arrays on it
  ``epoch_worlds(program, data, ts, mesh)``                 one epoch of the run, its worlds split over the mesh
  ``train_worlds(program, data, ts, epochs, on_epoch)``      ``ppo.train.train`` for one run so split (the CLI's
                                                            ``train --coordinator ...``: ``runs/session.py``)

Each process builds the same task data and the same initial state (the same seed); ``place`` keeps each process's
share of the worlds on its devices. Saving a state split over processes (its worlds) is left to the caller:
``gather`` brings every leaf to every process (the parameters and normalisers are replicated already).
"""

from __future__ import annotations

import functools

import jax
import numpy as np
from jax.experimental import multihost_utils

from dragmesh2_jax.ppo.train import WORLD_AXIS, NonFiniteLearning, TrainProgram, TrainState, epoch
from dragmesh2_jax.task.env import TaskData

P = jax.sharding.PartitionSpec
_JOINED: list[bool] = []  # whether this process joined the runtime (``initialize``)


def initialize(coordinator: str, num_processes: int, process_id: int) -> None:
    """Join the multi-process runtime (before anything else touches JAX's devices): ``coordinator`` is process 0's
    ``host:port``. On CPU the collectives go through gloo."""
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(coordinator_address=coordinator, num_processes=num_processes, process_id=process_id)
    _JOINED.append(True)


def joined() -> bool:
    """Whether this process joined the runtime: a run it trains splits its worlds over every process's devices (one
    process with several devices, joined alone, splits them over its own)."""
    return bool(_JOINED)


def writer() -> bool:
    """Whether this process writes what the run produces (process 0; every process computes it all)."""
    return jax.process_index() == 0


def world_mesh() -> jax.sharding.Mesh:
    """Every device of every process on the one axis the worlds split over."""
    return jax.sharding.Mesh(np.asarray(jax.devices()), (WORLD_AXIS,))


def data_specs(data: TaskData):
    """The task data's partition: replicated (an object's model, start bank and parameters: nothing per world)."""
    return jax.tree.map(lambda _: P(), data)


def state_specs(ts: TrainState):
    """The train state's partition: the worlds (every leaf of ``env_state``, leading axis) split, the rest (the
    parameters, optimiser, normalisers, rng, learning rate, adaptive weights) replicated."""
    return jax.tree.map(lambda _: P(), ts).replace(env_state=jax.tree.map(lambda _: P(WORLD_AXIS), ts.env_state))


def _global(x, sharding: jax.sharding.NamedSharding) -> jax.Array:
    """A global array from this process's full copy of ``x`` (each device takes its own block)."""
    host = np.asarray(x)
    return jax.make_array_from_callback(host.shape, sharding, lambda index: host[index])


def place(mesh: jax.sharding.Mesh, data: TaskData, ts: TrainState) -> tuple[TaskData, TrainState]:
    """``data`` and ``ts`` (each process's identical copy, e.g. ``init`` of the same seed) as global arrays on
    ``mesh``: the worlds split over its devices (the number of worlds a multiple of their count), the rest
    replicated."""
    n = mesh.devices.size
    if ts.env_state.reward.shape[0] % n:
        raise ValueError(f"{ts.env_state.reward.shape[0]} worlds do not split over {n} devices")
    put = lambda tree, specs: jax.tree.map(  # noqa: E731
        lambda x, spec: _global(x, jax.sharding.NamedSharding(mesh, spec)), tree, specs)
    return put(data, data_specs(data)), put(ts, state_specs(ts))


@functools.partial(jax.jit, static_argnums=(0, 3))
def epoch_worlds(program: TrainProgram, data: TaskData, ts: TrainState,
                 mesh: jax.sharding.Mesh) -> tuple[TrainState, dict]:
    """One epoch of one run (``ts`` and ``data`` placed by :func:`place`), its worlds split over ``mesh``: the new
    state (placed alike) and the epoch's metrics (replicated: the whole batch's)."""
    f = jax.shard_map(functools.partial(epoch, program, axis=WORLD_AXIS), mesh=mesh,
                      in_specs=(data_specs(data), state_specs(ts)), out_specs=(state_specs(ts), P()),
                      check_vma=False)
    return f(data, ts)


def train_worlds(program: TrainProgram, data: TaskData, ts: TrainState, epochs: int, on_epoch=None) -> TrainState:
    """``ppo.train.train`` for one run (``ts`` without a run axis: every process's identical copy) up to ``epochs``,
    its worlds split over the global mesh. ``on_epoch(ts, metrics)`` gets the state placed on the mesh (``gather``
    reads it whole: a collective, so every process calls it at the same epochs) and the epoch's metrics (the whole
    batch's, on every process) as host arrays with a run axis of one."""
    mesh = world_mesh()
    first = int(ts.epoch)
    data, ts = place(mesh, data, ts)
    for e in range(first + 1, epochs + 1):
        ts, m = epoch_worlds(program, data, ts, mesh)
        m = {k: np.asarray(v.addressable_data(0), np.float64)[None] for k, v in m.items()}
        program.task.check_overflow(int(m["overflow"].sum()), f"epoch {e}")
        if not np.all(np.isfinite(m["loss"])):
            raise NonFiniteLearning(e, m["loss"][0:1])
        if on_epoch is not None:
            on_epoch(ts, m)
    return ts


def gather(tree):
    """Every leaf of ``tree`` (global arrays, split over processes or not) as a host array on every process."""
    return jax.tree.map(lambda x: np.asarray(multihost_utils.process_allgather(x, tiled=True)), tree)
