"""Trajectory files: the reference's frame lists load, ours round-trip exactly, anything else is rejected."""

import json

import numpy as np
import pytest

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.trajectory.schema import parse_trajectory, read_trajectory, write_trajectory


def test_reference_45261_drawer(shared_dir):
    t = read_trajectory(shared_dir / "reference" / "trajectories" / "45261.json")
    assert [(p, b - a) for p, a, b in t.phase_blocks()] == [("approach", 65), ("grasp", 45), ("drag", 161)]
    assert t.joint_positions.shape == (271, 5)
    assert t.target_index == 0  # the joint with the largest motion range
    assert t.drag_start == 110
    assert t.q_min == pytest.approx(0.0, abs=1e-5) and t.q_max == pytest.approx(0.312, abs=1e-3)
    assert t.q_done == pytest.approx(t.q_min + 0.5 * (t.q_max - t.q_min))
    assert t.hand_q.shape == (271, 51)


def test_the_drag_schedule_is_the_plans_joint_at_each_control_step_of_the_drag_then_held(shared_dir):
    """45261 is a 30 Hz file: at 60 Hz each of its 160 drag frames after the grasp stands for two control steps, as
    in the hand targets the replay applies; after the drag the plan's last q holds."""
    t = read_trajectory(shared_dir / "reference" / "trajectories" / "45261.json")
    q = t.target_q[t.drag_start + 1:t.drag_start + 161]
    s = t.drag_schedule(1.0 / 60.0, 400)
    assert s.shape == (400,) and len(t.drag_targets(1.0 / 60.0)) == 320
    np.testing.assert_allclose(s[:320], np.repeat(q, 2), atol=1e-6)
    np.testing.assert_allclose(s[320:], q[-1], atol=1e-6)
    np.testing.assert_allclose(t.drag_schedule(1.0 / 30.0, 100), q[:100], atol=1e-6)


def test_reference_45661_has_grasp_drag_release(shared_dir):
    t = read_trajectory(shared_dir / "reference" / "trajectories" / "45661.json")
    assert [p for p, _, _ in t.phase_blocks()] == ["grasp", "drag", "release"]
    assert t.target_index == 1 and t.drag_start == 40
    assert t.q_max == pytest.approx(0.264, abs=1e-3)


def test_round_trip_is_exact(shared_dir, tmp_path):
    t = read_trajectory(shared_dir / "reference" / "trajectories" / "45661.json")
    t = type(t)(frames=t.frames, header={"object_id": "45661", "target": {"joint_index": 1}})
    write_trajectory(t, tmp_path / "t.json")
    back = read_trajectory(tmp_path / "t.json")
    assert back.frames == t.frames and back.header == t.header
    np.testing.assert_array_equal(back.hand_q, t.hand_q)


@pytest.mark.parametrize("data, fragment", [
    ({"frames": []}, "not a trajectory"),
    ([], "no frames"),
    ([{"phase": "drag"}], "lacks"),
    ([{"phase": "drag", "virtual_xyz": [0, 0], "wrist_rpy": [0, 0, 0], "finger_dofs": [0] * 45,
       "wrist_pos": [0, 0, 0], "wrist_rot": [0, 0, 0, 1], "joint_positions": [0]}], "virtual_xyz"),
    ("hello", "not a trajectory"),
])
def test_wrong_schema_is_a_clear_error(data, fragment):
    with pytest.raises(DragMeshError, match=fragment):
        parse_trajectory(data)


def test_malformed_file(tmp_path):
    p = tmp_path / "bad.json"
    p.write_text("[{")
    with pytest.raises(DragMeshError, match="malformed JSON"):
        read_trajectory(p)
    with pytest.raises(DragMeshError, match="no such"):
        read_trajectory(tmp_path / "missing.json")
    json.loads("[]")


def test_a_trajectory_without_drag_frames_is_refused(shared_dir, tmp_path):
    """No drag phase: no grasp to start from and nothing to reach (it was once evaluated as 0.00 success)."""
    frames = json.loads((shared_dir / "reference" / "trajectories" / "45661.json").read_text())
    for f in frames:
        f["phase"] = "grasp" if f["phase"] == "drag" else f["phase"]
    (tmp_path / "t.json").write_text(json.dumps(frames))
    with pytest.raises(DragMeshError, match="no drag frames"):
        read_trajectory(tmp_path / "t.json")
