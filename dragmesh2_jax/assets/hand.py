"""The 51-DoF SMPL-X hand (paper §3.1): 6 virtual wrist DoFs + 15 finger bodies x 3 hinges.

Geometry is a box palm and one capsule per phalanx, generated from the spec table below (numbers from the
public DragMesh-2 reference hand, design §11). Frames: the wrist body ``{side}_Wrist`` sits at the origin of
the virtual-joint chain; in the hand frame the fingers point along -y and the palm faces -z (right hand).

DoF order (= action order, fixed):
    0-2   virtual x/y/z (slide, metres, world axes)
    3-5   wrist x/y/z   (hinge, radians; R = Rx(q3) Ry(q4) Rz(q5), intrinsic XYZ)
    6-50  Index1..3, Middle1..3, Pinky1..3, Ring1..3, Thumb1..3, each x/y/z (hinge, radians)
Axes the reference locks (+-0.1 deg) stay joints so the action stays 51-d.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

FINGERS = ("Index", "Middle", "Pinky", "Ring", "Thumb")
NUM_DOFS = 51
NUM_VIRTUAL = 6
#: Palm-centre offset in the wrist frame (m): the contact point used for palm-to-handle distance (design §2).
PALM_OFFSET = (-0.003, -0.054, -0.004)


@dataclass(frozen=True)
class PhalanxSpec:
    """One finger body: offset from its parent body, capsule end points (body frame, m), radius (m),
    and x/y/z hinge ranges (degrees)."""

    name: str
    pos: tuple[float, float, float]
    fromto: tuple[float, float, float, float, float, float]
    radius: float
    range_x: tuple[float, float]
    range_y: tuple[float, float]
    range_z: tuple[float, float]


_LOCK = (-0.1, 0.1)
_SEG1 = ((-20.0, 90.0), _LOCK, (-20.0, 20.0))
_SEG2 = ((0.0, 100.0), _LOCK, _LOCK)
_SEG3 = ((0.0, 80.0), _LOCK, _LOCK)


def _chain(finger: str, rows, ranges) -> tuple[PhalanxSpec, ...]:
    return tuple(
        PhalanxSpec(f"{finger}{i + 1}", pos, fromto, radius, *rng)
        for i, ((pos, fromto, radius), rng) in enumerate(zip(rows, ranges, strict=True))
    )


#: The spec table: (body offset, capsule fromto, radius) per segment; reference hand, design §11.
PHALANGES: tuple[PhalanxSpec, ...] = (
    *_chain("Index", [
        ((0.0196, -0.0999, -0.0118), (0.0006, -0.0064, 0.0004, 0.0024, -0.0256, 0.0018), 0.0091),
        ((0.0030, -0.0319, 0.0022), (0.0000, -0.0045, -0.0005, 0.0000, -0.0180, -0.0019), 0.0076),
        ((0.0001, -0.0225, -0.0023), (0.0004, -0.0041, -0.0001, 0.0016, -0.0164, -0.0003), 0.0067),
    ], (_SEG1, _SEG2, _SEG3)),
    *_chain("Middle", [
        ((-0.0037, -0.1074, -0.0094), (-0.0008, -0.0061, 0.0002, -0.0032, -0.0245, 0.0006), 0.0094),
        ((-0.0040, -0.0306, 0.0008), (-0.0008, -0.0047, -0.0004, -0.0033, -0.0188, -0.0016), 0.0070),
        ((-0.0041, -0.0235, -0.0020), (-0.0004, -0.0043, 0.0000, -0.0017, -0.0172, 0.0000), 0.0064),
    ], (_SEG1, _SEG2, _SEG3)),
    *_chain("Pinky", [
        ((-0.0435, -0.0820, -0.0176), (-0.0024, -0.0031, -0.0002, -0.0096, -0.0124, -0.0009), 0.0067),
        ((-0.0120, -0.0155, -0.0011), (-0.0022, -0.0031, -0.0003, -0.0090, -0.0124, -0.0013), 0.0065),
        ((-0.0112, -0.0155, -0.0017), (-0.0018, -0.0027, 0.0001, -0.0074, -0.0108, 0.0003), 0.0052),
    ], (_SEG1, _SEG2, _SEG3)),
    *_chain("Ring", [
        ((-0.0271, -0.0954, -0.0124), (-0.0011, -0.0056, 0.0003, -0.0042, -0.0224, 0.0012), 0.0080),
        ((-0.0053, -0.0280, 0.0015), (-0.0014, -0.0046, -0.0003, -0.0057, -0.0183, -0.0012), 0.0074),
        ((-0.0071, -0.0228, -0.0015), (-0.0010, -0.0042, 0.0001, -0.0041, -0.0167, 0.0004), 0.0060),
    ], (_SEG1, _SEG2, _SEG3)),
    *_chain("Thumb", [
        ((0.0259, -0.0386, -0.0211), (0.0050, -0.0034, 0.0002, 0.0200, -0.0136, 0.0008), 0.0120),
        ((0.0250, -0.0170, 0.0010), (0.0031, -0.0041, -0.0010, 0.0124, -0.0164, -0.0041), 0.0095),
        ((0.0155, -0.0205, -0.0052), (0.0035, -0.0037, -0.0006, 0.0140, -0.0148, -0.0025), 0.0090),
    ], (((-45.0, 45.0), (-45.0, 130.0), (-70.0, 30.0)), (_LOCK, _LOCK, (-55.0, 20.0)),
        (_LOCK, _LOCK, (-80.0, 15.0)))),
)

PALM_BOX_POS = (-0.0029, -0.0537, -0.0044)
PALM_BOX_HALF = (0.04, 0.0402, 0.0159)
PALM_MASS = 0.2517  # kg (reference: density 1230.8 over the box)
PHALANX_DENSITY = 1000.0  # kg/m^3


@dataclass(frozen=True)
class DriveGains:
    """Position (PD) actuator of one DoF group: stiffness kp, damping kv, |force| limit, joint armature.

    Units: N/m, N s/m, N for slides; N m/rad, N m s/rad, N m for hinges; armature kg or kg m^2.
    The reference's PhysX drives (design §1: kp 1e5/5e3/8e3) are implicit and far stiffer than an explicit
    MuJoCo PD allows at dt = 1/240 s on 1-15 g phalanges; these values keep omega*dt < 0.7 per group
    with the armature listed, are near-critically damped (kv ~ 2 sqrt(kp I)), and track a 0.05 rad/m
    target step in well under one 1/60 s control period. ``tests/assets/test_hand.py`` checks stability.
    """

    kp: float
    """stiffness"""
    kv: float
    """damping"""
    force_limit: float
    """|force| limit"""
    armature: float
    """joint armature"""


@dataclass(frozen=True)
class HandConfig:
    """Hand model options. Defaults: right hand, gains chosen for dt = 1/240 s with implicitfast."""

    side: Literal["right", "left"] = "right"
    """left: the right hand's mirror image across its y-z plane"""
    virtual: DriveGains = DriveGains(kp=3000.0, kv=80.0, force_limit=300.0, armature=0.1)
    wrist: DriveGains = DriveGains(kp=100.0, kv=2.5, force_limit=50.0, armature=0.01)
    finger: DriveGains = DriveGains(kp=30.0, kv=0.5, force_limit=1.0, armature=0.002)
    virtual_range: tuple[tuple[float, float], ...] = ((-2.0, 2.0), (-2.0, 2.0), (0.0, 2.0))
    """m, x/y/z slides"""
    wrist_range_deg: tuple[float, float] = (-180.0, 180.0)
    """the three wrist hinges' range, degrees"""
    friction: float = 1.5
    """sliding friction of hand geoms"""
    contact_timeconst: float = 0.0085
    """Contact and finger joint-limit stiffness: solref time constant (s). MuJoCo's default 0.02 lets the light,
    armature-dominated phalanges sink ~2 cm into a handle (or 0.1 rad past a limit) under full drive; 2 dt (dt = 1/240
    s) is the stiffest value MuJoCo accepts."""
    rgba: tuple[float, float, float, float] = (0.85, 0.65, 0.5, 1.0)
    """the hand's colour in pictures (red, green, blue, alpha in [0, 1])"""

    def __post_init__(self):
        if self.side not in ("right", "left"):
            raise ValueError(f"hand side must be 'right' or 'left', got {self.side!r}")


