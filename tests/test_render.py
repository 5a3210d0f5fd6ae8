"""Pictures researchers would rather look at: MuJoCo's renderer wherever a GL context can be made (OSMesa on a CPU
machine: CI installs libosmesa6), the scene dressed and framed on the hand and the handle, the matplotlib drawing as
the fallback that says why, and videos whose panels say their damping, step, progress, load and outcome."""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from dragmesh2_jax import render
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import HANDLE_RGBA, PART_RGBA
from tests.conftest import in_ci


def _rgb(rgba: str) -> np.ndarray:
    return 255 * np.asarray([float(x) for x in rgba.split()[:3]])


def _share_near(img: np.ndarray, rgb: np.ndarray, tol: float = 60.0) -> float:
    """The share of pixels within ``tol`` of a colour (lit surfaces shade it)."""
    return float(np.mean(np.linalg.norm(img.astype(float) - rgb, axis=-1) < tol))


def test_mujoco_renders_the_expert_grasp_in_colour(drawer_task, tmp_path):
    if render.gl_problem():
        msg = f"MuJoCo cannot render here: {render.gl_problem()}"
        if in_ci():
            pytest.fail(msg)  # CI installs libosmesa6
        pytest.skip(msg)
    t = drawer_task
    grasp = t.traj.frames[t.traj.drag_start]
    used = render.render_pose(t.scene, grasp.hand_q, grasp.joint_positions[t.traj.target_index], tmp_path / "a.png",
                              width=320, height=240)
    img = np.asarray(Image.open(tmp_path / "a.png").convert("RGB"))
    assert used == "mujoco" and img.shape == (240, 320, 3)
    assert img.std() > 20 and len(np.unique(img.reshape(-1, 3), axis=0)) > 500  # neither blank nor one colour
    assert _share_near(img, _rgb(HANDLE_RGBA)) > 0.0005  # the handle is in view, in its own colour
    assert _share_near(img, _rgb(PART_RGBA)) > 0.01  # and the target part
    hand = 255 * np.asarray(t.scene.config.hand.rgba[:3])
    assert _share_near(img, hand, 40.0) > 0.005  # and the hand


def test_without_gl_the_matplotlib_drawing_stands_in_and_says_why_once(drawer_task, monkeypatch, capsys, tmp_path):
    monkeypatch.setattr(render, "gl_problem", lambda: "no GL backend (test)")
    monkeypatch.setattr(render, "_SAID", [])
    assert render.resolve_renderer("auto") == "matplotlib" == render.resolve_renderer("auto")
    assert capsys.readouterr().err.count("note: pictures drawn with matplotlib (no GL backend (test))") == 1
    with pytest.raises(DragMeshError, match="--renderer mujoco: no GL backend"):
        render.resolve_renderer("mujoco")
    with pytest.raises(DragMeshError, match="unknown renderer"):
        render.resolve_renderer("povray")
    t = drawer_task
    used = render.render_pose(t.scene, t.traj.frames[0].hand_q, t.traj.q_start, tmp_path / "b.png", 320, 240)
    assert used == "matplotlib" and (tmp_path / "b.png").read_bytes()[:4] == b"\x89PNG"
    img = np.asarray(Image.open(tmp_path / "b.png").convert("RGB"))
    assert img.shape == (240, 320, 3)  # the size asked for
    assert img.std() > 20 and len(np.unique(img.reshape(-1, 3), axis=0)) > 100  # a drawing, not a blank canvas
    assert _share_near(img, _rgb(PART_RGBA)) > 0.01  # the target part is drawn, in its colour


def test_a_video_puts_the_dampings_side_by_side_and_marks_how_each_ended(drawer_task, tmp_path):
    """The expert drag at x1 and x8 on the packaged drawer: both open; each panel ends on the green banner."""
    t = drawer_task
    c = tracking_controller(t)
    path, used = render.render_policy_video(t, c, [1.0, 8.0], tmp_path / "v.gif", every=40, width=200, height=150)
    with Image.open(path) as gif:
        assert gif.size == (400, 150) and gif.n_frames >= 3
        gif.seek(gif.n_frames - 1)
        last = np.asarray(gif.convert("RGB"))
    opened = np.asarray(render.OUTCOME_COLOURS["opened"], float)
    for panel in (last[-4:, 150:190], last[-4:, 350:390]):  # the banners' plain right half
        assert np.abs(panel.reshape(-1, 3).mean(0) - opened).max() < 40
    top = last[:20, :100].astype(float)
    assert top.mean() > 180  # the overlay box (white, text on it) at the top left


@pytest.mark.parametrize("mediapy", ["as installed", "hidden"])
def test_write_video_writes_an_mp4_or_else_a_gif_of_the_same_frames_beside_it(tmp_path, monkeypatch, mediapy):
    """``.mp4`` where mediapy and ffmpeg are installed: an MP4 of every frame at the frames' size (decoded back with
    ffmpeg). Without them (or with mediapy hidden): the GIF beside it, every frame in order at the frames' size and
    1/fps apart, and no MP4 left behind."""
    if mediapy == "hidden":
        monkeypatch.setitem(sys.modules, "mediapy", None)  # ``import mediapy`` raises ImportError
    colours = [(200, 40, 40), (40, 160, 60), (40, 60, 200), (230, 200, 40), (120, 120, 120)]
    frames = [Image.new("RGB", (64, 48), c) for c in colours]
    out = Path(render.write_video(frames, tmp_path / "v.mp4", fps=20))
    if out.suffix == ".mp4":
        assert out == tmp_path / "v.mp4" and out.read_bytes()[4:8] == b"ftyp"  # an MP4 container
        ffmpeg = shutil.which("ffmpeg")  # decoded by ffmpeg itself: mediapy's reader lags ffmpeg's options
        if ffmpeg:
            raw = subprocess.run([ffmpeg, "-v", "error", "-i", str(out), "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
                                 capture_output=True, check=True).stdout
            video = np.frombuffer(raw, np.uint8).reshape(-1, 48, 64, 3)
            assert len(video) == len(frames)
            np.testing.assert_allclose(video.reshape(5, -1, 3).mean(1), colours, atol=12)  # a lossy codec
        return
    assert out == tmp_path / "v.gif" and not (tmp_path / "v.mp4").exists()
    with Image.open(out) as gif:
        assert gif.size == (64, 48) and gif.n_frames == len(frames)
        for k, colour in enumerate(colours):
            gif.seek(k)
            assert gif.info["duration"] == 50  # ms: 20 frames per second
            assert np.abs(np.asarray(gif.convert("RGB")).reshape(-1, 3) - colour).max() <= 8


def test_annotations_and_the_outcome_banner():
    img = render.annotate(Image.new("RGB", (240, 180), (30, 30, 30)), ["damping x4   step 12", "wrist load 80.0 N"],
                          "detached")
    a = np.asarray(img).astype(float)
    assert a[:10, :100].mean() > 150  # the box behind the text
    assert np.abs(a[-3:, 200] - render.OUTCOME_COLOURS["detached"]).max() < 40  # the red banner
