"""Grasp geometry from a handle frame (paper Appendix B, "Wrist and finger poses"; design §9).

Wrist orientation R_w: columns X = handle long axis, Y = outward normal, Z = X x Y, so the fingers (hand -y)
point into the object and the palm (hand -z) faces the bar. The long axis sign picks which side of the bar
the palm sits on (see :func:`wrist_orientation`). Wrist position x_w = palm_target - R_w o_palm compensates
the palm-centre offset. Finger poses: open (all 0), pre-shape, and a grasp adapted to the handle thickness.
All positions are world frame, metres; angles radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from dragmesh2_jax.assets import hand as hand_lib
from dragmesh2_jax.assets.target import HandleFrame
from dragmesh2_jax.scene import Scene, contact_depth

# Finger DoF indices within the 45 finger DoFs (action index - 6): flexion is each segment's x hinge.
MCP = (0, 9, 18, 27)  # Index1_x, Middle1_x, Pinky1_x, Ring1_x
PIP = (3, 12, 21, 30)
DIP = (6, 15, 24, 33)
THUMB_ABD, THUMB_FLEX, THUMB_ROT, THUMB_PIP, THUMB_DIP = 36, 37, 38, 41, 44


@dataclass(frozen=True)
class GraspParams:
    """Palm placement relative to the handle (m). The hook (design §9): the palm beside the bar, the fingers pointing
    into the part, ``palm_clearance`` + thickness/2 out along the palm normal and ``normal_offset`` out along the
    handle normal (0.030 and 0.025 + 0.008). The wrap (``wrap``, beyond the paper): the palm over the handle's outer
    face and facing the part, the fingers across the bar, ``palm_clearance`` out from that face and ``normal_offset``
    back from the bar against the fingers, so that the bar lies under the proximal phalanges and the fingers curl
    around it into the gap behind; the hook's fingertips meet the part first where that gap is narrow (the tuning
    door's 19 mm: results/screen/RULE.md, twenty-fifth lever)."""

    palm_clearance: float = 0.030
    normal_offset: float = 0.033
    flip: bool = False  # put the palm on the other side of the bar (the wrap: the fingers the other way across it)
    wrap: bool = False


def wrist_orientation(handle: HandleFrame, opening_dir: np.ndarray | None = None,
                      away_from_pivot: np.ndarray | None = None, flip: bool = False) -> np.ndarray:
    """R_w (3x3, world). Of the two long-axis signs, choose the one whose palm (-Z) pushes along the opening
    direction's part across the bar (lids: palm under the bar), then the palm on the side away from a hinge,
    then the palm above the bar (drawers)."""
    y = handle.normal / np.linalg.norm(handle.normal)
    options = []
    for sgn in (1.0, -1.0):
        x = sgn * handle.long_axis
        x = x - (x @ y) * y
        x /= np.linalg.norm(x)
        z = np.cross(x, y)
        score = 0.5 * z[2]
        if opening_dir is not None:
            perp = opening_dir - (opening_dir @ y) * y
            score += -4.0 * float(z @ perp)
        if away_from_pivot is not None:
            score += 1.0 * float(z @ away_from_pivot)
        options.append((score, np.stack([x, y, z], axis=1)))
    options.sort(key=lambda o: -o[0])
    return options[1 if flip else 0][1]


#: The wrap placements (GraspParams.wrap), the fingers one way across the bar and the other: the palm 22 mm out from
#: the handle's outer face, 45 mm back from the bar (on the tuning door, 60 mm puts the bar past the proximal
#: phalanges, which drag the hand 24 mm along it as they close; results/screen/RULE.md, twenty-fifth lever).
WRAPS = (GraspParams(palm_clearance=0.022, normal_offset=0.045, wrap=True),
         GraspParams(palm_clearance=0.022, normal_offset=0.045, flip=True, wrap=True))


def wrap_orientation(handle: HandleFrame, flip: bool = False) -> np.ndarray:
    """R_w of the wrap (GraspParams): Z = the handle's outward normal, so that the palm (-Z) faces the part, X = the
    long axis (its sign flipped by ``flip``), the fingers (-Y) across the bar."""
    z = handle.normal / np.linalg.norm(handle.normal)
    x = (-1.0 if flip else 1.0) * handle.long_axis
    x = x - (x @ z) * z
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def palm_target(handle: HandleFrame, R: np.ndarray, params: GraspParams = GraspParams()) -> np.ndarray:
    """Where the palm centre goes for the grasp (world)."""
    if params.wrap:
        return (handle.centre + handle.normal * (handle.thickness / 2 + params.palm_clearance)
                + R[:, 1] * params.normal_offset)
    return (handle.centre + R[:, 2] * (handle.thickness / 2 + params.palm_clearance)
            + handle.normal * params.normal_offset)


def wrist_position(palm: np.ndarray, R: np.ndarray) -> np.ndarray:
    """x_w = c - R_w o_palm: wrist origin that puts the palm centre at ``palm``."""
    return palm - R @ np.asarray(hand_lib.PALM_OFFSET)


def hand_q(wrist_pos: np.ndarray, R: np.ndarray, fingers: np.ndarray) -> np.ndarray:
    """The 51-d hand configuration: virtual xyz, wrist intrinsic-XYZ angles, 45 finger angles."""
    return np.concatenate([wrist_pos, hand_lib.wrist_euler_from_matrix(R), fingers])


