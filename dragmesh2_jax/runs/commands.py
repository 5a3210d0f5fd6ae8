"""Each command's whole job as a library function (the CLI only parses and prints; notebooks, experiments and
tests call these): describe an object, generate a trajectory, train, fine-tune, load a trained run, evaluate a
checkpoint or a controller that needs no training, render a run's video."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
from pathlib import Path

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.baselines import tracking
from dragmesh2_jax.baselines.parallel_jaw import PARALLEL_JAW, parallel_jaw
from dragmesh2_jax.errors import DragMeshError, FolderBusy, NotSaved, NotWritable
from dragmesh2_jax.evaluation.evaluate import ENVELOPE_DAMPINGS, ENVELOPE_PACES, envelope, evaluate, markdown_table
from dragmesh2_jax.evaluation.protocol import PAPER, EvalProtocol
from dragmesh2_jax.io import os_error_line
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.ppo.checkpoint import load_checkpoint
from dragmesh2_jax.ppo.train import TrainProgram, TrainState, init_jit, seed_keys
from dragmesh2_jax.render import render_policy_video, render_pose, render_trajectory_gif
from dragmesh2_jax.runs.build import load_task, program_of
from dragmesh2_jax.runs.finetunes import get_finetune
from dragmesh2_jax.runs.presets import DEFAULT_METHOD
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import RESUMABLE, start_or_resume
from dragmesh2_jax.runs.spec import RunSpec, apply_overrides, finetune_spec, method_defaults, on_objects
from dragmesh2_jax.runs.teachers import named_teachers, teacher_runs
from dragmesh2_jax.scene import SceneConfig, build_scene
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.task.env import contact_budget
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.generator import generate
from dragmesh2_jax.trajectory.schema import write_trajectory
from dragmesh2_jax.viewer import require_display, view


def parse_floats(text: str, what: str, minimum: float | None = None, above: float | None = None) -> list[float]:
    """Comma-separated finite numbers (``"1,2,4"``), each >= ``minimum`` and > ``above`` when given."""
    try:
        vals = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise DragMeshError(f"{what}: expected comma-separated numbers, got {text!r}") from None
    if not vals:
        raise DragMeshError(f"{what}: no values given")
    if not all(math.isfinite(v) for v in vals):
        raise DragMeshError(f"{what}: values must be finite, got {text!r}")
    if minimum is not None and min(vals) < minimum:
        raise DragMeshError(f"{what}: values must be >= {minimum:g}, got {text!r}")
    if above is not None and min(vals) <= above:
        raise DragMeshError(f"{what}: values must be > {above:g}, got {text!r}")
    return vals


def describe_object(folder: str, scene_config: SceneConfig = SceneConfig(), render: str | None = None,
                    renderer: str = "auto") -> dict:
    """An object's summary (target, joint, handle), its scene's statistics and handle in the world, the contact pairs
    and MJX's buffers for the expert drag, and, with ``render``, a picture of the expert grasp (the hand at the
    origin where no trajectory can be made) written there."""
    obj = load_gapartnet(folder)
    scene = build_scene(obj, scene_config)
    info = obj.summary()
    info["scene"] = scene.stats
    info["handle_world"] = {"centre": [round(float(x), 5) for x in scene.handle.centre],
                            "thickness_m": round(scene.handle.thickness, 5)}
    info["contacts"] = {"pairs": contacts.pairs(scene)}
    try:
        traj = generate(obj, scene=scene)
    except DragMeshError as e:
        traj, info["contacts"]["budget"] = None, None
        info["contacts"]["note"] = f"no expert drag to probe ({e})"
    if traj is not None:
        budget = contact_budget(scene, traj, TaskConfig(), reset_starts(scene, traj, None))
        info["contacts"]["budget"] = budget.to_json()
    if render:
        frame = traj.frames[traj.drag_start] if traj is not None else None
        pose = ((frame.hand_q, frame.joint_positions[traj.target_index]) if frame is not None
                else (scene.initial_data().qpos[scene.ids.hand_qpos], scene.ids.target_range[0]))
        info["render"] = {"path": str(render), "renderer": render_pose(scene, *pose, render, renderer=renderer)}
    return info


def make_trajectory(object_dir: str, out: str, render: str | None = None, renderer: str = "auto"):
    """Generate an object's reference trajectory into ``out`` (and, with ``render``, a GIF of it executed);
    returns (trajectory, renderer used or None)."""
    if render and not render.endswith(".gif"):
        raise DragMeshError(f"{render}: only .gif videos are supported")
    obj = load_gapartnet(object_dir)
    traj = generate(obj)
    write_trajectory(traj, out)
    return traj, (render_trajectory_gif(obj, traj, render, renderer=renderer) if render else None)


def train_defaults(out: str | None, method: str | None, resume: bool, seeds: list[int] | None) -> RunSpec:
    """The tree a ``train`` command's flags change: the recorded run's when it resumes one, else the method's."""
    if resume and out:
        run = RunDir(Path(out) / f"seed_{seeds[0]}") if seeds else RunDir(out)
        if run.exists():
            return run.spec()
    return method_defaults(method or DEFAULT_METHOD)


