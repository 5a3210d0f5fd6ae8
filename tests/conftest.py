"""Shared test fixtures: the ../shared data (a failure, not a skip, when CI=true) and JAX's compile cache."""

from __future__ import annotations

import contextlib
import importlib.util
import os
import shutil
import subprocess
import time
from importlib.metadata import entry_points
from pathlib import Path

import jax
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.train import TrainProgram
from dragmesh2_jax.runs.build import load_task, program_of
from dragmesh2_jax.runs.spec import RunSpec, method_spec
from dragmesh2_jax.scene import build_scene

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("DRAGMESH2_SHARED", ROOT.parent / "shared"))
GAPARTNET = SHARED / "gapartnet"
REAL_OBJECTS = ("45261", "45661", "45780", "11712")


#: The one tiny network and batch of the training tests: every tiny run shares their compiled programs.
#: The xdist group of the modules whose fixtures train tiny PICA runs (``tiny_spec``): on one worker, their epoch and
#: evaluation programs compile once rather than once per worker.
TINY_RUNS = "tiny_runs"
TINY_SIZES = {"state_sizes": (64, 64), "hist_dim": 32, "heads": 2, "critic_sizes": (64,)}  # the method's encoder
TINY_NET = NetworkConfig(**TINY_SIZES)  # and critic: this is PICA's
TINY_PPO = {"num_envs": 4, "rollout_len": 8}
TINY_SCHEDULE = {"epochs": 2}


def tiny_spec(method: str = "pica", obj: str | None = None, backend: str = "mujoco", task: dict | None = None,
              scene: dict | None = None, impl: str = "jax", schedule: dict | None = None, **ppo) -> RunSpec:
    """A method on ``obj`` (default: the packaged drawer) with the tiny network sizes, batch and schedule."""
    return method_spec(method, obj or str(default_object()), {**TINY_PPO, **ppo}, task, scene, backend, impl,
                       TINY_SIZES, schedule={**TINY_SCHEDULE, **(schedule or {})})


def tiny_program(method: str = "pica", obj: str | None = None, backend: str = "mujoco", trajectory=None,
                 task: dict | None = None, impl: str = "jax", **ppo) -> TrainProgram:
    return program_of(tiny_spec(method, obj, backend, task, impl=impl, **ppo), trajectory)


def pytest_collection_modifyitems(items):
    """Tests marked ``long`` (or ``mjx``, which compiles for minutes) first: the workers take whole groups in
    collection order, so the longest start at once instead of running alone at the end."""
    items.sort(key=lambda item: not (item.get_closest_marker("long") or item.get_closest_marker("mjx")))


def in_ci() -> bool:
    """Whether this is CI (``CI=true`` or ``CI=1``, as CI services set it): missing data is a failure there."""
    return os.environ.get("CI", "").lower() in ("true", "1")


def _enable_jax_cache() -> None:
    """A persistent compilation cache for local reruns. Not in CI, where the clone starts with an empty cache (so it
    only adds writes) and where a worker once crashed inside jaxlib while writing an MJX executable to it."""
    if in_ci():
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
    if in_ci():
        pytest.fail(msg)
    pytest.skip(msg)


def require_package(name: str, extra: str | None = None) -> None:
    """An optional package (an extra): a failure under CI (which installs every extra), a skip elsewhere."""
    if importlib.util.find_spec(name) is not None:
        return
    msg = f"{name} is not installed (pip install -e \".[{extra or name}]\")"
    if in_ci():
        pytest.fail(msg)
    pytest.skip(msg)


def require_warp() -> None:
    """MJX's Warp implementation (the ``warp`` extra)."""
    require_package("warp")


@pytest.fixture(scope="session")
def gapartnet_dir() -> Path:
    return require_shared(GAPARTNET)


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    return require_shared(SHARED)


@pytest.fixture(scope="session")
def real_objects(gapartnet_dir):
    """The four real objects, loaded once."""
    return {oid: load_gapartnet(require_shared(gapartnet_dir / oid)) for oid in REAL_OBJECTS}


@pytest.fixture(scope="session")
def real_scenes(real_objects):
    return {oid: build_scene(obj) for oid, obj in real_objects.items()}


@pytest.fixture(scope="session")
def default_scene():
    return build_scene(load_gapartnet(default_object()))


@pytest.fixture(scope="session")
def drawer_task():
    """The packaged drawer with a generated trajectory, on the C backend (compiles in ~1 s)."""
    return load_task(str(default_object()), None, backend="mujoco")


@contextlib.contextmanager
def read_only(folder: Path):
    """``folder`` (created, with what it holds) on read-only storage for the block: a read-only bind mount where this
    process may mount (root, as in CI: permission bits do not stop root), else its permission bits."""
    folder.mkdir(parents=True, exist_ok=True)
    mounted = os.geteuid() == 0 and subprocess.run(
        ["mount", "--bind", str(folder), str(folder)], capture_output=True).returncode == 0
    if mounted:
        subprocess.run(["mount", "-o", "remount,bind,ro", str(folder)], check=True, capture_output=True)
    elif os.geteuid() == 0:
        pytest.fail("root, but a read-only bind mount could not be made") if in_ci() else pytest.skip("no mount")
    else:
        modes = {p: p.stat().st_mode for p in [folder, *folder.rglob("*")] if p.is_dir()}
        for p in modes:
            p.chmod(0o555)
    try:
        yield folder
    finally:
        if mounted:
            subprocess.run(["umount", str(folder)], check=True, capture_output=True)
        else:
            for p, mode in modes.items():
                p.chmod(mode)


@contextlib.contextmanager
def small_filesystem(folder: Path, size: str = "1m"):
    """``folder`` (created, empty) as a real filesystem of ``size`` bytes (a tmpfs) for the block: a full disk that is
    the operating system's, not a patched write. Mounting needs root (CI's case: a failure there, a skip elsewhere)."""
    folder.mkdir(parents=True, exist_ok=True)
    mount = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], capture_output=True)
    if mount.returncode != 0:
        why = f"a {size} filesystem could not be mounted: {mount.stderr.decode().strip()}"
        pytest.fail(why) if in_ci() else pytest.skip(why)
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], check=True, capture_output=True)


def grow(folder: Path, size: str) -> None:
    """A ``small_filesystem`` given more room, what it holds kept."""
    subprocess.run(["mount", "-o", f"remount,size={size}", str(folder)], check=True, capture_output=True)


def fill(folder: Path, leave: int) -> Path:
    """Fill ``folder``'s filesystem but ``leave`` bytes (about: its blocks round) with one file; returns it."""
    stat = os.statvfs(folder)
    filler = folder / "filler"
    filler.write_bytes(b"\0" * max(0, stat.f_bavail * stat.f_frsize - leave))
    return filler


@pytest.fixture
def display():
    """A virtual screen (Xvfb, which CI installs) for the viewer: its DISPLAY name."""
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        if in_ci():
            pytest.fail("Xvfb is not installed (CI installs it: apt-get install xvfb)")
        pytest.skip("no Xvfb here")
    number = 90 + os.getpid() % 9
    server = subprocess.Popen([xvfb, f":{number}", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def installed_command():
    """The ``dragmesh2`` command as installed (its console-script entry point), to call in-process."""
    (ep,) = entry_points(group="console_scripts", name="dragmesh2")
    return ep.load()
