"""Pictures of a scene: MuJoCo's offscreen renderer where a GL backend exists, else a GL-free matplotlib
drawing of the same geoms (so a picture is always written, and the caller is told which renderer ran)."""

from __future__ import annotations

import functools
import io
import os
import warnings
from pathlib import Path

import matplotlib.image
import mujoco
import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from PIL import Image, ImageDraw
from scipy.spatial import ConvexHull

from dragmesh2_jax.evaluation import rollout as rollouts
from dragmesh2_jax.io import atomic_write_bytes
from dragmesh2_jax.scene import SceneConfig, build_scene


def _look_at_camera(model: mujoco.MjModel, target: np.ndarray) -> mujoco.MjvCamera:
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = target
    cam.distance, cam.azimuth, cam.elevation = 0.9, 200.0, -25.0
    return cam


def _render_gl(model, data, target, width, height) -> bytes:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = mujoco.Renderer(model, height, width)
    with r:
        r.update_scene(data, camera=_look_at_camera(model, target))
        img = r.render()
    buf = io.BytesIO()
    matplotlib.image.imsave(buf, img, format="png")
    return buf.getvalue()


def _geom_polys(model, data, g):
    """Faces (list of Nx3 arrays) of geom ``g`` in world coordinates, or a capsule segment."""
    pos, R, size, typ = data.geom_xpos[g], data.geom_xmat[g].reshape(3, 3), model.geom_size[g], model.geom_type[g]
    if typ == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v = model.mesh_vert[model.mesh_vertadr[m]: model.mesh_vertadr[m] + model.mesh_vertnum[m]]
    elif typ == mujoco.mjtGeom.mjGEOM_BOX:
        v = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)]) * size
    elif typ == mujoco.mjtGeom.mjGEOM_CAPSULE:
        a = pos + R[:, 2] * size[1]
        b = pos - R[:, 2] * size[1]
        return "segment", (a, b, size[0])
    else:
        return None, None
    w = v @ R.T + pos
    try:
        hull = ConvexHull(w)
        return "faces", [w[s] for s in hull.simplices]
    except Exception:
        return None, None


def _render_matplotlib(model, data, target, width, height) -> bytes:
    fig = Figure(figsize=(width / 100, height / 100), dpi=100)  # no pyplot: no display backend
    ax = fig.add_subplot(111, projection="3d")
    ax.computed_zorder = False  # draw in our order: object first, hand (contype 1) on top
    for g in sorted(range(model.ngeom), key=lambda g: model.geom_contype[g] == 1):
        kind, payload = _geom_polys(model, data, g)
        rgba = model.geom_rgba[g].copy()
        if kind == "faces":
            rgba[3] = min(rgba[3], 0.35 if model.geom_contype[g] == 0 else 0.8)
            ax.add_collection3d(Poly3DCollection(payload, facecolors=[rgba], edgecolors=(0, 0, 0, 0.08),
                                                 linewidths=0.2))
        elif kind == "segment":
            a, b, r = payload
            ax.plot(*np.stack([a, b]).T, color=rgba[:3] * 0.8, linewidth=max(1.5, r * 1100), solid_capstyle="round",
                    zorder=10)
    half = 0.22
    ax.set_xlim(target[0] - half, target[0] + half)
    ax.set_ylim(target[1] - half, target[1] + half)
    ax.set_zlim(target[2] - half, target[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=200)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    return buf.getvalue()


@functools.lru_cache(maxsize=1)
def gl_available() -> bool:
    """Whether MuJoCo's offscreen GL can be used here. Only tried where a GL backend is configured
    (``MUJOCO_GL`` set, or a ``DISPLAY``), and at most once per process: a failed GL context can abort it."""
    if not (os.environ.get("MUJOCO_GL") or os.environ.get("DISPLAY")):
        return False
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 16, 16)
        r.close()
        return True
    except Exception:
        return False


def render_image(model: mujoco.MjModel, data: mujoco.MjData, target=None, width: int = 800, height: int = 600,
                 backend: str = "auto") -> tuple[bytes, str]:
    """PNG bytes of the scene looking at ``target`` (world point) and the renderer used: ``"mujoco"`` (GL
    offscreen) or ``"matplotlib"`` (no GL backend available, or ``backend="matplotlib"``)."""
    target = np.asarray(target if target is not None else data.xpos[-1], dtype=np.float64)
    if backend == "mujoco" or (backend == "auto" and gl_available()):
        try:
            return _render_gl(model, data, target, width, height), "mujoco"
        except Exception:
            if backend == "mujoco":
                raise
    return _render_matplotlib(model, data, target, width, height), "matplotlib"