def run_dirs(out: str | Path, seeds: list[int] | None) -> list[RunDir]:
    """The run folders of a training command: ``out``, or one per seed in ``out/seed_N``."""
    return [RunDir(Path(out) / f"seed_{s}") for s in seeds] if seeds else [RunDir(out)]


def train_run(out: str, object_dir: str | list[str] | None, trajectory: str | None, method: str | None = None,
              tree: RunSpec | None = None, backend: str = "auto", impl: str = "auto", seeds: list[int] | None = None,
              resume: bool = False, progress: bool = True, wandb: str | None = None, holdout: int | None = None,
              overwrite: bool = False, teachers: list[str] | None = None
              ) -> tuple[TrainProgram, list[tuple[int, list[dict]]]]:
    """A training run in ``out`` (or one per seed, as one program, in ``out/seed_N``) of ``tree``, the run's whole
    configuration tree as the command's flags left it (``train_defaults``: the method's, or the recorded run's when
    it resumes; None: the default method's), new or resumed from its record (``resume``: a longer schedule extends
    it, other checkpoint or robustness intervals and buffer sizes (``TaskConfig.RESIZABLE``) revise it; a method,
    object or any other config value that differs from the record is refused); ``object_dir`` a list: one policy
    over several objects, the last ``holdout`` held aside for checkpoint selection; ``overwrite``: what the folders
    hold of earlier runs is removed first; ``teachers``: a distilled run's (``runs/teachers.py``). Returns (program,
    [(seed, log rows)])."""
    if seeds is not None and not seeds:
        raise DragMeshError("--seeds: no seeds given")
    runs = run_dirs(out, seeds)
    tree = tree or train_defaults(out, method, resume, seeds)
    if resume:
        if trajectory is not None:
            raise DragMeshError(f"{out}: --resume continues the run on the trajectories it keeps; drop --trajectory")
        if runs[0].exists():
            _check_resume(runs[0], tree, method, object_dir, holdout, teachers)
        program, _, logs = start_or_resume(tree if runs[0].exists() else None, runs, resume=True, backend=backend,
                                           impl=impl, progress=progress, wandb=wandb, overwrite=overwrite)
        return program, [(r.spec().schedule.seed, rows) for r, rows in zip(runs, logs, strict=True)]
    spec = dataclasses.replace(on_objects(tree.on(backend, impl), object_dir, holdout or 0),
                               teachers=named_teachers(teachers or (), tree.ppo.distill_coef))
    teacher_runs(spec)  # refused before a folder is written
    program, _, logs = start_or_resume(spec, runs, seeds, trajectory, resume=False, progress=progress, wandb=wandb,
                                       overwrite=overwrite)
    return program, list(zip(seeds or [spec.schedule.seed], logs, strict=True))


def _check_resume(run: RunDir, tree: RunSpec, method: str | None, object_dir, holdout: int | None,
                  teachers: list[str] | None = None) -> None:
    """A resume continues the recorded run exactly: flags that would change it are refused, saying what differs."""
    recorded = run.spec()
    differ = recorded.differences(method, object_dir)
    was = recorded.overrides(tree)  # the recorded values at the paths the flags change
    differ += [f"{k} {flag_value(v)} (recorded {flag_value(was[k])})"
               for k, v in tree.overrides(recorded).items() if k not in RESUMABLE]
    if holdout is not None and holdout != recorded.holdout:
        differ.append(f"holdout {holdout} (recorded {recorded.holdout})")
    if teachers is not None and named_teachers(teachers, recorded.ppo.distill_coef) != recorded.teachers:
        differ.append(f"teachers {' '.join(teachers)} (recorded {' '.join(recorded.teachers) or 'none'})")
    if differ:
        raise DragMeshError(f"{run.path}: --resume continues the recorded run exactly, but the flags change "
                            f"{'; '.join(differ)}; drop them, or start a new run in another --out")


