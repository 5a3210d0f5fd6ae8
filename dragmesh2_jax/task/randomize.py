"""Domain randomisation as data, in MuJoCo Playground's ``randomize.py`` manner: each world draws multipliers of
model fields at reset, and the physics backends write that world's values of those fields before it steps (the
``(model, in_axes)`` pattern, on both engines).

One :class:`Randomizer` per randomised field: its multiplier's name (kept in the world's info and given to a
privileged critic), the ``MjModel`` field it changes, the ``TaskConfig`` range it is drawn from (``None``: fixed at
1) and how the multiplier changes the nominal field. Randomising another field (``body_mass``,
``actuator_gainprm``, ...) is one more entry of :data:`RANDOMIZERS`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from dragmesh2_jax.physics.base import Layout, WorldFields
from dragmesh2_jax.task.config import TaskConfig


@dataclass(frozen=True)
class Randomizer:
    name: str  # the multiplier's name
    field: str  # the MjModel field it changes
    range: Callable[[TaskConfig], tuple[float, float] | None]  # where it is drawn from (None: 1)
    apply: Callable[[jnp.ndarray, jnp.ndarray, jnp.ndarray, Layout], jnp.ndarray]  # (nominal, x, damping, layout)
    log: Callable[[TaskConfig], bool] = lambda c: False  # drawn log-uniform over its range (else uniform)


RANDOMIZERS = (
    # the target joint's damping: nominal x multiplier (paper §3.2.3; the reference's drand ranges)
    Randomizer("damping_scale", "dof_damping", lambda c: c.damping_range,
               lambda f, x, damping, L: f.at[L.target_dof].set(damping * x), lambda c: c.damping_log),
    # the sliding friction of the object's colliding geoms (off in the paper)
    Randomizer("friction_scale", "geom_friction", lambda c: c.friction_range,
               lambda f, x, damping, L: f.at[:, 0].multiply(jnp.where(L.object_geoms, x, 1.0))),
)
#: The model fields each world has its own value of.
FIELDS = tuple(r.field for r in RANDOMIZERS)
DAMPING = RANDOMIZERS[0].name  # the multiplier an evaluation cell fixes


def sample(key: jax.Array, config: TaskConfig) -> dict[str, jnp.ndarray]:
    """One world's multipliers, uniform (or log-uniform) over each randomizer's range."""
    out = {}
    for r, k in zip(RANDOMIZERS, jax.random.split(key, len(RANDOMIZERS)), strict=True):
        rng = r.range(config)
        if rng is None:
            out[r.name] = jnp.float32(1.0)
        elif r.log(config):
            out[r.name] = jnp.exp(jax.random.uniform(k, (), minval=jnp.log(rng[0]), maxval=jnp.log(rng[1])))
        else:
            out[r.name] = jax.random.uniform(k, (), minval=rng[0], maxval=rng[1])
    return out


def world_fields(scales: dict, nominal: WorldFields, damping: jnp.ndarray, layout: Layout) -> WorldFields:
    """The world's model fields: each nominal field changed by its multiplier (``damping``: the nominal
    target-joint damping)."""
    return {r.field: r.apply(nominal[r.field], scales[r.name], damping, layout) for r in RANDOMIZERS}


def privileged(scales: dict) -> jnp.ndarray:
    """The multipliers as a privileged observation, in the order of :data:`RANDOMIZERS`."""
    return jnp.stack([scales[r.name] for r in RANDOMIZERS])
