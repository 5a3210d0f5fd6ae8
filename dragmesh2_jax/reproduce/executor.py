"""Running a plan: each step not done yet trains a run or evaluates a checkpoint or controller, writing its result
into the folder, so an interrupted reproduction resumes where it stopped."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from dragmesh2_jax.assets.procedural import table1_mix
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import evaluate, markdown_table
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.progress import LogLines, to_log
from dragmesh2_jax.render import render_policy_video
from dragmesh2_jax.reproduce.paper import FINETUNE_EPOCHS, GENERALIST_OBJECT_SEED
from dragmesh2_jax.reproduce.planning import CONTACTS, Eval, ReproduceConfig, Run, plan
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.runs.commands import baseline_controllers, dataset_objects, finetune_run, load_run
from dragmesh2_jax.runs.rundir import epoch_name
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.runs.spec import ROBUST_EVERY, apply_overrides, method_spec
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.trajectory.dataset import build_dataset


def _train(run: Run, c: ReproduceConfig, out: Path) -> None:
    folder = run.folder(out)
    if folder.trained_epochs() >= run.epochs:
        return
    # main/ablation evaluate a base run's best_robust checkpoint; the appendix tables evaluate named epochs
    schedule = {"epochs": run.epochs, "seed": run.seed, "save_every": max(1, c.scaled(FINETUNE_EPOCHS) // 2),
                "robust_every": ROBUST_EVERY if run.parent is None else 0}
    ppo, scene = {"num_envs": c.num_envs}, CONTACTS[c.contacts]
    if run.train_objects:  # no best_robust: the table reads the checkpoints along the budget
        objects, trajectories = _scaling_subset(c, out, run.train_objects)
        spec = method_spec(run.method, objects, ppo, backend=c.backend, scene=scene,
                           schedule={**schedule, "save_every": c.scaling_epochs[0], "robust_every": 0})
        start_or_resume(spec, [folder], trajectory=trajectories, progress=False)
    elif run.generalist:
        objects, trajectories = dataset_objects(_dataset(c, out))
        spec = method_spec(run.method, objects, ppo, backend=c.backend, scene=scene, holdout=c.holdout,
                           schedule=schedule)
        start_or_resume(spec, [folder], trajectory=trajectories, progress=False)
    elif run.parent is None:
        spec = method_spec(run.method, run.object, ppo, backend=c.backend, scene=scene, schedule=schedule)
        start_or_resume(spec, [folder], progress=False)  # new, interrupted or extended
    elif folder.exists() and folder.epoch_checkpoints():  # the next stage: the recorded fine-tune, longer
        spec = apply_overrides(folder.spec(), {f"schedule.{k}": v for k, v in schedule.items()})
        start_or_resume(spec, [folder], resume=True, progress=False)
    else:  # new, or stopped before its first checkpoint (started again)
        parent = run.parent.folder(out).checkpoint(epoch_name(run.parent.epochs))
        finetune_run(str(parent), run.recipe, str(folder.path), None if c.backend == "auto" else c.backend,
                     epochs=run.epochs - run.parent.epochs, object_dir=run.object if run.parent.generalist else None,
                     schedule={k: schedule[k] for k in ("save_every", "robust_every")}, progress=False)


def _dataset(c: ReproduceConfig, out: Path) -> Path:
    """The generalist's dataset: ``c.dataset``, else ``c.train_objects`` procedural objects built into ``out``
    (resumable: objects already there are kept)."""
    if c.dataset is not None:
        return Path(c.dataset)
    build_dataset([], out / "dataset", progress=False, procedural=c.train_objects, seed=GENERALIST_OBJECT_SEED)
    return out / "dataset"


def _scaling_subset(c: ReproduceConfig, out: Path, n: int) -> tuple[list[str], list[str]]:
    """The first ``n`` objects of the scaling dataset (``max(c.scaling)`` procedural objects in the Table 1 mix,
    built into ``out`` and resumable) in the mix of ``n`` (so each size's objects hold the smaller sizes'), and their
    trajectories; an object whose trajectory failed its gate is left out (the run's record lists what it trained
    on)."""
    folder = out / "scaling_dataset"
    build_dataset([], folder, progress=False, procedural=max(c.scaling), seed=GENERALIST_OBJECT_SEED)
    names = {f"{cat}_{GENERALIST_OBJECT_SEED + i:04d}" for cat, k in table1_mix(n).items() for i in range(k)}
    pairs = [(o, t) for o, t in zip(*dataset_objects(folder), strict=True) if Path(o).name in names]
    if not pairs:
        raise DragMeshError(f"{folder}: none of the first {n} objects passed its trajectory gate")
    return [o for o, _ in pairs], [t for _, t in pairs]


def _evaluate(ev: Eval, c: ReproduceConfig, out: Path) -> dict:
    if ev.run is None:
        p = c.controller_protocol
        scene = apply_overrides(SceneConfig(), CONTACTS[c.contacts])
        task, controller = baseline_controllers()[ev.controller](p.task(load_task(ev.object, None, c.backend,
                                                                                  scene_config=scene)))
        result = evaluate(task, controller, p)
        result.update(label=ev.label, seed=ev.seed, object=Path(ev.object).name)
        atomic_write_json(ev.path(out, c), result)
        return result
    folder = ev.run.folder(out)
    if ev.checkpoint != "best_robust" and folder.trained_epochs() < ev.run.epochs:
        raise DragMeshError(f"{folder.path}: trained to epoch {folder.trained_epochs()}, not {ev.run.epochs} (the "
                            "evaluation of a stage runs right after it)")
    program, ts, _, ck = load_run(ev.checkpoint_path(out), c.backend, object_dir=ev.object if ev.zero_shot else None)
    controller, task = program.controller(ts), program.task
    protocol = c.protocol(ev.project)
    result = evaluate(protocol.task(task), controller, protocol)
    result.update(checkpoint=str(ck), epoch=int(ts.epoch), run_epochs=ev.run.epochs, label=ev.label, seed=ev.seed,
                  object=Path(ev.object).name, zero_shot=ev.zero_shot)
    folder.write_evaluation(ck, protocol, result, markdown_table(result), on=ev.on)
    if c.video_every and ev.seed == c.seeds[0]:  # one video per method and object: the first seed's policy
        render_policy_video(EvalProtocol(starts=None).task(task), controller, list(c.dampings),
                            video_path(out, ev), every=c.video_every)
    return result


def video_path(out: Path, ev: Eval) -> Path:
    """Where the video of an evaluated run goes (a GIF, or an MP4 where mediapy and ffmpeg are installed)."""
    return out / "videos" / f"{Path(ev.object).name}_{ev.label}.mp4"


def _cost(step: Run | Eval, c: ReproduceConfig) -> float:
    """Relative cost for the progress estimate: an epoch of training ~ one evaluation cell."""
    if isinstance(step, Eval):
        return len(c.dampings) * (1 if step.run is None else len(c.modes))
    return float(step.epochs - (step.parent.epochs if step.parent else 0))


def execute(steps: list[Run | Eval], c: ReproduceConfig, out: Path, progress: bool = True,
            on_step: Callable[[Run | Eval], None] | None = None) -> None:
    """Run every step not yet done (each writes its result into ``out``). On a terminal a progress bar covers the
    plan; elsewhere (a log) each finished step is one line with the elapsed and estimated time left."""
    todo = [s for s in steps if not _done(s, c, out)]
    total, spent = sum(_cost(s, c) for s in todo), 0.0
    lines = LogLines("reproduce", total, enabled=progress)
    with Progress(TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(), TextColumn("left"),
                  TimeRemainingColumn(), disable=not progress or to_log()) as bar:
        task = bar.add_task("reproduce", total=max(total, 1.0))
        for step in todo:
            what = f"train {step.name} s{step.seed} to {step.epochs}" if isinstance(step, Run) \
                else f"evaluate {step.label}"
            bar.update(task, description=f"{Path(step.object).name}: {what}")
            if isinstance(step, Run):
                _train(step, c, out)
            else:
                _evaluate(step, c, out)
            bar.advance(task, _cost(step, c))
            spent += _cost(step, c)
            lines(spent, f"{Path(step.object).name}: {what} done")
            if on_step:
                on_step(step)


def _current(ev: Eval, c: ReproduceConfig, out: Path) -> dict | None:
    """An evaluation's result when written, and of a run trained to the plan's epochs (a run extended to a
    larger budget is evaluated again); None otherwise."""
    path = ev.path(out, c)
    if not path.is_file():
        return None
    try:
        result = json.loads(path.read_text())
    except json.JSONDecodeError:
        return None  # damaged: evaluated again
    return result if ev.run is None or result.get("run_epochs") == ev.run.epochs else None


def _done(step: Run | Eval, c: ReproduceConfig, out: Path) -> bool:
    """A run is done at its epochs; an evaluation when its result is current."""
    if isinstance(step, Eval):
        return _current(step, c, out) is not None
    return step.folder(out).trained_epochs() >= step.epochs


def started(table: str, c: ReproduceConfig, out: Path) -> bool:
    """Whether ``out`` holds any step of ``table``'s plan, done or not: a run's record or an evaluation's file."""
    return any(s.path(out, c).is_file() if isinstance(s, Eval) else s.folder(out).exists() for s in plan(table, c))


def evaluations(table: str, c: ReproduceConfig, out: Path) -> list[dict]:
    """The evaluations of ``table``'s plan done so far."""
    return [r for s in plan(table, c) if isinstance(s, Eval) and (r := _current(s, c, out)) is not None]
