"""``dragmesh2 bench env``: physics throughput of the pulling task per backend and batch size;
``dragmesh2 bench train``: PPO epochs per second, compile time and the paper's per-object budget, one run or a
seed-vmapped column of runs as one program; ``dragmesh2 bench learning``: short training curves compared with
recorded ones (the learning regression check to run before a change to the task, policies or PPO lands)."""

from __future__ import annotations

import os
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.physics.engines import require_impl
from dragmesh2_jax.ppo.config import PAPER_EPOCHS
from dragmesh2_jax.ppo.train import TrainProgram, epoch_jit, epoch_runs, init_jit, init_runs, run_mesh, seed_keys
from dragmesh2_jax.runs.build import load_task, mix_of, program_of, template_slots
from dragmesh2_jax.runs.spec import method_spec
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import make_batched
from dragmesh2_jax.task.protocol import Env
from dragmesh2_jax.task.wrappers import AutoReset


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


def engine_name(task: Env) -> str:
    """``mujoco`` (the C engine), ``mjx-jax`` or ``mjx-warp``."""
    return task.engine if task.engine == "mujoco" else f"{task.engine}-{task.config.resolved_impl()}"


def buffers(task: Env) -> dict:
    """Contact slots and constraint rows one world of the task's engine holds (the C engine's grow as needed)."""
    return task.buffers if task.budget is None else {**task.buffers, "budget": task.budget.to_json()}


def _env_run(task: Env, num_envs: int, steps: int, seed: int = 0):
    """``steps`` control steps of ``num_envs`` worlds with random actions, compiled: (run, the batch's task, compile
    seconds); ``run()`` steps them and returns the world-steps that overflowed."""
    task = task.sized(num_envs)
    reset, step = make_batched(AutoReset(task))
    keys = jax.random.split(jax.random.PRNGKey(seed), num_envs)
    actions = jnp.asarray(np.random.default_rng(seed).uniform(-1, 1, (steps, num_envs, NUM_DOFS)).astype(np.float32))

    @jax.jit
    def run(keys, actions):
        s = reset(keys)

        def body(s, a):
            s = step(s, a)
            return s, s.metrics["overflow"].sum()

        s, overflow = jax.lax.scan(body, s, actions)
        return s.obs.state, overflow.sum()

    t0 = time.perf_counter()
    compiled = run.lower(keys, actions).compile()
    compile_s = time.perf_counter() - t0
    return (lambda: int(jax.block_until_ready(compiled(keys, actions))[1])), task, compile_s


def _timed(run) -> tuple[float, int]:
    t0 = time.perf_counter()
    overflow = run()
    return time.perf_counter() - t0, overflow


def _env_row(task: Env, num_envs: int, steps: int, compile_s: float, dt: float) -> dict:
    ctrl = num_envs * steps / dt
    return {"backend": task.engine, "engine": engine_name(task), "num_envs": num_envs, "steps": steps,
            "compile_s": round(compile_s, 3), "control_steps_per_s": round(ctrl, 1),
            "physics_steps_per_s": round(ctrl * task.substeps, 1), "wall_s": round(dt, 4),
            "object": task.object_id, "objects": len(task.trajectories), **buffers(task), **machine()}


def bench_env(task: Env, num_envs: int, steps: int, seed: int = 0) -> dict:
    """Time ``steps`` control steps of ``num_envs`` worlds with random actions (compile timed separately)."""
    run, task, compile_s = _env_run(task, num_envs, steps, seed)
    run()  # warm
    dt, overflow = _timed(run)
    task.check_overflow(overflow, "bench env")
    return _env_row(task, num_envs, steps, compile_s, dt)


def bench_env_pair(task: Env, baseline: Env, num_envs: int, steps: int, rounds: int = 5, seed: int = 0) -> dict:
    """``task`` against ``baseline`` side by side (both compiled first, then timed in turn ``rounds`` times, so a
    drift of the machine's speed reaches both): each one's row at its median time and the ratio of their rates pair
    by pair (``ratio``: the median, ``ratio_min``/``ratio_max``)."""
    runs = [_env_run(t, num_envs, steps, seed) for t in (task, baseline)]
    for run, _, _ in runs:
        run()  # warm
    times = [[], []]
    for _ in range(rounds):
        for i, (run, t, _) in enumerate(runs):
            dt, overflow = _timed(run)
            t.check_overflow(overflow, "bench env")
            times[i].append(dt)
    rows = [_env_row(t, num_envs, steps, c, float(np.median(ts))) for (_, t, c), ts in zip(runs, times, strict=True)]
    return {"task": rows[0], "baseline": rows[1], **_ratios(*times)}


def _ratios(times: list[float], baseline: list[float]) -> dict:
    """The rate of a program over its baseline's, pair by pair (each pair timed in turn): the median and the range."""
    ratios = np.asarray(baseline) / np.asarray(times)
    return {"rounds": len(times), "ratio": round(float(np.median(ratios)), 3),
            "ratio_min": round(float(ratios.min()), 3), "ratio_max": round(float(ratios.max()), 3)}


