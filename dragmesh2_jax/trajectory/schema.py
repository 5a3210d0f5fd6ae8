"""Trajectory files: the reference implementation's frame schema plus a header.

A frame (design §9): ``phase`` (approach|grasp|drag|release), ``step`` (index within the phase),
``virtual_xyz`` (3, m), ``wrist_rpy`` (3, rad, intrinsic XYZ), ``finger_dofs`` (45, rad) -- together the
measured 51-d hand q -- ``wrist_pos`` (3, m) and ``wrist_rot`` (4, quaternion xyzw) of the wrist body, and
``joint_positions`` (every movable object joint, m or rad, scaled world units). Our files may add
``hand_target`` (51, the PD command of that frame).

The project writes ``{"format": "dragmesh2-trajectory", "version": 1, "header": {...}, "frames": [...]}``;
the reader also accepts the reference's bare list of frames.

Task quantities derived from a trajectory (paper eq. done/progress; design §4):
  target joint = argmax over joints of (max - min) over frames, q_min/q_max over frames,
  q_done = q_min + rho (q_max - q_min) with rho = 0.5, drag start = first "drag" frame,
  q_start = q at the drag start, q_goal = q_max.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dragmesh2_jax.assets.hand import NUM_DOFS
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_text

FORMAT = "dragmesh2-trajectory"
VERSION = 1
RHO = 0.5  # the paper's success-threshold fraction (Table 7; design §4)
PHASES = ("approach", "grasp", "drag", "release")
_VECTORS = {"virtual_xyz": 3, "wrist_rpy": 3, "finger_dofs": 45, "wrist_pos": 3, "wrist_rot": 4}


@dataclass(frozen=True)
class Frame:
    phase: str
    step: int
    virtual_xyz: tuple[float, ...]
    wrist_rpy: tuple[float, ...]
    finger_dofs: tuple[float, ...]
    wrist_pos: tuple[float, ...]
    wrist_rot: tuple[float, ...]
    joint_positions: tuple[float, ...]
    hand_target: tuple[float, ...] | None = None

    @property
    def hand_q(self) -> np.ndarray:
        """The 51-d hand configuration in action order."""
        return np.concatenate([self.virtual_xyz, self.wrist_rpy, self.finger_dofs])

    def to_json(self) -> dict:
        d = {"phase": self.phase, "step": self.step}
        for k in (*_VECTORS, "joint_positions"):
            d[k] = list(getattr(self, k))
        if self.hand_target is not None:
            d["hand_target"] = list(self.hand_target)
        return d


@dataclass(frozen=True)
class Trajectory:
    frames: tuple[Frame, ...]
    header: dict = field(default_factory=dict)

    def __post_init__(self):
        if not self.frames:
            raise DragMeshError("trajectory has no frames")

    @property
    def joint_positions(self) -> np.ndarray:
        return np.array([f.joint_positions for f in self.frames], dtype=np.float64)

    @property
    def hand_q(self) -> np.ndarray:
        return np.stack([f.hand_q for f in self.frames])

    @property
    def phases(self) -> list[str]:
        return [f.phase for f in self.frames]

    @property
    def target_index(self) -> int:
        """Index into ``joint_positions``: the header's, else the joint with the largest range (design §2)."""
        if "target" in self.header and "joint_index" in self.header["target"]:
            return int(self.header["target"]["joint_index"])
        jp = self.joint_positions
        return int(np.argmax(jp.max(axis=0) - jp.min(axis=0)))

    @property
    def target_q(self) -> np.ndarray:
        return self.joint_positions[:, self.target_index]

    @property
    def q_min(self) -> float:
        return float(self.target_q.min())

    @property
    def q_max(self) -> float:
        return float(self.target_q.max())

    def q_done_at(self, rho: float) -> float:
        """Success threshold q_done = q_min + rho (q_max - q_min)."""
        return self.q_min + rho * (self.q_max - self.q_min)

    @property
    def q_done(self) -> float:
        """The paper's success threshold (rho = 0.5)."""
        return self.q_done_at(RHO)

    @property
    def drag_start(self) -> int:
        """First frame of the drag phase (the expert grasp state); fallback min(40, T-1) as the reference."""
        return next((i for i, p in enumerate(self.phases) if p == "drag"), min(40, len(self.frames) - 1))

    @property
    def start_hand_q(self) -> np.ndarray:
        """The hand's start configuration: the drag-start frame's, its fingers at the header's ``grip`` where the
        grasp is seated (their targets just past the handle, so that a hand whose targets stay put holds it)."""
        q = np.asarray(self.frames[self.drag_start].hand_q, np.float64).copy()
        if "grip" in self.header:
            q[len(q) - len(self.header["grip"]):] = self.header["grip"]
        return q

    @property
    def q_start(self) -> float:
        return float(self.target_q[self.drag_start])

    @property
    def q_goal(self) -> float:
        return self.q_max

    def phase_blocks(self) -> list[tuple[str, int, int]]:
        """Contiguous phases as (phase, first frame, last frame + 1)."""
        out, start = [], 0
        ph = self.phases
        for i in range(1, len(ph) + 1):
            if i == len(ph) or ph[i] != ph[start]:
                out.append((ph[start], start, i))
                start = i
        return out

    def _drag_frames(self, control_dt: float) -> list[int]:
        """The frames of the expert drag, one per control step of ``control_dt``: those after the drag start through
        the end of the first contiguous drag block, each repeated frame_dt / control_dt times (1 for ours, 2 for the
        reference's 30 Hz files); the drag start alone for a drag block of one frame."""
        frame_dt = self.header.get("scene", {}).get("frame_dt", 1.0 / 30.0)
        hold = max(1, int(round(frame_dt / control_dt)))
        start = self.drag_start
        end = next((b for p, a, b in self.phase_blocks() if p == "drag" and a == start), len(self.frames))
        return [i for i in (list(range(start + 1, end)) or [start]) for _ in range(hold)]

    def drag_targets(self, control_dt: float, pace: float = 1.0) -> np.ndarray:
        """The expert drag as hand PD targets, one per control step of ``control_dt`` (``_drag_frames``). At another
        ``pace`` the same path is resampled in time (0.5: twice as many steps, linearly interpolated; 1: the frames
        themselves)."""
        if not (math.isfinite(pace) and pace > 0):
            raise DragMeshError(f"pace must be a positive number, got {pace}")
        targets = np.asarray([self.frames[i].hand_target or self.frames[i].hand_q
                              for i in self._drag_frames(control_dt)], np.float32)
        n = len(targets)
        t = np.linspace(0.0, n - 1.0, max(1, int(round(n / pace))))
        return np.stack([np.interp(t, np.arange(n), targets[:, j]) for j in range(targets.shape[1])],
                        1).astype(np.float32)

    def held_targets(self, control_dt: float, steps: int, pace: float = 1.0) -> np.ndarray:
        """:meth:`drag_targets` over an episode of ``steps`` control steps, the last target held (as an expert drag
        replays it)."""
        targets = self.drag_targets(control_dt, pace)
        return targets[np.minimum(np.arange(steps), len(targets) - 1)]

    def drag_schedule(self, control_dt: float, steps: int) -> np.ndarray:
        """The target joint where the expert drag, at its own pace, puts it after each of ``steps`` control steps:
        the plan's q of the frame whose hand target the step applies (``drag_targets``), the last held once the drag
        ends."""
        frames = self._drag_frames(control_dt)
        return self.target_q[[frames[min(t, len(frames) - 1)] for t in range(steps)]].astype(np.float32)

    def to_json(self) -> dict:
        return {"format": FORMAT, "version": VERSION, "header": self.header,
                "frames": [f.to_json() for f in self.frames]}


