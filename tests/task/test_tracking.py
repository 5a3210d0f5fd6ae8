"""The trajectory-tracking baseline opens the objects through contact, on both physics backends."""

import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.evaluation.evaluate import track
from dragmesh2_jax.runs.build import load_task
from tests.conftest import REAL_OBJECTS
from tests.task.conftest import MJX_JAX_OBJECT, assert_bounded_divergence, assert_sensors_agree


@pytest.mark.parametrize("oid", REAL_OBJECTS)
def test_tracking_opens_every_real_object_at_x1_on_the_c_backend(gapartnet_dir, oid):
    task = load_task(str(gapartnet_dir / oid), None, backend="mujoco")
    (cell,) = track(task, [1.0])
    t = task.traj
    assert cell["success_rate"] == 1.0 and cell["detach_rate"] == 0.0
    assert cell["progress_mean"] >= (t.q_done - t.q_start) / (t.q_goal - t.q_start) - 1e-3


def test_reference_trajectory_tracks_in_our_physics(gapartnet_dir, shared_dir):
    """The authors' Isaac Gym trajectory for 45261 (30 Hz frames) also opens the drawer here."""
    task = load_task(str(gapartnet_dir / "45261"), str(shared_dir / "reference/trajectories/45261.json"),
                     backend="mujoco")
    assert all(r["success_rate"] == 1.0 for r in track(task, [1.0, 2.0]))


@pytest.mark.mjx
def test_mjx_jax_diverges_boundedly_and_its_load_sensors_agree(mjx_jax_traces):
    """The packaged drawer at x1/x2/x4, the same PD targets from the same start: MJX-JAX's first second stays within
    bounds of the C engine's and its load sensors agree as the grasp builds up. The verdicts of whole episodes, on
    every shared object, are MJX-Warp's (tests/physics/test_mjx_backend.py): MJX-JAX's compile costs minutes per
    object here."""
    assert_bounded_divergence(mjx_jax_traces, load_gapartnet(MJX_JAX_OBJECT).target.joint.is_revolute)
    assert_sensors_agree(mjx_jax_traces)
