"""Grasp geometry from a handle frame (paper Appendix B, "Wrist and finger poses"; design §9).

Wrist orientation R_w: columns X = handle long axis, Y = outward normal, Z = X x Y, so the fingers (hand -y)
point into the object and the palm (hand -z) faces the bar. The long axis sign picks which side of the bar
the palm sits on (see :func:`wrist_orientation`). Wrist position x_w = palm_target - R_w o_palm compensates
the palm-centre offset. Finger poses: open (all 0), pre-shape, and a grasp adapted to the handle thickness.
All positions are world frame, metres; angles radians.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dragmesh2_jax.assets import hand as hand_lib
from dragmesh2_jax.assets.target import HandleFrame

# Finger DoF indices within the 45 finger DoFs (action index - 6): flexion is each segment's x hinge.
MCP = (0, 9, 18, 27)  # Index1_x, Middle1_x, Pinky1_x, Ring1_x
PIP = (3, 12, 21, 30)
DIP = (6, 15, 24, 33)
THUMB_ABD, THUMB_FLEX, THUMB_ROT, THUMB_PIP, THUMB_DIP = 36, 37, 38, 41, 44


@dataclass(frozen=True)
class GraspParams:
    """Palm placement relative to the handle (m): the palm sits ``palm_clearance`` + thickness/2 out along the
    palm normal and ``normal_offset`` out along the handle normal (design §9: 0.030 and 0.025 + 0.008)."""

    palm_clearance: float = 0.030
    normal_offset: float = 0.033
    flip: bool = False  # put the palm on the other side of the bar


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


def palm_target(handle: HandleFrame, R: np.ndarray, params: GraspParams = GraspParams()) -> np.ndarray:
    """Where the palm centre goes for the grasp (world)."""
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
