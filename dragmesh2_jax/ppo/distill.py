"""Teachers for distillation (``PPOConfig.distill_coef``): per-object specialists label the student's steps.

:class:`Teachers` holds one policy's parameters per object of the run (``policy_params``: the network and its own
observation normalisers), stacked on a leading object axis, and which objects have one (a run may be taught on a
stated subset of its objects: the others' steps carry no label). Every teacher is a policy of the student's network
on the student's observation, so its deterministic action on a world's observation is that step's label:
``label`` gathers each world's teacher by the world's object (``info["object"]`` of an object mix; 0 on one object)
and evaluates them all at once (a ``vmap`` over the worlds with their own parameters).
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
from flax import struct

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.task.protocol import Obs


@struct.dataclass
class Teachers:
    params: dict  # each object's teacher's policy parameters, on a leading object axis (zeros where none)
    taught: jnp.ndarray  # (objects,) 1.0 where the object has a teacher

    @classmethod
    def stack(cls, params: list[dict | None]) -> Teachers:
        """The teachers of a run's objects in their order, None where an object has none (at least one has)."""
        given = [p for p in params if p is not None]
        if not given:
            raise DragMeshError("distillation needs a teacher for at least one of the run's objects")
        zeros = jax.tree.map(jnp.zeros_like, given[0])
        return cls(params=jax.tree.map(lambda *xs: jnp.stack(xs), *[zeros if p is None else p for p in params]),
                   taught=jnp.asarray([p is not None for p in params], jnp.float32))

    @property
    def num_objects(self) -> int:
        return self.taught.shape[0]

    def label(self, policy: Callable, obs: Obs, objects: jnp.ndarray) -> tuple[jnp.ndarray, jnp.ndarray]:
        """(each world's label, 1.0 where its object has a teacher): ``policy(params, obs, key)``, the deterministic
        policy of the student's network, with each world's teacher's parameters on its observation; ``objects``:
        each world's object index."""
        mine = jax.tree.map(lambda p: p[objects], self.params)
        one = lambda p, o: policy(p, jax.tree.map(lambda x: x[None], o), None)[0]  # noqa: E731
        return jax.lax.stop_gradient(jax.vmap(one)(mine, obs)), self.taught[objects]


def world_objects(info: dict, worlds: int) -> jnp.ndarray:
    """Each world's object index: an object mix's ``info["object"]``, 0 on one object."""
    return info["object"] if "object" in info else jnp.zeros(worlds, jnp.int32)
