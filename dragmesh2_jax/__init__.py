"""dragmesh2_jax: DragMesh-2 (contact-driven dexterous pulling of articulated objects) in JAX/MuJoCo-MJX.

Data flow, one package per stage:
    assets (hand, GAPartNet objects)  ->  scene (MjModel + ids)  ->  physics backend  ->  task
    ->  policies  ->  PPO  ->  evaluation  ->  experiments / reports
"""

from dragmesh2_jax.errors import DragMeshError

__all__ = ["DragMeshError"]
__version__ = "0.1.0"
