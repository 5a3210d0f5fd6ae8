"""A generated trajectory's grasp rested on a scene's own contacts (``TaskConfig.expert_rest``; results/screen/RULE.md,
twenty-fifth lever).

A planned grasp lies inside the handle: the plan's wrist and finger targets are where the handle stopped the hand
short of them, and the drives press the hand toward them (the wrist with up to 100 N, each finger with its drive's
limit). Seating it kinematically (``grasp.seat``) backs the whole hand out along the handle's normal, which drags a
finger curled behind a bar through the bar and off it. Resting it instead lets the physics push each phalanx out along
its own contact normal under light finger drives; the drag then starts where the hand rests, the wrist's targets
there and the fingers' ``grip_closure`` past it, a grip whose force that offset bounds."""

from __future__ import annotations

import copy
import dataclasses

import mujoco
import numpy as np

from dragmesh2_jax.assets import hand as hand_lib
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.trajectory import grasp
from dragmesh2_jax.trajectory.schema import Frame, Trajectory

#: Each finger drive's limit while the fingers come to rest on the handle (N m: a seventh of the 2 N m drives that
#: press the soft-planned grasp 4.6 mm into the tuning door's bar), and for how long (physics steps: 1 s at
#: dt = 1/240 s, by when the fingers have stopped).
REST_FORCE, REST_SUBSTEPS = 0.3, 240
#: The target joint's damping while the hand rests (N s/m or N m s/rad): the part held where the drag starts.
HELD_DAMPING = 1e6


def rest(scene: Scene, hand_q: np.ndarray, obj_q: float) -> np.ndarray:
    """Where the hand configuration ``hand_q`` comes to rest on ``scene``'s contacts with the part held at ``obj_q``:
    the wrist's drives holding ``hand_q``'s pose, the fingers' pressing toward their angles with at most
    ``REST_FORCE``, so that each joint stops where the handle or the part stops it."""
    m, ids = copy.deepcopy(scene.model), scene.ids
    m.actuator_forcerange[ids.hand_actuators[hand_lib.NUM_VIRTUAL:]] = (-REST_FORCE, REST_FORCE)
    m.dof_damping[ids.target_dof] = HELD_DAMPING
    d = mujoco.MjData(m)
    d.qpos[ids.hand_qpos] = np.clip(hand_q, ids.hand_range[:, 0], ids.hand_range[:, 1])
    d.qpos[ids.target_qpos] = obj_q
    d.ctrl[ids.hand_actuators] = d.qpos[ids.hand_qpos]
    for _ in range(REST_SUBSTEPS):
        mujoco.mj_step(m, d)
    return d.qpos[ids.hand_qpos].copy()


def rested(scene: Scene, traj: Trajectory, closure: float) -> Trajectory:
    """``traj`` with its grasp rested on ``scene``'s contacts (:func:`rest`): the drag-start frame at the rested hand;
    the drag's and release's wrist targets moved so that the drag starts at the rest (the move carried in the hand's
    frame, which a door's drag turns): the planned wrist lies inside the handle, and its drive would press the hand
    there (the wrap's fingers pull the hand 5-28 mm along the bar from its plan, 30-85 N across it); the fingers'
    targets ``closure`` past the rest (the header's ``grip``). The frames before the drag stay as they were executed;
    the header's ``generator.rested`` says how far the hand moved from the drag-start frame and from its target."""
    s = traj.drag_start
    start = traj.frames[s]
    q = rest(scene, start.hand_q, traj.q_start)
    v = hand_lib.NUM_VIRTUAL
    grip = grasp.gripping(q[v:], closure)
    planned = np.asarray(start.hand_target, np.float64)
    in_hand = hand_lib.matrix_from_wrist_euler(planned[3:v]).T @ (q[:3] - planned[:3])

    def moved(f: Frame) -> Frame:
        target = np.asarray(f.hand_target, np.float64).copy()
        target[:3] += hand_lib.matrix_from_wrist_euler(target[3:v]) @ in_hand
        target[v:] = grip if f.phase == "drag" else target[v:]
        return dataclasses.replace(f, hand_target=tuple(float(x) for x in target))

    frames = [f if k < s else moved(f) for k, f in enumerate(traj.frames)]
    frames[s] = dataclasses.replace(frames[s], virtual_xyz=tuple(q[:3]), wrist_rpy=tuple(q[3:v]),
                                    finger_dofs=tuple(q[v:]))
    how = {"force_nm": REST_FORCE, "wrist_moved_m": [float(x) for x in q[:3] - start.hand_q[:3]],
           "target_moved_m": [float(x) for x in q[:3] - planned[:3]],
           "fingers_moved_rad": float(np.max(np.abs(q[v:] - start.hand_q[v:])))}
    header = {**traj.header, "generator": {**traj.header["generator"], "rested": how},
              "grip": [float(x) for x in grip]}
    return Trajectory(frames=tuple(frames), header=header)
