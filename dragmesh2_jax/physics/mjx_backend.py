"""MJX backend: ``mjx.step`` under ``lax.scan`` for the substeps, in either of MJX's implementations (``jax``: XLA
programs; ``warp``: MuJoCo Warp's kernels through JAX's FFI, which also run on a CPU). The MJX model is an argument
(``data.model``), not a constant of the program; a world's model fields (damping, friction, ...) are written into its
copy of the model inside the step, so nothing recompiles.

Buffers (``physics/contacts.py``): MJX-JAX keeps ``budget.contacts`` contact slots per world (its
``max_contact_points``), MJX-Warp one contact buffer of ``budget.contacts`` per world for the whole batch
(``naconmax``) and ``budget.constraints`` rows per world (``njmax``). Warp's state mixes per-world fields with fields
the batch shares (its contact buffer): a bank of starts stacks only the per-world ones, :meth:`MjxBackend.sized` gives
the shared ones the batch's size, and states merge with ``mjx.Data.where``, which keeps them.
"""

from __future__ import annotations

import contextlib
import copy
import importlib.util
import io

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from flax import struct

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics.base import Kinematics, Layout, Start, WorldFields, penetration
from dragmesh2_jax.physics.batch import map_batched, shared
from dragmesh2_jax.physics.contacts import ContactBudget, overflow_message
from dragmesh2_jax.physics.engines import avoid_lapack_deadlock, require_impl
from dragmesh2_jax.scene import CONTACT_SLICE, FORCE_SLICE, Scene, compile_scene

if importlib.util.find_spec("warp") is not None:  # MJX's Warp implementation (the ``warp`` extra)
    import warp

    warp.config.log_level = warp.LOG_WARNING  # before it starts: its start-up lines go to stdout, with a command's JSON

with contextlib.redirect_stdout(io.StringIO()):  # mujoco.mjx prints "Failed to import warp" when warp is absent
    from mujoco import mjx
    from mujoco.mjx._src.collision_driver import make_condim


#: MuJoCo Warp's overflow bits (``OverflowType``) that mean a buffer was too small: nefc > njmax (1), njmax_nnz (2),
#: broadphase (4), narrowphase (8) and CCD (16) buffers. Solver iteration limits (512, 1024) are not overflows.
WARP_BUFFER_OVERFLOW = 0b11111


@struct.dataclass
class MjxData:
    model: mjx.Model
    bank: mjx.Data  # the start states: per-world fields stacked, fields the batch shares (Warp's contacts) once
    layout: Layout


def candidates(model: mujoco.MjModel) -> int:
    """The contacts per world MJX-JAX reserves for ``model`` without a cap (every pair's most)."""
    return len(make_condim(model))


def _bank(starts: list[mjx.Data] | mjx.Data, sized: mjx.Data) -> mjx.Data:
    """A bank of start states: the per-world leaves of ``starts`` (states to stack, or a bank already stacked), the
    leaves the batch shares and the static fields (Warp's buffer sizes) ``sized``'s."""
    if isinstance(starts, list):
        starts = jax.tree.map(lambda *xs: jnp.stack(xs), *starts)
    template, treedef = jax.tree_util.tree_flatten_with_path(sized)
    own = jax.tree_util.tree_leaves(starts)
    return jax.tree_util.tree_unflatten(treedef, [y if shared(path) else x
                                                  for (path, y), x in zip(template, own, strict=True)])