def render_png(model: mujoco.MjModel, data: mujoco.MjData, path: str | Path, target=None, width: int = 800,
               height: int = 600, backend: str = "auto") -> str:
    """Write a PNG of the scene looking at ``target``; returns the renderer used (see :func:`render_image`)."""
    png, used = render_image(model, data, target, width, height, backend)
    atomic_write_bytes(path, png)
    return used


def set_pose(scene, data: mujoco.MjData, hand_q, obj_q) -> mujoco.MjData:
    """``data`` at hand configuration ``hand_q`` (51) and target-joint position ``obj_q``, kinematics computed."""
    data.qpos[scene.ids.hand_qpos] = hand_q
    data.qpos[scene.ids.target_qpos] = obj_q
    mujoco.mj_forward(scene.model, data)
    return data


def _frame(scene, data, width: int, height: int):
    """(PIL image, renderer) of ``data`` looking at the handle."""
    png, used = render_image(scene.model, data, scene.handle.centre, width, height)
    return Image.open(io.BytesIO(png)).convert("RGB"), used


def _write_gif(frames, path: str | Path, frame_ms: int) -> None:
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=frame_ms, loop=0)
    atomic_write_bytes(path, buf.getvalue())


def render_trajectory_gif(obj, traj, path: str | Path, every: int = 15, width: int = 480, height: int = 360) -> str:
    """A GIF of a trajectory replayed kinematically (recorded hand q and object joints) every ``every`` frames."""
    sc = build_scene(obj, SceneConfig(scale=traj.header.get("scene", {}).get("scale", 0.4)))
    d = sc.initial_data()
    images, used = [], "matplotlib"
    for f in traj.frames[::every]:
        img, used = _frame(sc, set_pose(sc, d, f.hand_q, f.joint_positions[traj.target_index]), width, height)
        images.append(img)
    _write_gif(images, path, 250)
    return used


def render_policy_video(task, policy, params, dampings: list[float], path: str | Path, every: int = 6,
                        width: int = 360, height: int = 270, seed: int = 0) -> tuple[str, str]:
    """Rollouts of ``policy`` at each damping side by side, one panel per damping (labelled with the multiplier
    and the outcome), every ``every`` control steps, played in real time; a finished episode holds its last frame
    (the state before its last step). MP4 where ``mediapy`` and ffmpeg are available, else GIF (by ``path``'s
    suffix: ``.mp4`` falls back to ``.gif``). Returns the path written and the renderer: ``"mujoco"`` (GL) or
    ``"matplotlib"``."""
    rows = rollouts.frames(rollouts.rollout(task, policy, params, dampings, 1, seed, steps=task.config.episode_length),
                           dampings)
    sc = task.scene
    d = sc.initial_data()
    T = max(r["steps"] for r in rows)
    frames, used = [], "matplotlib"
    for t in [*range(0, T, every), T - 1]:
        panels = []
        for r in rows:
            k = min(t, r["steps"] - 1)
            img, used = _frame(sc, set_pose(sc, d, r["hand_q"][k], r["obj_q"][k]), width, height)
            end = "" if t < r["steps"] - 1 else (" opened" if r["success"] else " failed")
            ImageDraw.Draw(img).text((8, 8), f"damping x{r['damping']:g}  step {k}{end}", fill=(0, 0, 0))
            panels.append(img)
        frame = Image.new("RGB", (width * len(panels), height), "white")
        for i, p in enumerate(panels):
            frame.paste(p, (i * width, 0))
        frames.append(frame)
    frame_s = every * task.config.control_dt  # real time between frames
    path = Path(path)
    if path.suffix == ".mp4":
        try:
            import mediapy  # optional: MP4 where it and ffmpeg are installed

            mediapy.write_video(str(path), [np.asarray(f) for f in frames], fps=1.0 / frame_s)
            return str(path), used
        except Exception:  # no mediapy or no ffmpeg: a GIF instead
            path = path.with_suffix(".gif")
    _write_gif(frames, path, round(1000 * frame_s))
    return str(path), used
