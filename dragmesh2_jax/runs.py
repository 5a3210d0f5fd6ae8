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
                 impl: str = "jax", finetune: str | None = None, task_config=None, scene_config=None, **ppo):
    """A Trainer for ``method_name`` on the object: its task is the preset's (the method's task overrides), or
    ``task_config`` when given (a recorded run's; backend and impl are the arguments'), with a fine-tune preset's
    overrides on top when ``finetune`` names one; the scene is the default or ``scene_config``."""
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
    if meta.get("finetune"):
        raise DragMeshError(f"{run_dir} is itself a fine-tune ({meta['finetune']}); start from its parent run")
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
