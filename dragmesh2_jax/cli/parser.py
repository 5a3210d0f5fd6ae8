"""``dragmesh2``'s parser: every subcommand, its flags and their help, each bound to its handler."""

from __future__ import annotations

import argparse
import os
import sys

from dragmesh2_jax.assets.procedural import GENERALIST_MIX
from dragmesh2_jax.bench import LEARNING_EPOCHS, LEARNING_METHOD, LEARNING_SEEDS
from dragmesh2_jax.cli.flags import NONNEGATIVE, POSITIVE, flag_value, one_damping
from dragmesh2_jax.cli.handlers import (
    cmd_bench,
    cmd_bench_learning,
    cmd_bench_soak,
    cmd_bench_train,
    cmd_dataset,
    cmd_demo,
    cmd_envelope,
    cmd_evaluate,
    cmd_finetune,
    cmd_inspect,
    cmd_objects,
    cmd_open,
    cmd_reproduce,
    cmd_train,
    cmd_trajectory,
    cmd_video,
    cmd_view,
)
from dragmesh2_jax.evaluation.evaluate import ENVELOPE_DAMPINGS, ENVELOPE_PACES
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.ppo.config import PAPER_EPOCHS, PPOConfig
from dragmesh2_jax.render import RENDERERS, VIDEO_EVERY
from dragmesh2_jax.reproduce import (
    CHECKPOINTS,
    CONTACTS,
    GENERALIST_HOLDOUT,
    GENERALIST_OBJECTS,
    SCALING_OBJECTS,
    TABLES,
)
from dragmesh2_jax.runs.finetunes import FINETUNES
from dragmesh2_jax.runs.generalist import OPEN_EPISODES
from dragmesh2_jax.runs.overrides import RECIPE_DAMPINGS
from dragmesh2_jax.runs.presets import DEFAULT_METHOD, RECOMMENDED, offered
from dragmesh2_jax.runs.spec import ROBUST_EVERY, SAVE_EVERY

OVERWRITE_HELP = ("start again in a folder that holds a run's products: removes its run.json, trajectories, logs, "
                  "tb/, checkpoints/, evaluations/ and exported actor (what else the folder holds stays)")

def _csv(values) -> str:
    return ",".join(f"{v:g}" for v in values)


class _Help(argparse.HelpFormatter):
    """Every option's default in its help, unless the help says it already (a default that depends on the method,
    the run or the machine) or there is none to show."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if not action.option_strings or "default" in text or any(action.default is d for d in
                                                                   (None, False, argparse.SUPPRESS)):
            return text
        return f"{text} (default: %(default)s)".strip()


class _Parser(argparse.ArgumentParser):
    """Usage errors as one line ``error: ...`` and status 2, like every other bad input; every default in --help."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", _Help)
        kwargs.setdefault("allow_abbrev", False)  # --seed is the schedule's, not short for train's --seeds
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        print(f"error: {self.prog}: {message}", file=sys.stderr)
        raise SystemExit(2)


def _add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scale", type=float, default=0.4, help="object scale (default 0.4, as the reference)")
    p.add_argument("--collide", choices=["target", "all"], default="target",
                   help="object pieces that collide with the hand (default: target part near the handle)")


def _add_renderer_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--renderer", default="auto", choices=RENDERERS,
                   help="mujoco (OSMesa on a CPU, EGL on a GPU) | matplotlib (GL-free) | auto (MuJoCo's where it runs)")


def _add_backend_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    p.add_argument("--impl", default="auto", help="MJX: auto (Warp on a GPU where installed) | jax | warp")


