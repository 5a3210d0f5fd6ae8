"""Hand + object scene: one ``mujoco.MjModel`` and a frozen record of the ids the task needs.

World frame: z-up, metres. The object's base frame is scaled by ``scale`` (default 0.4, as the reference)
and placed at ``object_pos``; the hand's virtual joints move the wrist in world coordinates from the origin.

Choices (documented, all in :class:`SceneConfig`):
  * Only the target joint stays a DoF: passive (no actuator), viscous ``damping`` (10 N s/m or N m s/rad,
    design §2), armature 0.005, limits from the URDF (prismatic limits scaled). Every other movable joint
    is locked at its closed (lower) position: it has no action channel and would only add DoFs and contacts.
  * Contacts: hand against object only (hand geoms contype=1/conaffinity=2, object 2/1); no finger
    self-collision, no part-part collisions. By default only target-part pieces within ``collision_radius``
    of the handle collide (the handle and the front around it), which bounds MJX's contact buffer; static
    pieces are visual. ``collide="all"`` makes every object piece collide.
  * The handle moves with the target part even where its link hangs off a joint of its own (a door knob's turn);
    a handle link without a mesh is grasped by its annotated box (``stats["handle_geometry"]``).
  * Target part mass: a thin-shell estimate, ``link_areal_density`` x the surface of its bounding box.
  * The one-structure template (``build_scene(..., slots=n)``, what an MJX mix of procedural objects is built on):
    a slide and a hinge on the target part (the other kind parked, its axis zero), n collision boxes (the empty ones
    parked 5 m away), the non-colliding pieces left out, the same names everywhere: MJX stacks such models.
  * Solver for MJX: Newton, few iterations, implicitfast integrator (stiff PD damping), dense Jacobian,
    Euler damping off, pyramidal cone; dt = 1/240 s (the reference's PhysX substep).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Literal

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from dragmesh2_jax.assets import gripper as gripper_lib
from dragmesh2_jax.assets import hand as hand_lib
from dragmesh2_jax.assets.collision import ConvexPiece, GeometryConfig, as_box, hull_distance, link_pieces
from dragmesh2_jax.assets.gapartnet import GAPartNetObject
from dragmesh2_jax.assets.target import HandleFrame
from dragmesh2_jax.errors import DragMeshError

#: Frame sensors (12 values) both backends read: palm centre, handle centre, handle x (long) and y (normal) axes.
SENSORS = ("palm_pos", "handle_pos", "handle_xaxis", "handle_yaxis")
FRAME_SIZE = 3 * len(SENSORS)
#: The contact sensor after them (2 values): how many contacts the hand has and the signed distance of the deepest
#: (m, negative where the hand penetrates the object; only hand-object pairs collide, so every contact is one).
CONTACT_SENSOR = "deepest_contact"
CONTACT_SLICE = slice(FRAME_SIZE, FRAME_SIZE + 2)
#: Contact-load sensors last (22 values): the wrist force and torque (N, N m; the load the virtual arm carries, in
#: the wrist frame) and the normal contact force on the palm and on each of the 15 phalanges (N).
FORCE_SENSORS = ("wrist_force", "wrist_torque")
FORCE_SIZE = 6 + 16  # with the hand; the gripper's is 6 + 3 (palm, two pads)
FORCE_SLICE = slice(CONTACT_SLICE.stop, None)
EFFECTORS = ("hand", "parallel_jaw")
WRIST_SITE = "wrist_ft"
TARGET_JOINT = "target_joint"
TARGET_BODY = "object_target"
HANDLE_SITE = "handle"
#: The one-structure template's joints on the target part (``build_scene(..., slots=n)``): both in every world, the
#: object's kind moving, the other parked (``PARKED_RANGE`` marks it; its axis is zeroed by ``compile_scene``).
TEMPLATE_JOINTS = {"target_slide": "slide", "target_hinge": "hinge"}
PARKED_RANGE = (-1.0, 1.0)
#: A template's collision slots (``slot0``...), and where an empty one sits: a 1 mm box 5 m below its part.
SLOT = "slot"
#: The template's slots: the most pieces near the handle of any procedural object (a drawer's front and bar: 7).
TEMPLATE_SLOTS = 7
PARKED_POS, PARKED_HALF = (0.0, 0.0, -5.0), 0.001
#: Colours that tell the handle, the target part and the rest of the object apart from each other and from the hand
#: in a picture (the hand is skin-coloured: assets/hand.py). No physics reads them.
HANDLE_RGBA, PART_RGBA, BODY_RGBA = "0.95 0.55 0.15 1", "0.55 0.72 0.88 1", "0.78 0.78 0.76 1"
OTHER_HANDLE_RGBA = "0.55 0.55 0.55 1"
#: Physics steps from rest that settle a written start state: one control period (design §4 and §12: shorter than
#: the reference's four).
RESET_SETTLE_SUBSTEPS = 4


@dataclass(frozen=True)
class SceneConfig:
    scale: float = 0.4
    """object scale (design §2)"""
    object_pos: tuple[float, float, float] = (0.5, 0.0, 0.6)
    """m, world (design §2)"""
    timestep: float = 1.0 / 240.0
    """s: the reference's 60 Hz control x 4 PhysX substeps"""
    damping: float = 10.0
    """nominal target-joint damping (design §2)"""
    armature: float = 0.005
    """object DoF armature (design §2)"""
    link_areal_density: float = 5.0
    """kg/m^2 (thin-shell mass of the target part)"""
    friction: float = 1.5
    """object sliding friction"""
    object_contact: Literal["hand", "mujoco"] = "mujoco"
    """the object's contact softness: "mujoco", MuJoCo's defaults (solref 0.02 s), which a hand-object contact
    averages with the hand's (0.014 s: 2.8x softer than the hand's, so the drives press the hand 4-9 mm into a handle);
    "hand", the hand's (``hand.contact_timeconst`` and solimp): about 1 mm (RESULTS.md, penetration)"""
    collide: Literal["target", "all"] = "target"
    """which object pieces collide with the hand: the target part's near its handle, or every piece"""
    collision_radius: float = 0.2
    """m (world): target-part pieces this near the handle's surface collide"""
    gravity: bool = True
    """gravity on (off: a part moves only by contact and its damping)"""
    solver_iterations: int = 4
    """MuJoCo's constraint solver iterations"""
    ls_iterations: int = 8
    """MuJoCo's line-search iterations per solver iteration"""
    effector: Literal["hand", "parallel_jaw"] = "hand"
    """the 51-DoF hand, or the parallel-jaw primitive's gripper"""
    hand: hand_lib.HandConfig = field(default_factory=hand_lib.HandConfig)
    gripper: gripper_lib.GripperConfig = field(default_factory=gripper_lib.GripperConfig)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)

    def __post_init__(self):
        if not 0 < self.scale < math.inf:
            raise DragMeshError(f"scene scale must be finite and positive, got {self.scale}")
        if not all(math.isfinite(x) for x in self.object_pos):
            raise DragMeshError(f"object_pos must be finite, got {self.object_pos}")
        if not (0 <= self.armature < math.inf and 0 < self.collision_radius < math.inf):
            raise DragMeshError(f"armature must be finite and >= 0, collision_radius finite and > 0, got "
                                f"{self.armature} and {self.collision_radius}")
        if not 0 < self.timestep <= 0.05:
            raise DragMeshError(f"scene timestep must be in (0, 0.05] s, got {self.timestep}")
        if not (math.isfinite(self.damping) and self.damping >= 0):
            raise DragMeshError(f"target-joint damping must be finite and >= 0, got {self.damping}")
        if not (math.isfinite(self.friction) and self.friction >= 0):
            raise DragMeshError(f"object friction must be finite and >= 0, got {self.friction}")
        if self.collide not in ("target", "all"):
            raise DragMeshError(f"collide must be 'target' or 'all', got {self.collide!r}")
        if self.effector not in EFFECTORS:
            raise DragMeshError(f"effector must be one of {', '.join(EFFECTORS)}, got {self.effector!r}")

    @property
    def effector_names(self) -> dict:
        """DoF, palm site, wrist body and touch site names of the effector."""
        if self.effector == "hand":
            side = self.hand.side
            return {"dofs": hand_lib.dof_names(side), "palm": hand_lib.palm_site_name(side),
                    "wrist": hand_lib.wrist_body_name(side), "touch": hand_lib.touch_site_names(side)}
        return {"dofs": gripper_lib.dof_names(), "palm": gripper_lib.palm_site_name(),
                "wrist": gripper_lib.wrist_body_name(), "touch": gripper_lib.touch_site_names()}

    def active_dofs(self) -> np.ndarray:
        """The effector DoFs that move (the hand locks 24 finger axes)."""
        return hand_lib.active_dofs(self.hand) if self.effector == "hand" else gripper_lib.active_dofs()


