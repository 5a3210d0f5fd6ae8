"""The training run: epochs in Python around the jitted ``Trainer.epoch``; logs, checkpoints, exact resume.

Run folder:
    run.json               the run record (``record.py``): method, PPO/task/scene configs, object, versions
    trajectory.json        the reference trajectory the task was built from
    log.jsonl, log.csv     one row per epoch
    tb/                    the same scalars (train/*, robust/*) as TensorBoard event files (``tensorboard --logdir``)
    robust.jsonl, robust.csv  the robustness evaluation every ``robust_every`` epochs (paper App. B.3-B.4):
                           det success at x1/x2/x4 from perturbed starts, a few episodes per cell
    checkpoints/epoch_NNNN every ``save_every`` epochs; best (by training reward); best_robust (by mean then
                           worst success over the damping set, ties by lower active clip099); final. Orbax
                           directories (``ppo/checkpoint.py``) of the whole TrainState (params, optimiser, env
                           state, normalisers, rng, epoch), so ``--resume`` continues exactly where the run stopped.

Several seeds train as one program (:func:`train_runs`: the epoch ``vmap``ped over a run axis, sharded over the
local devices when there are several); each seed still gets its own run folder of the layout above
(``OUT/seed_N``), so evaluation and fine-tunes read it like any run.
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io
import json
import time
from pathlib import Path

import jax
import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.checkpoint import checkpoint_epoch, find_checkpoint, load_checkpoint, save_checkpoint
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


def latest_checkpoint(run_dir: Path) -> Path | None:
    cks = [(e, p) for p in (run_dir / "checkpoints").glob("epoch_*") if (e := checkpoint_epoch(p)) is not None]
    return max(cks)[1] if cks else None


def write_run_meta(run_dir: Path, trainer: Trainer, object_dir: str, extra: dict | None = None,
                   seed: int | None = None) -> None:
    """The run record (``record.make_record``) and the trajectory beside it, written once when the run starts."""
    from dragmesh2_jax.record import make_record

    write_trajectory(trainer.task.traj, run_dir / "trajectory.json")
    atomic_write_json(run_dir / "run.json", make_record(trainer, object_dir, seed, extra))


def robust_evaluator(trainer: Trainer, selection: RobustSelection):
    """``ts -> row``: det success per damping from the selection's perturbed starts (its own bank seed, not the
    final evaluation's), in one parallel rollout."""
    from dragmesh2_jax.evaluation.evaluate import make_rollout
    from dragmesh2_jax.runs import eval_task
    from dragmesh2_jax.task.config import ResetNoise

    task = eval_task(trainer.task, noise=ResetNoise(seed=selection.seed))
    rollout = make_rollout(task, trainer.make_policy(deterministic=True), list(selection.dampings),
                           selection.episodes, key=(trainer.signature(), "det"))  # compiled once per structure

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


def run_mesh(num_runs: int) -> jax.sharding.Mesh | None:
    """A mesh over this process's devices when there are several and the runs split evenly over them; else None
    (one device runs them all). Several hosts: each process trains its own seeds on its own devices (logs and
    checkpoints are written by the process that owns the runs)."""
    from dragmesh2_jax.ppo.train import RUN_AXIS

    devices = jax.local_devices()
    n = len(devices)
    return jax.sharding.Mesh(np.asarray(devices), (RUN_AXIS,)) if n > 1 and num_runs % n == 0 else None


def _resume_epoch(run_dirs: list[Path]) -> int:
    """The newest epoch every run folder has a checkpoint of (runs save together; an interruption between two
    folders' saves leaves the older epoch the common one)."""
    common = None
    for d in run_dirs:
        epochs = {e for p in (d / "checkpoints").glob("epoch_*") if (e := checkpoint_epoch(p)) is not None}
        common = epochs if common is None else common & epochs
    if not common:
        raise DragMeshError(f"{run_dirs[0].parent if len(run_dirs) > 1 else run_dirs[0]}: nothing to resume "
                            "(no checkpoints/epoch_* common to every run)")
    return max(common)


def take_run(ts: TrainState, i: int) -> TrainState:
    return jax.tree.map(lambda x: x[i], ts)