def bench_train(program: TrainProgram, epochs: int, runs: int = 1) -> dict:
    """Time one compiling epoch and ``epochs`` more of ``program`` (``runs`` > 1: that many seeds as one
    vmapped program, sharded over the devices when they divide it). A second program of the same signature
    (another object of the same structure) finds it compiled: its first epoch shows it. ``budget_s``: the
    compiling epoch and 149 more at this batch (the paper's per-object budget at 64 envs)."""
    data = program.data(runs)
    if runs > 1:
        mesh = run_mesh(runs)
        ts = init_runs(program, data, seed_keys(list(range(runs))))
        epoch = lambda ts: epoch_runs(program, data, ts, mesh)  # noqa: E731
    else:
        ts = init_jit(program, data, seed_keys([0])[0])
        epoch = lambda ts: epoch_jit(program, data, ts)  # noqa: E731
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
    c = program.config
    steps = runs * c.num_envs * c.rollout_len
    return {"method": program.name, "backend": program.task.engine, "num_envs": c.num_envs,
            "runs": runs, "object": program.task.object_id, "first_epoch_s": round(first, 2),
            "s_per_epoch": round(per, 4), "env_steps_per_s": round(steps / per, 1),
            "physics_steps_per_s": round(steps * program.task.substeps / per, 1),
            "budget_s": round(first + (PAPER_EPOCHS - 1) * per, 1), **machine()}


def bench_train_pair(program: TrainProgram, baseline: TrainProgram, epochs: int = 2, rounds: int = 3) -> dict:
    """``program`` against ``baseline`` side by side: both compiled (each one's first epoch timed), then ``epochs``
    epochs of each in turn ``rounds`` times; each one's row at its median seconds per epoch and the ratio of their
    rates pair by pair (``ratio``: the median, ``ratio_min``/``ratio_max``)."""
    runs = []
    for p in (program, baseline):
        data = p.data()
        ts = jax.block_until_ready(init_jit(p, data, seed_keys([0])[0]))
        t0 = time.perf_counter()
        ts = jax.block_until_ready(epoch_jit(p, data, ts)[0])
        runs.append([p, data, ts, time.perf_counter() - t0, []])
    for _ in range(rounds):
        for run in runs:
            p, data, ts = run[:3]
            t0 = time.perf_counter()
            for _ in range(epochs):
                ts, _ = epoch_jit(p, data, ts)
            run[2] = jax.block_until_ready(ts)
            run[4].append((time.perf_counter() - t0) / epochs)
    rows = []
    for p, _, _, first, per in runs:
        steps, s = p.config.num_envs * p.config.rollout_len, float(np.median(per))
        rows.append({"method": p.name, "engine": engine_name(p.task), "objects": len(p.task.trajectories),
                     "num_envs": p.config.num_envs, "first_epoch_s": round(first, 2), "s_per_epoch": round(s, 4),
                     "physics_steps_per_s": round(steps * p.task.substeps / s, 1), **machine()})
    return {"program": rows[0], "baseline": rows[1], **_ratios(runs[0][4], runs[1][4])}


def bench_soak(task: Env, dampings: list[float], num_envs: int, steps: int, seed: int = 0) -> list[dict]:
    """Random actions in [-1, 1] for ``steps`` control steps in ``num_envs`` worlds per damping multiplier, all in
    one rollout: per damping the worlds whose physics went non-finite (the task resets and counts each, and the rest
    of the batch goes on: the batch's final observations are checked finite)."""
    n = len(dampings) * num_envs
    scales = jnp.repeat(jnp.asarray(dampings, jnp.float32), num_envs)
    task = task.sized(n)
    reset, step = make_batched(AutoReset(task))

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
        rows.append({"object": task.object_id, "backend": task.engine, "damping": d,
                     "worlds": num_envs, "physics_steps": num_envs * steps * task.substeps,
                     "nonfinite_events": int(bad[w].sum()), "nonfinite_worlds": int((bad[w] > 0).sum()),
                     "episodes": int(episodes[w].sum()), "batch_finite": bool(finite[w].all()),
                     "wall_s_all_dampings": round(wall, 2)})
    return rows


