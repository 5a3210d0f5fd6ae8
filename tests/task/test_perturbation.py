"""Perturbed starts (evaluation that measures a rate): seeded, bounded, and still tracked at x1."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.hand import NUM_VIRTUAL, active_dofs
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import track
from dragmesh2_jax.evaluation.protocol import EVAL_RESET_NOISE, PAPER, EvalProtocol
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import contact_depth
from dragmesh2_jax.task.config import ResetNoise
from dragmesh2_jax.task.env import PullTask, make_batched
from dragmesh2_jax.task.starts import CLEARANCE_MARGIN, SEATED_DEPTH, reset_starts
from tests.conftest import REAL_OBJECTS


def test_starts_are_seeded_and_bounded(drawer_task):
    """Starts as drawn: within 2 sigma of the expert grasp, the locked axes untouched, the part only opened."""
    noise = ResetNoise(bank=16, seed=3, clear=False, seat=False)
    a = reset_starts(drawer_task.scene, drawer_task.traj, noise)
    b = reset_starts(drawer_task.scene, drawer_task.traj, noise)
    c = reset_starts(drawer_task.scene, drawer_task.traj, dataclasses.replace(noise, seed=4))
    assert len(a) == 16
    np.testing.assert_array_equal(np.stack([h for h, _ in a]), np.stack([h for h, _ in b]))
    assert not np.allclose(np.stack([h for h, _ in a]), np.stack([h for h, _ in c]))
    (h0, q0), = reset_starts(drawer_task.scene, drawer_task.traj, None)  # the paper's exact start
    dq = np.stack([h for h, _ in a]) - h0
    locked = ~active_dofs()
    assert np.all(np.abs(dq[:, :3]) <= 2 * noise.wrist_pos + 1e-12)
    assert np.all(np.abs(dq[:, 3:NUM_VIRTUAL]) <= 2 * noise.wrist_rot + 1e-12)
    assert np.all(np.abs(dq[:, NUM_VIRTUAL:]) <= 2 * noise.fingers + 1e-12)
    np.testing.assert_array_equal(dq[:, locked], 0.0)  # the 24 locked axes are never perturbed
    assert np.abs(dq[:, NUM_VIRTUAL:]).max() > 0.5 * noise.fingers  # and the noise is real
    opened = np.array([q for _, q in a]) - q0
    t = drawer_task.traj
    assert np.all(opened >= 0) and np.all(opened <= noise.object_q * (t.q_done - t.q_start) + 1e-12)


def test_clear_starts_lie_no_deeper_in_the_part_than_the_expert_grasp(drawer_task):
    """Drawn as is, a start presses the hand into the drawer's bar: the bar opened into the still hand and the wrist
    shifted into it. A clear start moves the wrist with the drawer and lets a hand in the bar relax out of it: none
    lies deeper than the expert grasp's own contact (the margin and a tenth of a millimetre of the relaxation's
    last step), and the perturbation stays: the starts still differ by millimetres."""
    scene, traj = drawer_task.scene, drawer_task.traj
    noise = ResetNoise(bank=16, seed=3)
    drawn = reset_starts(scene, traj, dataclasses.replace(noise, clear=False, seat=False))
    clear = reset_starts(scene, traj, noise)
    is_hand = scene.geom_mask(scene.ids.hand_geoms)
    depth = lambda start: contact_depth(is_hand, scene.settled_state(*start, 0))  # noqa: E731  the pose as written
    exact = depth(reset_starts(scene, traj, None)[0])
    assert [q for _, q in clear] == [q for _, q in drawn]  # the same draws
    assert max(map(depth, clear)) <= exact + CLEARANCE_MARGIN + 1e-4
    assert sum(depth(s) > exact + 0.002 for s in drawn) >= len(drawn) // 4
    assert np.std([h[:3] for h, _ in clear], axis=0).max() > 0.001


def test_seated_starts_rest_on_the_handle_where_the_grasp_as_written_lies_inside_it():
    """The packaged drawer's seated grasp is written 8 mm inside its bar on the hand's contacts (seated on other
    contacts): clear starts around it lie as deep, seated ones within SEATED_DEPTH of the surface (and the margin),
    and the perturbation stays."""
    task = load_task(str(default_object()), None, backend="mujoco", expert_grasp="seated")
    scene, traj = task.scene, task.traj
    is_hand = scene.geom_mask(scene.ids.hand_geoms)
    depth = lambda start: contact_depth(is_hand, scene.settled_state(*start, 0))  # noqa: E731  the pose as written
    noise = ResetNoise(bank=16, seed=3)
    seated, around = reset_starts(scene, traj, noise), reset_starts(scene, traj, dataclasses.replace(noise, seat=False))
    assert depth(reset_starts(scene, traj, None)[0]) > 0.005 and np.median([depth(s) for s in around]) > 0.005
    assert max(map(depth, seated)) <= SEATED_DEPTH + CLEARANCE_MARGIN + 1e-4
    assert np.std([h[:3] for h, _ in seated], axis=0).max() > 0.001
    with pytest.raises(DragMeshError, match="seat needs clear"):
        ResetNoise(clear=False)


def test_each_reset_draws_one_of_the_perturbed_starts(drawer_task):
    task = PAPER.task(drawer_task)
    assert task.config.reset_noise == EVAL_RESET_NOISE and task.num_starts == EVAL_RESET_NOISE.bank
    reset, _ = make_batched(task)
    s = jax.jit(reset)(jax.random.split(jax.random.PRNGKey(0), 8), jnp.ones(8))
    hand = np.asarray(s.obs.state[:, :51])
    assert len({tuple(np.round(h, 6)) for h in hand}) > 4  # different worlds start differently
    exact = EvalProtocol(starts=None).task(drawer_task)
    s = jax.jit(make_batched(exact)[0])(jax.random.split(jax.random.PRNGKey(0), 4), jnp.ones(4))
    np.testing.assert_array_equal(np.asarray(s.obs.state[0]), np.asarray(s.obs.state[3]))


def test_bad_noise_is_rejected():
    with pytest.raises(DragMeshError):
        ResetNoise(fingers=-0.1)
    with pytest.raises(DragMeshError):
        ResetNoise(bank=0)


@pytest.mark.parametrize("oid", REAL_OBJECTS)
def test_tracking_still_opens_every_real_object_at_x1_from_perturbed_starts(gapartnet_dir, oid):
    """The evaluation perturbation is small enough that the expert drag still opens every shared object."""
    base = load_task(str(gapartnet_dir / oid), None, backend="mujoco")
    task = PullTask(base.scene, base.traj, dataclasses.replace(base.config, reset_noise=EVAL_RESET_NOISE))
    (cell,) = track(task, [1.0], episodes=8, seed=1)
    assert cell["success_rate"] == 1.0, cell
