"""The generalist: one policy over procedural objects of every category. Its training run
(``train --generalist``: the ``generalist`` method over ``GENERALIST_MIX``, built into the run's own folder and held
aside one object per category for its robustness checks), and ``open``: the packaged generalist on any object
folder, no training (the trajectory built, deterministic episodes, a short report, a video and a still)."""

from __future__ import annotations

from pathlib import Path

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.baselines.tracking import tracking_controller
from dragmesh2_jax.errors import DragMeshError, NotSaved
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.checkpoint import save_actor
from dragmesh2_jax.ppo.train import TrainProgram
from dragmesh2_jax.render import VIDEO_EVERY, render_policy_video
from dragmesh2_jax.runs.commands import (
    dataset_objects,
    evaluate_loaded,
    load_run,
    run_dirs,
    train_defaults,
    train_run,
)
from dragmesh2_jax.runs.rundir import ACTOR_NAME, RunDir
from dragmesh2_jax.runs.spec import RunSpec
from dragmesh2_jax.runs.teachers import named_teachers
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.load import generated_as_planned, generator_params, plan_scene_config
from dragmesh2_jax.trajectory.dataset import build_dataset
from dragmesh2_jax.trajectory.generator import GeneratorParams
from dragmesh2_jax.trajectory.schema import write_trajectory

GENERALIST = "generalist"  # its method, and the packaged run's name (runs/rundir.PACKAGED)
#: Where ``train --generalist`` builds its objects and their trajectories, inside OUT (a dataset folder).
DATASET = "objects"
OPEN_EPISODES = 10  # deterministic episodes of ``open``, each from its own perturbed start
#: What ``open`` reports of the policy and of the expert drag side by side: how the part was opened.
AS_A_PERSON = ("steps_mean", "wrist_load_peak_n", "palm_speed_peak_m_s", "penetration_p95_mm", "penetration_max_mm")


def generalist_objects(out: str | Path, progress: bool = True) -> tuple[list[str], list[str], int]:
    """The generalist's objects: ``procedural.GENERALIST_MIX`` built under ``out/objects`` with their trajectories
    (resumable), those whose trajectory passed its gate, the last of each category last: (objects, trajectories,
    how many are held aside)."""
    folder = Path(out) / DATASET
    objects = procedural.synthesize_mix(procedural.GENERALIST_MIX, procedural.GENERALIST_SEED, folder / "objects")
    build_dataset(objects, folder, progress=progress)
    return procedural.held_aside_by_category(*dataset_objects(folder))


def generalist_run(out: str, seeds: list[int] | None, resume: bool, backend: str, impl: str,
                   tree: RunSpec | None = None, progress: bool = True, wandb: str | None = None,
                   overwrite: bool = False, method: str | None = None, teachers: list[str] | None = None
                   ) -> tuple[TrainProgram, list]:
    """``train --generalist``: ``method`` (None: ``tree``'s; the ``generalist`` method, or the recorded run's when it
    resumes) over the generalist's objects (``generalist_objects``), new or resumed; ``tree``: its configuration tree
    as the command's flags left it. A method whose expert grasps the handle otherwise than the dataset's generator
    (``generalist_residual``: the seated grasp that holds) trains on trajectories generated under its own grasp.
    ``teachers``: a distilled generalist's specialists (``generalist_distilled``; ``runs/teachers.py``)."""
    tree = tree or train_defaults(out, method or GENERALIST, resume, seeds)
    if not resume:
        named_teachers(teachers or (), tree.ppo.distill_coef)  # before the objects are built
    with RunDir(out).writing():  # its objects are built into OUT: by the one writer, and never into another run
        if not resume and not overwrite:
            for run in run_dirs(out, seeds):
                run.require_new()
        objects, trajectories, holdout = generalist_objects(out, progress)
        return train_run(out, objects, None if resume else own_trajectories(tree, trajectories),
                         method or tree.method, tree, backend, impl, seeds, resume, progress=progress, wandb=wandb,
                         holdout=holdout, overwrite=overwrite, teachers=teachers)


def own_trajectories(tree: RunSpec, trajectories: list[str]) -> list[str] | None:
    """The dataset's trajectories where ``tree``'s expert is planned as the dataset's generator planned it (its grasp,
    in the default scene), else None: each object's trajectory is generated under the tree's own."""
    same = (generator_params(tree.task) == GeneratorParams() and generated_as_planned(tree.task)
            and plan_scene_config(tree.task, tree.scene) == SceneConfig())
    return trajectories if same else None


def package_run(checkpoint: str, dest: str | Path, command: str) -> Path:
    """A trained run's policy as a packaged run in ``dest`` (``runs/rundir.PACKAGED``): its record (its objects by
    name: they do not ship), its exported actor, and a README with the command that trained it and how far it
    got. Returns ``dest``."""
    run, ck = RunDir.of_checkpoint(checkpoint)
    _, ts, run, ck = load_run(checkpoint, object_dir=str(procedural.default_object()))  # one scene, not every object
    dest = Path(dest)
    save_actor(ts, dest / ACTOR_NAME)
    record = run.record()
    atomic_write_json(dest / "run.json", {**record, "object": Path(record["object"]).name, "objects": [
        {**o, "folder": Path(o["folder"]).name} for o in record.get("objects") or []]})
    last = next((r for r in run.log_rows() if r["epoch"] == int(ts.epoch)), {})
    atomic_write_text(dest / "README.md", "\n".join([
        f"# The packaged {run.spec().method} policy", "",
        f"The actor of `{ck.relative_to(run.path)}` at epoch {int(ts.epoch)} of {run.spec().schedule.epochs} "
        f"({last.get('env_steps', 0):,} env steps, {last.get('seconds', 0) / 3600:.1f} h of training), trained by:",
        "", "```bash", command, "```", "",
        "`run.json` is its run record (its objects by name: they are built by the command), `actor.msgpack` the "
        "policy's parameters and observation normalisers (`ppo/checkpoint.save_actor`).", ""]))
    return dest


