"""``dragmesh2 bench env``: physics throughput of the pulling task per backend and batch size;
``dragmesh2 bench train``: PPO epochs per second, compile time and the paper's per-object budget, one run or a
seed-vmapped column of runs as one program."""

from __future__ import annotations

import os
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS
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
    reset, step = make_batched(task)
    keys = jax.random.split(jax.random.PRNGKey(seed), num_envs)
    actions = jnp.asarray(np.random.default_rng(seed).uniform(-1, 1, (steps, num_envs, NUM_DOFS)).astype(np.float32))

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


PAPER_EPOCHS = 150  # the paper's per-object budget: 150 epochs x 64 envs x 32 steps


def bench_train(trainer, epochs: int, runs: int = 1) -> dict:
    """Time one compiling epoch and ``epochs`` more of ``trainer`` (``runs`` > 1: that many seeds as one
    vmapped program, sharded over the devices when they divide it). A second trainer of the same signature
    (another object of the same structure) finds the program compiled: its first epoch shows it. ``budget_s``:
    the compiling epoch and 149 more at this batch (the paper's per-object budget at 64 envs)."""
    from dragmesh2_jax.ppo.runner import run_mesh

    if runs > 1:
        mesh = run_mesh(runs)
        ts = trainer.init_runs(list(range(runs)))
        epoch = lambda ts: trainer.epoch_runs(ts, mesh)  # noqa: E731
    else:
        ts, epoch = trainer.init(), trainer.epoch
    jax.block_until_ready(ts)
    t0 = time.perf_counter()
    ts, _ = epoch(ts)
    jax.block_until_ready(ts)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    for _ in range(epochs):
        ts, _ = epoch(ts)
    jax.block_until_ready(ts)
    per = (time.perf_counter() - t0) / epochs
    c = trainer.config
    steps = runs * c.num_envs * c.rollout_len
    return {"method": trainer.method.name, "backend": trainer.task.backend.name, "num_envs": c.num_envs,
            "runs": runs, "object": trainer.task.scene.obj.object_id, "first_epoch_s": round(first, 2),
            "s_per_epoch": round(per, 4), "env_steps_per_s": round(steps / per, 1),
            "physics_steps_per_s": round(steps * trainer.task.substeps / per, 1),
            "budget_s": round(first + (PAPER_EPOCHS - 1) * per, 1), **machine()}


def bench_soak(task: PullTask, dampings: list[float], num_envs: int, steps: int, seed: int = 0) -> list[dict]:
    """Random actions in [-1, 1] for ``steps`` control steps in ``num_envs`` worlds per damping multiplier, all in
    one rollout: per damping the worlds whose physics went non-finite (the task resets and counts each, and the rest
    of the batch goes on: the batch's final observations are checked finite)."""
    n = len(dampings) * num_envs
    scales = jnp.repeat(jnp.asarray(dampings, jnp.float32), num_envs)
    reset, step = make_batched(task)

    @jax.jit
    def run(key):
        k_reset, k_act = jax.random.split(key)
        s = reset(jax.random.split(k_reset, n), scales)

        def body(s, k):
            s = step(s, jax.random.uniform(k, (n, NUM_DOFS), minval=-1.0, maxval=1.0))
            return s, (s.metrics["nonfinite"], s.done)

        s, (bad, done) = jax.lax.scan(body, s, jax.random.split(k_act, steps))
        finite = jnp.all(jnp.stack([jnp.all(jnp.isfinite(x.reshape(n, -1)), axis=1)
                                    for x in jax.tree.leaves(s.obs)]), axis=0)
        return bad.sum(0), done.sum(0), finite

    t0 = time.perf_counter()
    bad, episodes, finite = (np.asarray(x) for x in jax.device_get(run(jax.random.PRNGKey(seed))))
    wall = time.perf_counter() - t0
    rows = []
    for i, d in enumerate(dampings):
        w = slice(i * num_envs, (i + 1) * num_envs)
        rows.append({"object": task.scene.obj.object_id, "backend": task.backend.name, "damping": d,
                     "worlds": num_envs, "physics_steps": num_envs * steps * task.substeps,
                     "nonfinite_events": int(bad[w].sum()), "nonfinite_worlds": int((bad[w] > 0).sum()),
                     "episodes": int(episodes[w].sum()), "batch_finite": bool(finite[w].all()),
                     "wall_s_all_dampings": round(wall, 2)})
    return rows


# ------------------------------------------------------------------ sweeps behind ``dragmesh2 bench``
def bench_env_sweep(object_dir: str | None, trajectory: str | None, backends: list[str], num_envs: list[int],
                    steps: int, mjx_steps: int | None = None, impl: str = "jax", report=None) -> list[dict]:
    """``bench_env`` for every backend x batch size on one object (default: the packaged drawer); MJX may take
    fewer steps (``mjx_steps``: it is slow on a CPU). ``report(row)`` sees each row as it is measured."""
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.runs import load_task

    rows = []
    for backend in backends:
        task = load_task(object_dir or str(default_object()), trajectory, backend, impl)
        for n in num_envs:
            rows.append(bench_env(task, n, mjx_steps if backend == "mjx" and mjx_steps else steps))
            if report:
                report(rows[-1])
    return rows


def bench_train_sweep(objects: list[str] | None, method: str, backend: str, num_envs: list[int], runs: list[int],
                      epochs: int, impl: str = "jax", report=None) -> list[dict]:
    """``bench_train`` for every object x batch size x run count (objects of one structure share a program)."""
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.runs import make_trainer

    rows = []
    for obj in objects or [str(default_object())]:
        for n in num_envs:
            for r in runs:
                rows.append(bench_train(make_trainer(obj, None, method, backend, impl, num_envs=n), epochs, r))
                if report:
                    report(rows[-1])
    return rows


def bench_soak_sweep(objects: list[str] | None, dampings: list[float], num_envs: int, steps: int, seed: int = 0,
                     backend: str = "auto", impl: str = "jax") -> list[dict]:
    """``bench_soak`` on every object (default: the packaged drawer)."""
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.runs import load_task

    rows = []
    for obj in objects or [str(default_object())]:
        rows += bench_soak(load_task(obj, None, backend, impl), dampings, num_envs, steps, seed)
    return rows
