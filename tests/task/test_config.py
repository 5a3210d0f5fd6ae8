"""The task's configuration (task/config.py): the engine ``auto`` picks where it runs."""

import importlib.util

import jax
import pytest

from dragmesh2_jax.task import config as config_module
from dragmesh2_jax.task.config import TaskConfig


@pytest.mark.parametrize(("device", "warp", "backend", "impl"), [
    ("cpu", True, "mujoco", "jax"),  # a CPU steps the C engine; MJX asked for there is MJX-JAX
    ("gpu", True, "mjx", "warp"),  # a GPU steps MJX, Warp where it is installed (3.7x MJX-JAX there)
    ("gpu", False, "mjx", "jax"),
])
def test_auto_picks_the_c_engine_on_a_cpu_and_warp_on_a_gpu_where_installed(monkeypatch, device, warp, backend, impl):
    monkeypatch.setattr(jax, "default_backend", lambda: device)
    find = importlib.util.find_spec
    monkeypatch.setattr(config_module.importlib.util, "find_spec",
                        lambda name, *a: (find("jax") if warp else None) if name == "warp" else find(name, *a))
    auto = TaskConfig()
    assert (auto.backend, auto.impl) == ("auto", "auto")
    assert (auto.resolved_backend(), auto.resolved_impl()) == (backend, impl)
    assert TaskConfig(impl="jax").resolved_impl() == "jax"  # a choice given is kept
