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

import numpy as np

from tests.conftest import ROOT

EPOCHS = 2
TIMEOUT = 400  # seconds, each worker (compiling the tiny epoch takes ~10 s)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def _worker(out, *args, devices: int = 1) -> subprocess.Popen:
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    env.pop("XLA_FLAGS", None)
    if devices > 1:
        env["XLA_FLAGS"] = f"--xla_force_host_platform_device_count={devices}"
    cmd = [sys.executable, "-m", "tests.ppo.distributed_worker", str(out), str(EPOCHS), *map(str, args)]
    return subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


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
