"""One process of ``test_distributed.py``: the tiny PICA run's first epochs with its worlds split over a global mesh.

``python -m tests.ppo.distributed_worker OUT EPOCHS [COORDINATOR NUM_PROCESSES PROCESS_ID]``: with a coordinator,
the process joins ``jax.distributed`` (gloo on CPU) and the mesh spans every process's devices; without, the mesh is
this process's devices (``XLA_FLAGS=--xla_force_host_platform_device_count=2`` gives two). Process 0 writes the
initial and final parameters, every epoch's metrics and the final worlds' states to ``OUT`` (.npz).
"""

from __future__ import annotations

import sys


def merged_stats(mesh) -> dict:
    """A batch's statistics merged over the mesh's shards (``RunningStats.update`` with the axis) and the same batch's
    in one piece, from non-zero statistics: the test asserts they agree."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from dragmesh2_jax.policies.normalize import RunningStats
    from dragmesh2_jax.ppo.train import WORLD_AXIS

    P = jax.sharding.PartitionSpec
    n = mesh.devices.size
    x = np.random.default_rng(0).normal(3.0, 2.0, (8, 4 * n, 5)).astype(np.float32)  # (steps, worlds, size)
    x[:, : 4 * n // 2] += 5.0  # the shards' means differ
    stats = RunningStats(jnp.full(5, 1.0), jnp.full(5, 2.0), jnp.float32(10.0))
    whole = stats.update(jnp.asarray(x))
    split = P(None, WORLD_AXIS)
    sharded = jax.jit(jax.shard_map(lambda s, x: s.update(x, WORLD_AXIS), mesh=mesh, in_specs=(P(), split),
                                    out_specs=P(), check_vma=False))
    xs = jax.make_array_from_callback(x.shape, jax.sharding.NamedSharding(mesh, split), lambda i: x[i])
    merged = sharded(stats, xs)
    return {f"{name}_{k}": np.asarray(getattr(s, k)) for name, s in (("whole", whole), ("merged", merged))
            for k in ("mean", "var", "count")}


def main(argv: list[str]) -> None:
    out, epochs = argv[0], int(argv[1])
    from dragmesh2_jax.ppo import distributed

    if len(argv) > 2:  # before anything touches a device
        distributed.initialize(argv[2], int(argv[3]), int(argv[4]))
    import jax
    import numpy as np

    from dragmesh2_jax.ppo.train import init_jit
    from tests.conftest import tiny_program

    program = tiny_program()
    data = program.data()
    ts = init_jit(program, data, jax.random.PRNGKey(0))
    first = jax.tree.leaves(jax.device_get(ts.params))
    mesh = distributed.world_mesh()
    data, ts = distributed.place(mesh, data, ts)
    saved = {}
    for e in range(epochs):
        ts, metrics = distributed.epoch_worlds(program, data, ts, mesh)
        saved |= {f"metric{e}_{k}": np.asarray(v) for k, v in metrics.items()}
    params = jax.tree.leaves(ts.params)  # replicated: every process holds them whole
    saved |= {f"param{i}": np.asarray(p) for i, p in enumerate(params)}
    saved |= {f"initial{i}": np.asarray(p) for i, p in enumerate(first)}
    saved |= {f"stats_{k}": np.asarray(getattr(ts.state_stats, k)) for k in ("mean", "var", "count")}
    saved["lr"], saved["devices"] = np.asarray(ts.lr), np.int32(mesh.devices.size)
    worlds = distributed.gather(ts.env_state)  # every world, from every process
    saved |= {"worlds_qpos": worlds.physics.qpos, "worlds_reward": worlds.reward}
    saved |= merged_stats(mesh)
    if jax.process_index() == 0:
        np.savez(out, **saved)


if __name__ == "__main__":
    main(sys.argv[1:])
