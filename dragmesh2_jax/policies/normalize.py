"""Running mean / variance (Welford / parallel algorithm) for observation and aux-target normalisation."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class RunningStats:
    mean: jnp.ndarray
    var: jnp.ndarray
    count: jnp.ndarray

    @classmethod
    def create(cls, size: int) -> RunningStats:
        # typed, not weak: a restored checkpoint's statistics then match a fresh run's, and resuming in the same
        # process reuses the compiled epoch
        return cls(jnp.zeros(size, jnp.float32), jnp.ones(size, jnp.float32), jnp.asarray(1e-4, jnp.float32))

    def update(self, x: jnp.ndarray, axis: str | None = None) -> RunningStats:
        """Merge a batch (..., size) into the statistics. ``axis``: a mesh axis the batch is split over (inside
        ``shard_map``, equal shards): the shards' moments are merged first (the global mean, and the global variance
        as the mean of each shard's variance plus its mean's squared offset), so every shard holds the same
        statistics, those of the whole batch."""
        x = x.reshape(-1, x.shape[-1])
        n = x.shape[0]
        bm, bv = x.mean(0), x.var(0)
        if axis is not None:
            local = bm
            bm = jax.lax.pmean(local, axis)
            bv = jax.lax.pmean(bv + (local - bm) ** 2, axis)
            n = n * jax.lax.axis_size(axis)
        tot = self.count + n
        delta = bm - self.mean
        mean = self.mean + delta * n / tot
        m2 = self.var * self.count + bv * n + delta**2 * self.count * n / tot
        return RunningStats(mean, m2 / tot, tot)

    def normalize(self, x: jnp.ndarray, clip: float = 5.0) -> jnp.ndarray:
        return jnp.clip((x - self.mean) / jnp.sqrt(self.var + 1e-5), -clip, clip)
