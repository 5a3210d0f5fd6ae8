"""The training run: epochs in Python around the jitted ``Trainer.epoch``; logs, checkpoints, exact resume.

Run folder:
    run.json               method, task/PPO config, object folder (the trajectory is copied beside it)
    trajectory.json        the reference trajectory the task was built from
    log.jsonl, log.csv     one row per epoch
    checkpoints/epoch_NNNN.npz  every ``save_every`` epochs; best.npz (by training reward), final.npz
A checkpoint holds every leaf of the TrainState (params, optimiser, env state, normalisers, rng, epoch), so
``--resume`` continues exactly where the run stopped.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import time
from pathlib import Path

import jax
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_bytes, atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.train import Trainer, TrainState
from dragmesh2_jax.trajectory.schema import write_trajectory

LOG_KEYS = ("epoch", "reward", "success", "progress", "detach", "clip099", "episode_return", "episodes", "loss",
            "policy_loss", "value_loss", "bounds_loss", "aux_loss", "kl", "lr", "w_aux", "action_l2", "nonfinite",
            "seconds", "env_steps")


def save_checkpoint(ts: TrainState, path: Path) -> Path:
    leaves = [np.asarray(x) for x in jax.tree.leaves(ts)]
    buf = io.BytesIO()
    np.savez(buf, *leaves)
    return atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(template: TrainState, path: Path) -> TrainState:
    if not Path(path).is_file():
        raise DragMeshError(f"{path}: no such checkpoint")
    z = np.load(path)
    leaves, treedef = jax.tree.flatten(template)
    if len(z.files) != len(leaves):
        raise DragMeshError(f"{path}: checkpoint does not match this method/config ({len(z.files)} arrays, "
                            f"expected {len(leaves)})")
    new = []
    for i, ref in enumerate(leaves):
        a = z[f"arr_{i}"]
        if a.shape != np.shape(ref):
            raise DragMeshError(f"{path}: array {i} has shape {a.shape}, expected {np.shape(ref)}")
        new.append(jax.numpy.asarray(a, dtype=np.asarray(ref).dtype))
    return jax.tree.unflatten(treedef, new)


def latest_checkpoint(run_dir: Path) -> Path | None:
    ck = sorted((run_dir / "checkpoints").glob("epoch_*.npz"))
    return ck[-1] if ck else None


def write_run_meta(run_dir: Path, trainer: Trainer, object_dir: str) -> None:
    write_trajectory(trainer.task.traj, run_dir / "trajectory.json")
    meta = {"method": trainer.method.name, "object": str(Path(object_dir).resolve()),
            "trajectory": "trajectory.json", "backend": trainer.task.backend.name,
            "ppo": dataclasses.asdict(trainer.config), "task": json.loads(json.dumps(
                dataclasses.asdict(trainer.task.config), default=str))}
    atomic_write_json(run_dir / "run.json", meta)


def train(trainer: Trainer, run_dir: str | Path, object_dir: str, resume: bool = False, save_every: int = 10,
          progress: bool = True, log_fn=None) -> tuple[TrainState, list[dict]]:
    """Train to ``trainer.config.epochs`` epochs; returns the final state and the log rows."""
    run_dir = Path(run_dir)
    c = trainer.config
    ts = trainer.init()
    rows: list[dict] = []
    if resume:
        ck = latest_checkpoint(run_dir)
        if ck is None:
            raise DragMeshError(f"{run_dir}: nothing to resume (no checkpoints/epoch_*.npz)")
        ts = load_checkpoint(ts, ck)
        log = run_dir / "log.jsonl"
        if log.is_file():
            rows = [json.loads(x) for x in log.read_text().splitlines() if x.strip()]
            rows = [r for r in rows if r["epoch"] <= int(ts.epoch)]
    else:
        if (run_dir / "log.jsonl").exists():
            raise DragMeshError(f"{run_dir}: already holds a run (use --resume, or another --out)")
        run_dir.mkdir(parents=True, exist_ok=True)
        write_run_meta(run_dir, trainer, object_dir)
    best = max((r["reward"] for r in rows), default=-np.inf)
    start = int(ts.epoch)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.fields[stats]}"), disable=not progress) as bar:
        task = bar.add_task(f"train {trainer.method.name}", total=c.epochs, completed=start, stats="")
        t_start = time.time()
        for _ in range(start, c.epochs):
            ts, m = trainer.epoch(ts)
            m = {k: float(v) for k, v in jax.device_get(m).items()}
            e = int(ts.epoch)
            row = {"epoch": e, **{k: m[k] for k in LOG_KEYS if k in m}, "seconds": round(time.time() - t_start, 2),
                   "env_steps": e * c.num_envs * c.rollout_len}
            rows.append(row)
            _write_logs(run_dir, rows)
            if e % save_every == 0:
                save_checkpoint(ts, run_dir / "checkpoints" / f"epoch_{e:04d}.npz")
            if row["reward"] > best:
                best = row["reward"]
                save_checkpoint(ts, run_dir / "checkpoints" / "best.npz")
            bar.update(task, completed=e, stats=f"reward {row['reward']:.2f}  success {row['success']:.2f}  "
                                                  f"progress {row['progress']:.2f}  clip099 {row['clip099']:.2f}")
            if log_fn:
                log_fn(row)
    save_checkpoint(ts, run_dir / "checkpoints" / "final.npz")
    return ts, rows


def _write_logs(run_dir: Path, rows: list[dict]) -> None:
    atomic_write_text(run_dir / "log.jsonl", "".join(json.dumps(r) + "\n" for r in rows))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=LOG_KEYS, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(run_dir / "log.csv", buf.getvalue())
