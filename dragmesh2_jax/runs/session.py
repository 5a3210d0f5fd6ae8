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

import numpy as np
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)
from tensorboardX import SummaryWriter

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import PHYSICAL
from dragmesh2_jax.evaluation.protocol import SELECTION, EvalProtocol
from dragmesh2_jax.evaluation.rollout import cells, rollout
from dragmesh2_jax.ppo import distributed
from dragmesh2_jax.ppo.checkpoint import load_checkpoint, save_checkpoint
from dragmesh2_jax.ppo.train import (
    NonFiniteLearning,
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
from dragmesh2_jax.runs.spec import RunSpec, Schedule
from dragmesh2_jax.runs.teachers import load_teachers
from dragmesh2_jax.task.config import RESIZABLE
from dragmesh2_jax.trajectory.schema import Trajectory


def robust_score(row: dict) -> tuple:
    """How the robustness checks rank (checkpoint selection, paper App. B.3-B.4): ``best_robust`` keeps the best by
    mean, then worst success, ties by lower active clip099."""
    return row["mean_success"], row["worst_success"], -row["clip099_active"]


def training_success(rows: list[dict]) -> str:
    """What a command reports of a training's success: the last epoch's in which episodes ended (an epoch where none
    ended reads 0; worlds reset together finish together, so many epochs end none)."""
    ended = next((r for r in reversed(rows) if r.get("episodes", 0) > 0), None)
    return (f"training success {ended['success']:.2f} (epoch {ended['epoch']}'s episodes)" if ended else
            "no training episode ended")


def selection_check(program: TrainProgram, p: EvalProtocol = SELECTION, heldout=None):
    """``ts -> row``: det success per damping of the selection protocol ``p`` (its own starts) on the training env,
    or on ``heldout`` (a run's held-aside objects: each world draws one), and the physical figures of its worst
    damping (the largest over the dampings), one parallel rollout compiled once per program signature."""
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
                            TimeElapsedColumn(), TextColumn("left"), TimeRemainingColumn(),
                            TextColumn("{task.fields[stats]}"), disable=not enabled or to_log())
        self.task = self.bar.add_task(name, total=total, completed=done, stats="")
        self.lines = LogLines(name, total, done, every=max(1, total // 10), enabled=enabled)
        if enabled and done < total:  # the first epoch waits for its program to compile: say so, not nothing
            print(f"{name}: compiling the epoch program (the first epoch waits for it)", file=sys.stderr, flush=True)

    def update(self, epoch: int, stats: str) -> None:
        self.bar.update(self.task, completed=epoch, stats=stats)
        self.lines(epoch, f"epoch {epoch}/{self.total}  {stats}")


def start_or_resume(spec: RunSpec | None, runs: list[RunDir], seeds: list[int] | None = None,
                    trajectory: str | Trajectory | None = None, resume: bool | None = None,
                    start: TrainState | None = None, backend: str | None = None, impl: str = "auto",
                    selection: EvalProtocol | None = None, progress: bool = True, log_fn=None,
                    wandb: str | None = None, overwrite: bool = False
                    ) -> tuple[TrainProgram, TrainState, list[list[dict]]]:
    """Train the runs in ``runs`` (one per seed, as one program) to their schedule's epochs, holding each run
    folder's lock throughout (a second writer is one error line).

    ``resume``: True continues the runs exactly from their newest common checkpoint (their records define them);
    False starts new runs of ``spec`` (a folder that holds a run's products, checkpoints or evaluations, is an error:
    ``RunDir.require_new``); None resumes when every folder has an epoch checkpoint and starts otherwise.
    ``overwrite``: remove what the runs' folders hold of earlier runs (``RunDir.clear``, said on stderr) and start
    new runs. A checkpoint whose replacement a kill interrupted is put back first (``RunDir.restore_interrupted``).
    A run stopped before its first checkpoint, whatever stopped it, starts again either way (resumed, from its
    record). A resumed run takes the schedule of ``spec`` where one is given (None: its own): its epochs (more extend
    the run) and its checkpoint and robustness intervals, and its buffer sizes, revised in its record; the rest of the
    record stands. ``start``: a fine-tune's first state (one run). ``backend``:
    resume on this engine instead of the recorded task's. ``selection``: the protocol of the robustness checks
    that keep ``best_robust`` (every ``schedule.robust_every`` epochs; None: ``SELECTION`` at
    ``schedule.robust_episodes`` episodes). ``wandb``: a W&B project that gets the same
    scalars as TensorBoard. Returns the program, the final state (leading run axis) and each run's log rows."""
    if seeds is None and spec is not None and not resume:  # a resume trains the seeds its runs recorded
        seeds = [spec.schedule.seed]
    if not runs or (seeds is not None and len(seeds) != len(runs)):
        raise DragMeshError("one run folder per seed, at least one")
    if start is not None and len(runs) != 1:
        raise DragMeshError("a fine-tune continues one run, not several seeds")
    if distributed.joined() and len(runs) != 1:
        raise DragMeshError("a run over several processes (--coordinator) trains one seed: drop --seeds")
    if wandb:
        wandb_module()  # before anything is written: a missing extra leaves no folder behind
    if overwrite and resume:
        raise DragMeshError("--overwrite starts the run again: drop --resume (or drop --overwrite to continue it)")
    with contextlib.ExitStack() as locks:
        for r in runs:
            locks.enter_context(r.writing())
            for line in r.restore_interrupted():
                print(f"note: {line}", file=sys.stderr)
        return _start_or_resume(spec, runs, seeds, trajectory, False if overwrite else resume, start, backend, impl,
                                selection, progress, log_fn, wandb, overwrite)


#: What a resume may change of a run's schedule: its length (more epochs extend it), checkpoint and robustness
#: intervals. Its seed and how it is read stand with the rest of the record.
RESCHEDULABLE = ("epochs", "save_every", "robust_every", "robust_episodes")
#: What a resume may change of a recorded tree, by dotted path: the above and the buffer sizes (``_continued``).
RESUMABLE = frozenset({f"schedule.{k}" for k in RESCHEDULABLE} | {f"task.{k}" for k in RESIZABLE})


def _continued(recorded: RunSpec, given: RunSpec | None) -> RunSpec:
    """A recorded run under the schedule a command gives (None: its own), as far as a resume may change it, and with
    the buffer sizes it gives (``TaskConfig.RESIZABLE``: how the run is computed, not what it learns; None: the
    recorded ones)."""
    if given is None:
        return recorded
    schedule = {k: getattr(given.schedule, k) for k in RESCHEDULABLE}
    sizes = {k: v for k in RESIZABLE if (v := getattr(given.task, k)) is not None}
    return dataclasses.replace(recorded, schedule=dataclasses.replace(recorded.schedule, **schedule),
                               task=dataclasses.replace(recorded.task, **sizes))


def _start_or_resume(given, runs, seeds, trajectory, resume, start, backend, impl, selection, progress, log_fn,
                     wandb, overwrite):
    recorded = all(r.exists() for r in runs)
    common = _resume_epoch(runs) if recorded else None
    spec = given
    if resume and common is None:
        if not recorded:
            raise DragMeshError(f"{runs[0].path}: nothing to resume (no run.json; start the run without --resume)")
        # stopped before its first checkpoint
        spec, seeds = _continued(runs[0].spec(), given), [r.spec().schedule.seed for r in runs]
        if spec.parent is not None and start is None:
            raise DragMeshError(f"{runs[0].path}: a fine-tune stopped before its first checkpoint: run its finetune "
                                "command again (it starts from its parent's checkpoint)")
        trajectory = runs[0].trajectories()
        spec = spec.on(backend, impl) if backend else spec
    if resume is None:
        resume = common is not None
    if resume and common is not None:
        recorded_spec = runs[0].spec()
        seeds = [r.spec().schedule.seed for r in runs]
        for r in runs[1:]:  # seeds of one program: the same run but for the seed
            if r.spec().with_seed(seeds[0]) != recorded_spec:
                raise DragMeshError(f"{r.path}: its record differs from {runs[0].path}'s in more than the seed: not "
                                    "seeds of one run, so they cannot resume as one program")
        spec = _continued(recorded_spec, given)
        done = max(common, max(r.trained_epochs() for r in runs))
        if spec.schedule.epochs < done:
            raise DragMeshError(f"{runs[0].path}: already trained {done} epochs; --epochs {spec.schedule.epochs} "
                                "would undo them (give more epochs to extend the run)")
        spec = spec.on(backend, impl) if backend else spec
        program, heldout, tasks = programs_of(spec, runs[0].trajectories())
        template = init_jit(program, program.data(), seed_keys(seeds[:1])[0])
        teachers = _teachers(spec, tasks, template)
        states = [_restore(template, r.epoch_checkpoints()[common]) for r in runs]
        ts = stack_runs(states)
        rows = [r.log_rows(common) for r in runs]
        robust_rows = [r.robust_rows(common) for r in runs]
        for r in runs:  # each keeps its own seed
            if (continued := _continued(r.spec(), given)) != r.spec():
                r.revise(continued)
    else:
        if spec is None:
            raise DragMeshError("a new run needs its spec")
        for r in runs:
            if not overwrite:
                r.require_new()
        program, heldout, tasks = programs_of(spec, trajectory)
        ts = init_runs(program, program.data(len(seeds)), seed_keys(seeds)) if start is None else stack_runs([start])
        teachers = _teachers(spec, tasks, take_run(ts, 0))  # before a folder is written: they may be refused
        for r, s in zip(runs, seeds, strict=True):  # one stopped before its first checkpoint starts again
            if overwrite and (removed := r.clear()):  # once the new run is known to build
                print(f"note: --overwrite: removed {', '.join(removed)} from {r.path}", file=sys.stderr)
            budget = program.task.budget
            r.start(spec.with_seed(s), program.task.engine, [tr for t in tasks for tr in t.trajectories],
                    buffers=None if budget is None else budget.to_json())
        rows, robust_rows = [[] for _ in runs], [[] for _ in runs]
    ts = _loop(program, runs, ts, rows, robust_rows, spec.schedule, resume, selection, progress, log_fn, wandb,
               heldout, teachers)
    return program, ts, rows


def _teachers(spec: RunSpec, tasks: list, template: TrainState):
    """``load_teachers`` of ``spec`` (its training objects' tasks first in ``tasks``; a one-process run only)."""
    teachers = load_teachers(spec, [t.traj for t in tasks[:len(tasks) - spec.holdout]], template)
    if teachers is not None and distributed.joined():
        raise DragMeshError("a distilled run trains in one process: drop --coordinator")
    return teachers


def _loop(program: TrainProgram, runs: list[RunDir], ts: TrainState, rows: list[list[dict]],
          robust_rows: list[list[dict]], schedule: Schedule, resumed: bool, selection: EvalProtocol,
          progress: bool, log_fn, wandb: str | None, heldout=None, teachers=None) -> TrainState:
    c, epochs, save_every, robust_every = program.config, schedule.epochs, schedule.save_every, schedule.robust_every
    selection = selection or dataclasses.replace(SELECTION, episodes=schedule.robust_episodes)
    check = selection_check(program, selection, heldout) if robust_every > 0 else None
    first = int(ts.epoch[0])
    done = [first]  # the epochs trained: a state split over processes is read whole only where it is needed
    split = distributed.joined()  # one run, its worlds split over every process's devices (ppo/distributed.py)
    state_of = (lambda ts, i: distributed.gather(ts)) if split else take_run
    best = [max((r["reward"] for r in rr), default=-np.inf) for rr in rows]
    best_robust = [max((robust_score(r) for r in rr), default=None) for rr in robust_rows]
    name = program.name + (f" x {len(runs)} seeds" if len(runs) > 1 else "")
    bar = _Progress(f"train {name}", epochs, first, progress)
    t_start = time.time() - (rows[0][-1]["seconds"] if rows[0] else 0.0)  # a resumed run's clock goes on
    with bar.bar, contextlib.ExitStack() as stack:
        boards = [stack.enter_context(_Scalars(r, first if resumed else None, wandb)) for r in runs]

        def on_epoch(ts: TrainState, m: dict) -> None:
            done[0] += 1
            e = done[0]
            seconds = round(time.time() - t_start, 2)
            for i, run in enumerate(runs):
                row = {"epoch": e, **{k: float(v[i]) for k, v in m.items()}, "seconds": seconds,
                       "env_steps": e * c.num_envs * c.rollout_len}
                rows[i].append(row)
                run.write_log(rows[i])
                boards[i].write("train", row)
                improved = row["reward"] > best[i]
                robust_due = check is not None and (e % robust_every == 0 or e == epochs)
                kept = e % save_every == 0 or e == epochs  # the last epoch too: a finished run can be extended
                if kept or improved or robust_due:  # this run's state, only when it is needed
                    one = state_of(ts, i)
                if kept:
                    save_checkpoint(one, run.checkpoint(epoch_name(e)))
                if improved:
                    best[i] = row["reward"]
                    save_checkpoint(one, run.checkpoint("best"))
                if robust_due:
                    r = check(one)
                    r["selected"] = best_robust[i] is None or robust_score(r) > best_robust[i]
                    if r["selected"]:
                        best_robust[i] = robust_score(r)
                        save_checkpoint(one, run.checkpoint("best_robust"))
                    robust_rows[i].append(r)
                    run.write_robust(robust_rows[i])
                    boards[i].write("robust", r)
                if log_fn:
                    log_fn(row)
            mean = {k: float(np.mean(m[k])) for k in ("reward", "success", "progress", "clip099")}
            bar.update(e, f"reward {mean['reward']:.2f}  success {mean['success']:.2f}  progress "
                          f"{mean['progress']:.2f}  clip099 {mean['clip099']:.2f}")

        try:
            if split:
                ts = distributed.train_worlds(program, program.data(), take_run(ts, 0), epochs, on_epoch)
                ts = stack_runs([distributed.gather(ts)])
            else:
                ts = train(program, program.data(len(runs)), ts, epochs, run_mesh(len(runs)), on_epoch, teachers)
        except NonFiniteLearning as e:
            raise DragMeshError(f"{e}; {_last_good(runs[0], program.config.lr)}") from None
    for i, run in enumerate(runs):
        save_checkpoint(take_run(ts, i), run.checkpoint("final"))
    return ts


def _last_good(run: RunDir, lr: float) -> str:
    """Where a run whose learning went non-finite goes on from: its newest checkpoint, as a fine-tune at a lower
    learning rate (recorded as one)."""
    epochs = run.epoch_checkpoints()
    if not epochs:
        return f"{run.path} has no checkpoint yet: start it again with a lower --ppo.lr and --overwrite"
    ck = epochs[max(epochs)]
    return (f"its last good checkpoint is {ck}: continue from it at a lower learning rate with dragmesh2 finetune "
            f"--checkpoint {ck} --recipe continued --ppo.lr {lr / 10:g} --out NEW_RUN")


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