@dataclass(frozen=True)
class SceneIds:
    """Indices into the compiled model. Hand arrays are in the 51-DoF action order."""

    hand_qpos: np.ndarray
    """(51,) qpos addresses"""
    hand_dof: np.ndarray
    """(51,) dof (qvel) addresses"""
    hand_actuators: np.ndarray
    """(51,)"""
    hand_range: np.ndarray
    """(51, 2) joint limits"""
    target_qpos: int
    target_dof: int
    target_range: tuple[float, float]
    """MuJoCo units (m or rad); closed = lower"""
    target_is_revolute: bool
    handle_site: int
    palm_site: int
    wrist_body: int
    hand_geoms: np.ndarray
    object_collision_geoms: np.ndarray


@dataclass(frozen=True)
class Scene:
    model: mujoco.MjModel = field(repr=False)
    ids: SceneIds = field(repr=False)
    obj: GAPartNetObject = field(repr=False)
    config: SceneConfig
    xml: str = field(repr=False)
    handle: HandleFrame
    """world frame, object closed"""
    stats: dict

    def settled_state(self, hand_q: np.ndarray, obj_q: float,
                      substeps: int = RESET_SETTLE_SUBSTEPS) -> mujoco.MjData:
        """The state a task's reset writes: hand pose ``hand_q`` (clipped to its limits) with PD target = that pose,
        the target joint at ``obj_q``, then ``substeps`` physics steps from rest at nominal damping (design §4)."""
        m, ids = self.model, self.ids
        d = mujoco.MjData(m)
        d.qpos[ids.hand_qpos] = np.clip(hand_q, ids.hand_range[:, 0], ids.hand_range[:, 1])
        d.qpos[ids.target_qpos] = obj_q
        d.ctrl[ids.hand_actuators] = d.qpos[ids.hand_qpos]
        mujoco.mj_forward(m, d)
        for _ in range(substeps):
            mujoco.mj_step(m, d)
        return d

    def geom_mask(self, geoms) -> np.ndarray:
        """A mask over the model's geoms: True at ``geoms`` (ids)."""
        mask = np.zeros(self.model.ngeom, bool)
        mask[np.asarray(list(geoms), int)] = True
        return mask

    def initial_data(self) -> mujoco.MjData:
        """MjData at the closed object and the hand at the origin with PD targets = current pose."""
        d = mujoco.MjData(self.model)
        d.qpos[self.ids.target_qpos] = self.ids.target_range[0]
        d.ctrl[self.ids.hand_actuators] = d.qpos[self.ids.hand_qpos]
        mujoco.mj_forward(self.model, d)
        return d


