import pytest


@pytest.fixture(scope="session")
def drawer_task():
    """The packaged drawer with a generated trajectory, on the C backend (compiles in ~1 s)."""
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.cli import load_task

    return load_task(str(default_object()), None, backend="mujoco")


@pytest.fixture(scope="session")
def trajectory_45261(gapartnet_dir, tmp_path_factory):
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import write_trajectory

    path = tmp_path_factory.mktemp("traj") / "45261.json"
    write_trajectory(generate(load_gapartnet(gapartnet_dir / "45261")), path)
    return path


@pytest.fixture(scope="session")
def tracking_45261(gapartnet_dir, trajectory_45261):
    """Tracking rollouts of 45261 at x1/x2/x4 on both backends (one MJX compile for the whole session)."""
    from dragmesh2_jax.baselines.tracking import track
    from dragmesh2_jax.cli import load_task

    out = {}
    for backend in ("mujoco", "mjx"):
        task = load_task(str(gapartnet_dir / "45261"), str(trajectory_45261), backend=backend)
        out[backend] = track(task, [1.0, 2.0, 4.0], traces=True)
    return out