def train_runs(trainer: Trainer, run_dirs: list[Path], seeds: list[int], object_dir: str, resume: bool = False,
               save_every: int = 10, progress: bool = True, log_fn=None,
               selection: RobustSelection = RobustSelection(), start: TrainState | None = None,
               meta: dict | None = None, mesh: jax.sharding.Mesh | None = None) -> tuple[TrainState, list[list[dict]]]:
    """Train R runs (one per seed and folder) to ``trainer.config.epochs`` epochs as one program: the state has a
    leading run axis, one compiled epoch advances every run, split over ``mesh`` when given. Each folder gets
    its own logs, robustness rows and checkpoints. Returns the stacked final state and each run's log rows.
    A new single run starts from ``start`` when given (a fine-tune); ``meta`` adds keys to every run record."""
    run_dirs = [Path(d) for d in run_dirs]
    if len(run_dirs) != len(seeds) or not seeds:
        raise DragMeshError("one run folder per seed, at least one")
    if start is not None and len(seeds) != 1:
        raise DragMeshError("a fine-tune continues one run, not several seeds")
    c = trainer.config
    R = len(seeds)
    rows: list[list[dict]] = [[] for _ in seeds]
    robust_rows: list[list[dict]] = [[] for _ in seeds]
    if resume:
        e = _resume_epoch(run_dirs)
        template = take_run(trainer.init_runs(seeds[:1]), 0)
        states = [load_checkpoint(template, find_checkpoint(d, f"epoch_{e:04d}")) for d in run_dirs]
        ts = jax.tree.map(lambda *x: jax.numpy.stack(x), *states)
        rows = [_read_jsonl(d / "log.jsonl", e) for d in run_dirs]
        robust_rows = [_read_jsonl(d / "robust.jsonl", e) for d in run_dirs]
    else:
        for d, seed in zip(run_dirs, seeds, strict=True):
            if (d / "log.jsonl").exists():
                raise DragMeshError(f"{d}: already holds a run (use --resume, or another --out)")
            d.mkdir(parents=True, exist_ok=True)
            write_run_meta(d, trainer, object_dir, meta, seed=seed)
        ts = trainer.init_runs(seeds) if start is None else jax.tree.map(lambda x: x[None], start)
    robust = robust_evaluator(trainer, selection) if selection.every > 0 else None
    first = int(ts.epoch[0])
    best = [max((r["reward"] for r in rr), default=-np.inf) for rr in rows]
    best_robust = [max((selection.score(r) for r in rr), default=None) for rr in robust_rows]
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
    from tensorboardX import SummaryWriter

    name = trainer.method.name + (f" x {R} seeds" if R > 1 else "")
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  TextColumn("{task.fields[stats]}"), disable=not progress) as bar, contextlib.ExitStack() as stack:
        # a resumed run's event files drop the points past the checkpoint it continues from
        boards = [stack.enter_context(SummaryWriter(str(d / "tb"), purge_step=first + 1 if resume else None))
                  for d in run_dirs]
        task = bar.add_task(f"train {name}", total=c.epochs, completed=first, stats="")
        t_start = time.time() - (rows[0][-1]["seconds"] if rows[0] else 0.0)  # a resumed run's clock goes on
        for _ in range(first, c.epochs):
            ts, m = trainer.epoch_runs(ts, mesh)
            m = {k: np.asarray(v, np.float64) for k, v in jax.device_get(m).items()}
            e = int(ts.epoch[0])
            seconds = round(time.time() - t_start, 2)
            for i, d in enumerate(run_dirs):
                row = {"epoch": e, **{k: float(m[k][i]) for k in LOG_KEYS if k in m}, "seconds": seconds,
                       "env_steps": e * c.num_envs * c.rollout_len}
                rows[i].append(row)
                _write_table(d / "log", rows[i], LOG_KEYS)
                _board(boards[i], "train", row)
                improved = row["reward"] > best[i]
                robust_due = robust is not None and (e % selection.every == 0 or e == c.epochs)
                kept = e % save_every == 0 or e == c.epochs  # the last epoch too: a finished run can be extended
                if kept or improved or robust_due:  # this run's state, only when it is needed
                    one = take_run(ts, i)
                if kept:
                    save_checkpoint(one, d / "checkpoints" / f"epoch_{e:04d}")
                if improved:
                    best[i] = row["reward"]
                    save_checkpoint(one, d / "checkpoints" / "best")
                if robust_due:
                    r = robust(one)
                    r["selected"] = best_robust[i] is None or selection.score(r) > best_robust[i]
                    if r["selected"]:
                        best_robust[i] = selection.score(r)
                        save_checkpoint(one, d / "checkpoints" / "best_robust")
                    robust_rows[i].append(r)
                    _write_table(d / "robust", robust_rows[i], ROBUST_KEYS)
                    _board(boards[i], "robust", r)
                if log_fn:
                    log_fn(row)
            mean = {k: float(np.mean(m[k])) for k in ("reward", "success", "progress", "clip099")}
            bar.update(task, completed=e, stats=f"reward {mean['reward']:.2f}  success {mean['success']:.2f}  "
                                                  f"progress {mean['progress']:.2f}  clip099 {mean['clip099']:.2f}")
    for i, d in enumerate(run_dirs):
        save_checkpoint(take_run(ts, i), d / "checkpoints" / "final")
    return ts, rows


def _board(board, group: str, row: dict) -> None:
    for k, v in row.items():
        if k != "epoch" and isinstance(v, int | float):
            board.add_scalar(f"{group}/{k}", float(v), row["epoch"])


def train(trainer: Trainer, run_dir: str | Path, object_dir: str, resume: bool = False, save_every: int = 10,
          progress: bool = True, log_fn=None, selection: RobustSelection = RobustSelection(),
          start: TrainState | None = None, meta: dict | None = None) -> tuple[TrainState, list[dict]]:
    """One run (the config's seed) in ``run_dir``: :func:`train_runs` with one run. Returns its final state and
    log rows."""
    ts, rows = train_runs(trainer, [Path(run_dir)], [trainer.config.seed], object_dir, resume, save_every, progress,
                          log_fn, selection, start, meta)
    return take_run(ts, 0), rows[0]


def train_seeds(trainer: Trainer, out: str | Path, seeds: list[int], object_dir: str, **kwargs):
    """Seeds as one program, each in ``out/seed_N``, sharded over the devices when they divide the seeds."""
    dirs = [Path(out) / f"seed_{s}" for s in seeds]
    return train_runs(trainer, dirs, seeds, object_dir, mesh=run_mesh(len(seeds)), **kwargs)


def _write_table(stem: Path, rows: list[dict], keys: tuple[str, ...]) -> None:
    """``stem.jsonl`` and ``stem.csv``, each written atomically."""
    atomic_write_text(stem.with_suffix(".jsonl"), "".join(json.dumps(r) + "\n" for r in rows))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=keys, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    atomic_write_text(stem.with_suffix(".csv"), buf.getvalue())