def contact_depth(is_hand: np.ndarray, d: mujoco.MjData, among: np.ndarray | None = None) -> float:
    """The deepest hand-object penetration (m, >= 0) among ``d``'s contacts; ``is_hand``: a mask over the model's
    geoms; ``among``: only the contacts of these geoms (a mask too; None: every hand geom's)."""
    c = d.contact  # the active contacts' fields as arrays
    between = is_hand[c.geom1] != is_hand[c.geom2]
    if among is not None:
        between &= among[c.geom1] | among[c.geom2]
    return float(-np.min(c.dist[between], initial=0.0))


def _fmt(v) -> str:
    return " ".join(f"{float(x):.7g}" for x in np.asarray(v).ravel())


def _piece_geom(parent: ET.Element, asset: ET.Element, piece: ConvexPiece, name: str, scale: float, collide: bool,
                contact: dict[str, str], rgba: str) -> None:
    attrs = {"name": name, "rgba": rgba, "group": "2" if collide else "0"}
    if collide:
        attrs.update(contype="2", conaffinity="1", condim="3", **contact)
    else:
        attrs.update(contype="0", conaffinity="0")
    attrs["mass"] = "0"
    if piece.is_box:
        q = Rotation.from_matrix(piece.box_rot).as_quat()  # xyzw
        attrs.update(type="box", pos=_fmt(scale * piece.box_pos), size=_fmt(scale * piece.box_half),
                     quat=_fmt([q[3], q[0], q[1], q[2]]))
    else:
        ET.SubElement(asset, "mesh", name=f"{name}_mesh", vertex=_fmt(scale * piece.vertices), inertia="convex")
        attrs.update(type="mesh", mesh=f"{name}_mesh")
    ET.SubElement(parent, "geom", **attrs)


