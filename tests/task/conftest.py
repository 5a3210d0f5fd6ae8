import numpy as np
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.rollout import rollout, trace
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.trajectory.generator import generate

#: Control steps the backend parity compares (1 s of the same PD targets from the same start).
PARITY_STEPS = 60
#: The object MJX-JAX is compared on: the packaged drawer, whose parts are convex meshes as the real objects' are (one
#: compilation serves its parity and its load sensors; 51 s here against 117 s for the real drawer 45261, whose thin
#: boxes add box-capsule pairs): every shared object runs the same checks, each episode to its end, on MJX-Warp
#: (tests/physics/test_mjx_backend.py).
MJX_JAX_OBJECT = str(default_object())
#: Control steps whose load sensors are compared (the grasp before the pull builds up).
SENSOR_STEPS = 10


@pytest.fixture(scope="session")
def mjx_jax_traces():
    """The tracking baseline at x1/x2/x4 on MJX_JAX_OBJECT for PARITY_STEPS, on the C engine and MJX-JAX from one
    generated trajectory (``rollout.trace``)."""
    traj = generate(load_gapartnet(MJX_JAX_OBJECT))
    return {b: expert_trace(load_task(MJX_JAX_OBJECT, traj, backend=b), PARITY_STEPS) for b in ("mujoco", "mjx")}


def expert_trace(task, steps: int) -> dict:
    """The tracking baseline from the exact start at x1/x2/x4 for ``steps`` control steps (``rollout.trace``)."""
    c = tracking_controller(task)
    return trace(rollout(task, c.make_policy(True), c.params, [1.0, 2.0, 4.0], controls=c.controls, steps=steps,
                         key=c.key))


def assert_sensors_agree(traces, engine: str = "mjx") -> None:
    """The load sensors over the first SENSOR_STEPS of the same drag agree (``assert_loads_agree``; measured on
    45261, MJX-JAX: 1.0 N and 11 N of ~60 N)."""
    assert_loads_agree(*(traces[b]["force"][:SENSOR_STEPS] for b in ("mujoco", engine)))


def assert_loads_agree(c: np.ndarray, j: np.ndarray) -> None:
    """Load sensors of the C engine (``c``) and an MJX engine (``j``), [..., sensors]: wrist force within 2 N + 15%
    and the summed palm/phalanx normal force within 20% + 1 N, the grasp touching the handle."""
    fc, fj = np.linalg.norm(c[..., :3], axis=-1), np.linalg.norm(j[..., :3], axis=-1)
    assert np.all(np.abs(fc - fj) <= 2.0 + 0.15 * fc)
    tc, tj = c[..., 6:].sum(-1), j[..., 6:].sum(-1)
    assert np.all(np.abs(tc - tj) <= 0.2 * tc + 1.0) and tj.max() > 1.0  # the grasp touches the handle


def assert_bounded_divergence(traces, revolute: bool, engine: str = "mjx") -> None:
    """The same PD targets from the same start on the C engine and ``engine``, at x1/x2/x4, for PARITY_STEPS control
    steps."""
    c, j = ({k: v[:PARITY_STEPS] for k, v in traces[b].items() if k != "success"} for b in ("mujoco", engine))
    assert np.abs(c["q"] - j["q"]).max() < (0.05 if revolute else 0.01)  # object joint, rad or m
    assert np.abs(c["hand_q"][..., :3] - j["hand_q"][..., :3]).max() < 0.01  # wrist position, m
    # fingers in contact diverge most: MJX collides capsules with meshes by SAT, the C engine by CCD
    assert np.abs(c["hand_q"][..., 6:] - j["hand_q"][..., 6:]).max() < 0.6