def prefix(side: str) -> str:
    return "R" if side == "right" else "L"


def dof_names(side: str = "right") -> tuple[str, ...]:
    """The 51 joint names in action order."""
    p = prefix(side)
    names = [f"virtual_{a}" for a in "xyz"] + [f"{p}_Wrist_{a}" for a in "xyz"]
    names += [f"{p}_{ph.name}_{a}" for ph in PHALANGES for a in "xyz"]
    return tuple(names)


def fingertip_site_names(side: str = "right") -> tuple[str, ...]:
    p = prefix(side)
    return tuple(f"{p}_{f}_tip" for f in FINGERS)


#: The hand's contact impedance (MuJoCo solimp: dmin, dmax, width in m): 0.95 at contact, 0.99 from 1 mm deep.
CONTACT_SOLIMP = "0.95 0.99 0.001"
#: Touch sites enclose each hand geom by this margin (m), so a touch sensor sums that geom's contact normal forces.
TOUCH_MARGIN = 0.002


def touch_site_names(side: str = "right") -> tuple[str, ...]:
    """One touch site per hand collision geom: the palm, then the 15 phalanges in spec order."""
    p = prefix(side)
    return (f"{p}_palm_touch", *(f"{p}_{ph.name}_touch" for ph in PHALANGES))


