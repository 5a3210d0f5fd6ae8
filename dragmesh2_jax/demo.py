"""``dragmesh2 demo``, the main job on the built-in default, as a library function: reference trajectory ->
training the project's recipe (or another method) -> evaluation of the checkpoint its method reads at damping
x1/x2/x4 (det and stoch, perturbed starts) -> ``report.md`` with the success-vs-damping plot, the expert grasp and
a video of the policy at each damping."""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import jax
from matplotlib.figure import Figure

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.evaluate import PHYSICAL, markdown_table
from dragmesh2_jax.evaluation.protocol import PAPER, EvalProtocol
from dragmesh2_jax.io import atomic_write_figure, atomic_write_text
from dragmesh2_jax.progress import LogLines
from dragmesh2_jax.render import VIDEO_EVERY, render_policy_video, render_pose
from dragmesh2_jax.runs.commands import evaluate_loaded, load_run
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume, training_success
from dragmesh2_jax.runs.spec import method_defaults, method_spec

CPU_EPOCHS = 60  # a small preset on a CPU; on an accelerator the method's own budget


def run_demo(out: str | Path, object_dir: str | None = None, trajectory: str | None = None, epochs: int | None = None,
             backend: str = "auto", seed: int = 0, renderer: str = "auto", video_every: int = VIDEO_EVERY,
             method: str = "recommended", progress: bool = True, episodes: int = PAPER.episodes,
             overwrite: bool = False) -> Path:
    """Run the demo into ``out`` (by default the project's recipe, read by its checkpoint rule; ``episodes`` per
    evaluation cell; ``overwrite``: a run there, and what it made, removed first); returns the report's path."""
    gpu = jax.default_backend() != "cpu"
    protocol = dataclasses.replace(PAPER, episodes=episodes)
    epochs = epochs or (method_defaults(method).schedule.epochs if gpu else CPU_EPOCHS)
    out = Path(out)
    folder = str(object_dir or default_object())
    print(f"dragmesh2 demo: trajectory -> {method} ({epochs} epochs x 64 envs x 32 steps) -> evaluation at damping "
          f"x1/x2/x4; {'GPU: its full budget' if gpu else 'CPU: a small budget, about 3-5 minutes on 2 cores'}",
          file=sys.stderr)
    t0 = time.time()
    stages = LogLines("demo", 4, enabled=progress)
    run = RunDir(out)
    spec = method_spec(method, folder, backend=backend,
                       schedule={"epochs": epochs, "seed": seed, "save_every": max(epochs // 3, 1)})
    with run.writing():  # the whole demo: one writer of its folder at a time
        if not overwrite and run.exists() and (differ := run.spec().differences(method, folder,
                                                                                schedule={"seed": seed})):
            raise DragMeshError(f"{out}: holds a demo of another run ({'; '.join(differ)}); give another --out, or "
                                "--overwrite")
        # a rerun resumes the run there (trained further when asked for more epochs) and redoes the rest
        _, _, (rows,) = start_or_resume(spec, [run], trajectory=trajectory, resume=None, progress=progress,
                                        overwrite=overwrite)
        stages(1, f"1/4 trained ({epochs} epochs)")
        program, ts, run, ck = load_run(out)  # the checkpoint its method reads
        traj = program.task.traj
        result = run.evaluation(ck, protocol)  # a rerun that trained nothing more keeps its evaluation (if current)
        if result is None or (result.get("epoch"), result.get("run_epochs")) != (int(ts.epoch), run.trained_epochs()) \
                or not all(k in c for c in result["cells"] for k, _, _ in PHYSICAL):
            result, _ = evaluate_loaded(program, ts, run, ck, protocol)
        stages(2, f"2/4 evaluated {ck.name}")
        plot_success(result, out / "success_vs_damping.png")
        used = grasp_picture(program.task, out / "grasp.png", renderer)
        stages(3, f"3/4 pictures ({used} renderer)")
        video, _ = render_policy_video(EvalProtocol(starts=None).task(program.task), program.controller(ts),
                                       list(PAPER.dampings), out / "policy.mp4", every=video_every, renderer=renderer)
        stages(4, f"4/4 video {Path(video).name}")
    q = traj.header.get("quality", {})
    obj = program.task.scene.obj
    report = [
        f"# DragMesh-2 demo: {program.name} on {obj.object_id} ({obj.category})", "",
        f"- object: `{folder}`; target `{obj.target.joint.name}` "
        f"({'revolute' if program.task.scene.ids.target_is_revolute else 'prismatic'})",
        f"- reference trajectory: {len(traj.frames)} frames, quality gate {'passed' if q.get('passed') else 'n/a'}; "
        f"q_start {traj.q_start:.4f}, q_done {traj.q_done:.4f}, q_goal {traj.q_goal:.4f}",
        f"- training: {epochs} epochs x {program.config.num_envs} envs x {program.config.rollout_len} steps on the "
        f"{program.task.engine} backend; {training_success(rows)}, {rows[-1]['seconds']:.0f} s",
        f"- wall time (all stages): {time.time() - t0:.0f} s on {jax.default_backend()}", "",
        f"## Evaluation of `{ck.name}` ({protocol.episodes} episodes per cell, each from a perturbed expert grasp; 95% "
        "Wilson intervals)", "", markdown_table(result), "",
        "![success vs damping](success_vs_damping.png)", "", "The expert grasp state every episode starts from:",
        "", "![expert grasp](grasp.png)", "",
        f"The deterministic policy from the exact expert grasp at each damping, in real time ({used} renderer):", "",
        (f"![policy at x1, x2, x4]({Path(video).name})" if video.endswith(".gif") else
         f"[the video: policy at x1, x2, x4]({Path(video).name})"), "",
    ]
    atomic_write_text(out / "report.md", "\n".join(report))
    return out / "report.md"


def grasp_picture(task, path: Path, renderer: str = "auto") -> str:
    traj = task.traj
    frame = traj.frames[traj.drag_start]
    return render_pose(task.scene, frame.hand_q, frame.joint_positions[traj.target_index], path, renderer=renderer)


def plot_success(result: dict, path: Path) -> None:
    fig = Figure(figsize=(5, 3.5))
    ax = fig.subplots()
    for mode in ("det", "stoch"):
        rs = [r for r in result["cells"] if r["mode"] == mode]
        ax.plot([r["damping"] for r in rs], [r["success_rate"] for r in rs], "o-", label=mode)
    ax.set_xscale("log", base=2)
    ax.set_xlabel("damping multiplier")
    ax.set_ylabel("success rate")
    ax.set_ylim(-0.05, 1.05)
    ax.set_title(f"{result['method']} on {result['object_id']}")
    ax.legend()
    fig.tight_layout()
    atomic_write_figure(path, fig, dpi=120)
