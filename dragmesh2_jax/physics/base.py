"""The physics backend interface the task is written against (one world; the task ``vmap``s it).

The model is data, not a constant of the compiled program: a backend's ``data`` (a pytree: the MJX model or a
handle to the C engine's host models, the bank of start states, the :class:`Layout` of the scene) is an argument
of every function, so objects of the same model structure share one compiled program. A backend offers:
  * ``reset_state(data, i)``  the i-th post-settle start state: the expert grasp, or one of a bank of perturbed
                        expert grasps (identical on every backend: each is computed once on the host with the
                        C engine, see :meth:`Scene.settled_state`);
  * ``step(data, ps, ctrl, fields)``  n substeps with hand PD targets ``ctrl`` (51,) and this world's values of
                        any model fields (:data:`WorldFields`, e.g. ``dof_damping``, ``geom_friction``,
                        ``body_mass``): the Playground ``(model, in_axes)`` pattern, on both engines;
  * ``kinematics(data, ps)``  the few quantities the task reads: hand q/qd (51), target-joint q/qd, palm centre,
                        handle centre and handle axes (long, normal), world frame, the contact-load sensors
                        (wrist force/torque, palm and phalanx normal forces) and the deepest hand-object
                        penetration. Positions and sensors are those
                        MuJoCo computed at the start of the last substep (as ``mj_step`` leaves them);
  * ``overflow(data, ps)``  whether the world needed more contact or constraint room than the engine reserved
                        (``physics/contacts.py``): the task reports it, the trainer and evaluator stop on it;
  * ``sized(data, worlds)``  ``data`` for a batch of that many worlds (an engine whose buffers the batch shares
                        sizes them; the others return ``data``).
An engine whose state has fields the batch shares (MJX-Warp's contact buffer) gives its state a
``where(done, other)`` that keeps them (``mjx.Data.where``; ``task.protocol.where`` merges states by it).
"""

from __future__ import annotations

from typing import Any, Protocol

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dragmesh2_jax.scene import Scene


@struct.dataclass
class Kinematics:
    hand_q: jnp.ndarray  # (51,)
    hand_qd: jnp.ndarray  # (51,)
    obj_q: jnp.ndarray  # ()
    obj_qd: jnp.ndarray  # ()
    palm: jnp.ndarray  # (3,) m
    handle_pos: jnp.ndarray  # (3,) m
    handle_rot: jnp.ndarray  # (6,) handle long axis and outward normal (unit vectors)
    force: jnp.ndarray  # (FORCE_SIZE,) wrist force (3, N) and torque (3, N m), palm + 15 phalanx touch (16, N)
    penetration: jnp.ndarray  # () m: how deep the hand is in the object (0 without contact)


def penetration(contact: jnp.ndarray) -> jnp.ndarray:
    """The deepest penetration (m, >= 0) from the contact sensor's (contacts, signed distance of the deepest)."""
    return jnp.where(contact[0] > 0, jnp.maximum(-contact[1], 0.0), 0.0)


#: Per-world values of model fields, by ``MjModel`` field name, each of the field's full shape.
WorldFields = dict[str, jnp.ndarray]


@struct.dataclass
class Layout:
    """Where the task's quantities live in one object's compiled model: data, so that objects of the same
    structure (whatever their indices) run through one program."""

    hand_qpos: jnp.ndarray  # (51,) qpos addresses, action order
    hand_dof: jnp.ndarray  # (51,) dof addresses
    hand_actuators: jnp.ndarray  # (51,)
    target_qpos: jnp.ndarray  # ()
    target_dof: jnp.ndarray  # ()
    palm_site: jnp.ndarray  # ()
    handle_site: jnp.ndarray  # ()
    object_geoms: jnp.ndarray  # (ngeom,) bool: the object geoms that collide (friction randomisation)

    @classmethod
    def of(cls, scene: Scene) -> Layout:
        i = scene.ids
        geoms = np.zeros(scene.model.ngeom, bool)
        geoms[i.object_collision_geoms] = True
        return cls(*(jnp.asarray(x, jnp.int32) for x in (i.hand_qpos, i.hand_dof, i.hand_actuators, i.target_qpos,
                                                         i.target_dof, i.palm_site, i.handle_site)),
                   object_geoms=jnp.asarray(geoms))


class Backend(Protocol):
    name: str
    scene: Scene
    substeps: int
    data: Any  # this scene's backend data (a pytree)
    budget: Any  # the contact budget of an engine with static buffers (physics/contacts.py), else None

    def signature(self) -> tuple: ...  # what besides ``data`` the compiled program depends on

    def reset_state(self, data: Any, index: jnp.ndarray) -> Any: ...

    def step(self, data: Any, ps: Any, ctrl: jnp.ndarray, fields: WorldFields) -> Any: ...

    def kinematics(self, data: Any, ps: Any) -> Kinematics: ...

    def overflow(self, data: Any, ps: Any) -> jnp.ndarray: ...

    def sized(self, data: Any, worlds: int) -> Any: ...


#: A start state: (hand q (51), target-joint q), written at rest and settled (the expert grasp, or a perturbed one).
Start = tuple[np.ndarray, float]


def stack_states(states: list) -> Any:
    """A bank of per-world states (pytrees) stacked on a leading axis."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *states)


def take_state(bank: Any, index: jnp.ndarray) -> Any:
    return jax.tree.map(lambda x: x[index], bank)