def open_object(object_dir: str, damping: float, out: str | Path, checkpoint: str = GENERALIST,
                episodes: int = OPEN_EPISODES, backend: str | None = None, renderer: str = "auto",
                every: int = VIDEO_EVERY) -> dict:
    """``dragmesh2 open``: the packaged generalist (or ``checkpoint``) on ``object_dir`` at ``damping``, no training:
    the trajectory built, ``episodes`` deterministic episodes from perturbed starts, and in ``out`` the trajectory,
    ``report.md`` and ``report.json`` (success, steps, wrist load, the physical figures), ``video`` (MP4 or GIF) and
    ``still.png`` (its last frame). Returns the report; its ``evaluation`` is where the whole evaluation went: the
    run's evaluations, or ``out/evaluation.json`` where the run folder could not take it (another writer holds it,
    read-only storage; ``evaluation_not_in_run`` says why), None for a packaged run (never written)."""
    if not Path(object_dir).is_dir():
        raise DragMeshError(f"{object_dir}: no such object folder")
    out = Path(out)
    program, ts, run, ck = load_run(checkpoint, backend, object_dir=object_dir)
    protocol = EvalProtocol(dampings=(damping,), modes=("det",), episodes=episodes)
    try:
        result, evaluation = evaluate_loaded(program, ts, run, ck, protocol, Path(object_dir).name)
        not_in_run = None
    except NotSaved as e:  # the run folder's fault, not open's: the evaluation goes to open's folder instead
        result, not_in_run = e.result, e.reason
        evaluation = atomic_write_json(out / "evaluation.json", result)
    (cell,) = result["cells"]
    expert_task = protocol.task(program.task)  # the expert drag replayed from the same starts
    (expert,) = evaluate(expert_task, tracking_controller(expert_task), protocol)["cells"]
    task = EvalProtocol(starts=None).task(program.task)
    video, used = render_policy_video(task, program.controller(ts), [damping], out / "video.mp4", every=every,
                                      renderer=renderer, still=out / "still.png")
    write_trajectory(program.task.traj, out / "trajectory.json")
    report = {"object": str(Path(object_dir).resolve()), "checkpoint": str(ck), "method": run.spec().method,
              "damping": damping, "episodes": episodes, "success_rate": cell["success_rate"],
              "successes": cell["successes"], "steps_mean": cell["steps_mean"],
              "wrist_load_peak_n": cell["wrist_load_peak_n"], "palm_speed_peak_m_s": cell["palm_speed_peak_m_s"],
              "penetration_p95_mm": cell["penetration_p95_mm"], "penetration_max_mm": cell["penetration_max_mm"],
              "clip099_active": cell["clip099_active"],
              "clip099_policy_active": cell["clip099_policy_active"],
              "expert": {k: expert[k] for k in ("success_rate", "successes", *AS_A_PERSON)},
              "video": str(video), "renderer": used, "still": str(out / "still.png"),
              "evaluation": str(evaluation) if evaluation else None, "evaluation_not_in_run": not_in_run}
    atomic_write_json(out / "report.json", report)
    atomic_write_text(out / "report.md", _markdown(report, Path(object_dir).name))
    return report


def _markdown(r: dict, name: str) -> str:
    e = r["expert"]
    return "\n".join([
        f"# {name}: the {r['method']} policy at damping x{r['damping']:g}", "",
        f"- opened in **{r['successes']} of {r['episodes']}** deterministic episodes (perturbed starts), "
        f"{r['steps_mean']:.0f} control steps on average (1/60 s each)",
        f"- wrist load p95 {r['wrist_load_peak_n']:.0f} N, palm speed p95 {r['palm_speed_peak_m_s']:.2f} m/s, "
        f"penetration p95 {r['penetration_p95_mm']:.1f} mm (each episode's deepest contact; the deepest of all "
        f"{r['penetration_max_mm']:.1f} mm), saturated active DoFs {r['clip099_active']:.2f} (the policy's "
        f"own output: {r['clip099_policy_active']:.2f})",
        f"- checkpoint: `{r['checkpoint']}`", f"- video: `{Path(r['video']).name}` ({r['renderer']}), still: "
        "`still.png`", "", "Opened as a person would? The policy beside the expert drag (the object's own trajectory "
        "replayed open-loop from the same starts):", "",
        "| | opened | steps | wrist load p95 | palm speed p95 | penetration p95 (deepest) |",
        "|---|---|---|---|---|---|",
        *(f"| {who} | {x['successes']}/{r['episodes']} | {x['steps_mean']:.0f} | {x['wrist_load_peak_n']:.0f} N | "
          f"{x['palm_speed_peak_m_s']:.2f} m/s | {x['penetration_p95_mm']:.1f} ({x['penetration_max_mm']:.1f}) mm |"
          for who, x in (("policy", r), ("expert", e))),
        "", f"![the last frame]({Path(r['still']).name})", ""])
