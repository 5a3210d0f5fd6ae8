"""The program assembled as a library: object + trajectory -> task; method -> trainer; run folder -> trained
policy; the evaluation task. The CLI, ``experiments/``, notebooks and tests all build through here."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.task.config import EVAL_RESET_NOISE, ResetNoise


def parse_floats(text: str, what: str, minimum: float | None = None) -> list[float]:
    """Comma-separated finite numbers (``"1,2,4"``), each >= ``minimum`` when given."""
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
    return vals


def load_task(object_dir: str, trajectory: str | None = None, backend: str = "auto", impl: str = "jax",
              scene_config=None, **overrides):
    """Object + trajectory (generated when not given) -> PullTask, in the default scene or ``scene_config``."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.scene import SceneConfig, build_scene
    from dragmesh2_jax.task.config import TaskConfig
    from dragmesh2_jax.task.env import PullTask
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import read_trajectory

    if not object_dir:
        raise DragMeshError("no object folder given (--object)")
    config = TaskConfig(backend=backend, impl=impl, **overrides)  # validated before anything compiles
    obj = load_gapartnet(object_dir)
    traj = read_trajectory(trajectory) if trajectory else None
    if traj is not None:
        obj = adopt_trajectory_target(obj, traj)
    scene = build_scene(obj, scene_config or SceneConfig())
    return PullTask(scene, generate(obj, scene=scene) if traj is None else traj, config)


def adopt_trajectory_target(obj, traj):
    """The object with the part ``traj`` moves as its target (paper §3.1: the target joint is the DoF with the
    largest motion range in the reference trajectory), saying so when that is not the default target."""
    import sys

    from dragmesh2_jax.task.env import trajectory_joint

    moved = trajectory_joint(obj, traj)
    if moved != obj.target.joint.name:
        print(f"note: the trajectory moves joint {moved} of object {obj.object_id}; it becomes the target (the "
              f"default target was {obj.target.joint.name})", file=sys.stderr)
    return obj.with_target(moved)


def make_trainer(object_dir: str, trajectory: str | None, method_name: str, backend: str = "auto",
                 impl: str = "jax", finetune: str | None = None, task_config=None, scene_config=None,
                 task_changes: dict | None = None, scene_changes: dict | None = None, **ppo):
    """A Trainer for ``method_name`` on the object: its task is the preset's (the method's task overrides), or
    ``task_config`` when given (a recorded run's; backend and impl are the arguments'), with a fine-tune preset's
    overrides on top when ``finetune`` names one, and ``task_changes`` (TaskConfig fields) last; the scene is the
    default or ``scene_config``, with ``scene_changes`` (SceneConfig fields) on top."""
    from dragmesh2_jax.policies.methods import get_method, task_overrides
    from dragmesh2_jax.ppo.config import PPOConfig
    from dragmesh2_jax.ppo.finetune import get_finetune
    from dragmesh2_jax.ppo.train import Trainer
    from dragmesh2_jax.task.config import RewardConfig

    method = get_method(method_name)
    config = PPOConfig(**{k: v for k, v in ppo.items() if v is not None})
    if task_config is None:
        overrides = task_overrides(method)
    else:
        overrides = {f.name: getattr(task_config, f.name) for f in dataclasses.fields(task_config)
                     if f.name not in ("backend", "impl")}
    if finetune is not None:
        overrides.update(get_finetune(finetune).task_overrides(overrides.get("reward", RewardConfig())))
    overrides.update(task_changes or {})
    if scene_changes:
        from dragmesh2_jax.scene import SceneConfig

        scene_config = dataclasses.replace(scene_config or SceneConfig(), **scene_changes)
    task = load_task(object_dir, trajectory, backend, impl, scene_config, **overrides)
    return Trainer(task, method, config)


