"""Pictures and videos of the pulling task: MuJoCo's offscreen renderer wherever a GL context can be made (OSMesa on a
CPU machine, EGL on a GPU one: ``dragmesh2_jax/__init__.py`` picks the backend before MuJoCo loads), else a GL-free
matplotlib drawing of the same geoms, said once on stderr; ``renderer="mujoco"|"matplotlib"`` overrides.

MuJoCo draws a copy of the scene dressed for pictures (a floor under the object, a sky, a key and a fill light; the
physics model is untouched), from a camera framed on the hand and the handle: on the handle's outward side, turned
aside and looking down, at the hand-handle midpoint. The hand, the handle and the target part have their own colours
(``scene.py``). Videos put the dampings side by side and overlay each panel with its damping, step, progress to
q_done, wrist load and, at the end, how the episode ended.
"""

from __future__ import annotations

import functools
import io
import math
import os
import sys
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from PIL import Image, ImageDraw, ImageFont
from scipy.spatial import ConvexHull

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation import rollout as rollouts
from dragmesh2_jax.io import atomic_write_bytes
from dragmesh2_jax.policies.controller import Controller
from dragmesh2_jax.scene import Scene, SceneConfig, build_scene

RENDERERS = ("auto", "mujoco", "matplotlib")
#: Control steps between video frames: 2 at 60 Hz control is 30 frames per second, played in real time.
VIDEO_EVERY = 2
OUTCOME_COLOURS = {"opened": (40, 160, 60), "detached": (200, 40, 40), "timed out": (120, 120, 120)}


@dataclass(frozen=True)
class View:
    """A free camera: where it looks, from how far, from which side (degrees, MuJoCo's convention)."""

    lookat: tuple[float, float, float]
    distance: float
    azimuth: float
    elevation: float

    @classmethod
    def of(cls, scene: Scene, palm: np.ndarray | None = None, side: float = 35.0, elevation: float = -20.0,
           distance: float = 0.5) -> View:
        """Framed on the hand and the handle: from the handle's outward side (where the hand is), turned ``side``
        degrees aside (for a door, away from its hinge, so the opening door does not come between the camera and
        the hand), looking down at the midpoint of the handle and the palm."""
        h = scene.handle
        n = np.asarray(h.normal, float)
        look = h.centre if palm is None else 0.5 * (np.asarray(h.centre) + np.asarray(palm))
        turn = side  # a positive azimuth turns the camera towards -lateral (lateral = normal x up)
        joint = scene.obj.target.joint
        if joint.is_revolute:
            hinge = np.asarray(scene.config.object_pos) + scene.config.scale * np.asarray(joint.origin)
            if np.dot(np.asarray(h.centre) - hinge, np.cross(n, [0.0, 0.0, 1.0])) > 0:
                turn = -side
        azimuth = math.degrees(math.atan2(-n[1], -n[0])) + turn  # the camera looks back along the normal
        return cls(tuple(float(x) for x in look), distance, azimuth, elevation)

    def camera(self) -> mujoco.MjvCamera:
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = self.lookat
        cam.distance, cam.azimuth, cam.elevation = self.distance, self.azimuth, self.elevation
        return cam


def _object_bottom(scene: Scene) -> float:
    """The lowest point of the object's geoms (world z, object closed), from their bounding boxes."""
    m, d = scene.model, scene.initial_data()
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
    corners = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    low = np.inf
    for g in range(m.ngeom):
        if m.body_rootid[m.geom_bodyid[g]] == root:
            centre, half = m.geom_aabb[g, :3], m.geom_aabb[g, 3:]
            world = (centre + corners * half) @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g]
            low = min(low, float(world[:, 2].min()))
    return low


def dressed_model(scene: Scene) -> mujoco.MjModel:
    """The scene for pictures: the same bodies and joints (qpos layout), plus a floor under the object, a sky, and a key
    and a fill light. Nothing added collides; the physics never sees this model."""
    root = ET.fromstring(scene.xml)
    x, y, z = (float(v) for v in scene.handle.centre)
    asset = root.find("asset")
    if asset is None:
        asset = ET.SubElement(root, "asset")
    ET.SubElement(asset, "texture", name="sky", type="skybox", builtin="gradient", rgb1="0.85 0.9 0.97",
                  rgb2="0.45 0.55 0.7", width="256", height="256")
    ET.SubElement(asset, "texture", name="floor", type="2d", builtin="checker", rgb1="0.82 0.82 0.8",
                  rgb2="0.72 0.72 0.7", width="256", height="256")
    ET.SubElement(asset, "material", name="floor", texture="floor", texrepeat="8 8", reflectance="0.05")
    world = root.find("worldbody")
    for i, (tag, attrs) in enumerate((
            ("geom", {"name": "floor", "type": "plane", "size": "3 3 0.05", "material": "floor",
                      "pos": f"{x:.4f} {y:.4f} {_object_bottom(scene):.4f}", "contype": "0", "conaffinity": "0"}),
            ("light", {"name": "key", "pos": f"{x - 0.6:.4f} {y - 0.9:.4f} {z + 1.4:.4f}", "dir": "0.35 0.55 -0.75",
                       "diffuse": "0.7 0.7 0.68", "specular": "0.2 0.2 0.2", "castshadow": "true"}),
            ("light", {"name": "fill", "pos": f"{x + 1.2:.4f} {y + 0.8:.4f} {z + 0.6:.4f}", "dir": "-0.7 -0.5 -0.3",
                       "diffuse": "0.3 0.32 0.35", "castshadow": "false"}))):
        world.insert(i, ET.Element(tag, attrs))
    visual = root.find("visual")
    ET.SubElement(visual, "headlight", ambient="0.3 0.3 0.3", diffuse="0.25 0.25 0.25")
    ET.SubElement(visual, "quality", shadowsize="4096")
    visual.find("global").set("offwidth", "1920")
    visual.find("global").set("offheight", "1080")
    return mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))


