"""The contact and constraint buffers of an engine whose buffers are static (MJX), sized from a probe.

MuJoCo's C engine finds the contacts that exist (3-15 per world at the expert grasp of the shared objects); MJX
allocates its buffers before anything moves. MJX-JAX reserves a slot for every contact each hand-object geom pair
could make (238-510 per world for the packaged drawer and the shared objects) and its solver works on all of them
(1004-2092 constraint rows) every step; MJX-Warp keeps one contact buffer for the whole batch (``naconmax``) and
``njmax`` constraint rows per world, and drops what does not fit.

Only hand-object pairs can collide (the scene's contype/conaffinity: no hand self-contact, no locked or static
piece, only target-part pieces near the handle). Their budget comes from a probe: the expert drag replayed on the C
engine from the task's starts at the lowest and highest probed damping, counting the contacts and constraint rows
of every physics step. The budget is that count with a margin (``ContactBudget.of``); a world that needs more is
reported as an overflow (``Backend.overflow``), never silently dropped.
"""

from __future__ import annotations

import copy
import math
from dataclasses import asdict, dataclass, fields

import mujoco
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.physics.base import Start
from dragmesh2_jax.scene import FORCE_SENSORS, Scene, contact_depth

#: Constraint rows of one contact: condim 3 under the pyramidal cone is 2 (condim - 1) rows.
ROWS_PER_CONTACT = 4
#: The probe's dampings (x nominal): contacts and rows barely depend on it, but a stiffer part is pressed harder.
PROBE_DAMPINGS = (1.0, 8.0)
#: Starts of the task's bank the probe replays from.
PROBE_STARTS = 4
#: The budget: MARGIN x the probed contacts + EXTRA slots per world, rounded up to a multiple of QUANTUM (the slots
#: are a static size of MJX's program: objects of one structure whose grasps differ a little share it).
MARGIN = 2.0
EXTRA = 16
QUANTUM = 16


@dataclass(frozen=True)
class ContactBudget:
    """Per world: ``contacts`` slots (MJX-JAX's ``max_contact_points``; MJX-Warp's ``naconmax`` is this times the
    batch) and ``constraints`` rows (MJX-Warp's ``njmax``), with what the probe measured."""

    contacts: int
    constraints: int
    probed_contacts: int  # the most contacts of one world in one physics step of the probe
    probed_constraints: int  # the most constraint rows
    candidates: int  # contacts MJX-JAX would reserve without a cap

    @classmethod
    def of(cls, probed_contacts: int, probed_constraints: int, candidates: int, limited_dofs: int,
           contacts: int | None = None) -> ContactBudget:
        """``contacts`` slots (default: ``MARGIN`` times the probed contacts plus ``EXTRA``, for a policy grips
        differently from the expert, in ``QUANTUM``s; never above the candidates) and rows for every one of them and
        for every limited DoF at its limit."""
        if contacts is None:
            contacts = QUANTUM * math.ceil((MARGIN * probed_contacts + EXTRA) / QUANTUM)
        if contacts < 1:
            raise DragMeshError(f"contact slots per world must be >= 1, got {contacts}")
        contacts = min(candidates, contacts)
        constraints = max(ROWS_PER_CONTACT * contacts + limited_dofs, probed_constraints)
        return cls(contacts, constraints, probed_contacts, probed_constraints, candidates)

    @classmethod
    def joined(cls, budgets: list[ContactBudget]) -> ContactBudget:
        """One budget that holds each of ``budgets`` (a mix's objects share their engine's buffers)."""
        return cls(*(max(getattr(b, f.name) for b in budgets) for f in fields(cls)))

    def to_json(self) -> dict:
        return asdict(self)