def build_parser() -> argparse.ArgumentParser:
    """``dragmesh2`` and its subcommands; each sets ``func``, its handler."""
    p = _Parser(prog="dragmesh2", description="DragMesh-2 in JAX/MuJoCo-MJX")
    sub = p.add_subparsers(dest="cmd", required=True)

    pi = sub.add_parser("inspect", help="describe a GAPartNet object folder: target, joint, handle, collision")
    pi.add_argument("folder")
    pi.add_argument("--json", action="store_true", help="machine-readable output")
    pi.add_argument("--render", metavar="FILE.png", help="write a picture of the expert grasp")
    _add_renderer_arg(pi)
    _add_scene_args(pi)
    pi.set_defaults(func=cmd_inspect)

    po = sub.add_parser("objects", help="procedural GAPartNet-format objects")
    osub = po.add_subparsers(dest="objects_cmd", required=True)
    ps = osub.add_parser("synth", help="write procedural objects")
    ps.add_argument("--category", required=True, help="a category or 'all'")
    ps.add_argument("--count", type=POSITIVE, default=1, help="objects per category")
    ps.add_argument("--seed", type=int, default=0, help="seed of the first object (each next one: +1)")
    ps.add_argument("--out", required=True)
    pw = osub.add_parser("twin", help="write a procedural twin of a measured object: its size and handle kept, the "
                                      "rest drawn from --seed (the part's mass follows its size: `inspect` reports it)")
    pw.add_argument("--category", required=True, help="the twin's category (`objects list`)")
    pw.add_argument("--dims", required=True, metavar="W,D,H", help="the body's width, depth and height, m in the scene")
    pw.add_argument("--handle-length", required=True, type=float, help="m in the scene")
    pw.add_argument("--handle-kind", default="bar", help="bar, edge or knob, of those the category has")
    pw.add_argument("--seed", type=int, default=0, help="the seed the rest is drawn from")
    pw.add_argument("--out", required=True, help="the object folder to write (never overwritten)")
    osub.add_parser("list", help="categories and the packaged default objects")
    po.set_defaults(func=cmd_objects)

    pt = sub.add_parser("trajectory", help="generate one reference trajectory (exit 1 if it fails the gate)")
    pt.add_argument("--object", required=True)
    pt.add_argument("--out", required=True)
    pt.add_argument("--render", metavar="FILE.gif", help="write a video of the executed trajectory")
    _add_renderer_arg(pt)
    pt.set_defaults(func=cmd_trajectory)

    pds = sub.add_parser("dataset", help="trajectory datasets")
    dsub = pds.add_subparsers(dest="dataset_cmd", required=True)
    pb = dsub.add_parser("build", help="one trajectory per object folder; resumable")
    pb.add_argument("--objects", nargs="*", default=[], help="object folders or folders of object folders")
    pb.add_argument("--procedural", type=NONNEGATIVE, default=0, metavar="N",
                    help="also N procedural objects in the paper's Table 1 category mix (277: the paper's counts)")
    pb.add_argument("--seed", type=int, default=0, help="first seed of the procedural objects")
    pb.add_argument("--out", required=True)
    pb.add_argument("--quiet", action="store_true")
    pds.set_defaults(func=cmd_dataset)

    pbe = sub.add_parser("bench", help="benchmarks")
    bsub = pbe.add_subparsers(dest="bench_cmd", required=True)
    pbenv = bsub.add_parser("env", help="physics steps/s of the task per backend and batch size")
    pbenv.add_argument("--objects", nargs="+", metavar="FOLDER",
                       help="object folders (default: the packaged drawer); several: one batch mixing them (each world "
                            "steps one), as training over several objects")
    pbenv.add_argument("--trajectory")
    pbenv.add_argument("--num-envs", default="1,16,64,256", help="batch sizes, comma-separated")
    pbenv.add_argument("--steps", type=POSITIVE, default=50, help="control steps per timed run")
    pbenv.add_argument("--mjx-steps", type=POSITIVE, help="control steps for the MJX backend (slow on a CPU; "
                                                          "default: --steps)")
    pbenv.add_argument("--json", action="store_true")
    _add_backend_args(pbenv)
    pbenv.set_defaults(func=cmd_bench)
    pbtr = bsub.add_parser("train", help="PPO epochs/s, compile time and the paper's per-object budget; "
                                         "--runs N: N seeds as one vmapped program")
    pbtr.add_argument("--objects", nargs="+", metavar="FOLDER",
                      help="object folders (default: the packaged drawer); a second object of the same structure "
                           "reuses the compiled program")
    pbtr.add_argument("--method", default="pica", help="the method preset trained")
    pbtr.add_argument("--num-envs", default="64", help="batch sizes, comma-separated")
    pbtr.add_argument("--runs", default="1", help="seeds trained as one program (comma-separated list of counts)")
    pbtr.add_argument("--epochs", type=POSITIVE, default=3, help="timed epochs after the compiling one")
    pbtr.add_argument("--json", action="store_true")
    _add_backend_args(pbtr)
    pbtr.set_defaults(func=cmd_bench_train)
    pbs = bsub.add_parser("soak", help="random actions at damping x1..x8: worlds that go non-finite (isolated)")
    pbs.add_argument("--objects", nargs="+", help="object folders (default: the packaged drawer)")
    pbs.add_argument("--damping", default="1,2,4,8", help="damping multipliers, comma-separated (> 0)")
    pbs.add_argument("--num-envs", type=POSITIVE, default=64, help="worlds per damping")
    pbs.add_argument("--steps", type=POSITIVE, default=250, help="control steps per world")
    pbs.add_argument("--seed", type=int, default=0, help="seed of the random actions")
    pbs.add_argument("--json", action="store_true")
    _add_backend_args(pbs)
    pbs.set_defaults(func=cmd_bench_soak)
    pbl = bsub.add_parser("learning", help="short training curves vs recorded ones: exit 1 on a collapse or a "
                                           "drop in final success (run before a change to task, policies or PPO)")
    pbl.add_argument("--objects", nargs="+", help="object folders (default: the recorded ones, else the packaged "
                                                  "heavy drawer)")
    pbl.add_argument("--against", metavar="FILE.json", help="recorded curves to compare with (their method, epochs "
                                                            "and seeds are used)")
    pbl.add_argument("--record", metavar="FILE.json", help="write the curves measured now")
    pbl.add_argument("--method", help=f"default: the recorded curves', else {LEARNING_METHOD}")
    pbl.add_argument("--epochs", type=POSITIVE, help=f"default: the recorded curves', else {LEARNING_EPOCHS}")
    pbl.add_argument("--seeds", help=f"default: the recorded curves', else {flag_value(LEARNING_SEEDS)}")
    pbl.add_argument("--tolerance", type=float, default=0.2, help="allowed drop of final training success")
    pbl.add_argument("--backend", default="mujoco", help="mjx | mujoco | auto")
    pbl.set_defaults(func=cmd_bench_learning)

    ptr = sub.add_parser("train", help="train a policy with PPO", add_help=False,
                         description="the run's configuration flags follow the command's own, each with its default "
                                     "under --method (a resumed run: its recorded value)")
    ptr.add_argument("-h", "--help", action="store_true", help="show this help (the configuration flags by name) "
                                                               "and exit")
    ptr.add_argument("--help-tree", action="store_true",
                     help="show every configuration flag with its help and its default under --method, and exit")
    ptr.add_argument("--method", help=f"default: recommended ({DEFAULT_METHOD}; a resumed run: its own) | "
                                      + " | ".join(offered()) + " (--list-methods: every preset, with its status)")
    ptr.add_argument("--list-methods", action="store_true",
                     help="list every method and fine-tune preset (paper, recommended, generalist, experimental, "
                          "superseded) with what it is and its evidence, and exit")
    ptr.add_argument("--generalist", action="store_true",
                     help="the project's generalist: the generalist method over procedural objects of every "
                          f"category ({sum(GENERALIST_MIX.values())}, built into OUT/objects; one per category held "
                          "aside for its robustness checks), 10 M env steps; --method: another method over them "
                          "(generalist_residual); no --object/--objects/--dataset")
    ptr.add_argument("--object", help="object folder")
    ptr.add_argument("--objects", nargs="+", metavar="FOLDER", help="several object folders: one policy over all of "
                                                                    "them (each world draws one at every reset)")
    ptr.add_argument("--dataset", help="a folder written by dataset build: its objects whose trajectory passed")
    ptr.add_argument("--holdout", type=NONNEGATIVE,
                     help="of several objects, the last this many are held aside: best_robust is chosen on them "
                          "(default: 0)")
    ptr.add_argument("--trajectory", help="trajectory file (default: generate one)")
    ptr.add_argument("--teachers", nargs="+", metavar="RUN",
                     help="a distilled run's teachers (--ppo.distill-coef > 0, generalist_distilled): specialists, "
                          "each a run of the student's method on one of its training objects")
    ptr.add_argument("--out", help="run folder (required)")
    ptr.add_argument("--seeds", help="several seeds as one program (e.g. 0,1,2), each in OUT/seed_N; sharded over "
                                     "the devices when they divide the count")
    ptr.add_argument("--resume", action="store_true", help="continue the run in --out exactly")
    ptr.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    ptr.add_argument("--quiet", action="store_true")
    ptr.add_argument("--wandb", metavar="PROJECT", help="also log the scalars to this Weights & Biases project (the "
                                                         "wandb extra; WANDB_MODE=offline keeps them local)")
    ptr.add_argument("--coordinator", metavar="HOST:PORT", default=os.environ.get("JAX_COORDINATOR_ADDRESS"),
                     help="one run over several processes or hosts (jax.distributed): process 0's address; each "
                          "process steps its share of the worlds, process 0 writes --out ($JAX_COORDINATOR_ADDRESS)")
    ptr.add_argument("--num-processes", type=POSITIVE, default=os.environ.get("JAX_NUM_PROCESSES"),
                     help="with --coordinator: how many ($JAX_NUM_PROCESSES)")
    ptr.add_argument("--process-id", type=NONNEGATIVE, default=os.environ.get("JAX_PROCESS_ID"),
                     help="with --coordinator: this process's, 0 to N-1 ($JAX_PROCESS_ID)")
    _add_backend_args(ptr)
    ptr.set_defaults(func=cmd_train, tree=True, usage=ptr.format_help)

    pft = sub.add_parser("finetune", help="continue a trained run with a diagnostic preset (ARAM, Reconfig, ...)")
    pft.add_argument("--checkpoint", required=True,
                     help="a run's checkpoint, or the run folder (the checkpoint its method reads)")
    pft.add_argument("--recipe", required=True,
                     help=" | ".join(f"{name} ({f.epochs} epochs)" for name, f in FINETUNES.items()))
    pft.add_argument("--out", required=True, help="run folder of the fine-tune")
    pft.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    pft.add_argument("--ppo.lr", dest="lr", type=float,
                     help="Adam's learning rate from the checkpoint on (default: the checkpoint's own; a run whose "
                          "learning went non-finite goes on from its last good checkpoint at a lower one)")
    pft.add_argument("--epochs", type=POSITIVE, help="epochs to add (default: the preset's)")
    pft.add_argument("--seed", type=int, help="start the fine-tune's worlds and sampling from this seed (default: "
                                              "the run's seed, continuing the checkpoint's stream)")
    pft.add_argument("--save-every", type=POSITIVE, default=SAVE_EVERY, help="epochs between checkpoints")
    pft.add_argument("--robust-every", type=NONNEGATIVE, default=ROBUST_EVERY,
                     help="epochs between robustness evaluations that select best_robust (0: off)")
    pft.add_argument("--quiet", action="store_true")
    pft.add_argument("--object", help="fine-tune onto this object folder instead of the run's own (e.g. a policy "
                                      "trained over several objects, onto a new one)")
    pft.add_argument("--trajectory", help="trajectory file of --object (default: generate one)")
    _add_backend_args(pft)
    pft.set_defaults(func=cmd_finetune)

    pev = sub.add_parser("evaluate", help="evaluate a trained run or a controller: damping x mode cells, robustness")
    pev.add_argument("--checkpoint",
                     help="a run folder (the checkpoint its method reads: best_robust, else final, for the "
                          "paper's methods; final for the recipe) or one of its checkpoints/*")
    pev.add_argument("--method", help="a controller that needs no training, instead of --checkpoint: tracking "
                                      "(the expert drag replayed as PD targets) | tracking_delta (the same drag "
                                      "through the policies' action increments) | parallel_jaw (the GT-part-pose "
                                      "gripper primitive) | prior (with --checkpoint of a residual method's run: "
                                      "its expert prior alone, the residual at zero); with --checkpoint, on the "
                                      "run's own task (the expert in use: its trajectory, grasp and contacts), from "
                                      "the same starts")
    pev.add_argument("--object", help="object folder (with --method; with --checkpoint: the policy zero-shot on it)")
    pev.add_argument("--trajectory", help="trajectory file of --object (default: generate one)")
    pev.add_argument("--damping", help="damping multipliers, comma-separated (> 0; default: a run's method's "
                                       f"cells, the recipe's {_csv(RECIPE_DAMPINGS)}; else {_csv(PAPER.dampings)})")
    pev.add_argument("--mode", default=",".join(PAPER.modes), help="det (the mean action) and/or stoch (sampled)")
    pev.add_argument("--episodes", type=POSITIVE, default=PAPER.episodes, help="episodes per cell")
    pev.add_argument("--seed", type=int, default=PAPER.seed, help="seed of the starts and the stochastic actions")
    pev.add_argument("--exact-reset", action="store_true",
                     help="the paper's noise-free start (default: perturbed expert grasps, so cells are rates)")
    pev.add_argument("--json", action="store_true")
    pev.add_argument("--quiet", action="store_true", help="no progress lines on standard error")
    _add_backend_args(pev)
    pev.set_defaults(func=cmd_evaluate)

    pen = sub.add_parser("envelope", help="an object's physical envelope: the expert drag replayed at several paces "
                                          "and dampings (which cells are reachable through contact, load peaks)")
    pen.add_argument("--object", required=True, help="object folder")
    pen.add_argument("--trajectory", help="trajectory file (default: generate one)")
    pen.add_argument("--paces", default=_csv(ENVELOPE_PACES), help="replay speeds (0.5: twice as slow)")
    pen.add_argument("--damping", default=_csv(ENVELOPE_DAMPINGS), help="damping multipliers, comma-separated")
    pen.add_argument("--json", action="store_true")
    pen.add_argument("--plot", metavar="FILE.png", help="also draw the envelope as a figure")
    _add_backend_args(pen)
    pen.set_defaults(func=cmd_envelope)

    prp = sub.add_parser("reproduce", help="the paper's tables end to end: training, fine-tunes, evaluations, "
                                           "markdown, Figure 2 (resumable)")
    prp.add_argument("tables", nargs="+", choices=[*TABLES, "all"])
    prp.add_argument("--objects", nargs="+", help="object folders (default: the packaged drawer); the first is the "
                                                  "diagnostic object of the appendix tables")
    prp.add_argument("--seeds", default="0,1,2", help="training seeds, comma-separated")
    prp.add_argument("--methods", help="comma-separated rows of the main and ablation tables instead of the paper's "
                                       "(any method preset or controller)")
    prp.add_argument("--epochs", type=POSITIVE, default=PAPER_EPOCHS,
                     help="base budget; the appendix epochs scale with it")
    prp.add_argument("--num-envs", type=POSITIVE, help=f"default: {PPOConfig.num_envs}")
    prp.add_argument("--episodes", type=POSITIVE, help="episodes per cell (default: the paper's 20 in its tables, "
                     "100 in the project's generalist and scaling tables)")
    prp.add_argument("--damping", help="evaluation damping multipliers (default: the rows' methods' own, the "
                                       f"recipe's {_csv(RECIPE_DAMPINGS)}; else the paper's {_csv(PAPER.dampings)})")
    prp.add_argument("--train-objects", type=POSITIVE, default=GENERALIST_OBJECTS,
                     help="generalist: procedural training objects in the paper's Table 1 mix (built into --out)")
    prp.add_argument("--dataset", help="generalist: train on this dataset folder (dataset build) instead")
    prp.add_argument("--holdout", type=NONNEGATIVE, default=GENERALIST_HOLDOUT,
                     help="generalist: training objects held aside for its best_robust selection")
    prp.add_argument("--scaling", default=_csv(SCALING_OBJECTS),
                     help="scaling: training-set sizes (nested procedural objects in the Table 1 mix)")
    prp.add_argument("--mode", default=",".join(PAPER.modes), help="evaluation modes of trained runs (det, stoch)")
    prp.add_argument("--checkpoint-rule", choices=CHECKPOINTS,
                     help="main/ablation: evaluate each run's best_robust checkpoint (the paper's selection) or its "
                          "final one (rows then read METHOD@EPOCHS) (default: each method's own rule: best_robust "
                          "for the paper's, final for the recipe)")
    prp.add_argument("--video-every", type=NONNEGATIVE, default=VIDEO_EVERY,
                     help="control steps between video frames of each method's video (0: no videos)")
    prp.add_argument("--contacts", choices=list(CONTACTS), default="mujoco",
                     help="the physics every row trains and is evaluated on: MuJoCo's default object contacts, or the "
                          "hand's firm grip the recipe's levers use")
    prp.add_argument("--out", default="out/reproduce", help="the reproduction's folder (resumable)")
    prp.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    prp.add_argument("--quiet", action="store_true")
    prp.add_argument("--tables-only", action="store_true",
                     help="run nothing: write the tables from the evaluations already done, each by the plan "
                          "recorded in --out (the other flags are not needed; partial tables say so, and a table "
                          "is never replaced by one with fewer cells); --out must hold each table's runs (all: the "
                          "tables it holds)")
    prp.set_defaults(func=cmd_reproduce)

    pd = sub.add_parser("demo", help="the main job: trajectory, training the recipe, evaluation, report")
    pd.add_argument("--object", help="object folder (default: the packaged drawer cabinet)")
    pd.add_argument("--trajectory")
    pd.add_argument("--out", default="out/demo", help="the demo's run folder (a rerun resumes it)")
    pd.add_argument("--overwrite", action="store_true", help=OVERWRITE_HELP)
    pd.add_argument("--epochs", type=POSITIVE, help="default: 60 on a CPU, the method's budget on a GPU")
    pd.add_argument("--seed", type=int, default=0, help="training seed")
    pd.add_argument("--quiet", action="store_true")
    pd.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    pd.add_argument("--video-every", type=POSITIVE, default=VIDEO_EVERY, help="control steps between video frames")
    pd.add_argument("--episodes", type=POSITIVE, default=PAPER.episodes, help="episodes per evaluation cell")
    pd.add_argument("--method", default="recommended", help="the method the demo trains (recommended: the project's "
                                                            f"recipe, {RECOMMENDED})")
    _add_renderer_arg(pd)
    pd.set_defaults(func=cmd_demo)

    pop = sub.add_parser("open", help="the packaged generalist on any object folder, no training: the trajectory, "
                                      "deterministic episodes, a report (success, steps, wrist load), a video")
    pop.add_argument("--object", required=True, help="object folder (GAPartNet format)")
    pop.add_argument("--damping", type=one_damping, default=1.0, help="damping multiplier of the part's joint (> 0)")
    pop.add_argument("--out", help="folder of the report, video, still and trajectory (default: open_OBJECT)")
    pop.add_argument("--checkpoint", default="generalist", help="the policy: the packaged generalist, or a run "
                                                                "folder or checkpoint")
    pop.add_argument("--episodes", type=POSITIVE, default=OPEN_EPISODES, help="deterministic episodes")
    pop.add_argument("--video-every", type=POSITIVE, default=VIDEO_EVERY, help="control steps between video frames")
    _add_renderer_arg(pop)
    pop.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    pop.set_defaults(func=cmd_open)

    pv = sub.add_parser("video", help="a trained policy's rollouts at several dampings, side by side")
    pv.add_argument("--checkpoint", required=True,
                    help="run folder (the checkpoint its method reads) or checkpoint file")
    pv.add_argument("--damping", help="damping multipliers, side by side (default: the run's method's cells, "
                                      f"the recipe's {_csv(RECIPE_DAMPINGS)}; else {_csv(PAPER.dampings)})")
    pv.add_argument("--out", default="policy.mp4", help=".mp4 (where mediapy and ffmpeg exist, else GIF) or .gif")
    pv.add_argument("--video-every", type=POSITIVE, default=VIDEO_EVERY,
                    help="control steps between frames (played in real time: 2 is 30 frames a second)")
    _add_renderer_arg(pv)
    _add_backend_args(pv)
    pv.set_defaults(func=cmd_video)

    pw = sub.add_parser("view", help="MuJoCo's interactive viewer: a trained policy, or the expert drag, in real time "
                                     "(keys 1/2/4/8: damping; N: next episode)")
    pw.add_argument("--checkpoint", help="run folder (the checkpoint its method reads) or checkpoint")
    pw.add_argument("--object", help="object folder (with --checkpoint: the policy on another object)")
    pw.add_argument("--trajectory")
    pw.add_argument("--damping", type=one_damping, default=1.0, help="the damping multiplier it starts at (> 0)")
    pw.add_argument("--steps", type=POSITIVE, help="close after this many control steps (default: when closed)")
    _add_backend_args(pw)
    pw.set_defaults(func=cmd_view)
    return p
