"""A run past one machine (``ppo/distributed.py``): two processes joined by ``jax.distributed`` (CPU devices, gloo
collectives), each holding half the worlds of the tiny PICA run, give the same update as one process holding both
halves on two local devices (``--xla_force_host_platform_device_count=2``), the same program without
``jax.distributed``. Bit equality holds (the parameters, normalisers, learning rate, every metric of both epochs and
every world's state); the assertion allows rtol=1e-6 so that a reduction order changed by another XLA or gloo
version still passes.

Each case is a worker process (``tests/ppo/distributed_worker.py``); the three run at once (~40 s on two cores).
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time

import jax
import numpy as np

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.runs.rundir import RunDir
from tests.conftest import ROOT

EPOCHS = 2
TIMEOUT = 400  # seconds, each worker (compiling the tiny epoch takes ~10 s)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def _worker(out, *args, devices: int = 1) -> subprocess.Popen:
    return _process(["-m", "tests.ppo.distributed_worker", str(out), str(EPOCHS), *map(str, args)], devices)


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


def test_two_processes_update_as_one_process_with_both_shards(tmp_path):
    port = _free_port()
    multi, single = tmp_path / "multi.npz", tmp_path / "single.npz"
    procs = {f"process {i} of 2": _worker(multi, f"localhost:{port}", 2, i) for i in range(2)}
    procs["one process, two devices"] = _worker(single, devices=2)
    _finish(procs)
    a, b = np.load(multi), np.load(single)
    assert int(a["devices"]) == int(b["devices"]) == 2  # both split the 4 worlds in two
    assert sorted(a.files) == sorted(b.files)
    for k in a.files:
        np.testing.assert_allclose(a[k], b[k], rtol=1e-6, atol=1e-7, err_msg=k)
    params = [k for k in a.files if k.startswith("param")]
    assert params and any(not np.array_equal(a[k], a[k.replace("param", "initial")]) for k in params)  # it trained
    assert a["worlds_qpos"].shape[0] == 4  # every world, gathered from both processes
    assert float(a[f"metric{EPOCHS - 1}_kl"]) > 0 and np.isfinite(float(a[f"metric{EPOCHS - 1}_loss"]))
    # the normalisers' statistics merged over the shards are the whole batch's
    for k in ("mean", "var", "count"):
        np.testing.assert_allclose(b[f"merged_{k}"], b[f"whole_{k}"], rtol=1e-5, err_msg=k)


#: The tiny run both CLI cases train (the C engine, 4 worlds: two per device).
TINY_TRAIN = ["train", "--object", str(default_object()), "--seed", "0", "--epochs", str(EPOCHS), "--num-envs", "4",
              "--ppo.rollout-len", "8", "--robust-every", "0", "--network.state-sizes", "32,32", "--network.hist-dim",
              "16", "--network.heads", "2", "--network.critic-sizes", "32", "--backend", "mujoco", "--quiet"]


def _cli(out, port: int, processes: int, i: int, devices: int = 1) -> subprocess.Popen:
    return _process(["-m", "dragmesh2_jax.cli", *TINY_TRAIN, "--out", str(out), "--coordinator", f"localhost:{port}",
                     "--num-processes", str(processes), "--process-id", str(i)], devices)


def test_train_over_two_processes_from_the_cli_equals_one_process_holding_both_shards(tmp_path):
    """``train --coordinator --num-processes 2 --process-id I`` (JAX's usual environment variables work too): each
    process steps half the worlds, process 0 writes the run folder; one process joined alone with two devices
    splits the same worlds over its own. The two runs' logs and final checkpoints agree."""
    two, one = tmp_path / "two", tmp_path / "one"
    port = _free_port()
    procs = {f"process {i} of 2": _cli(two, port, 2, i) for i in range(2)}
    procs["one process, two devices"] = _cli(one, _free_port(), 1, 0, devices=2)
    _finish(procs)
    runs = [RunDir(p) for p in (two, one)]
    rows = [r.log_rows() for r in runs]
    assert [r["epoch"] for r in rows[0]] == list(range(1, EPOCHS + 1))
    for a, b in zip(*rows, strict=True):
        for k in ("loss", "reward", "kl", "success"):
            np.testing.assert_allclose(a[k], b[k], rtol=1e-6, atol=1e-7, err_msg=k)
    states = [load_run(str(r.path))[1] for r in runs]
    for a, b in zip(*(jax.tree.leaves(s.params) for s in states), strict=True):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-6, atol=1e-7)
    assert int(states[0].epoch) == EPOCHS and int(states[0].env_state.reward.shape[0]) == 4  # every world saved


def test_a_process_of_a_run_needs_its_count_and_id(tmp_path):
    p = _process(["-m", "dragmesh2_jax.cli", *TINY_TRAIN, "--out", str(tmp_path / "x"), "--coordinator",
                  "localhost:1", "--num-processes", "2", "--process-id", "2"])
    out, _ = p.communicate(timeout=120)
    assert p.returncode == 2 and out.strip().splitlines()[-1].startswith("error: --coordinator needs")
    assert not (tmp_path / "x").exists()
