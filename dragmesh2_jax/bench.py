"""``dragmesh2 bench env``: physics throughput of the pulling task per backend and batch size."""

from __future__ import annotations

import os
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.task.env import PullTask, make_batched


def machine() -> dict:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")), cpu)
    except OSError:
        pass
    devs = jax.devices()
    return {"cpu": cpu, "cores": os.cpu_count(), "jax_backend": jax.default_backend(),
            "device": str(devs[0].device_kind if devs else "?"), "jax": jax.__version__}


def bench_env(task: PullTask, num_envs: int, steps: int, seed: int = 0) -> dict:
    """Time ``steps`` control steps of ``num_envs`` worlds with random actions (compile timed separately)."""
    if task.backend.name == "mjx":
        from dragmesh2_jax.physics.mjx_backend import warn_cpu_batch

        warn_cpu_batch(num_envs)
    reset, step = make_batched(task)
    keys = jax.random.split(jax.random.PRNGKey(seed), num_envs)
    actions = jnp.asarray(np.random.default_rng(seed).uniform(-1, 1, (steps, num_envs, 51)).astype(np.float32))

    @jax.jit
    def run(keys, actions):
        s = reset(keys)
        s, _ = jax.lax.scan(lambda s, a: (step(s, a), None), s, actions)
        return s.obs.state

    t0 = time.perf_counter()
    compiled = run.lower(keys, actions).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(compiled(keys, actions))  # warm
    t0 = time.perf_counter()
    jax.block_until_ready(compiled(keys, actions))
    dt = time.perf_counter() - t0
    ctrl = num_envs * steps / dt
    return {"backend": task.backend.name, "num_envs": num_envs, "steps": steps, "compile_s": round(compile_s, 3),
            "control_steps_per_s": round(ctrl, 1), "physics_steps_per_s": round(ctrl * task.substeps, 1),
            "wall_s": round(dt, 4), "object": task.scene.obj.object_id, **machine()}