def _handle_box_geom(parent: ET.Element, frame: HandleFrame, scale: float, contact: dict[str, str],
                     name: str) -> None:
    """The handle's annotated box (the graspable side of a knob annotated through the panel) as a collision box."""
    rot = np.stack([frame.long_axis, frame.short_axis, frame.normal], axis=1)
    if np.linalg.det(rot) < 0:
        rot[:, 1] = -rot[:, 1]
    q = Rotation.from_matrix(rot).as_quat()  # xyzw
    ET.SubElement(parent, "geom", name=name, type="box", pos=_fmt(scale * frame.centre),
                  size=_fmt(scale * np.maximum([frame.length, frame.width, frame.thickness], 1e-3) / 2),
                  quat=_fmt([q[3], q[0], q[1], q[2]]), contype="2", conaffinity="1", condim="3", mass="0",
                  rgba=HANDLE_RGBA, group="2", **contact)


def _piece_near(piece: ConvexPiece, handle_box: np.ndarray, radius: float, scale: float) -> bool:
    """Whether the piece's hull comes within ``radius`` of the handle's box (surface to surface: a large flat
    panel counts by its nearest point, not by its vertices or its centre)."""
    return hull_distance(scale * piece.corners(), handle_box) <= radius


def compile_scene(xml: str) -> mujoco.MjModel:
    """The scene's model from its XML; in a template, the parked joint disabled (its axis zero: it moves nothing and
    no force reaches it) and the constants MuJoCo derives from the joints (inverse weights) taken again without it."""
    model = mujoco.MjModel.from_xml_string(xml)
    parked = [model.joint(name).id for name in TEMPLATE_JOINTS
              if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name) >= 0
              and model.jnt_range[model.joint(name).id].tolist() == list(PARKED_RANGE)]
    if parked:
        model.jnt_axis[parked] = 0.0
        mujoco.mj_setConst(model, mujoco.MjData(model))
    return model


