"""The 51-DoF SMPL-X hand: DoF order, limits, mass, frames, mirroring, and PD stability at dt = 1/240 s."""

import mujoco
import numpy as np
import pytest

from dragmesh2_jax.assets import hand


def _model(side="right"):
    return mujoco.MjModel.from_xml_string(hand.hand_only_xml(hand.HandConfig(side=side)))


def test_dof_order_is_virtual_wrist_then_five_fingers():
    names = hand.dof_names()
    assert len(names) == 51 == hand.NUM_DOFS
    assert names[:6] == ("virtual_x", "virtual_y", "virtual_z", "R_Wrist_x", "R_Wrist_y", "R_Wrist_z")
    fingers = [n.split("_")[1] for n in names[6:]]
    assert fingers[::9] == ["Index1", "Middle1", "Pinky1", "Ring1", "Thumb1"]
    assert [n[-1] for n in names[6:9]] == ["x", "y", "z"]


def test_model_has_51_joints_and_actuators_in_action_order():
    m = _model()
    assert m.nq == m.nv == m.nu == 51
    for i, name in enumerate(hand.dof_names()):
        assert mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, i) == name
        assert m.actuator_trnid[i, 0] == i


def test_locked_axes_stay_joints_with_tiny_range():
    r = hand.dof_ranges()
    widths = np.degrees(r[6:, 1] - r[6:, 0])
    assert np.sum(np.isclose(widths, 0.2)) == 24  # 24 locked (+-0.1 deg), 21 free finger DoFs
    assert r[2, 0] == 0.0  # virtual_z lower limit 0 (design §1)


def test_mass_matches_reference_hand():
    m = _model()
    assert m.body_subtreemass[1] == pytest.approx(0.332, abs=0.002)


def test_wrist_rotation_is_intrinsic_xyz():
    m = _model()
    d = mujoco.MjData(m)
    d.qpos[:6] = [0.1, -0.2, 0.3, 0.4, -0.5, 0.6]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.xpos[1], [0.1, -0.2, 0.3], atol=1e-12)
    np.testing.assert_allclose(d.xmat[1].reshape(3, 3), hand.matrix_from_wrist_euler([0.4, -0.5, 0.6]), atol=1e-9)
    np.testing.assert_allclose(hand.wrist_euler_from_matrix(hand.matrix_from_wrist_euler([0.4, -0.5, 0.6])),
                               [0.4, -0.5, 0.6], atol=1e-9)


def test_sites_palm_centre_and_fingertips():
    m = _model()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    palm = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "R_palm_centre")
    np.testing.assert_allclose(d.site_xpos[palm], hand.PALM_OFFSET, atol=1e-12)
    tips = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, n) for n in hand.fingertip_site_names()]
    assert min(tips) >= 0
    # fingers point along -y of the hand frame
    assert all(d.site_xpos[t][1] < -0.1 for t in tips if t != tips[-1])


def test_left_hand_is_the_mirror_image():
    mr, ml = _model("right"), _model("left")
    dr, dl = mujoco.MjData(mr), mujoco.MjData(ml)
    q = np.random.default_rng(0).uniform(*hand.dof_ranges().T)
    q[:6] = 0
    dr.qpos[:], dl.qpos[:] = q, q
    mujoco.mj_forward(mr, dr)
    mujoco.mj_forward(ml, dl)
    assert hand.dof_names("left")[3] == "L_Wrist_x"
    np.testing.assert_allclose(dl.xpos * [-1, 1, 1], dr.xpos, atol=1e-9)


def test_pd_control_is_stable_and_tracks_targets():
    m = _model()
    d = mujoco.MjData(m)
    d.qpos[2] = 0.5
    lo, hi = m.jnt_range.T
    rng = np.random.default_rng(1)
    for t in range(1200):  # 5 s of random 0.05-increment targets at 60 Hz
        if t % 4 == 0:
            d.ctrl[:] = np.clip(d.qpos + 0.05 * rng.uniform(-1, 1, 51), lo, hi)
        mujoco.mj_step(m, d)
        assert np.all(np.abs(d.qvel) < 50), f"unstable at step {t}"
    d.ctrl[:] = np.clip(d.qpos + 0.05, lo, hi)
    for _ in range(48):  # 0.2 s
        mujoco.mj_step(m, d)
    assert np.max(np.abs(d.ctrl - d.qpos)) < 0.01
