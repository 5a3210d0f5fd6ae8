"""The GT-part-pose parallel-jaw primitive (paper Table 2, row 2): a scripted controller that knows the target
part's pose and joint. It starts ``approach`` out along the handle's outward normal with the jaws open, moves in
along the normal until the finger tips reach past the handle's centre, closes the jaws across the handle, then
pulls along the joint's motion: a straight line along a slider's axis, an arc about a hinge (the wrist turning
with the part), at a fixed rate until the joint's range is used up. Open loop and deterministic: one value per
damping (det and stoch are the same controller).

It runs the task with the gripper (``assets/gripper.py``) in place of the hand, with the reference trajectory's
task boundary (q_start, q_goal, q_done) and the evaluation protocol's starts, through the same evaluator: the same
cells and metrics as every policy.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets import gripper
from dragmesh2_jax.assets.target import opening_direction
from dragmesh2_jax.assets.urdf import axis_angle_matrix
from dragmesh2_jax.baselines.tracking import replay
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.task.env import PullTask
from dragmesh2_jax.trajectory.generator import continuous_euler

PARALLEL_JAW = "parallel_jaw"


@dataclass(frozen=True)
class PrimitiveParams:
    approach: float = 0.08  # m out along the handle normal where each episode starts
    grip_depth: float = 0.015  # m the finger tips reach past the handle's centre
    approach_steps: int = 30  # control steps (1/60 s) to move in
    close_steps: int = 20  # control steps to close the jaws (then they squeeze at the actuator's force limit)
    pull_speed: float = 0.15  # m/s along a slider's axis
    pull_rate: float = 0.6  # rad/s about a hinge


def jaw_frame(handle) -> np.ndarray:
    """Wrist rotation (world): fingers reach along -normal (local z), jaws close along the handle's short axis
    (local x), so the jaws squeeze the handle across its width."""
    z = -handle.normal / np.linalg.norm(handle.normal)
    x = handle.short_axis - (handle.short_axis @ z) * z
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z], axis=1)


def primitive_plan(scene, steps: int, params: PrimitiveParams = PrimitiveParams()) -> tuple[np.ndarray, np.ndarray]:
    """(start q (8,), PD targets (steps, 8)) of the primitive in ``scene`` (a gripper scene), from the target part's
    ground-truth pose: approach, close, pull."""
    h, t = scene.handle, scene.obj.target
    s, pos = scene.config.scale, np.asarray(scene.config.object_pos)
    R_w = jaw_frame(h)
    grasp = h.centre + h.normal * (gripper.FINGER_LENGTH - params.grip_depth)  # the palm (= wrist origin)
    start = grasp + h.normal * params.approach
    lo, hi = scene.ids.target_range
    axis = t.joint.axis / np.linalg.norm(t.joint.axis)
    pivot = pos + s * t.joint.origin
    open_dir = opening_direction(t.part, t.joint, t.handle.centre)
    dt = scene.config.timestep * round(1 / 60 / scene.config.timestep)  # the control period
    # Fingers along a horizontal normal put the middle wrist hinge at 90 deg (gimbal lock of the Euler chain):
    # scipy warns, and the angles it returns are still exact for the rotation, which is what the PD targets need.
    warnings.filterwarnings("ignore", message="Gimbal lock detected", category=UserWarning)
    rpy = continuous_euler(R_w, None)
    opened, closed = np.full(2, gripper.FINGER_TRAVEL), np.zeros(2)
    targets = []
    for k in range(steps):
        a = min(1.0, (k + 1) / params.approach_steps)
        c = min(1.0, max(0.0, (k + 1 - params.approach_steps) / params.close_steps))
        pulled = max(0, k + 1 - params.approach_steps - params.close_steps) * dt
        R, palm = R_w, (1 - a) * start + a * grasp
        if pulled and t.joint.is_revolute:
            R_d = axis_angle_matrix(axis, min(params.pull_rate * pulled, hi - lo))
            R, palm = R_d @ R_w, pivot + R_d @ (grasp - pivot)
        elif pulled:
            palm = grasp + min(params.pull_speed * pulled, hi - lo) * open_dir
        rpy = continuous_euler(R, rpy)
        targets.append(np.concatenate([palm, rpy, (1 - c) * opened + c * closed]))
    return np.concatenate([start, continuous_euler(R_w, None), opened]), np.asarray(targets, np.float32)


def parallel_jaw(task: PullTask, params: PrimitiveParams = PrimitiveParams()) -> tuple[PullTask, Controller]:
    """The primitive on ``task``'s object: its own task (the gripper in ``task``'s scene settings, ``task``'s
    config, trajectory boundary and start perturbation) and the controller that drives it."""
    scene = build_scene(task.scene.obj, dataclasses.replace(task.scene.config, effector=PARALLEL_JAW))
    start, targets = primitive_plan(scene, task.config.episode_length, params)
    traj = task.traj
    jaw_task = PullTask(scene, traj, task.config, start=(start, traj.frames[traj.drag_start].joint_positions[
        traj.target_index]))
    return jaw_task, Controller(PARALLEL_JAW, lambda deterministic: replay, jnp.asarray(targets), controls="targets",
                                key=PARALLEL_JAW)