def flag_value(value) -> str:
    """A value as a flag writes it: a tuple comma-separated, a bool in lower case."""
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value).lower() if isinstance(
        value, bool) else str(value)


def dataset_objects(folder: str | Path) -> tuple[list[str], list[str]]:
    """The object folders of a dataset (written by ``dataset build``) whose trajectory passed its gate, and those
    trajectories."""
    records = sorted((Path(folder) / "records").glob("*.json"))
    if not records:
        raise DragMeshError(f"{folder}: not a dataset folder (no records; make one with dragmesh2 dataset build)")
    passed = []
    for path in records:
        try:
            rec = json.loads(path.read_text())
        except json.JSONDecodeError as e:
            raise DragMeshError(f"{path}: not valid JSON ({e})") from None
        if rec.get("passed") and rec.get("trajectory"):
            passed.append((rec["folder"], str(Path(folder) / rec["trajectory"])))
    if not passed:
        raise DragMeshError(f"{folder}: no object of the dataset passed its trajectory gate")
    return [o for o, _ in passed], [t for _, t in passed]


def run_dampings(checkpoint: str | Path) -> tuple[float, ...]:
    """The damping cells a run is evaluated at by default: its method's (the recipe's x1-x16), else the paper's."""
    run, _ = RunDir.of_checkpoint(checkpoint)
    return run.spec().schedule.dampings or PAPER.dampings


def load_run(checkpoint: str | Path, backend: str | None = None, impl: str = "auto", keep_env: bool = True,
             object_dir: str | None = None, trajectory: str | None = None
             ) -> tuple[TrainProgram, TrainState, RunDir, Path]:
    """(program, train state, run, checkpoint path) from a checkpoint inside a run folder (or the run folder: its
    ``best_robust`` checkpoint, else ``final``). On an engine other than the one the run trained on, the policy
    (parameters and normalisers) is moved into a fresh state of that engine: a policy trained on one engine
    evaluates on the other. With ``object_dir`` the program is the run's on that object instead of the run's
    objects (its trajectory generated unless given) and only the policy is loaded: a zero-shot evaluation or a
    fine-tune onto a new object builds one scene, not every training object's."""
    run, ck = RunDir.of_checkpoint(checkpoint)
    spec, trajectories = run.spec(), None
    if run.packaged and not object_dir:  # it ships without its training objects: on the built-in default object
        object_dir = str(default_object())
    if object_dir:
        spec, trajectories, keep_env = on_object(spec, object_dir), [trajectory], True
    trained_on = run.backend
    trajectories = trajectories or run.trajectories()
    program = program_of(spec.on(backend or trained_on, impl), trajectories)
    fresh = init_jit(program, program.data(), seed_keys([spec.schedule.seed])[0])
    if program.task.engine == trained_on:
        return program, load_checkpoint(fresh, ck, keep_env=keep_env), run, ck
    source = program_of(spec.on(trained_on, impl), trajectories)
    src = load_checkpoint(init_jit(source, source.data(), seed_keys([spec.schedule.seed])[0]), ck, keep_env=True)
    return program, fresh.replace(params=src.params, state_stats=src.state_stats, token_stats=src.token_stats,
                                  aux_stats=src.aux_stats, privileged_stats=src.privileged_stats,
                                  value_stats=src.value_stats, epoch=src.epoch, aram_lambda=src.aram_lambda,
                                  multipliers=src.multipliers, object_success=src.object_success), run, ck


def on_object(spec: RunSpec, object_dir: str) -> RunSpec:
    """``spec`` on one object instead of its own object(s): a policy carried onto a new object (with no mix to draw
    from, the object curriculum is off)."""
    return dataclasses.replace(spec, object=str(object_dir), objects=(), holdout=0,
                               task=dataclasses.replace(spec.task, object_curriculum=0.0))