def build_scene(obj: GAPartNetObject, config: SceneConfig = SceneConfig(), use_cache: bool = True,
                slots: int | None = None) -> Scene:
    """Compose the hand and ``obj`` into one model. See the module docstring for the modelling choices.

    ``slots``: build it on the one-structure template (``TEMPLATE_JOINTS``): the same bodies, joints and geoms for
    every object whose colliding pieces are at most ``slots`` boxes (procedural objects), so that MJX stacks the
    models of a mix of categories; its sizes, poses, axes, ranges and masses are the object's data. Pieces that do not
    collide are left out (they carry no mass and meet nothing), an empty slot is parked out of reach."""
    s = config.scale
    t = obj.target
    pos = np.asarray(config.object_pos, dtype=np.float64)
    handle_obj = t.handle
    handle_local = s * handle_obj.centre  # in the object body frame (object placed at ``pos``)
    handle_box = s * handle_obj.corners()

    if slots is not None and config.collide != "target":
        raise DragMeshError("the one-structure template holds the target part's pieces near its handle only "
                            "(collide='target')")
    # a template's names are the same in every world (MJX keeps names as static fields of the model)
    root = ET.Element("mujoco", model="dragmesh2_template" if slots is not None else f"dragmesh2_{obj.object_id}")
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    opt = ET.SubElement(root, "option", timestep=f"{config.timestep:.9g}", integrator="implicitfast",
                        solver="Newton", iterations=str(config.solver_iterations),
                        ls_iterations=str(config.ls_iterations), cone="pyramidal", jacobian="dense",
                        gravity="0 0 -9.81" if config.gravity else "0 0 0")
    ET.SubElement(opt, "flag", eulerdamp="disable")
    vis = ET.SubElement(root, "visual")
    ET.SubElement(vis, "global", offwidth="960", offheight="720")
    asset = ET.SubElement(root, "asset")
    world = ET.SubElement(root, "worldbody")
    ET.SubElement(world, "light", pos="0 -1 2.5", dir="0.2 0.4 -1", directional="true", diffuse="0.8 0.8 0.8")
    hand_body, actuators = (hand_lib.build_hand_mjcf(config.hand) if config.effector == "hand"
                            else gripper_lib.build_gripper_mjcf(config.gripper))
    ET.SubElement(hand_body, "site", name=WRIST_SITE, pos="0 0 0", size="0.005", group="4")
    world.append(hand_body)

    obj_body = ET.SubElement(world, "body", name="object", pos=_fmt(pos))
    contact = {"friction": f"{config.friction} 0.02 0.001"}
    if config.object_contact == "hand":  # else MuJoCo's defaults, which a contact averages with the hand's
        contact.update(solref=f"{config.hand.contact_timeconst} 1", solimp=hand_lib.CONTACT_SOLIMP)
    handle_links = {p.link for p in obj.parts if p.is_handle}
    n_collide, max_verts, n_pieces, handle_collides = 0, 0, 0, False
    target_pieces: list[ConvexPiece] = []
    target_body = ET.Element("body", name=TARGET_BODY, pos="0 0 0")
    j = t.joint
    lower, upper = (s * j.lower, s * j.upper) if not j.is_revolute else (j.lower, j.upper)
    joint = {"pos": _fmt(s * j.origin), "axis": _fmt(j.axis), "damping": f"{config.damping}",
             "armature": f"{config.armature}", "limited": "true", "solreflimit": f"{config.hand.contact_timeconst} 1"}
    moving = "hinge" if j.is_revolute else "slide"
    if slots is not None and (lower, upper) == PARKED_RANGE:  # compile_scene would take it for the parked joint
        raise DragMeshError(f"{obj.folder}: a target range of exactly {PARKED_RANGE} is the template's parked mark")
    for name, kind in ((TARGET_JOINT, moving),) if slots is None else TEMPLATE_JOINTS.items():
        span = (lower, upper) if kind == moving else PARKED_RANGE  # a parked joint never meets its limits
        ET.SubElement(target_body, "joint", name=name, type=kind, range=f"{span[0]:.7g} {span[1]:.7g}",
                      ref=f"{lower if kind == moving else 0.0:.7g}", **joint)
    for name, link in obj.links.items():
        # the handle moves with the part even where it hangs off a joint of its own (a door knob's turn)
        in_target = name in t.attached_links or name == handle_obj.link
        # Only handles that can be touched are decomposed (decomposition is the slow, cached step).
        decompose = (name in handle_links and config.geometry.decompose_handles
                     and (in_target or config.collide == "all"))
        pieces = link_pieces(link, decompose=decompose, config=config.geometry, use_cache=use_cache)
        for k, piece in enumerate(pieces):
            collide = config.collide == "all" or (
                in_target and _piece_near(piece, handle_box, config.collision_radius, s))
            rgba = ((HANDLE_RGBA if in_target else OTHER_HANDLE_RGBA) if name in handle_links
                    else PART_RGBA if in_target else BODY_RGBA)
            if slots is None:
                _piece_geom(target_body if in_target else obj_body, asset, piece, f"{name}_{k}", s, collide, contact,
                            rgba)
            elif collide:  # the template holds the pieces that collide, each as a box in its own slot
                box = as_box(piece)
                if box is None:
                    raise DragMeshError(f"{obj.folder}: link {name} collides through a hull that is not a box; the "
                                        "one-structure template holds boxes (procedural objects)")
                _piece_geom(target_body, asset, box, f"{SLOT}{n_collide}", s, True, contact, rgba)
            n_collide += collide
            handle_collides |= collide and name == handle_obj.link
            n_pieces += 1
            max_verts = max(max_verts, piece.num_vertices)
            if in_target:
                target_pieces.append(piece)
    if not target_pieces:
        raise DragMeshError(f"{obj.folder}: target part {t.part.link} has no geometry")
    handle_geometry = "mesh"
    if handle_obj.source == "handle" and not handle_collides:  # a handle link without a mesh: its annotated box
        _handle_box_geom(target_body, handle_obj, s, contact, "handle_box" if slots is None else f"{SLOT}{n_collide}")
        handle_geometry, n_collide = "annotated box", n_collide + 1
    if n_collide == 0:
        raise DragMeshError(f"{obj.folder}: no collision geometry within {config.collision_radius} m of the handle")
    if slots is not None:
        if n_collide > slots:
            raise DragMeshError(f"{obj.folder}: {n_collide} collision pieces do not fit the template's {slots} slots")
        for k in range(n_collide, slots):  # the slots this object leaves empty: parked out of every hand's reach
            ET.SubElement(target_body, "geom", name=f"{SLOT}{k}", type="box", pos=_fmt(PARKED_POS),
                          size=_fmt([PARKED_HALF] * 3), contype="2", conaffinity="1", condim="3", mass="0",
                          group="2", rgba=PART_RGBA, **contact)
    corners = s * np.concatenate([p.corners() for p in target_pieces])
    lo, hi = corners.min(0), corners.max(0)
    ext = np.maximum(hi - lo, 0.01)
    mass = config.link_areal_density * 2 * (ext[0] * ext[1] + ext[1] * ext[2] + ext[0] * ext[2])
    inertia = mass / 12 * np.array([ext[1] ** 2 + ext[2] ** 2, ext[0] ** 2 + ext[2] ** 2, ext[0] ** 2 + ext[1] ** 2])
    ET.SubElement(target_body, "inertial", pos=_fmt((lo + hi) / 2), mass=f"{mass:.6g}", diaginertia=_fmt(inertia))
    ET.SubElement(target_body, "site", name=HANDLE_SITE, pos=_fmt(handle_local),
                  xyaxes=_fmt(np.concatenate([handle_obj.long_axis, handle_obj.normal])), size="0.008",
                  rgba="0 1 0 1", group="3")
    obj_body.append(target_body)
    root.append(actuators)
    sensor = ET.SubElement(root, "sensor")
    eff = config.effector_names
    ET.SubElement(sensor, "framepos", name=SENSORS[0], objtype="site", objname=eff["palm"])
    ET.SubElement(sensor, "framepos", name=SENSORS[1], objtype="site", objname=HANDLE_SITE)
    ET.SubElement(sensor, "framexaxis", name=SENSORS[2], objtype="site", objname=HANDLE_SITE)
    ET.SubElement(sensor, "frameyaxis", name=SENSORS[3], objtype="site", objname=HANDLE_SITE)
    ET.SubElement(sensor, "contact", name=CONTACT_SENSOR, data="found dist", reduce="mindist", num="1")
    ET.SubElement(sensor, "force", name=FORCE_SENSORS[0], site=WRIST_SITE)
    ET.SubElement(sensor, "torque", name=FORCE_SENSORS[1], site=WRIST_SITE)
    for name in eff["touch"]:
        ET.SubElement(sensor, "touch", name=name, site=name)
    xml = ET.tostring(root, encoding="unicode")
    try:
        model = compile_scene(xml)
    except ValueError as e:
        raise DragMeshError(f"{obj.folder}: MuJoCo cannot compile the scene ({str(e).splitlines()[0]})") from None

    names = eff["dofs"]
    jid = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n) for n in names]
    tj = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, TARGET_JOINT if slots is None else next(
        name for name, kind in TEMPLATE_JOINTS.items() if kind == moving))
    hand_geoms = np.array([g for g in range(model.ngeom) if model.geom_contype[g] == 1])
    obj_geoms = np.array([g for g in range(model.ngeom) if model.geom_contype[g] == 2])
    ids = SceneIds(
        hand_qpos=np.array([model.jnt_qposadr[i] for i in jid]),
        hand_dof=np.array([model.jnt_dofadr[i] for i in jid]),
        hand_actuators=np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"act_{n}") for n in names]),
        hand_range=np.array([model.jnt_range[i] for i in jid]),
        target_qpos=int(model.jnt_qposadr[tj]), target_dof=int(model.jnt_dofadr[tj]),
        target_range=(float(lower), float(upper)), target_is_revolute=bool(j.is_revolute),
        handle_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, HANDLE_SITE),
        palm_site=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, eff["palm"]),
        wrist_body=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, eff["wrist"]),
        hand_geoms=hand_geoms, object_collision_geoms=obj_geoms,
    )
    stats = {"collision_pieces": int(n_collide), "pieces": int(n_pieces), "max_hull_vertices": int(max_verts),
             "target_mass_kg": round(float(mass), 4), "nq": int(model.nq), "nv": int(model.nv), "nu": int(model.nu),
             "ngeom": int(model.ngeom), "contact_pairs": int(len(hand_geoms) * len(obj_geoms)),
             "handle_geometry": handle_geometry, "structure": "own" if slots is None else f"template of {slots} slots"}
    return Scene(model=model, ids=ids, obj=obj, config=config, xml=xml, handle=handle_obj.scaled(s, pos), stats=stats)
