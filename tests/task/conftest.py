import numpy as np
import pytest

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.evaluation.rollout import rollout, trace
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.trajectory.generator import generate

#: Control steps the backend parity compares (1 s of the same PD targets from the same start).
PARITY_STEPS = 60
#: The object whose traces run a whole episode (one MJX compilation serves its parity and its verdicts).
WHOLE_EPISODE = "45261"
#: The revolute door whose first second is compared on MJX-JAX too.
MJX_DOOR = "45780"


@pytest.fixture(scope="session")
def tracking_tasks(gapartnet_dir):
    """A real object's task on both backends from one generated trajectory, built once per object per session:
    ``tracking_tasks(oid) -> {backend: task}``."""
    cache = {}

    def get(oid):
        if oid not in cache:
            traj = generate(load_gapartnet(gapartnet_dir / oid))
            cache[oid] = {b: load_task(str(gapartnet_dir / oid), traj, backend=b) for b in ("mujoco", "mjx")}
        return cache[oid]

    return get


@pytest.fixture(scope="session")
def tracking_traces(tracking_tasks):
    """The tracking baseline at x1/x2/x4 on both backends (``rollout.trace``): PARITY_STEPS steps, a whole episode
    for WHOLE_EPISODE."""
    cache = {}

    def get(oid):
        if oid not in cache:
            cache[oid] = {b: expert_trace(t, t.config.episode_length if oid == WHOLE_EPISODE else PARITY_STEPS)
                          for b, t in tracking_tasks(oid).items()}
        return cache[oid]

    return get


def expert_trace(task, steps: int) -> dict:
    """The tracking baseline from the exact start at x1/x2/x4 for ``steps`` control steps (``rollout.trace``)."""
    c = tracking_controller(task)
    return trace(rollout(task, c.make_policy(True), c.params, [1.0, 2.0, 4.0], controls=c.controls, steps=steps,
                         key=c.key))


def assert_bounded_divergence(traces, revolute: bool, engine: str = "mjx") -> None:
    """The same PD targets from the same start on the C engine and ``engine``, at x1/x2/x4, for PARITY_STEPS control
    steps."""
    c, j = ({k: v[:PARITY_STEPS] for k, v in traces[b].items() if k != "success"} for b in ("mujoco", engine))
    assert np.abs(c["q"] - j["q"]).max() < (0.05 if revolute else 0.01)  # object joint, rad or m
    assert np.abs(c["hand_q"][..., :3] - j["hand_q"][..., :3]).max() < 0.01  # wrist position, m
    # fingers in contact diverge most: MJX collides capsules with meshes by SAT, the C engine by CCD
    assert np.abs(c["hand_q"][..., 6:] - j["hand_q"][..., 6:]).max() < 0.6
