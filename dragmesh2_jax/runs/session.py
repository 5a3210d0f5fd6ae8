"""A training run from start to finish: :func:`start_or_resume` is the one way a run starts, resumes or is extended
(train, finetune, reproduce and the demo all call it). It owns what happens around the pure epochs of
``ppo/train.py``: the run folders' records, logs, TensorBoard scalars and checkpoints, and the robustness checks
that keep ``best_robust`` (paper App. B.3-B.4).

Several seeds train as one program (the epoch ``vmap``ped over a run axis, sharded over the local devices when they
divide the seeds); each seed has its own run folder, so evaluation and fine-tunes read it like any run.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import sys
import time
from dataclasses import dataclass

import numpy as np
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from tensorboardX import SummaryWriter

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import PHYSICAL
from dragmesh2_jax.evaluation.protocol import SELECTION, EvalProtocol
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.ppo.checkpoint import load_checkpoint, save_checkpoint
from dragmesh2_jax.ppo.train import (
    TrainProgram,
    TrainState,
    init_jit,
    init_runs,
    policy_params,
    run_mesh,
    seed_keys,
    stack_runs,
    take_run,
    train,
)
from dragmesh2_jax.progress import LogLines, to_log
from dragmesh2_jax.runs.build import programs_of
from dragmesh2_jax.runs.rundir import RunDir, epoch_name
from dragmesh2_jax.runs.spec import ROBUST_EVERY, RunSpec
from dragmesh2_jax.trajectory.schema import Trajectory


@dataclass(frozen=True)
class Selection:
    """Checkpoint selection by robustness during training: every ``every`` epochs (0: off) the det policy runs the
    selection protocol, and ``best_robust`` keeps the best by mean, then worst success, ties by lower active
    clip099."""

    every: int = ROBUST_EVERY
    protocol: EvalProtocol = SELECTION

    @staticmethod
    def score(row: dict) -> tuple:
        return row["mean_success"], row["worst_success"], -row["clip099_active"]


def selection_check(program: TrainProgram, selection: Selection, heldout=None):
    """``ts -> row``: det success per damping of the selection protocol (its own starts) on the training env, or on
    ``heldout`` (a run's held-aside objects: each world draws one), and the physical figures of its worst damping
    (the largest over the dampings), one parallel rollout compiled once per program signature."""
    p = selection.protocol
    task, policy, dampings = p.task(heldout or program.task), program.make_policy(True), list(p.dampings)

    def check(ts: TrainState) -> dict:
        result = rollout(task, policy, policy_params(ts), dampings, p.episodes, p.seed,
                         key=(program.signature, "det"))
        rs = cells(result, dampings, p.episodes)
        s = [r["success_rate"] for r in rs]
        return {"epoch": int(ts.epoch), "mean_success": float(np.mean(s)), "worst_success": float(np.min(s)),
                "clip099_active": float(np.mean([r["clip099_active"] for r in rs])),
                **{f"success_x{r['damping']:g}": r["success_rate"] for r in rs},
                **{k: float(np.max([r[k] for r in rs])) for k, _, _ in PHYSICAL}}  # the worst damping's

    return check


def _restore(template: TrainState, path) -> TrainState:
    """A checkpoint to continue from exactly; one whose worlds an earlier version saved in another layout (its
    policy loads) continues from its policy with fresh worlds, said on stderr."""
    try:
        return load_checkpoint(template, path)
    except DragMeshError:
        ts = load_checkpoint(template, path, keep_env=True)  # the policy itself must load, or this is the error
        print(f"note: {path}: its worlds could not be restored (saved in another layout by an earlier version, or "
              "damaged): training continues from its policy with fresh worlds, not bit-exact", file=sys.stderr)
        return ts


def _resume_epoch(runs: list[RunDir]) -> int | None:
    """The newest epoch every run folder has a checkpoint of (runs save together; an interruption between two
    folders' saves leaves the older epoch the common one); None when there is none."""
    common = set.intersection(*(set(r.epoch_checkpoints()) for r in runs))
    return max(common) if common else None


class _Progress:
    """A progress bar on a terminal; in a log one plain line per tenth of the epochs (``progress.LogLines``)."""

    def __init__(self, name: str, total: int, done: int, enabled: bool):
        self.total = total
        self.bar = Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                            TimeElapsedColumn(), TextColumn("{task.fields[stats]}"), disable=not enabled or to_log())
        self.task = self.bar.add_task(name, total=total, completed=done, stats="")
        self.lines = LogLines(name, total, done, every=max(1, total // 10), enabled=enabled)

    def update(self, epoch: int, stats: str) -> None:
        self.bar.update(self.task, completed=epoch, stats=stats)
        self.lines(epoch, f"epoch {epoch}/{self.total}  {stats}")


def start_or_resume(spec: RunSpec | None, runs: list[RunDir], seeds: list[int] | None = None,
                    trajectory: str | Trajectory | None = None, resume: bool | None = None,
                    start: TrainState | None = None, epochs: int | None = None, backend: str | None = None,
                    impl: str = "jax", save_every: int | None = None, selection: Selection | None = None,
                    progress: bool = True, log_fn=None, wandb: str | None = None
                    ) -> tuple[TrainProgram, TrainState, list[list[dict]]]:
    """Train the runs in ``runs`` (one per seed, as one program) to ``epochs`` (default: the spec's), holding each
    run folder's lock throughout (a second writer is one error line).

    ``resume``: True continues the runs exactly from their newest common checkpoint (their records define them:
    ``spec`` may be None); False starts new runs of ``spec`` (a folder that holds a run with a checkpoint is an
    error); None resumes when every folder has a checkpoint and starts otherwise. A run stopped before its first
    checkpoint, whatever stopped it, starts again either way (resumed, from its record). ``start``: a fine-tune's
    first state (one run). ``backend``: resume on this engine instead of the recorded task's. ``save_every`` and
    ``selection.every``: the checkpoint and robustness intervals (None: the spec's, or a resumed run's own); a
    resume to more epochs or with other intervals revises the record's schedule. ``wandb``: a W&B project that
    gets the same scalars as TensorBoard. Returns the program, the final state (leading run axis) and each run's log
    rows."""
    seeds = list(seeds) if seeds is not None else [spec.ppo.seed] if spec else None
    if not runs or (seeds is not None and len(seeds) != len(runs)):
        raise DragMeshError("one run folder per seed, at least one")
    if start is not None and len(runs) != 1:
        raise DragMeshError("a fine-tune continues one run, not several seeds")
    if save_every is not None and save_every < 1:
        raise DragMeshError(f"save_every must be >= 1, got {save_every}")
    if wandb:
        wandb_module()  # before anything is written: a missing extra leaves no folder behind
    with contextlib.ExitStack() as locks:
        for r in runs:
            locks.enter_context(r.writing())
        return _start_or_resume(spec, runs, seeds, trajectory, resume, start, epochs, backend, impl, save_every,
                                selection, progress, log_fn, wandb)


def _scheduled(spec: RunSpec, epochs: int | None, save_every: int | None, selection: Selection | None) -> RunSpec:
    """``spec`` with the schedule a command asks for (None: as it is)."""
    return dataclasses.replace(
        spec, ppo=dataclasses.replace(spec.ppo, epochs=epochs or spec.ppo.epochs),
        save_every=save_every or spec.save_every,
        robust_every=spec.robust_every if selection is None else selection.every)


def _start_or_resume(spec, runs, seeds, trajectory, resume, start, epochs, backend, impl, save_every, selection,
                     progress, log_fn, wandb):
    recorded = all(r.exists() for r in runs)
    common = _resume_epoch(runs) if recorded else None
    if resume and common is None:
        if not recorded:
            raise DragMeshError(f"{runs[0].path}: nothing to resume (no run.json; start the run without --resume)")
        spec, seeds = runs[0].spec(), [r.spec().ppo.seed for r in runs]  # stopped before its first checkpoint
        if spec.parent is not None and start is None:
            raise DragMeshError(f"{runs[0].path}: a fine-tune stopped before its first checkpoint: run its finetune "
                                "command again (it starts from its parent's checkpoint)")
        trajectory = runs[0].trajectories()
        spec = spec.on(backend, impl) if backend else spec
    if resume is None:
        resume = common is not None
    if resume and common is not None:
        recorded_spec = runs[0].spec()
        spec = recorded_spec.on(backend, impl) if backend else recorded_spec
        seeds = [r.spec().ppo.seed for r in runs]
        for r in runs[1:]:  # seeds of one program: the same run but for the seed
            if r.spec().with_seed(seeds[0]) != recorded_spec:
                raise DragMeshError(f"{r.path}: its record differs from {runs[0].path}'s in more than the seed: not "
                                    "seeds of one run, so they cannot resume as one program")
        done = max(common, max(r.trained_epochs() for r in runs))
        if epochs is not None and epochs < done:
            raise DragMeshError(f"{runs[0].path}: already trained {done} epochs; --epochs {epochs} would undo "
                                "them (give more epochs to extend the run)")
        program, heldout, _ = programs_of(spec, runs[0].trajectories())
        template = init_jit(program, program.data(), seed_keys(seeds[:1])[0])
        states = [_restore(template, r.epoch_checkpoints()[common]) for r in runs]
        ts = stack_runs(states)
        rows = [r.log_rows(common) for r in runs]
        robust_rows = [r.robust_rows(common) for r in runs]
        spec = _scheduled(spec, max(epochs or 0, recorded_spec.ppo.epochs), save_every, selection)
        if spec.schedule != recorded_spec.schedule:
            for r in runs:
                r.revise(spec)
    else:
        if spec is None:
            raise DragMeshError("a new run needs its spec")
        spec = _scheduled(spec, max(epochs or 0, spec.ppo.epochs), save_every, selection)
        for r in runs:
            if r.exists() and r.epoch_checkpoints():
                raise DragMeshError(f"{r.path}: already holds a run (use --resume, or another --out)")
        program, heldout, tasks = programs_of(spec, trajectory)
        for r, s in zip(runs, seeds, strict=True):  # one stopped before its first checkpoint starts again
            budget = program.task.backend.budget
            r.start(spec.with_seed(s), program.task.backend.name, [t.traj for t in tasks], replace=True,
                    buffers=None if budget is None else budget.to_json())
        ts = init_runs(program, program.data(len(seeds)), seed_keys(seeds)) if start is None else stack_runs([start])
        rows, robust_rows = [[] for _ in runs], [[] for _ in runs]
    target = epochs or spec.ppo.epochs
    selection = Selection(every=spec.robust_every, protocol=(selection or Selection()).protocol)
    ts = _loop(program, runs, ts, rows, robust_rows, target, resume, spec.save_every, selection, progress, log_fn,
               wandb, heldout)
    return program, ts, rows


def _loop(program: TrainProgram, runs: list[RunDir], ts: TrainState, rows: list[list[dict]],
          robust_rows: list[list[dict]], epochs: int, resumed: bool, save_every: int, selection: Selection,
          progress: bool, log_fn, wandb: str | None, heldout=None) -> TrainState:
    c = program.config
    check = selection_check(program, selection, heldout) if selection.every > 0 else None
    first = int(ts.epoch[0])
    best = [max((r["reward"] for r in rr), default=-np.inf) for rr in rows]
    best_robust = [max((selection.score(r) for r in rr), default=None) for rr in robust_rows]
    name = program.method.name + (f" x {len(runs)} seeds" if len(runs) > 1 else "")
    bar = _Progress(f"train {name}", epochs, first, progress)
    t_start = time.time() - (rows[0][-1]["seconds"] if rows[0] else 0.0)  # a resumed run's clock goes on
    with bar.bar, contextlib.ExitStack() as stack:
        boards = [stack.enter_context(_Scalars(r, first if resumed else None, wandb)) for r in runs]

        def on_epoch(ts: TrainState, m: dict) -> None:
            e = int(ts.epoch[0])
            seconds = round(time.time() - t_start, 2)
            for i, run in enumerate(runs):
                row = {"epoch": e, **{k: float(v[i]) for k, v in m.items()}, "seconds": seconds,
                       "env_steps": e * c.num_envs * c.rollout_len}
                rows[i].append(row)
                run.write_log(rows[i])
                boards[i].write("train", row)
                improved = row["reward"] > best[i]
                robust_due = check is not None and (e % selection.every == 0 or e == epochs)
                kept = e % save_every == 0 or e == epochs  # the last epoch too: a finished run can be extended
                if kept or improved or robust_due:  # this run's state, only when it is needed
                    one = take_run(ts, i)
                if kept:
                    save_checkpoint(one, run.checkpoint(epoch_name(e)))
                if improved:
                    best[i] = row["reward"]
                    save_checkpoint(one, run.checkpoint("best"))
                if robust_due:
                    r = check(one)
                    r["selected"] = best_robust[i] is None or selection.score(r) > best_robust[i]
                    if r["selected"]:
                        best_robust[i] = selection.score(r)
                        save_checkpoint(one, run.checkpoint("best_robust"))
                    robust_rows[i].append(r)
                    run.write_robust(robust_rows[i])
                    boards[i].write("robust", r)
                if log_fn:
                    log_fn(row)
            mean = {k: float(np.mean(m[k])) for k in ("reward", "success", "progress", "clip099")}
            bar.update(e, f"reward {mean['reward']:.2f}  success {mean['success']:.2f}  progress "
                          f"{mean['progress']:.2f}  clip099 {mean['clip099']:.2f}")

        ts = train(program, program.data(len(runs)), ts, epochs, run_mesh(len(runs)), on_epoch)
    for i, run in enumerate(runs):
        save_checkpoint(take_run(ts, i), run.checkpoint("final"))
    return ts


def wandb_module():
    """The wandb package (the ``wandb`` extra), or one error line."""
    try:
        import wandb  # optional: the wandb extra
    except ImportError:
        raise DragMeshError("--wandb needs the wandb package (pip install -e \".[wandb]\")") from None
    return wandb


class _Scalars:
    """A run's scalars, ``group/metric`` by epoch: TensorBoard's event files in the run folder, and the same on
    Weights & Biases when a project is given (the ``wandb`` extra; ``WANDB_MODE=offline`` keeps them local). A
    resumed run's event files drop the points past the checkpoint it continues from; its W&B run is the same run,
    continued."""

    def __init__(self, run: RunDir, resumed_from: int | None, wandb_project: str | None):
        purge = None if resumed_from is None else resumed_from + 1
        self.board = SummaryWriter(str(run.tensorboard), purge_step=purge)
        self.wandb = None
        if wandb_project:
            wandb = wandb_module()
            run_id = hashlib.sha1(str(run.path.resolve()).encode()).hexdigest()[:16]
            self.wandb = wandb.init(project=wandb_project, name=run.path.name, id=run_id, resume="allow",
                                    dir=str(run.path), config=run.record(), reinit="create_new")

    def write(self, group: str, row: dict) -> None:
        scalars = {f"{group}/{k}": float(v) for k, v in row.items() if k != "epoch" and isinstance(v, int | float)}
        for k, v in scalars.items():
            self.board.add_scalar(k, v, row["epoch"])
        if self.wandb is not None:
            self.wandb.log(scalars, step=row["epoch"])

    def __enter__(self) -> _Scalars:
        return self

    def __exit__(self, *exc) -> None:
        self.board.close()
        if self.wandb is not None:
            self.wandb.finish()
