"""dragmesh2_jax: DragMesh-2 (contact-driven dexterous pulling of articulated objects) in JAX/MuJoCo-MJX.

Data flow, one package per stage:
    assets (hand, GAPartNet objects)  ->  scene (MjModel + ids)  ->  physics backend  ->  task
    ->  policies  ->  PPO  ->  evaluation  ->  experiments / reports
"""

import ctypes.util
import os
from pathlib import Path

from dragmesh2_jax.errors import DragMeshError


def _choose_gl() -> None:
    """MuJoCo's GL backend, chosen before MuJoCo loads (it reads ``MUJOCO_GL`` once): a display's own where there is
    one, else EGL on an NVIDIA GPU machine, else OSMesa where libosmesa6 is installed (CPU rendering); an explicit
    ``MUJOCO_GL`` is left alone. Without any, pictures fall back to matplotlib (``render.py`` says why)."""
    if os.environ.get("MUJOCO_GL") or os.environ.get("DISPLAY"):
        return
    if Path("/dev/nvidiactl").exists() and ctypes.util.find_library("EGL"):
        os.environ["MUJOCO_GL"] = "egl"
    elif ctypes.util.find_library("OSMesa"):
        os.environ["MUJOCO_GL"] = "osmesa"


_choose_gl()

__all__ = ["DragMeshError"]
__version__ = "0.1.0"
