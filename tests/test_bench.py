"""The benchmark command reports the documented keys (speed itself is measured, never asserted)."""

import json

from dragmesh2_jax.cli import main


def test_bench_env_json(capsys):
    assert main(["bench", "env", "--backend", "mujoco", "--num-envs", "1,2", "--steps", "3", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["num_envs"] for r in rows] == [1, 2]
    for r in rows:
        assert {"compile_s", "control_steps_per_s", "physics_steps_per_s", "backend", "cpu", "cores"} <= set(r)
        assert r["physics_steps_per_s"] == r["control_steps_per_s"] * 4 or abs(
            r["physics_steps_per_s"] - 4 * r["control_steps_per_s"]) < 1