def finetune_run(checkpoint: str, recipe: str, out: str, backend: str | None = None, impl: str = "auto",
                 epochs: int | None = None, schedule: dict | None = None, selection: EvalProtocol | None = None,
                 progress: bool = True, object_dir: str | None = None, trajectory: str | None = None,
                 overwrite: bool = False, lr: float | None = None) -> tuple[Path, list[dict]]:
    """A fine-tune preset continuing a trained run from ``checkpoint`` for the preset's epochs (or ``epochs``),
    counted on from the checkpoint's epoch, into ``out`` (on ``object_dir`` instead of the run's objects: a policy
    trained over several objects fine-tuned onto a new one), under the run's schedule with ``schedule``'s fields
    (``save_every``, ``robust_every``, ...) changed; ``selection``: the robustness checks' protocol (None: the
    schedule's). A ``seed`` in ``schedule`` starts the fine-tune's worlds and its sampling stream from that seed
    (several fine-tunes of one checkpoint, one per seed); without one it continues the checkpoint's stream under the
    run's seed; ``overwrite``: what ``out`` holds of an earlier run is removed first; ``lr``: Adam's learning rate from
    the checkpoint on (None: the checkpoint's). Returns (parent checkpoint, log rows)."""
    more = get_finetune(recipe).epochs if epochs is None else epochs
    if more < 1:
        raise DragMeshError(f"fine-tune epochs must be >= 1, got {more}")
    parent, ts, run, ck = load_run(checkpoint, backend, impl, object_dir=object_dir, trajectory=trajectory)
    if run.packaged and not object_dir:  # as load_run: onto the built-in default object
        object_dir = str(default_object())
    spec = finetune_spec(run.spec().on(parent.task.engine, impl), recipe, str(ck.resolve()),
                         int(ts.epoch) + more, schedule)
    trajectories = [trajectory] if object_dir else run.trajectories()
    if object_dir:
        spec = on_object(spec, object_dir)
    if lr is not None:
        spec = apply_overrides(spec, {"ppo.lr": lr})
    program = program_of(spec, trajectories)
    fresh = init_jit(program, program.data(), seed_keys([spec.schedule.seed])[0])
    start = load_checkpoint(fresh, ck, keep_env=True)
    if "seed" in (schedule or {}):
        start = start.replace(rng=fresh.rng)
    if lr is not None:  # the adaptive schedule's rate lives in the state: it starts from the one given
        start = start.replace(lr=fresh.lr)
    _, _, logs = start_or_resume(spec, [RunDir(out)], trajectory=list(program.task.trajectories),
                                 resume=False, start=start, selection=selection, progress=progress,
                                 overwrite=overwrite)
    return ck, logs[0]


def evaluate_checkpoint(checkpoint: str, protocol: EvalProtocol = PAPER, backend: str | None = None,
                        impl: str = "auto", object_dir: str | None = None,
                        trajectory: str | None = None, progress: bool = False, baseline: str | None = None
                        ) -> tuple[dict, Path]:
    """The protocol for a trained run's checkpoint on its own object(s), or zero-shot on ``object_dir`` (any object
    folder; its trajectory generated unless given), written into the run's evaluations (keyed by checkpoint,
    protocol and, zero-shot, object); returns the result and its file. ``baseline`` (``baseline_controllers``):
    that controller instead of the policy, on the run's own task (the expert in use: its trajectory, grasp and
    contacts), keyed by its name. The run's lock is held throughout (a run
    another process writes is refused before anything is computed); a run on read-only storage is evaluated and
    its result raised whole in :class:`NotSaved`. ``progress``: lines to standard error (``evaluate``)."""
    run, _ = RunDir.of_checkpoint(checkpoint)
    with contextlib.ExitStack() as lock:
        with contextlib.suppress(NotWritable):  # read-only: evaluated all the same, the result raised whole
            if not run.packaged:
                lock.enter_context(run.writing())
        program, ts, run, ck = load_run(checkpoint, backend, impl, object_dir=object_dir, trajectory=trajectory)
        return evaluate_loaded(program, ts, run, ck, protocol, Path(object_dir).name if object_dir else None,
                               progress, baseline)