def palm_site_name(side: str = "right") -> str:
    return f"{prefix(side)}_palm_centre"


def wrist_body_name(side: str = "right") -> str:
    return f"{prefix(side)}_Wrist"


def dof_ranges(config: HandConfig = HandConfig()) -> np.ndarray:
    """(51, 2) joint limits in action order (m for slides, rad for hinges)."""
    rows = [list(r) for r in config.virtual_range]
    rows += [[math.radians(config.wrist_range_deg[0]), math.radians(config.wrist_range_deg[1])]] * 3
    for ph in PHALANGES:
        for lo, hi in (ph.range_x, ph.range_y, ph.range_z):
            rows.append([math.radians(lo), math.radians(hi)])
    return np.asarray(rows, dtype=np.float64)


def active_dofs(config: HandConfig = HandConfig()) -> np.ndarray:
    """(51,) bool: the DoFs that move. The 24 finger axes locked to +-0.1 deg (design §11) take an action that
    moves nothing; everything else (6 wrist + 21 finger DoFs) is active."""
    r = dof_ranges(config)
    return (r[:, 1] - r[:, 0]) > 2 * math.radians(max(abs(x) for x in _LOCK)) + 1e-9


def _mirror(v, side: str):
    """Positions mirror across the hand's y-z plane for the left hand."""
    v = list(v)
    if side == "left":
        for i in range(0, len(v), 3):
            v[i] = -v[i]
    return v


def _axis(a: str, side: str) -> str:
    """Hinge axes under the mirror: x stays, y and z flip, so q > 0 keeps its anatomical meaning."""
    base = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}[a]
    if side == "left" and a in "yz":
        base = tuple(-c for c in base)
    return _fmt(base)


def _fmt(v) -> str:
    return " ".join(f"{float(x):.6g}" for x in v)


def add_virtual_joints(wrist: ET.Element, names, ranges: np.ndarray, virtual: DriveGains, rotation: DriveGains) -> None:
    """The floating wrist's six DoFs on ``wrist``: world-frame slides x, y, z, then hinges giving Rx Ry Rz (read by
    ``matrix_from_wrist_euler``). Shared by the hand and the parallel-jaw gripper."""
    for i in range(3):
        ET.SubElement(wrist, "joint", name=names[i], type="slide", axis=_fmt(np.eye(3)[i]),
                      armature=f"{virtual.armature}", range=_fmt(ranges[i]), limited="true")
    for i in range(3):
        ET.SubElement(wrist, "joint", name=names[3 + i], type="hinge", axis=_fmt(np.eye(3)[i]),
                      armature=f"{rotation.armature}", range=_fmt(ranges[3 + i]), limited="true")


