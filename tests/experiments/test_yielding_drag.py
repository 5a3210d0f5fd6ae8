"""A pace that yields, on the expert (experiments/yielding_drag.py): the drag's target capped at a lead of the part's
range ahead of the part's progress, read from the observation the task gives."""

import importlib.util
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines.tracking import drag_targets, replay
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.task.observation import phi

SCRIPT = Path(__file__).resolve().parents[2] / "experiments" / "yielding_drag.py"
_spec = importlib.util.spec_from_file_location("yielding_drag", SCRIPT)
yielding_drag = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(yielding_drag)


def test_the_progress_it_reads_is_the_tasks_and_the_target_waits_for_a_part_that_lags():
    task = load_task(str(default_object()), None, backend="mujoco")
    state = task.reset(jax.random.PRNGKey(0), 1.0, 0)
    progress = phi(task.params, state.info["q_prev"])[0]
    assert float(state.obs.state[yielding_drag.PROGRESS]) == float(progress)
    unbounded, lagging = yielding_drag.controller(task, float("inf")), yielding_drag.controller(task, 0.05)
    targets = drag_targets(task)
    late = state.obs.replace(step=jnp.int32(len(targets) // 2))  # half the drag's time gone, the part not moved
    np.testing.assert_array_equal(unbounded.make_policy(True)(unbounded.params, late, None),
                                  replay(jnp.asarray(targets), late, None))  # no lead: the time-indexed drag
    held = lagging.make_policy(True)(lagging.params, late, None)
    _, planned, _ = lagging.params
    cap = int(np.searchsorted(np.asarray(planned), float(progress) + 0.05, side="right"))
    assert cap < len(targets) // 2
    np.testing.assert_array_equal(held, targets[cap])  # the target waits where the plan has the part a lead ahead
    bounded = yielding_drag.controller(task, 0.05, "actions")  # through the action bound, as the recipe's prior
    q = late.state[: targets.shape[1]]
    assert bounded.controls == "actions"
    np.testing.assert_allclose(bounded.make_policy(True)(bounded.params, late, None),
                               np.clip((targets[cap] - q) / task.config.alpha, -1.0, 1.0), rtol=1e-6)
