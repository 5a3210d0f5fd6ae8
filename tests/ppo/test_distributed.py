"""A run past one machine (``ppo/distributed.py``, ``train --coordinator``): two processes joined by
``jax.distributed`` (CPU devices, gloo collectives), each holding half the worlds of a tiny run, train as one process
holding both halves on two local devices (``--xla_force_host_platform_device_count=2``, joined alone). Bit equality
holds (every logged metric, the parameters, normalisers, learning rate and every world's state); the assertions allow
rtol=1e-6 so that a reduction order changed by another XLA or gloo version still passes. The normalisers' statistics
merged over the shards are the whole batch's.

Each case is its own process; the reference first, then the two of a run at once.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time

import jax
import numpy as np

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.trajectory.generator import generate
from dragmesh2_jax.trajectory.schema import write_trajectory
from tests.conftest import ROOT

EPOCHS = 2
TIMEOUT = 400  # seconds, each worker (compiling the tiny epoch takes ~10 s)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def _process(argv: list[str], devices: int = 1) -> subprocess.Popen:
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    env.pop("XLA_FLAGS", None)
    if devices > 1:
        env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={devices}"
    return subprocess.Popen([sys.executable, *argv], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)


def _finish(procs: dict[str, subprocess.Popen]) -> None:
    """Wait for every worker; a failure (or a timeout) shows each worker's output."""
    deadline, logs, failed = time.monotonic() + TIMEOUT, {}, []
    for name, p in procs.items():
        try:
            logs[name] = p.communicate(timeout=max(1.0, deadline - time.monotonic()))[0]
        except subprocess.TimeoutExpired:
            for q in procs.values():
                q.kill()
            logs[name] = p.communicate()[0] + f"\n(killed after {TIMEOUT} s)"
        if p.returncode != 0:
            failed.append(name)
    assert not failed, "\n\n".join(f"--- worker {n} (exit {procs[n].returncode}):\n{logs[n][-4000:]}" for n in procs)


def test_the_normalisers_statistics_merged_over_shards_are_the_whole_batch_s(tmp_path):
    out = tmp_path / "stats.npz"
    _finish({"one process, two devices": _process(["-m", "tests.ppo.distributed_worker", str(out)], devices=2)})
    a = np.load(out)
    assert int(a["devices"]) == 2
    for k in ("mean", "var", "count"):
        np.testing.assert_allclose(a[f"merged_{k}"], a[f"whole_{k}"], rtol=1e-5, err_msg=k)


#: The tiny run both CLI cases train (the C engine, 4 worlds: two per device; the trajectory is the test's).
TINY_TRAIN = ["train", "--object", str(default_object()), "--seed", "0", "--epochs", str(EPOCHS), "--num-envs", "4",
              "--ppo.rollout-len", "8", "--robust-every", "0", "--network.state-sizes", "32,32", "--network.hist-dim",
              "16", "--network.heads", "2", "--network.critic-sizes", "32", "--backend", "mujoco", "--quiet"]


def _cli(out, trajectory, port: int, processes: int, i: int, devices: int = 1) -> subprocess.Popen:
    return _process(["-m", "dragmesh2_jax.cli", *TINY_TRAIN, "--trajectory", str(trajectory), "--out", str(out),
                     "--coordinator", f"localhost:{port}", "--num-processes", str(processes), "--process-id", str(i)],
                    devices)


def test_train_over_two_processes_from_the_cli_equals_one_process_holding_both_shards(tmp_path):
    """``train --coordinator --num-processes 2 --process-id I`` (JAX's usual environment variables work too): each
    process steps half the worlds, process 0 writes the run folder; one process joined alone with two devices
    splits the same worlds over its own. The two runs' logs and final checkpoints agree."""
    two, one, trajectory = tmp_path / "two", tmp_path / "one", tmp_path / "t.json"
    write_trajectory(generate(load_gapartnet(default_object())), trajectory)
    # the reference first: the two processes then read the expert's load it probed from the cache, not replaying it
    # at once on the same cores
    _finish({"one process, two devices": _cli(one, trajectory, _free_port(), 1, 0, devices=2)})
    port = _free_port()
    _finish({f"process {i} of 2": _cli(two, trajectory, port, 2, i) for i in range(2)})
    runs = [RunDir(p) for p in (two, one)]
    rows = [r.log_rows() for r in runs]
    assert [r["epoch"] for r in rows[0]] == list(range(1, EPOCHS + 1))
    for a, b in zip(*rows, strict=True):
        for k in ("loss", "reward", "kl", "success"):
            np.testing.assert_allclose(a[k], b[k], rtol=1e-6, atol=1e-7, err_msg=k)
    assert rows[0][-1]["kl"] > 0 and np.isfinite(rows[0][-1]["loss"])  # it learned
    states = [load_run(str(r.path))[1] for r in runs]
    assert int(states[0].epoch) == EPOCHS and int(states[0].env_state.reward.shape[0]) == 4  # every world saved
    # the parameters, normalisers, learning rate and every world's state, gathered from both processes
    for a, b in zip(*(jax.tree.leaves(s) for s in states), strict=True):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-6, atol=1e-7)


def test_a_process_of_a_run_needs_its_count_and_id(tmp_path):
    p = _process(["-m", "dragmesh2_jax.cli", *TINY_TRAIN, "--out", str(tmp_path / "x"), "--coordinator",
                  "localhost:1", "--num-processes", "2", "--process-id", "2"])
    out, _ = p.communicate(timeout=120)
    assert p.returncode == 2 and out.strip().splitlines()[-1].startswith("error: --coordinator needs")
    assert not (tmp_path / "x").exists()
