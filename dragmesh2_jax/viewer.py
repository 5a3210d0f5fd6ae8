"""``dragmesh2 view``: a controller (a trained policy, or the expert drag) driving the task in MuJoCo's interactive
viewer (``mujoco.viewer.launch_passive``), in real time. The task steps on its own engine (the C engine by default);
the viewer shows each control step's state in the scene dressed for pictures (``render.dressed_model``).

Keys: 1, 2, 4, 8 set the damping multiplier (the episode starts again at it); N starts a new episode from the next
perturbed start (the exact expert grasp when the task has no bank). The viewer's own keys and mouse work as usual.
"""

from __future__ import annotations

import os
import sys
import threading
import time

import glfw
import jax
import jax.numpy as jnp
import mujoco
import mujoco.viewer

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.render import dressed_model
from dragmesh2_jax.task.env import PullTask

#: Key codes (GLFW's: the ASCII upper case) -> damping multiplier.
DAMPING_KEYS = {ord("1"): 1.0, ord("2"): 2.0, ord("4"): 4.0, ord("8"): 8.0}
NEW_EPISODE_KEY = ord("N")


def require_display() -> None:
    """One error line where the viewer cannot open a window (no display, or one GLFW cannot reach)."""
    glfw.ERROR_REPORTING = False  # its own report is a warning per call; ours is the one line below
    if not glfw.init():
        shown = os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        raise DragMeshError(f"view needs a display ({f'cannot open {shown}' if shown else 'DISPLAY is not set'}): "
                            "run it on a desktop or under xvfb-run, or write a video with dragmesh2 video")
    glfw.terminate()


def view(task: PullTask, controller: Controller, damping: float = 1.0, steps: int | None = None,
         deterministic: bool = True) -> int:
    """Run ``controller`` on ``task`` in the viewer until it is closed (or for ``steps`` control steps); returns the
    control steps shown. An episode that ends (success, detachment, time limit) starts again."""
    task = task.sized(1)
    policy = controller.make_policy(deterministic)
    act = task.step_target if controller.controls == "targets" else task.step
    reset = jax.jit(lambda key, scale: task.reset(key, scale))

    @jax.jit
    def step(state, key):
        return act(state, policy(controller.params, state.obs, key))

    model = dressed_model(task.scene)
    data = mujoco.MjData(model)
    ids = task.scene.ids
    wanted = {"damping": damping, "restart": True}

    def on_key(code: int) -> None:
        if code in DAMPING_KEYS:
            wanted.update(damping=DAMPING_KEYS[code], restart=True)
        elif code == NEW_EPISODE_KEY:
            wanted["restart"] = True

    key = jax.random.PRNGKey(0)
    shown = 0
    before = set(threading.enumerate())
    with mujoco.viewer.launch_passive(model, data, key_callback=on_key) as v:
        state = None
        while v.is_running() and (steps is None or shown < steps):
            t0 = time.perf_counter()
            key, k_reset, k_act = jax.random.split(key, 3)
            if wanted["restart"] or bool(state.done):
                if wanted["restart"]:
                    print(f"view: damping x{wanted['damping']:g}", file=sys.stderr)
                state = reset(k_reset, jnp.float32(wanted["damping"]))
                wanted["restart"] = False
            else:
                state = step(state, k_act)
            k = task.kinematics(state)
            with v.lock():
                data.qpos[ids.hand_qpos] = k.hand_q
                data.qpos[ids.target_qpos] = k.obj_q
                mujoco.mj_forward(model, data)
            v.sync()
            shown += 1
            time.sleep(max(0.0, task.config.control_dt - (time.perf_counter() - t0)))
    for thread in set(threading.enumerate()) - before:  # the viewer's (daemon) thread: ending the process while it
        thread.join(timeout=10)                           # still tears down its GL context can crash it
    return shown
