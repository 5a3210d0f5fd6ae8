import pytest


@pytest.fixture(scope="session")
def tracking_rollouts(gapartnet_dir, tmp_path_factory):
    """Tracking rollouts of a real object at x1/x2/x4 on both backends, computed once per object per session
    (one MJX compile each): ``tracking_rollouts(oid) -> {backend: (rows, traces)}``."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.baselines.tracking import track
    from dragmesh2_jax.runs import load_task
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import write_trajectory

    cache = {}

    def get(oid):
        if oid not in cache:
            path = tmp_path_factory.mktemp("traj") / f"{oid}.json"
            write_trajectory(generate(load_gapartnet(gapartnet_dir / oid)), path)
            cache[oid] = {b: track(load_task(str(gapartnet_dir / oid), str(path), backend=b), [1.0, 2.0, 4.0],
                                   trace_steps=60) for b in ("mujoco", "mjx")}
        return cache[oid]

    return get