# ------------------------------------------------------------------ sweeps behind ``dragmesh2 bench``
def bench_env_sweep(objects: list[str] | None, trajectory: str | None, backends: list[str], num_envs: list[int],
                    steps: int, mjx_steps: int | None = None, impls: tuple[str, ...] = ("jax",),
                    report=None) -> list[dict]:
    """``bench_env`` for every engine (the C engine, and MJX in each of ``impls``) x batch size on one object
    (default: the packaged drawer), or on several mixed in one batch (each world steps one of them, as training over
    several objects does); MJX may take fewer steps (``mjx_steps``: it is slow on a CPU). ``report(row)`` sees each
    row as it is measured."""
    rows = []
    engines = [(b, i) for b in backends for i in (impls if b == "mjx" else ("jax",))]
    for backend, impl in engines:  # every engine asked for can run, before anything is measured
        TaskConfig(backend=backend, impl=impl)
        if backend == "mjx":
            require_impl(impl)
    objects = objects or [str(default_object())]
    for backend, impl in engines:
        slots = template_slots(len(objects), TaskConfig(backend=backend, impl=impl))
        task = mix_of([load_task(o, trajectory if len(objects) == 1 else None, backend, impl, slots=slots)
                       for o in objects])
        for n in num_envs:
            rows.append(bench_env(task, n, mjx_steps if backend == "mjx" and mjx_steps else steps))
            if report:
                report(rows[-1])
    return rows


def bench_train_sweep(objects: list[str] | None, method: str, backend: str, num_envs: list[int], runs: list[int],
                      epochs: int, impl: str = "auto", report=None) -> list[dict]:
    """``bench_train`` for every object x batch size x run count (objects of one structure share a program)."""
    rows = []
    for obj in objects or [str(default_object())]:
        for n in num_envs:
            for r in runs:
                spec = method_spec(method, obj, {"num_envs": n}, backend=backend, impl=impl)
                rows.append(bench_train(program_of(spec), epochs, r))
                if report:
                    report(rows[-1])
    return rows


def bench_soak_sweep(objects: list[str] | None, dampings: list[float], num_envs: int, steps: int, seed: int = 0,
                     backend: str = "auto", impl: str = "auto") -> list[dict]:
    """``bench_soak`` on every object (default: the packaged drawer)."""
    rows = []
    for obj in objects or [str(default_object())]:
        rows += bench_soak(load_task(obj, None, backend, impl), dampings, num_envs, steps, seed)
    return rows


# ------------------------------------------------------------------------------- learning regression
#: Training metrics the learning check records per epoch and seed.
CURVE_KEYS = ("success", "progress", "detach")
COLLAPSE_WINDOW = 5  # trailing epochs in which detachment and progress both near zero is a collapse
COLLAPSE_LEVEL = 0.05


#: What ``bench learning`` trains when nothing is recorded or given: a short curve per seed.
LEARNING_METHOD, LEARNING_EPOCHS, LEARNING_SEEDS = "pica", 40, (0, 1, 2)


def learning_curves(objects: list[str], method: str = LEARNING_METHOD, epochs: int = LEARNING_EPOCHS,
                    seeds: tuple[int, ...] = LEARNING_SEEDS,
                    backend: str = "mujoco", report=None) -> dict:
    """Per object, ``method`` trained ``epochs`` epochs from each seed (the seeds as one program) with the paper's
    batch: the training success, progress and detachment of every epoch and seed. ``report(object, row)`` sees the
    mean over seeds of each epoch."""
    t0 = time.perf_counter()
    curves = {}
    for obj in objects:
        program = program_of(method_spec(method, obj, backend=backend))
        data = program.data(len(seeds))
        ts = init_runs(program, data, seed_keys(list(seeds)))
        rows = {k: [] for k in CURVE_KEYS}
        for e in range(epochs):
            ts, m = epoch_runs(program, data, ts)
            m = jax.device_get(m)
            for k in CURVE_KEYS:
                rows[k].append([round(float(x), 4) for x in np.asarray(m[k])])
            if report:
                report(obj, {"epoch": e + 1, **{k: float(np.mean(rows[k][-1])) for k in CURVE_KEYS}})
        curves[obj] = rows
    return {"method": method, "epochs": epochs, "seeds": list(seeds), "backend": backend, "curves": curves,
            "wall_s": round(time.perf_counter() - t0, 1), **machine()}


def learning_regressions(current: dict, recorded: dict, tolerance: float) -> list[str]:
    """What got worse in ``current`` against ``recorded`` (curves of :func:`learning_curves`): a seed whose
    training collapsed to holding still (detachment and progress both under 0.05 over the last epochs), or an
    object whose final success (last epochs, mean over seeds) fell more than ``tolerance`` below the record."""
    problems = []
    for obj, rows in current["curves"].items():
        tail = {k: np.asarray(v[-COLLAPSE_WINDOW:]) for k, v in rows.items()}
        still = np.all((tail["detach"] < COLLAPSE_LEVEL) & (tail["progress"] < COLLAPSE_LEVEL), axis=0)
        problems += [f"{obj}: seed {s} collapsed to holding still (detach and progress < {COLLAPSE_LEVEL} over the "
                     f"last {COLLAPSE_WINDOW} epochs)" for s, bad in zip(current["seeds"], still, strict=True) if bad]
        if obj in recorded["curves"]:
            now = float(tail["success"].mean())
            then = float(np.mean(recorded["curves"][obj]["success"][-COLLAPSE_WINDOW:]))
            if now < then - tolerance:
                problems.append(f"{obj}: final training success {now:.2f}, recorded {then:.2f} (tolerance {tolerance})")
    return problems
