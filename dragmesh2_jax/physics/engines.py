"""What the physics engines need from the process before and beside them, apart from the engines themselves (so that
the CLI and the benchmarks can check and prepare for MJX without importing it: ``task/env.py`` imports MJX only when a
task chooses it)."""

from __future__ import annotations

import importlib.util
import os
import sys

import jax
import jaxlib
from jax._src import xla_bridge

from dragmesh2_jax.errors import DragMeshError


def avoid_lapack_deadlock() -> None:
    """Start JAX's CPU client with a one-thread intra-op pool when jaxlib < 0.11.

    jaxlib 0.10's CPU LAPACK kernels split a large batched Cholesky (MJX's Newton solver and implicitfast
    integrator, from about 5 worlds of the hand task) into chunks on XLA's intra-op pool and wait for them on a
    pool thread; two such calls at once on a 2-thread pool wait for each other forever (jax-ml/jax#36927, fixed
    in 0.11; RESULTS.md §1). The pool is sized from the CPU affinity when the client starts, so the client is
    started with one CPU and the affinity restored: the C engine's threads and everything else keep every core.
    It must run before anything starts JAX's backends (``MjxBackend`` and the CLI call it); when too late, it
    warns once."""
    version = tuple(int(x) for x in jaxlib.__version__.split(".")[:2])
    if version >= (0, 11) or not hasattr(os, "sched_setaffinity") or _accelerator_plugin():
        return
    cpus = os.sched_getaffinity(0)
    if len(cpus) == 1 or _DONE:
        return
    _DONE.append(True)
    if xla_bridge.backends_are_initialized():
        if jax.default_backend() == "cpu":
            print(f"warning: MJX on a CPU with jaxlib {jaxlib.__version__} can deadlock from about 5 worlds when JAX "
                  "started before the MJX backend was built (RESULTS.md §1); build it first, or run under "
                  "`taskset -c 0`", file=sys.stderr)
        return
    os.sched_setaffinity(0, {min(cpus)})
    try:
        jax.devices()
    finally:
        os.sched_setaffinity(0, cpus)


_DONE: list[bool] = []  # pinned (or warned) once per process


def _accelerator_plugin() -> bool:
    """Whether JAX may start an accelerator client here (a CUDA/ROCm plugin is installed and the platforms are
    not restricted to the CPU): then the pin is not ours to make (an accelerator's host threads need the cores)."""
    platforms = os.environ.get("JAX_PLATFORMS") or jax.config.jax_platforms or ""
    if platforms.strip().lower() == "cpu":
        return False
    return any(importlib.util.find_spec(m) is not None for m in ("jax_cuda12_plugin", "jax_cuda13_plugin",
                                                                "jax_rocm60_plugin", "jax_rocm7_plugin"))


def require_impl(impl: str) -> None:
    """One error line when MJX's ``impl`` cannot run here (Warp without its extra)."""
    if impl == "warp" and importlib.util.find_spec("warp") is None:
        raise DragMeshError("MJX's Warp implementation needs warp-lang (pip install -e \".[warp]\")")
