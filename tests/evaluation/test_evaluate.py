"""The evaluation protocol: rates with Wilson intervals, clip099 over all and over active DoFs, a policy
function as the only interface, det cells that are distributions over distinct perturbed starts."""

import dataclasses
import hashlib
import json
from types import SimpleNamespace

import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.hand import active_dofs
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import envelope, envelope_table, evaluate, markdown_table
from dragmesh2_jax.evaluation.protocol import PAPER, EvalProtocol
from dragmesh2_jax.evaluation.rollout import cells, frames, rollout, trace, wilson_interval
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.task.env import PullTask


def rollout_cells(task, policy, params, dampings, episodes, seed=42):
    return cells(rollout(task, policy, params, dampings, episodes, seed), dampings, episodes)


def test_wilson_interval():
    lo, hi = wilson_interval(0, 20)
    assert lo == 0.0 and hi == pytest.approx(0.1611, abs=1e-3)
    lo, hi = wilson_interval(20, 20)
    assert lo == pytest.approx(0.8389, abs=1e-3) and hi == 1.0
    lo, hi = wilson_interval(10, 20)
    assert lo == pytest.approx(0.2993, abs=1e-3) and hi == pytest.approx(0.7007, abs=1e-3)


def _pull_policy(task, locked_value):
    """A controller as a policy function: pull along the handle normal; locked axes get ``locked_value``."""
    a = np.where(active_dofs(), 0.0, locked_value).astype(np.float32)
    a[:3] = 0.5 * task.scene.handle.normal

    def policy(params, obs, key):
        return jnp.broadcast_to(jnp.asarray(a) * params, (obs.state.shape[0], 51))

    return policy


def test_clip099_counts_all_channels_and_active_ones_separately(drawer_task):
    task = PAPER.task(drawer_task)
    cells = rollout_cells(task, _pull_policy(task, locked_value=1.0), jnp.float32(1.0), [1.0], episodes=4)
    c = cells[0]
    assert c["clip099"] == 1.0  # a saturated locked axis saturates the all-channel figure...
    assert c["clip099_active"] == 0.0  # ...but moves nothing: the active-DoF figure sees no saturation
    cells = rollout_cells(task, _pull_policy(task, locked_value=0.0), jnp.float32(1.0), [1.0], episodes=4)
    assert cells[0]["clip099"] == 0.0


def test_a_residuals_own_saturation_is_counted_beside_the_applied_actions(drawer_task):
    """Under the expert prior the applied action is the policy's residual plus the expert drag's: a residual of zeros
    applies the expert's, which saturates active DoFs (its grip is pressed deeper than alpha), while the policy itself
    never goes near its bound; without the prior the policy's output is what is applied, one figure."""
    zeros = lambda params, obs, key: jnp.zeros((obs.state.shape[0], 51))  # noqa: E731
    residual = PAPER.task(PullTask(drawer_task.scene, drawer_task.traj,
                                   dataclasses.replace(drawer_task.config, expert_prior=True)))
    c = rollout_cells(residual, zeros, None, [1.0], episodes=4)[0]
    assert c["clip099_active"] > 0.2 and c["clip099_policy_active"] == 0.0
    assert "| 0.000 |" in markdown_table({"cells": [{**c, "mode": "det"}], "robustness": {}})
    task = PAPER.task(drawer_task)
    c = rollout_cells(task, _pull_policy(task, locked_value=0.0), jnp.float32(2.0), [1.0], episodes=4)[0]
    assert c["clip099_policy_active"] == c["clip099_active"] > 0.0  # the pull at 2x: at the bound, as applied


def test_cells_report_rates_with_intervals(drawer_task):
    task = PAPER.task(drawer_task)
    cells = rollout_cells(task, _pull_policy(task, 0.0), jnp.float32(1.0), [1.0, 4.0], episodes=6, seed=3)
    assert [c["damping"] for c in cells] == [1.0, 4.0]
    for c in cells:
        assert c["episodes"] == 6 and c["success_rate"] == c["successes"] / 6
        lo, hi = c["success_ci95"]
        assert lo <= c["success_rate"] <= hi
        assert 1 <= c["steps_mean"] <= task.config.episode_length and c["action_l2_mean"] > 0
    md = markdown_table({"cells": [{**c, "mode": "det"} for c in cells],
                         "robustness": {"det": {"mean_success": 0.5, "worst_success": 0.0, "clip099_active": 0.0}}})
    assert "clip099 active" in md and "[" in md