def _clip(fingers: np.ndarray) -> np.ndarray:
    lim = hand_lib.dof_ranges()[hand_lib.NUM_VIRTUAL:]
    return np.clip(fingers, lim[:, 0], lim[:, 1])


def open_pose() -> np.ndarray:
    return np.zeros(45)


def preshape_pose() -> np.ndarray:
    """Slightly curled fingers, thumb opposed (design §9 pre-shape)."""
    q = np.zeros(45)
    q[list(MCP)], q[list(PIP)], q[list(DIP)] = 0.30, 0.20, 0.10
    q[THUMB_ABD], q[THUMB_FLEX], q[THUMB_ROT], q[THUMB_PIP], q[THUMB_DIP] = 0.15, 0.40, -0.20, -0.15, -0.20
    return _clip(q)


def grasp_pose(thickness: float) -> np.ndarray:
    """Wrap grasp adapted to the handle thickness (m, world): joints close further around thicker bars."""
    t = float(np.clip(thickness, 0.005, 0.06))
    r = t / 2
    q = np.zeros(45)
    q[list(MCP)] = np.clip(0.70 + np.arcsin(min(r / 0.032, 0.95)) + 0.2, 0.70, 1.55)
    q[list(PIP)] = np.clip(0.75 + np.arcsin(min(r / 0.023, 0.95)) + 0.2, 0.75, 1.60)
    q[list(DIP)] = np.clip(0.40 + np.arcsin(min(r / 0.016, 0.95)) + 0.2, 0.40, 1.20)
    q[THUMB_ABD], q[THUMB_FLEX], q[THUMB_ROT] = 0.35, 1.2 + 8 * r, -0.45
    q[THUMB_PIP], q[THUMB_DIP] = -0.45 - 3 * r, -0.60 - 3 * r
    return _clip(q)


#: Joints that close the grip (indices into the 45 finger DoFs): the four fingers' flexion and the thumb's.
CLOSING = (*MCP, *PIP, *DIP, THUMB_FLEX, THUMB_PIP, THUMB_DIP)
#: The direction each of them closes in (:func:`grasp_pose`: the thumb's distal joints close negative).
CLOSING_SIGN = (1.0,) * 13 + (-1.0, -1.0)
#: The kinematic seat's steps: the hand backs out along the handle's normal by SEAT_STEP_M, a finger opens by
#: SEAT_OPEN of its angles, until nothing is deeper than the seat depth (at most SEAT_ITERATIONS steps each).
SEAT_STEP_M, SEAT_OPEN, SEAT_ITERATIONS = 0.0005, 0.02, 200


def seat(scene: Scene, hand_q: np.ndarray, obj_q: float, depth: float) -> np.ndarray:
    """The hand configuration ``hand_q`` (a grasp the physics pressed into the handle) moved out of the object,
    kinematically, until no hand geom is more than ``depth`` deep: the whole hand along the handle's outward normal
    until the palm and the proximal phalanges (which the fingers cannot move out) are out, then each finger opened
    (its angles scaled toward the open hand) until none of its phalanges is, then the whole hand again for what is
    left. What the fingers then hold is contact, not overlap: a PD target just past it grips with a force its
    offset bounds."""
    m, ids = scene.model, scene.ids
    d = mujoco.MjData(m)
    q = np.asarray(hand_q, np.float64).copy()
    d.qpos[ids.target_qpos] = obj_q
    p = hand_lib.prefix(scene.config.hand.side)
    is_hand = scene.geom_mask(ids.hand_geoms)
    geoms = lambda names: scene.geom_mask(  # noqa: E731
        mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, f"{p}_{n}") for n in names)

    def depth_of(among: np.ndarray) -> float:
        d.qpos[ids.hand_qpos] = q
        mujoco.mj_forward(m, d)
        return contact_depth(is_hand, d, among)

    def out(among: np.ndarray) -> None:
        for _ in range(SEAT_ITERATIONS):
            if depth_of(among) <= depth:
                return
            q[:3] += SEAT_STEP_M * scene.handle.normal

    out(geoms(["palm", *(f"{ph.name}_geom" for ph in hand_lib.PHALANGES if ph.name.endswith("1"))]))
    for finger in hand_lib.FINGERS:
        chain = [k for k, ph in enumerate(hand_lib.PHALANGES) if ph.name[:-1] == finger]
        among = geoms(f"{hand_lib.PHALANGES[k].name}_geom" for k in chain)
        dofs = [hand_lib.NUM_VIRTUAL + 3 * k + a for k in chain for a in range(3)]
        for _ in range(SEAT_ITERATIONS):
            if depth_of(among) <= depth:
                break
            q[dofs] *= 1.0 - SEAT_OPEN
    out(is_hand)
    return q


def gripping(seated_fingers: np.ndarray, closure: float) -> np.ndarray:
    """Finger PD targets ``closure`` rad past the seated fingers on every closing joint (the direction
    :func:`grasp_pose` closes it), within the hand's limits; the other joints stay: a grip whose force the offset
    bounds."""
    q = np.asarray(seated_fingers, np.float64).copy()
    closing = list(CLOSING)
    lim = hand_lib.dof_ranges()[hand_lib.NUM_VIRTUAL:][closing]
    q[closing] = np.clip(q[closing] + closure * np.asarray(CLOSING_SIGN), lim[:, 0], lim[:, 1])
    return q
