"""The benchmark command reports the documented keys (speed itself is measured, never asserted)."""

import json

import jax
import jax.numpy as jnp
import pytest

from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.bench import bench_soak, learning_regressions
from tests.conftest import installed_command, require_warp

dragmesh2 = installed_command()


def test_bench_env_json(capsys):
    assert dragmesh2(["bench", "env", "--backend", "mujoco", "--num-envs", "1,2", "--steps", "3", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["num_envs"] for r in rows] == [1, 2]
    for r in rows:
        assert {"compile_s", "control_steps_per_s", "physics_steps_per_s", "backend", "cpu", "cores"} <= set(r)
        assert r["physics_steps_per_s"] == r["control_steps_per_s"] * 4 or abs(
            r["physics_steps_per_s"] - 4 * r["control_steps_per_s"]) < 1
    assert {r["objects"] for r in rows} == {1}


def test_bench_env_mixes_objects_in_one_batch(capsys):
    """Several objects: one batch whose worlds step a drawer and a door, as training over several objects does."""
    pair = [str(packaged_object(n)) for n in ("drawer_cabinet_0000", "door_cabinet_0000")]
    assert dragmesh2(["bench", "env", "--backend", "mujoco", "--objects", *pair, "--num-envs", "4", "--steps", "3",
                      "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["objects"] == 2 and row["num_envs"] == 4 and row["physics_steps_per_s"] > 0


@pytest.mark.xdist_group("warp")  # beside the other Warp tests: Warp compiles its kernels once per process
def test_bench_env_puts_the_engines_side_by_side(capsys):
    """The C engine and MJX at the same number of worlds, each with the contact slots and constraint rows one world
    holds (MJX-JAX's first-step deadlock on a CPU: tests/physics/test_mjx_backend.py, in a fresh process)."""
    require_warp()
    assert dragmesh2(["bench", "env", "--backend", "mujoco,mjx", "--impl", "warp", "--num-envs", "2", "--steps", "2",
                      "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["engine"] for r in rows] == ["mujoco", "mjx-warp"] and {r["num_envs"] for r in rows} == {2}
    c, wp = rows
    assert c["contact_slots"] is None and all(r["physics_steps_per_s"] > 0 for r in rows)
    assert wp["contact_slots"] < wp["budget"]["candidates"]  # the probe's budget, capped
    assert wp["constraint_rows"] >= 4 * wp["contact_slots"]


def test_bench_soak_counts_non_finite_worlds_per_damping_and_keeps_the_batch(drawer_task):
    rows = bench_soak(drawer_task, [1.0, 8.0], num_envs=2, steps=5)
    assert [r["damping"] for r in rows] == [1.0, 8.0] and all(r["batch_finite"] for r in rows)
    assert all(r["physics_steps"] == 2 * 5 * drawer_task.substeps for r in rows)
    task = drawer_task.bind(drawer_task.data)  # the same task, with a backend whose x8 worlds blow up
    real = task.backend

    class Poison:
        name, scene, substeps, data = real.name, real.scene, real.substeps, real.data
        reset_state, kinematics, signature = real.reset_state, real.kinematics, real.signature
        overflow, sized = real.overflow, real.sized

        def step(self, data, ps, ctrl, fields):
            out = real.step(data, ps, ctrl, fields)
            bad = fields["dof_damping"][data.layout.target_dof] > 50
            return jax.tree.map(lambda x: jnp.where(bad, jnp.nan, x), out)

    task.backend = Poison()
    x1, x8 = bench_soak(task, [1.0, 8.0], num_envs=2, steps=3)
    assert x1["nonfinite_worlds"] == 0 and x8["nonfinite_worlds"] == 2 and x8["nonfinite_events"] == 6
    assert x1["batch_finite"] and x8["batch_finite"]  # isolated: reset, the batch goes on


def test_the_learning_check_names_a_collapse_and_a_drop_in_success():
    def curves(success, progress, detach):  # 6 epochs x 2 seeds, each constant
        return {"seeds": [0, 1], "curves": {"obj": {k: [list(v)] * 6 for k, v in
                                                     (("success", success), ("progress", progress),
                                                      ("detach", detach))}}}

    recorded = curves((0.9, 0.8), (0.5, 0.5), (0.1, 0.2))
    assert learning_regressions(recorded, recorded, 0.2) == []
    frozen = curves((0.0, 0.8), (0.01, 0.5), (0.0, 0.2))  # seed 0 holds still
    problems = learning_regressions(frozen, recorded, 0.2)
    assert any("seed 0 collapsed" in p for p in problems) and any("final training success 0.40" in p for p in problems)
    assert learning_regressions(frozen, {"curves": {}}, 0.2) == [problems[0]]  # nothing recorded: collapse only
