"""The training run: epochs in Python around the jitted ``Trainer.epoch``; logs, checkpoints, exact resume.

Run folder:
    run.json               method, task/PPO config, object folder (the trajectory is copied beside it)
    trajectory.json        the reference trajectory the task was built from
    log.jsonl, log.csv     one row per epoch
    robust.jsonl, robust.csv  the robustness evaluation every ``robust_every`` epochs (paper App. B.3-B.4):
                           det success at x1/x2/x4 from perturbed starts, a few episodes per cell
    checkpoints/epoch_NNNN.npz  every ``save_every`` epochs; best.npz (by training reward); best_robust.npz
                           (by mean then worst success over the damping set, ties by lower active clip099);
                           final.npz
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

LOG_KEYS = ("epoch", "reward", "success", "progress", "detach", "clip099", "clip099_active", "episode_return",
            "episodes", "loss", "policy_loss", "value_loss", "bounds_loss", "aux_loss", "kl", "lr", "w_aux",
            "action_l2", "nonfinite", "aram_lambda", "seconds", "env_steps")
ROBUST_KEYS = ("epoch", "mean_success", "worst_success", "clip099_active", "success_x1", "success_x2",
               "success_x4", "selected")


@dataclasses.dataclass(frozen=True)
class RobustSelection:
    """Checkpoint selection by robustness during training (paper App. B.3-B.4)."""

    every: int = 10  # epochs between evaluations (0: off)
    dampings: tuple[float, ...] = (1.0, 2.0, 4.0)
    episodes: int = 8  # per damping cell, det mode, perturbed starts
    seed: int = 7

    def score(self, row: dict) -> tuple:
        return row["mean_success"], row["worst_success"], -row["clip099_active"]


def save_checkpoint(ts: TrainState, path: Path) -> Path:
    leaves = [np.asarray(x) for x in jax.tree.leaves(ts)]
    buf = io.BytesIO()
    np.savez(buf, *leaves)
    return atomic_write_bytes(path, buf.getvalue())


def load_checkpoint(template: TrainState, path: Path, keep_env: bool = False) -> TrainState:
    """Restore ``template``'s structure from ``path``. With ``keep_env`` the environment state is the
    template's and only the learner (parameters, optimiser, normalisers, rng, epoch) is read: a policy saved
    under an older environment-state layout still loads for evaluation or a fine-tune (not for exact resume)."""
    if not Path(path).is_file():
        raise DragMeshError(f"{path}: no such checkpoint")
    z = np.load(path)
    leaves, treedef = jax.tree.flatten(template)
    index = list(range(len(leaves)))
    if keep_env and len(z.files) != len(leaves):
        n_before = len(jax.tree.leaves((template.params, template.opt_state)))
        n_env = len(jax.tree.leaves(template.env_state))
        n_after = len(leaves) - n_before - n_env
        if len(z.files) > n_before + n_after:
            # (file array, or None = keep the template's leaf) per template leaf
            index = [*range(n_before), *([None] * n_env), *range(len(z.files) - n_after, len(z.files))]
    if len(index) != len(leaves) or (not keep_env and len(z.files) != len(leaves)):
        raise DragMeshError(f"{path}: checkpoint does not match this method/config ({len(z.files)} arrays, "
                            f"expected {len(leaves)})")
    new = []
    for i, ref in zip(index, leaves, strict=True):
        if i is None:
            new.append(ref)
            continue
        a = z[f"arr_{i}"]
        if a.shape != np.shape(ref):
            raise DragMeshError(f"{path}: array {i} has shape {a.shape}, expected {np.shape(ref)}")
        new.append(jax.numpy.asarray(a, dtype=np.asarray(ref).dtype))
    return jax.tree.unflatten(treedef, new)


def latest_checkpoint(run_dir: Path) -> Path | None:
    ck = sorted((run_dir / "checkpoints").glob("epoch_*.npz"))
    return ck[-1] if ck else None


def write_run_meta(run_dir: Path, trainer: Trainer, object_dir: str, extra: dict | None = None) -> None:
    write_trajectory(trainer.task.traj, run_dir / "trajectory.json")
    meta = {**(extra or {}), "method": trainer.method.name, "object": str(Path(object_dir).resolve()),
            "trajectory": "trajectory.json", "backend": trainer.task.backend.name,
            "ppo": dataclasses.asdict(trainer.config), "task": json.loads(json.dumps(
                dataclasses.asdict(trainer.task.config), default=str))}
    atomic_write_json(run_dir / "run.json", meta)


def robust_evaluator(trainer: Trainer, selection: RobustSelection):
    """``ts -> row``: det success per damping from the selection's perturbed starts (its own bank seed, not the
    final evaluation's), in one parallel rollout."""
    from dragmesh2_jax.evaluation.evaluate import make_rollout
    from dragmesh2_jax.runs import eval_task
    from dragmesh2_jax.task.config import ResetNoise

    task = eval_task(trainer.task, noise=ResetNoise(seed=selection.seed))
    rollout = make_rollout(task, trainer.make_policy(deterministic=True), list(selection.dampings),
                           selection.episodes)  # compiled once, run every ``selection.every`` epochs

    def evaluate(ts: TrainState) -> dict:
        cells = rollout(trainer.policy_params(ts), seed=selection.seed)
        s = [r["success_rate"] for r in cells]
        return {"epoch": int(ts.epoch), "mean_success": float(np.mean(s)), "worst_success": float(np.min(s)),
                "clip099_active": float(np.mean([r["clip099_active"] for r in cells])),
                **{f"success_x{r['damping']:g}": r["success_rate"] for r in cells}}

    return evaluate