@functools.lru_cache(maxsize=1)
def gl_problem() -> str | None:
    """Why MuJoCo's renderer cannot run here (None: it can). Tried once per process: a failed GL context can abort
    it, so only where a backend is configured (``MUJOCO_GL``, or a ``DISPLAY``)."""
    if not (os.environ.get("MUJOCO_GL") or os.environ.get("DISPLAY")):
        return ("no GL backend: install libosmesa6 on a CPU machine (apt-get install libosmesa6), or set MUJOCO_GL "
                "(egl on a GPU machine)")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 16, 16).close()
        return None
    except Exception as e:
        return f"MuJoCo's renderer failed with MUJOCO_GL={os.environ.get('MUJOCO_GL', '(unset)')}: {e}"


_SAID: list[str] = []


def resolve_renderer(renderer: str = "auto") -> str:
    """``mujoco`` or ``matplotlib``: ``auto`` is MuJoCo's where it can run, else the fallback (said once, why)."""
    if renderer not in RENDERERS:
        raise DragMeshError(f"unknown renderer {renderer!r} (choose from {', '.join(RENDERERS)})")
    problem = gl_problem() if renderer != "matplotlib" else None
    if renderer == "mujoco" and problem:
        raise DragMeshError(f"--renderer mujoco: {problem}")
    if renderer == "auto" and problem:
        if not _SAID:
            _SAID.append(problem)
            print(f"note: pictures drawn with matplotlib ({problem})", file=sys.stderr)
        return "matplotlib"
    return "matplotlib" if renderer == "matplotlib" else "mujoco"


class Painter:
    """Frames of one scene: poses in, RGB images out, from one view, by one renderer (a GL context made once)."""

    def __init__(self, scene: Scene, width: int = 640, height: int = 480, renderer: str = "auto"):
        self.scene, self.width, self.height = scene, width, height
        self.used = resolve_renderer(renderer)
        self.model, self._gl = scene.model, None
        if self.used == "mujoco":
            self.model = dressed_model(scene)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self._gl = mujoco.Renderer(self.model, height, width)
        self.data = mujoco.MjData(self.model)

    def pose(self, hand_q, obj_q) -> mujoco.MjData:
        ids = self.scene.ids
        self.data.qpos[ids.hand_qpos] = hand_q
        self.data.qpos[ids.target_qpos] = obj_q
        mujoco.mj_forward(self.model, self.data)
        return self.data

    def palm(self) -> np.ndarray:
        return np.array(self.data.site_xpos[self.scene.ids.palm_site])

    def image(self, hand_q, obj_q, view: View | None = None) -> Image.Image:
        d = self.pose(hand_q, obj_q)
        view = view or View.of(self.scene, self.palm())
        if self._gl is not None:
            self._gl.update_scene(d, camera=view.camera())
            return Image.fromarray(self._gl.render())
        return Image.open(io.BytesIO(_render_matplotlib(self.scene.model, d, view, self.width, self.height))
                          ).convert("RGB")

    def close(self) -> None:
        if self._gl is not None:
            self._gl.close()
            self._gl = None

    def __enter__(self) -> Painter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


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