def test_the_episodes_of_a_cell_start_from_distinct_starts_and_every_cell_from_the_same(drawer_task):
    protocol = dataclasses.replace(PAPER, episodes=40)  # more episodes than the default bank: the bank grows
    assert PAPER.starts.bank == 32 and protocol.starts.bank == 40 and protocol.name != PAPER.name
    task = protocol.task(drawer_task)
    out = rollout(task, _pull_policy(task, 0.0), jnp.float32(1.0), [1.0, 4.0], 40, seed=3, steps=1)
    hand = np.round(out["hand_q"][0], 6)  # (worlds, 51) before the first step
    assert len({tuple(h) for h in hand[:40]}) == 40  # x1's 40 episodes: 40 distinct starts
    np.testing.assert_array_equal(hand[:40], hand[40:])  # x4's episodes from the same 40


def test_cells_traces_and_frames_are_views_of_one_rollout(drawer_task):
    """A fixed-length rollout's first episodes give the same cells as the early-stopping one; its trace and
    frames read the same steps; it records the policy's own action every step."""
    task = EvalProtocol(starts=None).task(drawer_task)
    policy, T = _pull_policy(task, 0.0), 40
    short = rollout(task, policy, jnp.float32(1.0), [1.0, 4.0], 1, seed=3)
    full = rollout(task, policy, jnp.float32(1.0), [1.0, 4.0], 1, seed=3, steps=T)
    finished = short["acc"]["steps"] < T  # worlds whose first episode ended within the fixed length
    for k in ("steps", "success", "detach"):
        np.testing.assert_array_equal(short["acc"][k][finished], full["acc"][k][finished])
    tr, fr = trace(full), frames(full, [1.0, 4.0])
    assert tr["q"].shape == (T, 2) and tr["hand_q"].shape == (T, 2, 51)
    pulls = np.asarray(policy(jnp.float32(1.0), SimpleNamespace(state=np.zeros((1, 1))), None))[0]
    np.testing.assert_allclose(full["policy"], np.broadcast_to(pulls, (T, 2, 51)))  # the policy's own action
    for i, f in enumerate(fr):
        assert f["steps"] == int(min(full["acc"]["steps"][i], T)) and f["hand_q"].shape == (f["steps"], 51)
        np.testing.assert_array_equal(f["hand_q"], tr["hand_q"][: f["steps"], i])


def test_a_protocol_is_one_value_that_names_its_files():
    assert PAPER.dampings == (1.0, 2.0, 4.0) and PAPER.modes == ("det", "stoch") and PAPER.episodes == 20
    names = {p.name for p in (PAPER, dataclasses.replace(PAPER, dampings=(1.0, 8.0)), EvalProtocol(starts=None),
                              dataclasses.replace(PAPER, episodes=100), dataclasses.replace(PAPER, seed=1))}
    assert len(names) == 5 and all("/" not in n for n in names)
    # starts kept clear around the grasp as written (before seating) keep the names their files were written under
    unseated = dataclasses.replace(PAPER, starts=dataclasses.replace(PAPER.starts, seat=False))
    before = {k: v for k, v in dataclasses.asdict(unseated.starts).items() if k != "seat"}
    digest = hashlib.sha1(json.dumps(before, sort_keys=True).encode()).hexdigest()[:6]
    assert f"_distinct-{digest}_" in unseated.name and unseated.name != PAPER.name
    for bad in ({"modes": ("greedy",)}, {"episodes": 0}, {"dampings": (-1.0,)}):
        with pytest.raises(DragMeshError):
            EvalProtocol(**bad)