class MjxBackend:
    name = "mjx"

    def __init__(self, scene: Scene, substeps: int, starts: list[Start], budget: ContactBudget,
                 settle_substeps: int = 4, impl: str = "jax"):
        avoid_lapack_deadlock()
        require_impl(impl)
        self.scene, self.substeps, self.impl = scene, substeps, impl
        self._starts = [scene.settled_state(hand_q, obj_q, settle_substeps) for hand_q, obj_q in starts]
        self._put_model(budget)

    def with_budget(self, budget: ContactBudget) -> MjxBackend:
        """This backend with other buffers (a mix's: the most any of its objects needs, so that their states stack)."""
        backend = copy.copy(self)
        backend._put_model(budget)
        return backend

    def _put_model(self, budget: ContactBudget) -> None:
        self.budget, impl = budget, self.impl
        self.capped = impl == "jax" and self.budget.contacts < self.budget.candidates
        self.model = self._model()
        model = mjx.put_model(self.model, impl=impl)
        # Static fields no step of ours reads, made equal in every world so that models of one structure (the
        # one-structure template's objects) stack: MJX-JAX's geom sizes for height fields (none here), MJX-Warp's DoF
        # lengths for sleeping islands (off here).
        if impl == "warp":  # its kernels print every overflow and solver iteration limit: overflows are ours to report
            model = model.replace(opt=model.opt.replace(_impl=model.opt._impl.replace(warn_overflow=0)),
                                  _impl=model._impl.replace(dof_length=np.ones_like(model._impl.dof_length)))
        elif self.model.nhfield == 0:
            model = model.replace(_impl=model._impl.replace(
                geom_rbound_hfield=np.zeros_like(model._impl.geom_rbound_hfield)))
        self.data = self.sized(MjxData(model=model, bank=None, layout=Layout.of(self.scene)), 1)
        # what one world holds: MJX-JAX's buffers are static per world, Warp's the budget
        if impl == "jax":
            c = self.data.bank._impl
            self.buffers = {"contact_slots": int(c.contact.dist.shape[-1]), "constraint_rows": int(c.efc_J.shape[-2])}
        else:
            self.buffers = {"contact_slots": self.budget.contacts, "constraint_rows": self.budget.constraints}

    def _model(self) -> mujoco.MjModel:
        """The scene's model; for MJX-JAX with a cap, the same with ``max_contact_points`` (the contacts of every
        pair are computed, the ``budget.contacts`` nearest kept)."""
        if not self.capped:
            return self.scene.model
        xml = self.scene.xml.replace("</mujoco>", f'<custom><numeric name="max_contact_points" '
                                                  f'data="{self.budget.contacts}"/></custom></mujoco>')
        return compile_scene(xml)

    def signature(self) -> tuple:
        return self.name, self.substeps, self.impl

    def sized(self, data: MjxData, worlds: int) -> MjxData:
        """``data`` for a batch of ``worlds`` worlds: MJX-Warp's shared contact buffer holds ``budget.contacts``
        per world (MJX-JAX's buffers are per world: the same data)."""
        if data.bank is not None and self.impl == "jax":
            return data
        buffers = {} if self.impl == "jax" else {"naconmax": self.budget.contacts * worlds,
                                                 "njmax": self.budget.constraints}
        starts = [self._put(d, buffers) for d in self._starts] if data.bank is None else data.bank
        return data.replace(bank=_bank(starts, self._put(self._starts[0], buffers)))

    def _put(self, d: mujoco.MjData, buffers: dict) -> mjx.Data:
        if d.ncon > self.budget.contacts:  # the engine cannot even hold this start
            raise DragMeshError(overflow_message(self.budget, 1, f"a start state has {d.ncon} contacts"))
        return mjx.put_data(self.model, d, impl=self.impl, **buffers)

    def reset_state(self, data: MjxData, index) -> mjx.Data:
        return map_batched(lambda x: x[index], data.bank)

    def step(self, data: MjxData, ps: mjx.Data, ctrl, fields: WorldFields) -> mjx.Data:
        m = data.model.replace(**fields)
        ps = ps.replace(ctrl=ps.ctrl.at[data.layout.hand_actuators].set(ctrl))

        def body(d, _):
            return mjx.step(m, d), None

        ps, _ = jax.lax.scan(body, ps, None, length=self.substeps)
        return ps

    def overflow(self, data: MjxData, ps: mjx.Data) -> jnp.ndarray:
        """Whether this world needed more contact or constraint room than it has (checked after the control step:
        Warp's overflow bits stay set for the episode; a capped MJX-JAX world is full when every kept slot holds an
        active contact, so more may have been dropped)."""
        if self.impl == "warp":
            return (ps._impl.overflow & WARP_BUFFER_OVERFLOW) != 0
        if not self.capped:
            return jnp.bool_(False)
        c = ps._impl.contact
        return jnp.sum(c.dist < c.includemargin) >= self.budget.contacts

    def kinematics(self, data: MjxData, ps: mjx.Data) -> Kinematics:
        L = data.layout
        R = ps.site_xmat[L.handle_site]
        return Kinematics(hand_q=ps.qpos[L.hand_qpos], hand_qd=ps.qvel[L.hand_dof],
                          obj_q=ps.qpos[L.target_qpos], obj_qd=ps.qvel[L.target_dof],
                          palm=ps.site_xpos[L.palm_site], handle_pos=ps.site_xpos[L.handle_site],
                          handle_rot=jnp.concatenate([R[:, 0], R[:, 1]]), force=ps.sensordata[FORCE_SLICE],
                          penetration=penetration(ps.sensordata[CONTACT_SLICE]))
