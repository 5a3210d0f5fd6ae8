import pytest


@pytest.fixture(scope="session")
def tracking_rollouts(gapartnet_dir, tmp_path_factory):
    """Tracking rollouts of a real object at x1/x2/x4 on both backends, one episode each, computed once per object
    per session (one MJX compile each): ``tracking_rollouts(oid) -> {backend: trace_rollout(...)}``."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.baselines.tracking import tracking_controller
    from dragmesh2_jax.evaluation.evaluate import trace_rollout
    from dragmesh2_jax.runs import load_task
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import write_trajectory

    cache = {}

    def get(oid):
        if oid not in cache:
            path = tmp_path_factory.mktemp("traj") / f"{oid}.json"
            write_trajectory(generate(load_gapartnet(gapartnet_dir / oid)), path)
            tasks = {b: load_task(str(gapartnet_dir / oid), str(path), backend=b) for b in ("mujoco", "mjx")}
            cache[oid] = {b: trace_rollout(t, tracking_controller(t), [1.0, 2.0, 4.0], t.config.episode_length)
                          for b, t in tasks.items()}
        return cache[oid]

    return get