def _frame(d, i: int, where: str) -> Frame:
    if not isinstance(d, dict):
        raise DragMeshError(f"{where}: frame {i} is not an object")
    missing = [k for k in ("phase", *_VECTORS, "joint_positions") if k not in d]
    if missing:
        raise DragMeshError(f"{where}: frame {i} lacks {', '.join(missing)}")
    vals = {}
    for k, n in _VECTORS.items():
        v = d[k]
        if not isinstance(v, list) or len(v) != n:
            raise DragMeshError(f"{where}: frame {i} field {k} must be a list of {n} numbers")
        vals[k] = tuple(float(x) for x in v)
    jp = d["joint_positions"]
    if not isinstance(jp, list) or not jp:
        raise DragMeshError(f"{where}: frame {i} field joint_positions must be a non-empty list")
    ht = d.get("hand_target")
    if ht is not None and (not isinstance(ht, list) or len(ht) != NUM_DOFS):
        raise DragMeshError(f"{where}: frame {i} field hand_target must be a list of {NUM_DOFS} numbers")
    try:
        jp = tuple(float(x) for x in jp)
        ht = tuple(float(x) for x in ht) if ht is not None else None
    except (TypeError, ValueError):
        raise DragMeshError(f"{where}: frame {i} has a non-numeric value") from None
    if not all(np.isfinite(jp)) or not all(np.isfinite(np.concatenate(list(vals.values())))):
        raise DragMeshError(f"{where}: frame {i} has a non-finite value")
    return Frame(phase=str(d["phase"]), step=int(d.get("step", i)), joint_positions=jp, hand_target=ht, **vals)


