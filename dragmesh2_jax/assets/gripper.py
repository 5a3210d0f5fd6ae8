"""A parallel-jaw gripper: the effector of the GT-part-pose primitive (paper Table 2, row 2).

A floating wrist with the hand's six virtual DoFs (world-frame slides x, y, z, then hinges giving the rotation
Rx Ry Rz, so ``hand.matrix_from_wrist_euler`` reads them) and two prismatic fingers. In the wrist frame the
fingers reach along +z (the approach direction) from the palm face at z = 0 and close along x; each finger's q is
its pad's distance from the centre line (0: closed, ``FINGER_TRAVEL``: open). PD position actuators like the hand's;
geoms collide with the object only (contype 1, conaffinity 2), as the hand's do.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL, DriveGains, HandConfig, add_virtual_joints

NAME = "PJ"
FINGERS = ("left", "right")  # +x and -x of the wrist frame
NUM_DOFS = NUM_VIRTUAL + len(FINGERS)
FINGER_TRAVEL = 0.045  # m per finger: 9 cm between the pads when open
FINGER_LENGTH = 0.06  # m, palm face to finger tip
PAD_HALF = (0.005, 0.015, FINGER_LENGTH / 2)  # m: thickness (x), width (y), half length (z)
PALM_HALF = (FINGER_TRAVEL + 2 * PAD_HALF[0], 0.02, 0.01)  # m, behind the palm face
PALM_MASS = 0.3  # kg
PAD_MASS = 0.05  # kg


@dataclass(frozen=True)
class GripperConfig:
    """Gripper options: drive gains (the wrist's are the hand's), pad friction, contact stiffness."""

    virtual: DriveGains = field(default_factory=lambda: HandConfig().virtual)
    wrist: DriveGains = field(default_factory=lambda: HandConfig().wrist)
    finger: DriveGains = DriveGains(kp=2000.0, kv=20.0, force_limit=40.0, armature=0.01)
    """N/m, N s/m, N (squeeze)"""
    friction: float = 1.5
    """sliding friction of the pads"""
    contact_timeconst: float = 0.0085
    """s, as the hand's"""


def dof_names() -> tuple[str, ...]:
    return (*(f"{NAME}_{a}" for a in ("x", "y", "z", "rx", "ry", "rz")), *(f"{NAME}_{f}" for f in FINGERS))


def palm_site_name() -> str:
    return f"{NAME}_palm"


def wrist_body_name() -> str:
    return f"{NAME}_wrist"


def touch_site_names() -> tuple[str, ...]:
    return (f"{NAME}_palm_touch", *(f"{NAME}_{f}_touch" for f in FINGERS))


def dof_ranges(config: GripperConfig = GripperConfig()) -> np.ndarray:
    hand = HandConfig()
    rot = np.radians(hand.wrist_range_deg)
    return np.array([*hand.virtual_range, *[rot] * 3, *[(0.0, FINGER_TRAVEL)] * len(FINGERS)])


def active_dofs() -> np.ndarray:
    """Every DoF of the gripper moves (no locked axes, unlike the hand's 24)."""
    return np.ones(NUM_DOFS, bool)


def _fmt(v) -> str:
    return " ".join(f"{float(x):.6g}" for x in np.ravel(v))


def build_gripper_mjcf(config: GripperConfig = GripperConfig()) -> tuple[ET.Element, ET.Element]:
    """The gripper as MJCF: a ``<body>`` for ``<worldbody>`` and an ``<actuator>`` block (as the hand's builder)."""
    names = dof_names()
    ranges = dof_ranges(config)
    geom = {"contype": "1", "conaffinity": "2", "condim": "3", "friction": f"{config.friction} 0.02 0.001",
            "solref": f"{config.contact_timeconst} 1", "solimp": "0.95 0.99 0.001", "rgba": "0.3 0.3 0.35 1",
            "group": "1"}
    wrist = ET.Element("body", name=wrist_body_name(), pos="0 0 0", gravcomp="1")
    add_virtual_joints(wrist, names, ranges, config.virtual, config.wrist)
    ET.SubElement(wrist, "geom", name=f"{NAME}_palm_geom", type="box", pos=_fmt([0, 0, -PALM_HALF[2]]),
                  size=_fmt(PALM_HALF), mass=f"{PALM_MASS}", **geom)
    ET.SubElement(wrist, "site", name=palm_site_name(), pos="0 0 0", size="0.006", rgba="1 0 0 1", group="3")
    ET.SubElement(wrist, "site", name=touch_site_names()[0], type="box", pos=_fmt([0, 0, -PALM_HALF[2]]),
                  size=_fmt(np.asarray(PALM_HALF) + 0.002), group="4")
    for k, (finger, sign) in enumerate(zip(FINGERS, (1.0, -1.0), strict=True)):
        body = ET.SubElement(wrist, "body", name=f"{NAME}_{finger}_finger", pos="0 0 0", gravcomp="1")
        ET.SubElement(body, "joint", name=names[NUM_VIRTUAL + k], type="slide", axis=_fmt([sign, 0, 0]),
                      armature=f"{config.finger.armature}", range=_fmt(ranges[NUM_VIRTUAL + k]), limited="true",
                      solreflimit=f"{config.contact_timeconst} 1")
        pad = [sign * PAD_HALF[0], 0.0, PAD_HALF[2]]  # inner face on the centre line at q = 0
        ET.SubElement(body, "geom", name=f"{NAME}_{finger}_pad", type="box", pos=_fmt(pad), size=_fmt(PAD_HALF),
                      mass=f"{PAD_MASS}", **geom)
        ET.SubElement(body, "site", name=touch_site_names()[1 + k], type="box", pos=_fmt(pad),
                      size=_fmt(np.asarray(PAD_HALF) + 0.002), group="4")
    actuators = ET.Element("actuator")
    for i, name in enumerate(names):
        g = config.virtual if i < 3 else config.wrist if i < NUM_VIRTUAL else config.finger
        ET.SubElement(actuators, "position", name=f"act_{name}", joint=name, kp=f"{g.kp}", kv=f"{g.kv}",
                      forcerange=f"{-g.force_limit} {g.force_limit}", forcelimited="true",
                      ctrlrange=_fmt(ranges[i]), ctrllimited="true")
    return wrist, actuators