def test_evaluate_needs_the_protocols_starts(drawer_task):
    c = Controller("pull", lambda det: _pull_policy(drawer_task, 0.0), jnp.float32(1.0))
    with pytest.raises(ValueError, match="protocol"):
        evaluate(drawer_task, c, PAPER)  # the training task's exact starts are not the protocol's
    res = evaluate(PAPER.task(drawer_task), c, dataclasses.replace(PAPER, episodes=2, modes=("det",)))
    assert [cell["damping"] for cell in res["cells"]] == [1.0, 2.0, 4.0] and res["protocol"]["episodes"] == 2


def test_evaluate_says_it_compiles_and_how_long_is_left(drawer_task, capsys):
    c = Controller("pull", lambda det: _pull_policy(drawer_task, 0.0), jnp.float32(1.0))
    protocol = dataclasses.replace(PAPER, episodes=2, dampings=(1.0,))
    evaluate(protocol.task(drawer_task), c, protocol, progress=True)
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("evaluate: compiling the rollout (1 dampings x 2 episodes per mode)")
    assert [line.split("  ")[0] for line in lines[1:]] == ["evaluate: mode det (1/2)", "evaluate: mode stoch (2/2)"]
    assert all("left ~" in line for line in lines[1:])
    evaluate(protocol.task(drawer_task), c, protocol)
    assert capsys.readouterr().err == ""  # quiet unless asked


@pytest.fixture(scope="module")
def door_task():
    """The packaged procedural door from the expert's exact grasp (C engine)."""
    return EvalProtocol(starts=None).task(load_task(str(packaged_object("door_cabinet_0000")), None,
                                                    backend="mujoco"))


def test_the_envelope_of_a_procedural_door(door_task):
    """The expert opens the packaged door at x1 at its own pace without detaching; each cell reports its length
    and wrist-load peak, and a slower replay takes more steps (and moves the part more slowly)."""
    task = door_task
    rows = envelope(task, paces=(0.5, 1.0), dampings=(1.0, 8.0))
    assert [(r["pace"], r["damping"]) for r in rows] == [(0.5, 1.0), (0.5, 8.0), (1.0, 1.0), (1.0, 8.0)]
    own = rows[2]
    assert own["opened"] and not own["detached"] and 0 < own["steps"] < task.config.episode_length
    assert all(r["wrist_load_peak_n"] > 0 and np.isfinite(r["wrist_load_peak_n"]) for r in rows)
    assert rows[0]["opened"] and rows[0]["steps"] > own["steps"]  # measured: 240 and 122 steps
    assert 0 < rows[0]["part_speed_peak"] < own["part_speed_peak"]
    table = envelope_table(rows)
    assert table.splitlines()[0] == "| pace | x1 | x8 |" and "| 1x | opens (" in table


def test_every_cell_reports_how_the_part_was_opened_and_the_experts_load_is_the_envelopes(door_task):
    """The physical figures of a cell: the expert's drag at its own pace, one episode from its exact grasp, peaks
    at the wrist load the envelope reports for that cell (computed by the other loop of the rollout); the palm and
    the part move at finite, positive speeds; its fingers sink millimetres into the handle; its increments change
    smoothly."""
    protocol = EvalProtocol(dampings=(1.0,), modes=("det",), episodes=1, starts=None)
    (cell,) = evaluate(protocol.task(door_task), tracking_controller(door_task), protocol)["cells"]
    (own,) = envelope(door_task, paces=(1.0,), dampings=(1.0,))
    assert cell["wrist_load_peak_n"] == pytest.approx(own["wrist_load_peak_n"], rel=1e-9) and own["opened"]
    assert cell["part_speed_peak"] == pytest.approx(own["part_speed_peak"], rel=1e-9)
    assert 0 < cell["palm_speed_peak_m_s"] < 2.0 and 0 < cell["part_speed_peak"] < 10.0  # rad/s
    # the expert's fingers press into the handle's collision hull (measured: 8.6 mm; 3.9-7.9 on the shared objects)
    assert 1.0 < cell["penetration_max_mm"] < 20.0 and 0 < cell["action_smoothness"] < 0.1
    md = markdown_table({"cells": [{**cell, "mode": "det"}], "robustness": {}})
    assert "wrist load p95 [N]" in md and f"| {cell['wrist_load_peak_n']:.0f} |" in md