def parse_trajectory(data, where: str = "trajectory") -> Trajectory:
    """From decoded JSON: the reference's bare frame list, or the project's ``{"format": ..., "frames": ...}``."""
    if isinstance(data, list):
        header = {}
        frames = data
    elif isinstance(data, dict) and data.get("format") == FORMAT and isinstance(data.get("frames"), list):
        if int(data.get("version", 0)) > VERSION:
            raise DragMeshError(f"{where}: trajectory format version {data['version']} is newer than {VERSION}")
        header, frames = dict(data.get("header") or {}), data["frames"]
    else:
        raise DragMeshError(f"{where}: not a trajectory (expected a list of frames or an object with "
                            f"format '{FORMAT}' and 'frames')")
    if not frames:
        raise DragMeshError(f"{where}: trajectory has no frames")
    parsed = tuple(_frame(f, i, where) for i, f in enumerate(frames))
    n = {len(f.joint_positions) for f in parsed}
    if len(n) != 1:
        raise DragMeshError(f"{where}: frames disagree on the number of object joints ({sorted(n)})")
    if not any(f.phase == "drag" for f in parsed):
        raise DragMeshError(f"{where}: no drag frames (phase 'drag'): the trajectory never pulls the part, so no "
                            "grasp to start from and nothing to reach")
    grip = header.get("grip")
    fingers = len(parsed[0].finger_dofs)
    if grip is not None and not (isinstance(grip, list) and len(grip) == fingers
                                 and all(isinstance(x, int | float) and math.isfinite(x) for x in grip)):
        raise DragMeshError(f"{where}: the header's grip must be {fingers} finite finger targets")
    return Trajectory(frames=parsed, header=header)


def read_trajectory(path: str | Path) -> Trajectory:
    path = Path(path)
    if not path.is_file():
        raise DragMeshError(f"{path}: no such trajectory file")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DragMeshError(f"{path}: malformed JSON ({e.msg} at line {e.lineno})") from None
    return parse_trajectory(data, where=str(path))


def write_trajectory(traj: Trajectory, path: str | Path) -> Path:
    """Write atomically. Floats are written with ``repr`` precision, so reading back round-trips exactly."""
    return atomic_write_text(path, json.dumps(traj.to_json()) + "\n")