def probe(scene: Scene, starts: list[Start], targets: np.ndarray, substeps: int, settle_substeps: int,
          dampings: tuple[float, ...] = PROBE_DAMPINGS) -> tuple[int, int]:
    """The most contacts and constraint rows one world has in any physics step of ``targets`` (one hand PD target
    per control step, then held for as long again) replayed from each start at each damping multiplier, C engine."""
    m = copy.copy(scene.model)
    dof = scene.ids.target_dof
    held = np.concatenate([targets, np.repeat(targets[-1:], len(targets), axis=0)])
    most = [0, 0]
    for scale in dampings:
        m.dof_damping[dof] = scene.model.dof_damping[dof] * scale
        for hand_q, obj_q in starts:
            d = scene.settled_state(hand_q, obj_q, settle_substeps)  # settled at nominal damping, as a reset
            for target in held:
                d.ctrl[scene.ids.hand_actuators] = target
                for _ in range(substeps):
                    mujoco.mj_step(m, d)
                    most = [max(most[0], d.ncon), max(most[1], d.nefc)]
    return most[0], most[1]


@dataclass(frozen=True)
class Replay:
    """What a replay of hand PD targets did (``replay``): the peak wrist load (N), the deepest hand-object
    penetration (m) after any control step, the control steps to ``until`` (None: not reached) and the palm's peak
    speed (m/s) over the control steps after the first ``settled_from``."""

    peak_load: float
    deepest: float
    steps: int | None
    palm_peak: float


def replay(scene: Scene, start: Start, targets: np.ndarray, substeps: int, settle_substeps: int, until: float,
           damping: float = 1.0, settled_from: int = 0) -> Replay:
    """``targets`` (one hand PD target per control step) replayed on the C engine at ``damping`` x nominal from
    ``start`` (settled as a reset settles it), read after each control step up to the step the target joint reaches
    ``until`` (an episode's success), as ``evaluation.envelope`` reads the expert at its own pace."""
    m = copy.copy(scene.model)
    m.dof_damping[scene.ids.target_dof] = scene.model.dof_damping[scene.ids.target_dof] * damping
    d = scene.settled_state(*start, settle_substeps)  # settled at nominal damping, as a reset
    force = m.sensor(FORCE_SENSORS[0]).adr[0] + np.arange(3)
    is_hand = scene.geom_mask(scene.ids.hand_geoms)
    peak, deepest, palm_peak, palm = 0.0, 0.0, 0.0, d.site_xpos[scene.ids.palm_site].copy()
    dt = substeps * m.opt.timestep  # a control step
    for k, target in enumerate(targets):
        d.ctrl[scene.ids.hand_actuators] = target
        for _ in range(substeps):
            mujoco.mj_step(m, d)
        peak = max(peak, float(np.linalg.norm(d.sensordata[force])))
        deepest = max(deepest, contact_depth(is_hand, d))
        if k >= settled_from:
            palm_peak = max(palm_peak, float(np.linalg.norm(d.site_xpos[scene.ids.palm_site] - palm)) / dt)
        palm = d.site_xpos[scene.ids.palm_site].copy()
        if d.qpos[scene.ids.target_qpos] >= until:
            return Replay(peak, deepest, k + 1, palm_peak)
    return Replay(peak, deepest, None, palm_peak)


def pairs(scene: Scene) -> list[tuple[str, str]]:
    """The geom pairs that can collide (contype/conaffinity: hand against the object's colliding pieces only)."""
    m = scene.model
    name = lambda g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"  # noqa: E731
    can = lambda a, b: (m.geom_contype[a] & m.geom_conaffinity[b]) or (m.geom_contype[b] & m.geom_conaffinity[a])  # noqa: E731
    geoms = [g for g in range(m.ngeom) if m.geom_contype[g] or m.geom_conaffinity[g]]
    return [(name(a), name(b)) for i, a in enumerate(geoms) for b in geoms[i + 1:]
            if can(a, b) and m.geom_bodyid[a] != m.geom_bodyid[b]]


def overflow_message(budget: ContactBudget, count: int, where: str) -> str:
    return (f"MJX's contact or constraint buffer overflowed in {count} world-steps ({where}): the budget is "
            f"{budget.contacts} contacts and {budget.constraints} constraint rows per world (the expert drag's probe "
            f"needed {budget.probed_contacts} contacts); give more with --task.contacts N")


def limited_dofs(scene: Scene) -> int:
    return int(np.sum(scene.model.jnt_limited))