def trainer_from_record(run_dir: str | Path, backend: str = "auto", impl: str = "jax", finetune: str | None = None,
                        **ppo_changes):
    """The trainer a run folder's record defines: its PPO, task and scene configs read back whole (a record of
    format 1 predates that: its method preset and the default scene), on ``backend``; a fine-tune preset on top
    when ``finetune`` names one; ``ppo_changes`` (e.g. more epochs) on top of the recorded PPO config."""
    from dragmesh2_jax.record import read_configs

    run_dir = Path(run_dir)
    meta = run_meta(run_dir)
    args = (meta["object"], str(run_dir / meta["trajectory"]), meta["method"], backend, impl)
    if meta.get("format", 1) >= 2:
        ppo, task, scene = read_configs(meta)
        return make_trainer(*args, finetune=finetune, task_config=task, scene_config=scene,
                            **{**dataclasses.asdict(ppo), **ppo_changes})
    if finetune is None:
        finetune = meta.get("finetune")
    return make_trainer(*args, finetune=finetune, **{**ppo_from_meta(meta), **ppo_changes})


def make_finetune(checkpoint: str | Path, name: str, backend: str = "auto", impl: str = "jax",
                  epochs: int | None = None):
    """(trainer, start state, parent checkpoint) of a fine-tune preset continuing a trained run from
    ``checkpoint`` for the preset's epochs (or ``epochs``), counted on from the checkpoint's epoch."""
    from dragmesh2_jax.ppo.checkpoint import load_checkpoint
    from dragmesh2_jax.ppo.finetune import get_finetune

    ft = get_finetune(name)
    parent, ts, run_dir, ck = load_run(checkpoint, backend, impl)
    meta = run_meta(run_dir)
    if meta.get("finetune") and meta.get("format", 1) < 2:  # its record lacks the task config the preset changed
        raise DragMeshError(f"{run_dir} is a fine-tune recorded before run records held the task config; start "
                            "from its parent run")
    more = ft.epochs if epochs is None else epochs
    if more < 1:
        raise DragMeshError(f"fine-tune epochs must be >= 1, got {more}")
    trainer = trainer_from_record(run_dir, parent.task.backend.name, impl, finetune=name,
                                  epochs=int(ts.epoch) + more)
    return trainer, load_checkpoint(trainer.init(), ck, keep_env=True), ck


def eval_task(task, exact_reset: bool = False, noise: ResetNoise = EVAL_RESET_NOISE):
    """The task of the evaluation protocol: the training task's object, trajectory and observation, from the
    protocol's perturbed starts (or the paper's exact start); damping is fixed per cell by the evaluator."""
    from dragmesh2_jax.task.env import PullTask

    config = dataclasses.replace(task.config, reset_noise=None if exact_reset else noise, damping_fixed=None)
    return PullTask(task.scene, task.traj, config)


def run_meta(run_dir: Path) -> dict:
    path = Path(run_dir) / "run.json"
    if not path.is_file():
        raise DragMeshError(f"{run_dir}: not a training run folder (no run.json)")
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise DragMeshError(f"{path}: not valid JSON ({e.msg})") from None


def ppo_from_meta(meta: dict) -> dict:
    return {**meta["ppo"], "aux_warmup": tuple(meta["ppo"]["aux_warmup"]),
            "aux_channel_weights": tuple(meta["ppo"]["aux_channel_weights"])}


#: Checkpoints a run folder offers, in the order ``resolve_checkpoint`` prefers them.
CHECKPOINT_PREFERENCE = ("best_robust", "final")


def resolve_checkpoint(path: str | Path) -> Path:
    """A checkpoint (an Orbax checkpoint directory, or an earlier version's ``.npz``), or for a run folder its
    ``best_robust`` checkpoint (selected by robustness during training), else its ``final`` one."""
    from dragmesh2_jax.ppo.checkpoint import LEGACY_SUFFIX, find_checkpoint

    p = Path(path)
    if (p / "run.json").is_file():
        for name in CHECKPOINT_PREFERENCE:
            ck = find_checkpoint(p, name)
            if ck is not None:
                return ck
        raise DragMeshError(f"{p}: no checkpoints/{{{','.join(CHECKPOINT_PREFERENCE)}}}")
    if (p / "learner").is_dir() or (p.suffix == LEGACY_SUFFIX and p.is_file()):
        return p
    raise DragMeshError(f"{p}: no such checkpoint (a run folder or one of its checkpoints/*)")


