"""dragmesh2_jax: DragMesh-2 (contact-driven dexterous pulling of articulated objects) in JAX/MuJoCo-MJX.

Data flow, one package per stage:
    assets (hand, GAPartNet objects)  ->  scene (MjModel + ids)  ->  physics backend  ->  task
    ->  policies  ->  PPO  ->  evaluation  ->  experiments / reports
"""

import importlib.util

from dragmesh2_jax.errors import DragMeshError

if importlib.util.find_spec("warp") is not None:  # MJX's Warp implementation (the ``warp`` extra)
    import warp

    warp.config.log_level = warp.LOG_WARNING  # before it starts: its start-up lines go to stdout, with a command's JSON

__all__ = ["DragMeshError"]
__version__ = "0.1.0"
