"""Compiled programs at scale: the object is data (objects of one structure share a compiled epoch), seeds train
as one vmapped program that equals separate runs, the run axis shards over devices, and a multi-seed run
resumes exactly."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import numpy as np

from dragmesh2_jax.assets.procedural import default_object, synthesize
from dragmesh2_jax.ppo.train import (
    epoch_jit,
    epoch_runs,
    init_jit,
    init_runs,
    seed_keys,
    take_run,
)
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from tests.conftest import tiny_program, tiny_spec

OBJ = str(default_object())


def _close(a, b, tol=2e-3):
    """Equal within float tolerance: a batched matmul may round differently from an unbatched one."""
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_allclose(np.asarray(x, np.float64), np.asarray(y, np.float64), rtol=tol, atol=tol)


def _first_epochs(programs):
    """One epoch of each program from its own init; the compiled epochs jax's cache gained for them."""
    before = epoch_jit._cache_size()
    states = []
    for p in programs:
        ts, m = epoch_jit(p, p.task.data, init_jit(p, p.task.data, jax.random.PRNGKey(0)))
        assert np.isfinite(float(m["loss"]))
        states.append(ts)
    return states, epoch_jit._cache_size() - before


def test_objects_of_the_same_structure_share_one_compiled_epoch(tmp_path):
    """Two procedural doors of different sizes (other meshes, other joint limits) and one PPO epoch program."""
    a, b = synthesize("door_cabinet", 2, 0, tmp_path)
    programs = [tiny_program("pica", str(p)) for p in (a, b)]
    assert programs[0] == programs[1] and programs[0].task is not programs[1].task
    states, compiled = _first_epochs(programs)
    assert compiled <= 1  # compiled once (or found compiled), run for both objects
    # each ran on its own object: the handle the observation reports is that object's
    for t, ts in zip(programs, states, strict=True):
        k = jax.vmap(t.task.kinematics)(ts.env_state)
        np.testing.assert_allclose(np.asarray(ts.env_state.obs.state[:, 102:105]), np.asarray(k.handle_pos),
                                   atol=1e-5)
    h0, h1 = (np.asarray(ts.env_state.obs.state[0, 102:105]) for ts in states)
    assert np.linalg.norm(h0 - h1) > 1e-3


def test_seed_vmapped_training_equals_separate_runs():
    p = tiny_program()
    data = p.task.data
    runs = init_runs(p, data, seed_keys([0, 1]))
    for _ in range(2):
        runs, m_runs = epoch_runs(p, data, runs)
    for i, seed in enumerate((0, 1)):
        ts = init_jit(p, data, seed_keys([seed])[0])
        for _ in range(2):
            ts, m = epoch_jit(p, data, ts)
        _close(take_run(runs, i).params, ts.params)
        np.testing.assert_allclose(float(m_runs["loss"][i]), float(m["loss"]), rtol=2e-3)
    assert not np.allclose(np.asarray(m_runs["loss"][0]), np.asarray(m_runs["loss"][1]))  # seeds differ


SHARDED = textwrap.dedent("""
    import json, sys
    import jax, numpy as np
    from dragmesh2_jax.ppo.train import epoch_runs, init_runs, run_mesh, seed_keys
    from tests.conftest import tiny_program

    p = tiny_program(obj=sys.argv[1])
    mesh = run_mesh(4)
    one = sharded = init_runs(p, p.task.data, seed_keys([0, 1, 2, 3]))
    one, m1 = epoch_runs(p, p.task.data, one)
    sharded, m4 = epoch_runs(p, p.task.data, sharded, mesh)
    diff = max(float(np.max(np.abs(np.asarray(a) - np.asarray(b))))
               for a, b in zip(jax.tree.leaves(one.params), jax.tree.leaves(sharded.params)))
    leaf = jax.tree.leaves(sharded.params)[0]
    print(json.dumps({"devices": jax.device_count(), "mesh": None if mesh is None else mesh.size, "diff": diff,
                      "shards": len(leaf.sharding.device_set), "loss1": np.asarray(m1["loss"]).tolist(),
                      "loss4": np.asarray(m4["loss"]).tolist()}))
""")


def test_runs_sharded_over_four_devices_equal_one_device():
    env = {**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=4"}
    out = subprocess.run([sys.executable, "-c", SHARDED, OBJ], env=env, capture_output=True, text=True, timeout=900,
                         cwd=Path(__file__).resolve().parents[2])
    assert out.returncode == 0, out.stderr[-3000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["devices"] == 4 and r["mesh"] == 4 and r["shards"] == 4  # the run axis lives on four devices
    assert r["diff"] < 2e-3
    np.testing.assert_allclose(r["loss1"], r["loss4"], rtol=2e-3)


def test_multi_seed_run_writes_a_folder_per_seed_and_resumes_exactly(tmp_path):
    quiet = {"save_every": 1, "robust_every": 0}
    spec = tiny_spec(schedule=quiet)
    runs = lambda name: [RunDir(tmp_path / name / f"seed_{s}") for s in (3, 4)]  # noqa: E731
    _, full, rows = start_or_resume(spec, runs("full"), [3, 4], resume=False, progress=False)
    assert [len(r) for r in rows] == [2, 2]
    for run, seed in zip(runs("full"), (3, 4), strict=True):
        assert run.spec().schedule.seed == seed and run.has_checkpoint("final")
    cut = tiny_spec(schedule={**quiet, "epochs": 1})  # one epoch, then resumed to two
    start_or_resume(cut, runs("cut"), [3, 4], resume=False, progress=False)
    _, resumed, rows2 = start_or_resume(spec, runs("cut"), resume=True, progress=False)
    assert [r.spec().schedule for r in runs("cut")] == [r.spec().schedule for r in runs("full")]  # each its seed
    for x, y in zip(jax.tree.leaves(full.params), jax.tree.leaves(resumed.params), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert [r["epoch"] for r in rows2[0]] == [1, 2]