def load_run(checkpoint: str | Path, backend: str = "auto", impl: str = "jax"):
    """(trainer, train state, run folder, checkpoint path) from a checkpoint inside a run folder (or the run
    folder: see ``resolve_checkpoint``). On a backend other than the one the run trained on, the policy
    (parameters and normalisers) is moved into a fresh state of that backend: a policy trained on one backend
    evaluates on the other."""
    from dragmesh2_jax.ppo.checkpoint import load_checkpoint
    from dragmesh2_jax.task.config import TaskConfig

    ck = resolve_checkpoint(checkpoint)
    run_dir = ck.parent.parent
    meta = run_meta(run_dir)
    trainer = trainer_from_record(run_dir, backend, impl)
    trained_on = meta.get("backend", trainer.task.backend.name)
    if trained_on == trainer.task.backend.name:
        return trainer, load_checkpoint(trainer.init(), ck, keep_env=True), run_dir, ck
    TaskConfig(backend=trained_on)  # validates the recorded name
    source = trainer_from_record(run_dir, trained_on, impl)
    src = load_checkpoint(source.init(), ck, keep_env=True)
    ts = trainer.init().replace(params=src.params, state_stats=src.state_stats, token_stats=src.token_stats,
                                aux_stats=src.aux_stats, privileged_stats=src.privileged_stats,
                                value_stats=src.value_stats, epoch=src.epoch)
    return trainer, ts, run_dir, ck


# ------------------------------------------------------------------------------------ whole commands
def describe_object(folder: str, scene_config=None, render: str | None = None) -> dict:
    """An object's summary (target, joint, handle), its scene's statistics and handle in the world, and, with
    ``render``, a picture of hand + object written there."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.scene import SceneConfig, build_scene

    obj = load_gapartnet(folder)
    scene = build_scene(obj, scene_config or SceneConfig())
    info = obj.summary()
    info["scene"] = scene.stats
    info["handle_world"] = {"centre": [round(float(x), 5) for x in scene.handle.centre],
                            "thickness_m": round(scene.handle.thickness, 5)}
    if render:
        from dragmesh2_jax.render import render_png

        info["render"] = {"path": str(render), "renderer": render_png(scene.model, scene.initial_data(), render,
                                                                     target=scene.handle.centre)}
    return info


def make_trajectory(object_dir: str, out: str, render: str | None = None):
    """Generate an object's reference trajectory into ``out`` (and, with ``render``, a GIF of it executed);
    returns (trajectory, renderer used or None)."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import write_trajectory

    if render and not render.endswith(".gif"):
        raise DragMeshError(f"{render}: only .gif videos are supported")
    obj = load_gapartnet(object_dir)
    traj = generate(obj)
    write_trajectory(traj, out)
    if not render:
        return traj, None
    from dragmesh2_jax.render import render_trajectory_gif

    return traj, render_trajectory_gif(obj, traj, render)


def train_from_args(out: str, object_dir: str | None, trajectory: str | None, method: str, backend: str = "auto",
                    impl: str = "jax", seeds: list[int] | None = None, resume: bool = False,
                    task_changes: dict | None = None, scene_changes: dict | None = None, selection=None,
                    save_every: int = 10, progress: bool = True, **ppo) -> tuple:
    """A training run (or one per seed, as one program, in ``out/seed_N``), new or resumed from its record;
    returns (trainer, [(seed, log rows)])."""
    from dragmesh2_jax.ppo.runner import RobustSelection, train, train_seeds

    record = Path(out) / (f"seed_{seeds[0]}" if seeds else "")
    if resume:
        trainer = trainer_from_record(record, backend, impl, **({"epochs": ppo["epochs"]} if ppo.get("epochs") else {}))
        object_dir = run_meta(record)["object"]
    else:
        trainer = make_trainer(object_dir, trajectory, method, backend, impl, task_changes=task_changes,
                               scene_changes=scene_changes, **ppo)
    kwargs = {"resume": resume, "save_every": save_every, "progress": progress,
              "selection": selection or RobustSelection()}
    if seeds:
        _, logs = train_seeds(trainer, out, seeds, object_dir, **kwargs)
        return trainer, list(zip(seeds, logs, strict=True))
    return trainer, [(trainer.config.seed, train(trainer, out, object_dir, **kwargs)[1])]


