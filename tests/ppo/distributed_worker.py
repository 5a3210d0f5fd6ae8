"""One process of ``test_distributed.py``: a batch's normaliser statistics merged over the shards of a mesh of this
process's devices (``XLA_FLAGS=--xla_force_host_platform_device_count=2`` gives two) and the same batch's in one
piece, written to OUT (.npz). ``python -m tests.ppo.distributed_worker OUT``.
"""

from __future__ import annotations

import sys


def main(argv: list[str]) -> None:
    import jax
    import jax.numpy as jnp
    import numpy as np

    from dragmesh2_jax.policies.normalize import RunningStats
    from dragmesh2_jax.ppo import distributed
    from dragmesh2_jax.ppo.train import WORLD_AXIS

    mesh = distributed.world_mesh()
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
    np.savez(argv[0], devices=np.int32(n), **{f"{name}_{k}": np.asarray(getattr(s, k))
                                              for name, s in (("whole", whole), ("merged", merged))
                                              for k in ("mean", "var", "count")})


if __name__ == "__main__":
    main(sys.argv[1:])