def test_the_settled_figures_leave_out_a_perturbed_starts_first_steps():
    """The expert drag on the packaged drawer, x1 and x8: from its exact grasp the palm peaks and the fingers sink
    deepest in the drag, so each figure equals its settled one. From starts drawn as is, the hand's first steps to
    its grasp (measured: 0.16-0.18 m/s) are 1.9-2.2x the drag's own pace, and a start pressed into the handle is
    1.4-1.5x deeper than the grasp (12.4-12.9 mm against 8.6); the settled figures keep the drag's (0.09 m/s against
    the exact grasp's 0.06-0.07; 8.6 mm). Clear starts press nothing in: their deepest is the grasp's own (8.0 mm
    measured), and the drag, starting from a hand relaxed out of the bar, sinks no deeper after its first steps
    (5.5 mm)."""
    task = load_task(str(packaged_object("drawer_cabinet_0000")), None, backend="mujoco")
    figures = {}
    clear = EvalProtocol().starts
    drawn = dataclasses.replace(clear, clear=False, seat=False)
    for name, starts in (("exact", None), ("drawn", drawn), ("clear", clear)):
        protocol = EvalProtocol(dampings=(1.0, 8.0), modes=("det",), episodes=8, starts=starts)
        figures[name] = [(c["palm_speed_peak_m_s"], c["palm_speed_settled_peak_m_s"], c["penetration_max_mm"],
                          c["penetration_settled_p95_mm"])
                         for c in evaluate(protocol.task(task), tracking_controller(task), protocol)["cells"]]
    for exact, drawn, clear in zip(figures["exact"], figures["drawn"], figures["clear"], strict=True):
        (palm, palm_settled, deepest, deepest_settled), (whole, settled, pressed, pressed_settled) = exact, drawn
        assert palm_settled == palm and whole > 1.5 * settled and settled < 1.5 * palm
        assert deepest_settled == pytest.approx(deepest) and pressed > 1.3 * pressed_settled
        assert pressed_settled == pytest.approx(deepest, abs=0.2)
        assert clear[2] <= deepest + 0.1 and clear[3] <= deepest and clear[1] < 1.5 * palm


def test_a_cells_peaks_are_the_95th_percentile_of_its_episodes_and_penetration_the_deepest():
    n = 20
    acc = {k: np.zeros(n) for k in ("steps", "clip", "clip_active", "clip_policy", "l2", "success", "detach",
                                    "progress", "ret", "change")}
    acc["steps"][:] = 10
    acc["load_peak"] = np.arange(1.0, n + 1)  # 1 .. 20 N
    acc["palm_speed_peak"], acc["palm_speed_settled_peak"], acc["part_speed_peak"] = np.ones(n), np.full(n, 0.5), \
        np.full(n, 2.0)
    acc["penetration_max"] = np.r_[np.zeros(n - 1), 0.004]
    acc["penetration_settled"] = np.linspace(0.0, 0.002, n)
    acc["change"][:] = 0.9  # 9 changes per episode
    (c,) = cells({"acc": acc}, [1.0], n)
    assert c["wrist_load_peak_n"] == pytest.approx(np.percentile(np.arange(1.0, n + 1), 95)) == pytest.approx(19.05)
    assert c["palm_speed_peak_m_s"] == 1.0 and c["palm_speed_settled_peak_m_s"] == 0.5 and c["part_speed_peak"] == 2.0
    assert c["penetration_max_mm"] == pytest.approx(4.0) and c["action_smoothness"] == pytest.approx(0.1)
    assert c["penetration_settled_p95_mm"] == pytest.approx(1000 * np.percentile(np.linspace(0.0, 0.002, n), 95))
    assert c["penetration_p95_mm"] == pytest.approx(1000 * np.percentile(acc["penetration_max"], 95))
