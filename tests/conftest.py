"""Shared test fixtures: the ../shared data (a failure, not a skip, when CI=true) and JAX's compile cache."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("DRAGMESH2_SHARED", ROOT.parent / "shared"))
GAPARTNET = SHARED / "gapartnet"
REAL_OBJECTS = ("45261", "45661", "45780", "11712")


def _enable_jax_cache() -> None:
    """A persistent compilation cache for local reruns. Not in CI, where the clone starts with an empty cache (so it
    only adds writes) and where a worker once crashed inside jaxlib while writing an MJX executable to it."""
    if os.environ.get("CI") == "true":
        return
    try:
        import jax
    except ImportError:
        return
    cache = os.environ.get("JAX_COMPILATION_CACHE_DIR", str(ROOT / ".cache" / "jax"))
    jax.config.update("jax_compilation_cache_dir", cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)


_enable_jax_cache()


def require_shared(path: Path) -> Path:
    """Return ``path`` if it exists; otherwise fail under CI (missing data is an error there), skip elsewhere."""
    if path.exists():
        return path
    msg = f"{path} is missing (tests read the real objects from ../shared)"
    if os.environ.get("CI", "").lower() == "true":
        pytest.fail(msg)
    pytest.skip(msg)


@pytest.fixture(scope="session")
def gapartnet_dir() -> Path:
    return require_shared(GAPARTNET)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    return require_shared(SHARED)


@pytest.fixture(scope="session")
def real_objects(gapartnet_dir):
    """The four real objects, loaded once."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet

    return {oid: load_gapartnet(require_shared(gapartnet_dir / oid)) for oid in REAL_OBJECTS}


@pytest.fixture(scope="session")
def real_scenes(real_objects):
    from dragmesh2_jax.scene import build_scene

    return {oid: build_scene(obj) for oid, obj in real_objects.items()}


@pytest.fixture(scope="session")
def default_scene():
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.scene import build_scene

    return build_scene(load_gapartnet(default_object()))


@pytest.fixture(scope="session")
def drawer_task():
    """The packaged drawer with a generated trajectory, on the C backend (compiles in ~1 s)."""
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.runs import load_task

    return load_task(str(default_object()), None, backend="mujoco")


def installed_command():
    """The ``dragmesh2`` command as installed (its console-script entry point), to call in-process."""
    from importlib.metadata import entry_points

    (ep,) = entry_points(group="console_scripts", name="dragmesh2")
    return ep.load()