def _render_matplotlib(model, data, view: View, width, height) -> bytes:
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
    target, half = np.asarray(view.lookat), 0.22
    ax.set_xlim(target[0] - half, target[0] + half)
    ax.set_ylim(target[1] - half, target[1] + half)
    ax.set_zlim(target[2] - half, target[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=-view.elevation, azim=view.azimuth + 180.0)  # matplotlib's angles are where the eye is
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    return buf.getvalue()


def _png(img: Image.Image) -> bytes:
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def render_pose(scene: Scene, hand_q, obj_q, path: str | Path, width: int = 800, height: int = 600,
                renderer: str = "auto") -> str:
    """Write a PNG of ``scene`` at hand configuration ``hand_q`` and target-joint position ``obj_q``, framed on the
    hand and the handle; returns the renderer used (``mujoco`` or ``matplotlib``)."""
    with Painter(scene, width, height, renderer) as p:
        atomic_write_bytes(path, _png(p.image(hand_q, obj_q)))
        return p.used


def _font(size: int):
    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow without FreeType: its fixed bitmap font
        return ImageFont.load_default()


def annotate(img: Image.Image, lines: list[str], outcome: str | None = None) -> Image.Image:
    """``lines`` in a box at the top left; at the end of an episode, its outcome as a coloured banner."""
    draw = ImageDraw.Draw(img, "RGBA")
    font = _font(max(11, img.height // 24))
    pad, step = 6, max(13, img.height // 20)
    draw.rectangle((0, 0, int(img.width * 0.62), pad + step * len(lines)), fill=(255, 255, 255, 190))
    for i, text in enumerate(lines):
        draw.text((pad, pad // 2 + i * step), text, fill=(20, 20, 20), font=font)
    if outcome is not None:
        h = step + pad
        draw.rectangle((0, img.height - h, img.width, img.height), fill=(*OUTCOME_COLOURS[outcome], 220))
        draw.text((pad, img.height - h + pad // 2), outcome.upper(), fill=(255, 255, 255), font=font)
    return img


def _write_gif(frames, path: str | Path, frame_ms: int) -> None:
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=frame_ms, loop=0)
    atomic_write_bytes(path, buf.getvalue())


def write_video(frames: list[Image.Image], path: str | Path, fps: float) -> str:
    """MP4 where ``mediapy`` and ffmpeg are installed (by ``path``'s suffix), else GIF beside it; the path written."""
    path = Path(path)
    if path.suffix == ".mp4":
        try:
            import mediapy  # optional: MP4 where it and ffmpeg are installed

            mediapy.write_video(str(path), [np.asarray(f) for f in frames], fps=fps)
            return str(path)
        except Exception:  # no mediapy or no ffmpeg: a GIF instead
            path = path.with_suffix(".gif")
    _write_gif(frames, path, round(1000 / fps))
    return str(path)


def render_trajectory_gif(obj, traj, path: str | Path, every: int = 15, width: int = 480, height: int = 360,
                          renderer: str = "auto") -> str:
    """A GIF of a trajectory replayed kinematically (recorded hand q and object joints) every ``every`` frames."""
    sc = build_scene(obj, SceneConfig(scale=traj.header.get("scene", {}).get("scale", 0.4)))
    with Painter(sc, width, height, renderer) as p:
        grasp = traj.frames[traj.drag_start]
        p.pose(grasp.hand_q, grasp.joint_positions[traj.target_index])
        view = View.of(sc, p.palm())
        images = [annotate(p.image(f.hand_q, f.joint_positions[traj.target_index], view), [f"{f.phase} {f.step}"])
                  for f in traj.frames[::every]]
        used = p.used
    _write_gif(images, path, 250)
    return used


def outcome(row: dict) -> str:
    return "opened" if row["success"] else "detached" if row["detach"] else "timed out"


def render_policy_video(task, controller: Controller, dampings: list[float], path: str | Path,
                        every: int = VIDEO_EVERY, width: int = 480, height: int = 360, seed: int = 0,
                        renderer: str = "auto", still: str | Path | None = None) -> tuple[str, str]:
    """Rollouts of ``controller`` (deterministic) at each damping side by side, one panel per damping, a frame every
    ``every`` control steps played in real time, each panel overlaid with its damping, step, progress to q_done and
    wrist load, and its outcome once its episode ends (it then holds its last frame: the state before its last
    step). MP4 where ``mediapy`` and ffmpeg are available, else GIF (``.mp4`` falls back to ``.gif``); ``still``:
    its last frame as a PNG too. Returns the path written and the renderer used."""
    if every < 1:
        raise DragMeshError(f"video frames every {every} control steps: must be >= 1")
    result = rollouts.rollout(task, controller.make_policy(True), controller.params, dampings, 1, seed,
                              controller.controls, steps=task.config.episode_length, key=controller.key)
    rows = rollouts.frames(result, dampings)
    p = task.params
    span = max(float(p.q_done - p.q_start), 1e-9)
    T = max(r["steps"] for r in rows)
    frames = []
    with Painter(task.scene, width, height, renderer) as painter:
        painter.pose(rows[0]["hand_q"][0], rows[0]["obj_q"][0])
        view = View.of(task.scene, painter.palm())  # one camera for the whole video
        last: dict[int, tuple[int, Image.Image]] = {}  # a finished panel holds its last frame
        for t in [*range(0, T, every), T - 1]:
            panels = []
            for i, r in enumerate(rows):
                k = min(t, r["steps"] - 1)
                if last.get(i, (None,))[0] != k:
                    img = painter.image(r["hand_q"][k], r["obj_q"][k], view)
                    last[i] = k, annotate(img, [f"damping x{r['damping']:g}   step {k}",
                                                f"to q_done {100 * (r['obj_q'][k] - float(p.q_start)) / span:5.1f}%",
                                                f"wrist load {r['wrist_load'][k]:5.1f} N"],
                                          outcome(r) if k == r["steps"] - 1 else None)
                panels.append(last[i][1])
            frame = Image.new("RGB", (width * len(panels), height), "white")
            for j, panel in enumerate(panels):
                frame.paste(panel, (j * width, 0))
            frames.append(frame)
        used = painter.used
    if still is not None:
        atomic_write_bytes(still, _png(frames[-1]))
    return write_video(frames, path, 1.0 / (every * task.config.control_dt)), used