def finetune_run(checkpoint: str, recipe: str, out: str, backend: str = "auto", impl: str = "jax",
                 epochs: int | None = None, selection=None, save_every: int = 10, progress: bool = True):
    """A fine-tune preset continuing a trained run into ``out``; returns (parent checkpoint, log rows)."""
    from dragmesh2_jax.ppo.runner import RobustSelection, train

    trainer, start, parent = make_finetune(checkpoint, recipe, backend, impl, epochs)
    meta = {"finetune": recipe, "parent": str(parent.resolve())}
    object_dir = run_meta(parent.parent.parent)["object"]
    _, rows = train(trainer, out, object_dir, save_every=save_every, progress=progress,
                    selection=selection or RobustSelection(), start=start, meta=meta)
    return parent, rows


def evaluate_checkpoint(checkpoint: str, dampings: list[float], modes: list[str], episodes: int = 20,
                        seed: int = 42, exact_reset: bool = False, backend: str = "auto", impl: str = "jax") -> dict:
    """The evaluation protocol for a trained run's checkpoint, written beside the run as ``eval_<checkpoint>.json``
    and ``.md``."""
    from dragmesh2_jax.evaluation.evaluate import evaluate, markdown_table
    from dragmesh2_jax.io import atomic_write_json, atomic_write_text

    check_protocol(modes, episodes)
    trainer, ts, run_dir, ck = load_run(checkpoint, backend, impl)
    result = evaluate(eval_task(trainer.task, exact_reset=exact_reset), trainer.controller(ts), dampings, modes,
                      episodes, seed=seed)
    result["checkpoint"] = str(ck)
    stem = ck.stem + ("_exact" if exact_reset else "")
    atomic_write_json(run_dir / f"eval_{stem}.json", result)
    atomic_write_text(run_dir / f"eval_{stem}.md", markdown_table(result) + "\n")
    return result


def baseline_controllers() -> dict:
    """Controllers that need no training, by name: ``name -> (task -> (the task it runs, Controller))`` (the
    primitive runs its own gripper in the task's place)."""
    from dragmesh2_jax.baselines import tracking
    from dragmesh2_jax.baselines.parallel_jaw import PARALLEL_JAW, parallel_jaw

    return {tracking.TRACKING: lambda task: (task, tracking.tracking_controller(task)),
            tracking.TRACKING_DELTA: lambda task: (task, tracking.tracking_delta_controller(task)),
            PARALLEL_JAW: parallel_jaw}


def evaluate_baseline(name: str, object_dir: str, trajectory: str | None, dampings: list[float], modes: list[str],
                      episodes: int = 20, seed: int = 42, exact_reset: bool = False, backend: str = "auto",
                      impl: str = "jax") -> dict:
    """The evaluation protocol for a controller that needs no training (``baseline_controllers``) on an object."""
    from dragmesh2_jax.evaluation.evaluate import evaluate

    known = baseline_controllers()
    if name not in known:
        raise DragMeshError(f"unknown controller {name!r} (choose from {', '.join(known)}; trained policies are "
                            "evaluated with --checkpoint)")
    check_protocol(modes, episodes)
    task, controller = known[name](eval_task(load_task(object_dir, trajectory, backend, impl), exact_reset=exact_reset))
    return evaluate(task, controller, dampings, modes, episodes, seed=seed)


def check_protocol(modes: list[str], episodes: int) -> None:
    from dragmesh2_jax.evaluation.evaluate import MODES

    bad = [m for m in modes if m not in MODES]
    if bad or not modes:
        raise DragMeshError(f"unknown evaluation mode(s) {bad} (choose from {', '.join(MODES)})")
    if episodes < 1:
        raise DragMeshError("episodes per cell must be >= 1")


def video_of_run(checkpoint: str, dampings: list[float], out: str, every: int, backend: str = "auto",
                 impl: str = "jax") -> tuple[Path, str, Path]:
    """A run's deterministic policy from the exact start at each damping, side by side; returns (video path,
    renderer used, checkpoint)."""
    from dragmesh2_jax.render import render_policy_video

    trainer, ts, _, ck = load_run(checkpoint, backend, impl)
    path, used = render_policy_video(eval_task(trainer.task, exact_reset=True), trainer.make_policy(True),
                                     trainer.policy_params(ts), dampings, out, every=every)
    return path, used, ck