def build_hand_mjcf(config: HandConfig = HandConfig()) -> tuple[ET.Element, ET.Element]:
    """The hand as MJCF: a ``<body>`` to place under ``<worldbody>`` and an ``<actuator>`` block.

    Geoms get contype=1, conaffinity=2 (hand never collides with itself; the object uses 2/1).
    Sites: ``{P}_palm_centre`` (palm contact centre) and ``{P}_{Finger}_tip`` (fingertips).
    """
    side = config.side
    p = prefix(side)
    names = dof_names(side)
    ranges = dof_ranges(config)
    rgba = _fmt(config.rgba)
    geom_common = {"contype": "1", "conaffinity": "2", "condim": "3", "friction": f"{config.friction} 0.02 0.001",
                   "solref": f"{config.contact_timeconst} 1", "solimp": CONTACT_SOLIMP, "rgba": rgba, "group": "1"}

    wrist = ET.Element("body", name=wrist_body_name(side), pos="0 0 0", gravcomp="1")
    # The six virtual DoFs are world-frame motions: never mirrored, so wrist_rpy means the same for both hands.
    add_virtual_joints(wrist, names, ranges, config.virtual, config.wrist)
    palm_pos = _mirror(PALM_BOX_POS, side)
    ET.SubElement(wrist, "geom", name=f"{p}_palm", type="box", pos=_fmt(palm_pos), size=_fmt(PALM_BOX_HALF),
                  mass=f"{PALM_MASS}", **geom_common)
    ET.SubElement(wrist, "site", name=palm_site_name(side), pos=_fmt(_mirror(PALM_OFFSET, side)), size="0.006",
                  rgba="1 0 0 1", group="3")
    ET.SubElement(wrist, "site", name=touch_site_names(side)[0], type="box", pos=_fmt(palm_pos),
                  size=_fmt(np.asarray(PALM_BOX_HALF) + TOUCH_MARGIN), group="4")

    parents = {}
    for k, ph in enumerate(PHALANGES):
        finger, seg = ph.name[:-1], int(ph.name[-1])
        parent = wrist if seg == 1 else parents[f"{finger}{seg - 1}"]
        body = ET.SubElement(parent, "body", name=f"{p}_{ph.name}", pos=_fmt(_mirror(ph.pos, side)), gravcomp="1")
        parents[ph.name] = body
        for j, a in enumerate("xyz"):
            dof = NUM_VIRTUAL + 3 * k + j
            ET.SubElement(body, "joint", name=names[dof], type="hinge", axis=_axis(a, side),
                          armature=f"{config.finger.armature}", range=_fmt(ranges[dof]), limited="true",
                          solreflimit=f"{config.contact_timeconst} 1")
        ft = _mirror(ph.fromto, side)
        ET.SubElement(body, "geom", name=f"{p}_{ph.name}_geom", type="capsule", fromto=_fmt(ft), size=f"{ph.radius}",
                      density=f"{PHALANX_DENSITY}", **geom_common)
        ET.SubElement(body, "site", name=touch_site_names(side)[1 + k], type="capsule", fromto=_fmt(ft),
                      size=f"{ph.radius + TOUCH_MARGIN}", group="4")
        if seg == 3:
            a, b = np.asarray(ft[:3]), np.asarray(ft[3:])
            tip = b + ph.radius * (b - a) / np.linalg.norm(b - a)
            ET.SubElement(body, "site", name=f"{p}_{finger}_tip", pos=_fmt(tip), size="0.004", rgba="0 0 1 1",
                          group="3")

    actuators = ET.Element("actuator")
    for i, name in enumerate(names):
        g = config.virtual if i < 3 else config.wrist if i < 6 else config.finger
        ET.SubElement(actuators, "position", name=f"act_{name}", joint=name, kp=f"{g.kp}", kv=f"{g.kv}",
                      forcerange=f"{-g.force_limit} {g.force_limit}", forcelimited="true",
                      ctrlrange=_fmt(ranges[i]), ctrllimited="true")
    return wrist, actuators


def hand_only_xml(config: HandConfig = HandConfig(), timestep: float = 1.0 / 240.0) -> str:
    """A standalone MJCF of the hand alone (for inspection and hand-only tests)."""
    root = ET.Element("mujoco", model=f"smplx_{config.side}_hand")
    ET.SubElement(root, "option", timestep=f"{timestep}", integrator="implicitfast", gravity="0 0 -9.81")
    world = ET.SubElement(root, "worldbody")
    body, acts = build_hand_mjcf(config)
    world.append(body)
    root.append(acts)
    return ET.tostring(root, encoding="unicode")


def wrist_euler_from_matrix(R: np.ndarray) -> np.ndarray:
    """Intrinsic XYZ Euler angles (q3, q4, q5) with R = Rx(q3) Ry(q4) Rz(q5)."""
    return Rotation.from_matrix(np.asarray(R)).as_euler("XYZ")


def matrix_from_wrist_euler(rpy) -> np.ndarray:
    return Rotation.from_euler("XYZ", np.asarray(rpy)).as_matrix()