def _read_jsonl(path: Path, max_epoch: int) -> list[dict]:
    if not path.is_file():
        return []
    rows = [json.loads(x) for x in path.read_text().splitlines() if x.strip()]
    return [r for r in rows if r["epoch"] <= max_epoch]


def train(trainer: Trainer, run_dir: str | Path, object_dir: str, resume: bool = False, save_every: int = 10,
          progress: bool = True, log_fn=None, selection: RobustSelection = RobustSelection(),
          start: TrainState | None = None, meta: dict | None = None) -> tuple[TrainState, list[dict]]:
    """Train to ``trainer.config.epochs`` epochs; returns the final state and the log rows. A new run starts
    from ``start`` when given (a fine-tune: a trained state), else from ``trainer.init()``; ``meta`` adds keys
    to the run record (run.json)."""
    run_dir = Path(run_dir)
    c = trainer.config
    ts = trainer.init() if start is None or resume else start
    rows: list[dict] = []
    robust_rows: list[dict] = []
    if resume:
        ck = latest_checkpoint(run_dir)
        if ck is None:
            raise DragMeshError(f"{run_dir}: nothing to resume (no checkpoints/epoch_*.npz)")
        ts = load_checkpoint(ts, ck)
        rows = _read_jsonl(run_dir / "log.jsonl", int(ts.epoch))
        robust_rows = _read_jsonl(run_dir / "robust.jsonl", int(ts.epoch))
    else:
        if (run_dir / "log.jsonl").exists():
            raise DragMeshError(f"{run_dir}: already holds a run (use --resume, or another --out)")
        run_dir.mkdir(parents=True, exist_ok=True)
        write_run_meta(run_dir, trainer, object_dir, meta)
    best = max((r["reward"] for r in rows), default=-np.inf)
    best_robust = max((selection.score(r) for r in robust_rows), default=None)
    robust = robust_evaluator(trainer, selection) if selection.every > 0 else None
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
            _write_table(run_dir / "log", rows, LOG_KEYS)
            if e % save_every == 0:
                save_checkpoint(ts, run_dir / "checkpoints" / f"epoch_{e:04d}.npz")
            if row["reward"] > best:
                best = row["reward"]
                save_checkpoint(ts, run_dir / "checkpoints" / "best.npz")
            if robust is not None and (e % selection.every == 0 or e == c.epochs):
                r = robust(ts)
                r["selected"] = best_robust is None or selection.score(r) > best_robust
                if r["selected"]:
                    best_robust = selection.score(r)
                    save_checkpoint(ts, run_dir / "checkpoints" / "best_robust.npz")
                robust_rows.append(r)
                _write_table(run_dir / "robust", robust_rows, ROBUST_KEYS)
            bar.update(task, completed=e, stats=f"reward {row['reward']:.2f}  success {row['success']:.2f}  "
                                                  f"progress {row['progress']:.2f}  clip099 {row['clip099']:.2f}")
            if log_fn:
                log_fn(row)
    save_checkpoint(ts, run_dir / "checkpoints" / "final.npz")
    return ts, rows


def _write_table(stem: Path, rows: list[dict], keys: tuple[str, ...]) -> None:
    """``stem.jsonl`` and ``stem.csv``, each written atomically."""
    atomic_write_text(stem.with_suffix(".jsonl"), "".join(json.dumps(r) + "\n" for r in rows))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(stem.with_suffix(".csv"), buf.getvalue())