def evaluate_loaded(program: TrainProgram, ts: TrainState, run: RunDir, ck: Path, protocol: EvalProtocol = PAPER,
                    on: str | None = None, progress: bool = False, baseline: str | None = None
                    ) -> tuple[dict, Path | None]:
    """:func:`evaluate_checkpoint` of a run already loaded (``load_run``); ``on``: the object of a zero-shot
    evaluation; ``baseline``: that controller on the run's task instead of the policy. A result that cannot be
    written (the storage, or another writer of the run) is raised whole (:class:`NotSaved`), never lost; a packaged
    run's is returned unwritten (None: the package is not a place to write)."""
    if baseline:
        task, controller = _baseline(baseline)(protocol.task(program.task))
        ck = ck.parent / baseline  # its evaluations are named by the controller, not a checkpoint
    else:
        task, controller = protocol.task(program.task), program.controller(ts)
    result = evaluate(task, controller, protocol, progress)
    result.update(checkpoint=str(ck), epoch=int(ts.epoch), run_epochs=run.trained_epochs(), zero_shot=on is not None)
    if run.packaged:
        return result, None
    try:
        return result, run.write_evaluation(ck, protocol, result, markdown_table(result), on=on)
    except OSError as e:
        raise NotSaved("the evaluation", os_error_line(e), result) from None
    except (NotWritable, FolderBusy) as e:  # busy only where the caller does not hold the lock (open)
        raise NotSaved("the evaluation", str(e), result) from None


def baseline_controllers() -> dict:
    """Controllers that need no training, by name: ``name -> (task -> (the task it runs, Controller))`` (the
    primitive runs its own gripper in the task's place)."""
    return {tracking.TRACKING: lambda task: (task, tracking.tracking_controller(task)),
            tracking.TRACKING_DELTA: lambda task: (task, tracking.tracking_delta_controller(task)),
            tracking.PRIOR: lambda task: (task, tracking.prior_controller(task)),
            PARALLEL_JAW: parallel_jaw}


def evaluate_baseline(name: str, object_dir: str, trajectory: str | None, protocol: EvalProtocol = PAPER,
                      backend: str = "auto", impl: str = "auto", progress: bool = False) -> dict:
    """The protocol for a controller that needs no training (``baseline_controllers``) on an object."""
    task, controller = _baseline(name)(protocol.task(load_task(object_dir, trajectory, backend, impl)))
    return evaluate(task, controller, protocol, progress)


def _baseline(name: str):
    known = baseline_controllers()
    if name not in known:
        raise DragMeshError(f"unknown controller {name!r} (choose from {', '.join(known)}; trained policies are "
                            "evaluated with --checkpoint)")
    return known[name]


def object_envelope(object_dir: str, trajectory: str | None, paces=ENVELOPE_PACES, dampings=ENVELOPE_DAMPINGS,
                    backend: str = "auto", impl: str = "auto") -> list[dict]:
    """An object's physical envelope (``evaluation.evaluate.envelope``) from the exact expert start."""
    return envelope(EvalProtocol(starts=None).task(load_task(object_dir, trajectory, backend, impl)), paces, dampings)


def view_run(checkpoint: str | None, object_dir: str | None, trajectory: str | None = None, damping: float = 1.0,
             steps: int | None = None, backend: str | None = None, impl: str = "auto") -> int:
    """``dragmesh2 view``: a run's deterministic policy (on its own object, or on ``object_dir``), or without a
    checkpoint the expert drag on ``object_dir``, in MuJoCo's viewer from the evaluation's perturbed starts; returns
    the control steps shown."""
    if not checkpoint and not object_dir:
        raise DragMeshError("give --checkpoint (a trained run), --object (the expert drag on it), or both")
    require_display()  # before anything is loaded or compiled
    if checkpoint:
        program, ts, _, _ = load_run(checkpoint, backend, impl, object_dir=object_dir, trajectory=trajectory)
        task, controller = program.task, program.controller(ts)
    else:
        task = load_task(object_dir, trajectory, backend or "mujoco", impl)
        controller = tracking.tracking_controller(task)
    return view(PAPER.task(task), controller, damping, steps)


def video_of_run(checkpoint: str, dampings: list[float], out: str, every: int, backend: str | None = None,
                 impl: str = "auto", renderer: str = "auto") -> tuple[Path, str, Path]:
    """A run's deterministic policy from the exact start at each damping, side by side; returns (video path,
    renderer used, checkpoint)."""
    program, ts, _, ck = load_run(checkpoint, backend, impl)
    task = EvalProtocol(starts=None).task(program.task)
    path, used = render_policy_video(task, program.controller(ts), dampings, out, every=every, renderer=renderer)
    return path, used, ck
