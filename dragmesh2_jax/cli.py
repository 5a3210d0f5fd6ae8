"""``dragmesh2``: the command-line entry point. Each subcommand is a thin shell over library functions.

Errors in input or configuration print one line ``error: ...`` and exit with status 2 (no traceback).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.bench import (
    LEARNING_EPOCHS,
    LEARNING_METHOD,
    LEARNING_SEEDS,
    bench_env_sweep,
    bench_soak_sweep,
    bench_train_sweep,
    learning_curves,
    learning_regressions,
)
from dragmesh2_jax.demo import run_demo
from dragmesh2_jax.errors import DragMeshError, NotSaved
from dragmesh2_jax.evaluation.evaluate import (
    ENVELOPE_DAMPINGS,
    ENVELOPE_PACES,
    envelope_figure,
    envelope_table,
    markdown_table,
)
from dragmesh2_jax.evaluation.protocol import PAPER, EvalProtocol
from dragmesh2_jax.io import atomic_write_json, os_error_line
from dragmesh2_jax.physics.mjx_backend import avoid_lapack_deadlock
from dragmesh2_jax.policies.methods import METHODS, RECIPE_DAMPINGS, RECOMMENDED
from dragmesh2_jax.policies.networks import NetworkConfig
from dragmesh2_jax.ppo.config import PAPER_EPOCHS, PPOConfig
from dragmesh2_jax.ppo.finetune import FINETUNES
from dragmesh2_jax.render import RENDERERS, VIDEO_EVERY
from dragmesh2_jax.reproduce import (
    CHECKPOINTS,
    GENERALIST_HOLDOUT,
    GENERALIST_OBJECTS,
    SCALING_OBJECTS,
    TABLES,
    ReproduceConfig,
    reproduce,
)
from dragmesh2_jax.runs.commands import (
    DEFAULT_METHOD,
    dataset_objects,
    describe_object,
    evaluate_baseline,
    evaluate_checkpoint,
    finetune_run,
    make_trajectory,
    object_envelope,
    parse_floats,
    run_dampings,
    train_run,
    video_of_run,
    view_run,
)
from dragmesh2_jax.runs.session import Selection
from dragmesh2_jax.runs.spec import ROBUST_EVERY, SAVE_EVERY
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.config import TaskConfig
from dragmesh2_jax.trajectory.dataset import build_dataset


def _csv(values) -> str:
    return ",".join(f"{v:g}" for v in values)


def _dampings(text: str, what: str = "--damping") -> list[float]:
    return parse_floats(text, what, above=0.0)


def _whole(minimum: int):
    """An argparse type: a whole number >= ``minimum``, refused when parsed (one error line, exit 2)."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"a whole number expected, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be >= {minimum}, got {value}")
        return value
    parse.__name__ = f"int>={minimum}"
    return parse


POSITIVE, NONNEGATIVE = _whole(1), _whole(0)


def _damping(text: str) -> float:
    """An argparse type: one damping multiplier (> 0)."""
    try:
        (value,) = _dampings(text)
    except DragMeshError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    except ValueError:
        raise argparse.ArgumentTypeError(f"one damping multiplier expected, got {text!r}") from None
    return value


def _modes(text: str) -> list[str]:
    return [m.strip() for m in text.split(",") if m.strip()]


def _err(*lines) -> None:
    print(*lines, file=sys.stderr)


def cmd_inspect(args) -> int:
    info = describe_object(args.folder, SceneConfig(scale=args.scale, collide=args.collide), args.render,
                           args.renderer)
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    t, h, s = info["target_joint"], info["handle"], info["scene"]
    print(f"object        {info['object_id']} ({info['category']})  {info['folder']}")
    print(f"target part   {info['target_part']['link']} [{info['target_part']['category']}]")
    print(f"target joint  {t['name']} {t['type']} axis {t['axis']} origin {t['origin']} range {t['range']}")
    print(f"handle        {h['source']} {h['link']} centre {h['centre']} normal {h['normal']} long {h['long_axis']}")
    print(f"              thickness {h['thickness']} width {h['width']} length {h['length']} (object units)")
    print(f"collision     {s['collision_pieces']} colliding pieces of {s['pieces']}, largest hull "
          f"{s['max_hull_vertices']} vertices, {s['contact_pairs']} hand-object geom pairs")
    print(f"model         nq {s['nq']} nv {s['nv']} nu {s['nu']} ngeom {s['ngeom']}, target part "
          f"{s['target_mass_kg']} kg")
    c = info["contacts"]
    print(f"contacts      {len(c['pairs'])} pairs can collide: each hand geom with each colliding object piece "
          "(no hand self-contact, no locked or static piece; --json lists them)")
    if c["budget"] is None:
        print(f"MJX buffers   {c['note']}")
    else:
        b = c["budget"]
        print(f"MJX buffers   expert drag (C engine, x1 and x8): at most {b['probed_contacts']} contacts, "
              f"{b['probed_constraints']} constraint rows per world; budget {b['contacts']} contacts, "
              f"{b['constraints']} rows per world (MJX-JAX would reserve {b['candidates']} contacts uncapped)")
    if args.render:
        print(f"picture       {info['render']['path']} ({info['render']['renderer']} renderer)")
    return 0


def cmd_objects(args) -> int:
    if args.objects_cmd == "synth":
        paths = procedural.synthesize_categories(args.category, args.count, args.seed, args.out)
        print(*paths, sep="\n")
        _err(f"{len(paths)} objects in {args.out}")
        return 0
    print("categories:", ", ".join(procedural.CATEGORIES))
    print(*procedural.default_objects(), sep="\n")
    return 0


def cmd_trajectory(args) -> int:
    traj, used = make_trajectory(args.object, args.out, args.render, args.renderer)
    q = traj.header["quality"]
    blocks = ", ".join(f"{p} {b - a}" for p, a, b in traj.phase_blocks())
    print(f"{args.out}: {len(traj.frames)} frames ({blocks}); target {traj.header['target']['joint_name']} "
          f"{traj.header['target']['type']}; q_start {traj.q_start:.4f} q_done {traj.q_done:.4f} "
          f"q_max {traj.q_max:.4f}; quality {'PASSED' if q['passed'] else 'FAILED: ' + '; '.join(q['reasons'])}")
    if used:
        print(f"video {args.render} ({used} renderer)")
    return 0 if q["passed"] else 1


def cmd_dataset(args) -> int:
    if args.procedural < 0:
        raise DragMeshError(f"--procedural must be >= 0, got {args.procedural}")
    res = build_dataset(args.objects, args.out, progress=not args.quiet, procedural=args.procedural, seed=args.seed)
    print(Path(res.summary).read_text())
    print(f"manifest {res.manifest}; {len(res.records) - len(res.failures)} of {len(res.records)} passed")
    return 0


def _print_env_row(r: dict) -> None:
    slots = "dynamic" if r["contact_slots"] is None else f"{r['contact_slots']:4d}"
    rows = "dynamic" if r["constraint_rows"] is None else f"{r['constraint_rows']:4d}"
    _err(f"{r['engine']:8s} envs {r['num_envs']:5d}  compile {r['compile_s']:7.2f} s  "
         f"control {r['control_steps_per_s']:10.1f}/s  physics {r['physics_steps_per_s']:11.1f}/s  "
         f"contact slots/world {slots}  rows/world {rows}")


def _print_train_row(r: dict) -> None:
    _err(f"{r['method']} {r['backend']:7s} {r['object']} envs {r['num_envs']:5d} x {r['runs']} runs  "
         f"first epoch {r['first_epoch_s']:7.2f} s  {r['s_per_epoch']:.3f} s/epoch  "
         f"env {r['env_steps_per_s']:10.1f}/s  physics {r['physics_steps_per_s']:11.1f}/s  "
         f"{PAPER_EPOCHS} epochs ~{r['budget_s']:.0f} s")


def _counts(text: str, what: str) -> list[int]:
    vals = parse_floats(text, what, minimum=1)
    if any(v != int(v) for v in vals):
        raise DragMeshError(f"{what}: whole numbers expected, got {text!r}")
    return [int(v) for v in vals]


def cmd_bench(args) -> int:
    objects = args.object.split(",") if args.object else None
    rows = bench_env_sweep(objects, args.trajectory, [b.strip() for b in args.backend.split(",")],
                           _counts(args.num_envs, "--num-envs"), args.steps, args.mjx_steps,
                           tuple(i.strip() for i in args.impl.split(",")), report=_print_env_row)
    if args.json:
        print(json.dumps(rows, indent=1))
    return 0


def cmd_bench_soak(args) -> int:
    rows = bench_soak_sweep(args.objects, _dampings(args.damping), args.num_envs, args.steps, args.seed,
                            args.backend, args.impl)
    for r in rows:
        _err(f"{r['object']:>20s} x{r['damping']:<4g} {r['physics_steps']:8d} physics steps  non-finite worlds "
             f"{r['nonfinite_worlds']:3d} ({r['nonfinite_events']} events)  episodes {r['episodes']:4d}")
    _err(f"{sum(r['physics_steps'] for r in rows)} physics steps, {sum(r['nonfinite_worlds'] for r in rows)} "
         "worlds went non-finite (each isolated and reset)")
    if args.json:
        print(json.dumps(rows, indent=1))
    if not all(r["batch_finite"] for r in rows):
        raise DragMeshError("a non-finite observation left the task (the isolation of non-finite worlds failed)")
    return 0 if not any(r["nonfinite_worlds"] for r in rows) else 1  # the target: no world goes non-finite


def cmd_bench_train(args) -> int:
    objects = args.object.split(",") if args.object else None
    rows = bench_train_sweep(objects, args.method, args.backend, _counts(args.num_envs, "--num-envs"),
                             _counts(args.runs, "--runs"), args.epochs, args.impl, report=_print_train_row)
    if args.json:
        print(json.dumps(rows, indent=1))
    return 0


def cmd_bench_learning(args) -> int:
    recorded = None
    seeds = None if args.seeds is None else tuple(int(s) for s in parse_floats(args.seeds, "--seeds", minimum=0))
    if args.against:
        recorded = _read_json(args.against)
        objects = args.objects or list(recorded["curves"])
        differ = []
        for k, v in (("method", args.method), ("epochs", args.epochs), ("seeds", seeds)):
            want = tuple(recorded[k]) if k == "seeds" else recorded[k]
            if v is not None and v != want:
                differ.append(f"--{k} {_show(v)} (recorded {_show(want)})")
        if differ:
            raise DragMeshError(f"--against {args.against} compares with the recorded curves, so it takes their "
                                f"method, epochs and seeds: {'; '.join(differ)} (drop them, or --record new curves)")
        method, epochs, seeds = recorded["method"], recorded["epochs"], tuple(recorded["seeds"])
    else:
        objects = args.objects or [str(procedural.packaged_object(procedural.HEAVY_DRAWER))]
        method, epochs = args.method or LEARNING_METHOD, args.epochs or LEARNING_EPOCHS
        seeds = seeds or LEARNING_SEEDS
    current = learning_curves(objects, method, epochs, seeds, args.backend, report=lambda o, r: _err(
        f"{Path(o).name:>20s} epoch {r['epoch']:3d}  success {r['success']:.2f}  progress {r['progress']:.2f}  "
        f"detach {r['detach']:.2f}"))
    if args.record:
        atomic_write_json(args.record, current)
        _err(f"recorded: {args.record}")
    problems = learning_regressions(current, recorded or {"curves": {}}, args.tolerance)
    for p in problems:
        print(f"regression: {p}")
    if not problems:
        print(f"no learning regression ({len(objects)} objects x {len(seeds)} seeds x {epochs} epochs)")
    return 1 if problems else 0


def _show(value) -> str:
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value)


def _read_json(path: str) -> dict:
    try:
        return json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise DragMeshError(f"{path}: cannot read recorded curves ({e})") from None


def _add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scale", type=float, default=0.4, help="object scale (default 0.4, as the reference)")
    p.add_argument("--collide", choices=["target", "all"], default="target",
                   help="object pieces that collide with the hand (default: target part near the handle)")


def _add_renderer_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--renderer", default="auto", choices=RENDERERS,
                   help="mujoco (OSMesa on a CPU, EGL on a GPU) | matplotlib (GL-free) | auto (MuJoCo's where it runs)")


def _add_backend_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    p.add_argument("--impl", default="jax", help="MJX implementation: jax | warp")


def cmd_train(args) -> int:
    seeds = None
    if args.seeds is not None:
        seeds = parse_floats(args.seeds, "--seeds", minimum=0)
        if any(s != int(s) for s in seeds) or len(set(seeds)) < len(seeds):
            raise DragMeshError(f"--seeds: distinct whole numbers expected, got {args.seeds!r}")
        seeds = [int(s) for s in seeds]
    objects, trajectory = args.object, args.trajectory
    if args.objects or args.dataset:
        if args.object:
            raise DragMeshError("give --object (one object), or --objects / --dataset (several), not both")
        objects, trajectory = list(args.objects or []), [None] * len(args.objects or [])
        if args.dataset:
            more, trajs = dataset_objects(args.dataset)
            objects, trajectory = objects + more, trajectory + trajs
    program, logs = train_run(
        args.out, objects, trajectory, args.method, args.backend, args.impl, seeds, args.resume, holdout=args.holdout,
        task_changes=config_changes(args, "task"), scene_changes=config_changes(args, "scene"),
        network_changes=config_changes(args, "network"),
        selection=None if args.robust_every is None else Selection(every=args.robust_every),
        save_every=args.save_every, progress=not args.quiet, wandb=args.wandb,
        epochs=args.epochs, num_envs=args.num_envs, seed=args.seed, lr_schedule=args.lr_schedule,
        **config_changes(args, "ppo"))
    for seed, rows in logs:
        last = rows[-1] if rows else {}
        print(f"{args.out}: {program.method.name} seed {seed} on {program.task.scene.obj.object_id} "
              f"({program.task.backend.name}), {last.get('epoch', 0)} epochs, training success "
              f"{last.get('success', 0):.2f}, reward {last.get('reward', 0):.2f}, {last.get('seconds', 0):.0f} s")
    return 0


def cmd_finetune(args) -> int:
    parent, rows = finetune_run(args.checkpoint, args.recipe, args.out, _engine(args.backend), args.impl, args.epochs,
                                Selection(every=args.robust_every), args.save_every, not args.quiet, args.object,
                                args.trajectory)
    last = rows[-1] if rows else {}
    print(f"{args.out}: {args.recipe} fine-tune of {parent} to epoch {last.get('epoch', 0)}, training success "
          f"{last.get('success', 0):.2f}, clip099 {last.get('clip099', 0):.2f}, {last.get('seconds', 0):.0f} s")
    return 0


def _protocol(args) -> EvalProtocol:
    return dataclasses.replace(PAPER, dampings=_cells(args.damping, args.checkpoint), modes=tuple(_modes(args.mode)),
                               episodes=args.episodes, seed=args.seed,
                               starts=None if args.exact_reset else PAPER.starts)


def _cells(damping: str | None, checkpoint: str | None) -> tuple[float, ...]:
    """``--damping``, else a run's method's cells (the recipe's x1-x16), else the paper's x1/x2/x4."""
    if damping is not None:
        return tuple(_dampings(damping))
    return run_dampings(checkpoint) if checkpoint else PAPER.dampings


def _engine(backend: str) -> str | None:
    """A trained run's engine: the one it trained on unless a flag names another."""
    return None if backend == "auto" else backend


def cmd_evaluate(args) -> int:
    protocol = _protocol(args)
    if bool(args.checkpoint) == bool(args.method):
        raise DragMeshError("give --checkpoint (a trained run) or --method with --object (a controller), not both")
    if args.checkpoint:
        try:
            result, path = evaluate_checkpoint(args.checkpoint, protocol, _engine(args.backend), args.impl,
                                               args.object, args.trajectory)
        except NotSaved as e:  # computed, not saved: printed whole, then the one error line
            print(json.dumps(e.result, indent=1) if args.json else markdown_table(e.result))
            raise
        _err(f"evaluation: {path}")
    else:
        result = evaluate_baseline(args.method, args.object, args.trajectory, protocol, args.backend, args.impl)
    print(json.dumps(result, indent=1) if args.json else markdown_table(result))
    return 0


def cmd_envelope(args) -> int:
    paces = parse_floats(args.paces, "--paces", minimum=0.01)
    rows = object_envelope(args.object, args.trajectory, paces, _dampings(args.damping), args.backend, args.impl)
    print(json.dumps(rows, indent=1) if args.json else envelope_table(rows))
    if args.plot:
        _err(f"figure: {envelope_figure(rows, args.plot, f'envelope of {Path(args.object).name}')}")
    return 0


def cmd_reproduce(args) -> int:
    seeds = [int(s) for s in parse_floats(args.seeds, "--seeds", minimum=0)]
    config = ReproduceConfig(objects=tuple(args.objects or [str(procedural.default_object())]), seeds=tuple(seeds),
                             epochs=args.epochs, num_envs=args.num_envs, episodes=args.episodes, backend=args.backend,
                             methods=tuple(args.methods.split(",")) if args.methods else None,
                             dampings=None if args.damping is None else tuple(_dampings(args.damping)),
                             train_objects=args.train_objects,
                             dataset=args.dataset, holdout=args.holdout, video_every=args.video_every,
                             scaling=tuple(int(n) for n in parse_floats(args.scaling, "--scaling", minimum=1)),
                             modes=tuple(_modes(args.mode)), checkpoint=args.checkpoint)
    for path in reproduce(args.tables, config, args.out, progress=not args.quiet, run=not args.tables_only):
        print(path.read_text())
        _err(f"table: {path}")
    return 0


def cmd_demo(args) -> int:
    """The main job on the built-in default: trajectory -> the recipe's training -> evaluation x1/x2/x4 -> report."""
    report = run_demo(args.out, args.object, args.trajectory, args.epochs, args.backend, args.seed, args.renderer,
                      args.video_every, args.method, progress=not args.quiet, episodes=args.episodes)
    print(report.read_text())
    _err(f"report: {report}")
    return 0


def cmd_video(args) -> int:
    dampings = _cells(args.damping, args.checkpoint)
    path, used, ck = video_of_run(args.checkpoint, dampings, args.out, args.every, _engine(args.backend), args.impl,
                                  args.renderer)
    print(f"{path}: det policy of {ck} at damping {', '.join(f'x{d:g}' for d in dampings)} ({used} renderer)")
    return 0


def cmd_view(args) -> int:
    shown = view_run(args.checkpoint, args.object, args.trajectory, args.damping, args.steps, _engine(args.backend),
                     args.impl)
    _err(f"view: {shown} control steps shown")
    return 0


# ------------------------------------------------------------- every config field as a flag
#: Config dataclasses whose fields ``dragmesh2 train`` takes as ``--<prefix>.<field>`` flags.
CONFIG_CLASSES = {"task": TaskConfig, "scene": SceneConfig, "ppo": PPOConfig, "network": NetworkConfig}


def _field_parser(tp):
    """An argparse type for a config field's annotation (scalars, optional scalars and tuples of numbers), or
    None for nested configs (set them in Python)."""
    text = str(tp)
    optional = "None" in text
    base = text.replace(" | None", "").replace("None | ", "").strip()
    scalar = {"int": int, "float": float, "str": str, "bool": _bool}.get(base)
    if scalar is not None:
        return (lambda s: None if s.lower() == "none" else scalar(s)) if optional else scalar
    if base.startswith("tuple[") and ("float" in base or "int" in base):
        num = float if "float" in base else int

        def tup(s):
            if optional and s.lower() == "none":
                return None
            return tuple(num(x) for x in s.split(",") if x.strip())
        return tup
    return None


def _bool(s: str) -> bool:
    if s.lower() not in ("true", "false", "1", "0"):
        raise argparse.ArgumentTypeError(f"expected true or false, got {s!r}")
    return s.lower() in ("true", "1")


def add_config_args(p: argparse.ArgumentParser, skip: tuple[str, ...] = ()) -> None:
    """``--task.alpha 0.03``, ``--ppo.num-envs 8``, ``--scene.damping 25``, ``--network.hist-dim 64``: every
    scalar and tuple field of the task, scene, PPO and network configs (defaults: the method preset's)."""
    for prefix, cls in CONFIG_CLASSES.items():
        g = p.add_argument_group(f"{prefix} config ({cls.__name__}; default: the preset's)")
        for f in dataclasses.fields(cls):
            parse = _field_parser(f.type)
            if parse is None or f"{prefix}.{f.name}" in skip:
                continue
            g.add_argument(f"--{prefix}.{f.name.replace('_', '-')}", dest=f"{prefix}__{f.name}", type=parse,
                           default=argparse.SUPPRESS, metavar=f.type if isinstance(f.type, str) else None,
                           help=f"default: the method's; {cls.__name__}'s {_csv_value(f.default)}")


def _csv_value(value) -> str:
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value).lower() if isinstance(
        value, bool) else str(value)


def config_changes(args, prefix: str) -> dict:
    """The ``--<prefix>.<field>`` flags given on the command line."""
    return {k.split("__", 1)[1]: v for k, v in vars(args).items() if k.startswith(f"{prefix}__")}


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
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        print(f"error: {self.prog}: {message}", file=sys.stderr)
        raise SystemExit(2)


def build_parser() -> argparse.ArgumentParser:
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
    pbenv.add_argument("--object", help="object folder (default: the packaged drawer); several, comma-separated: one "
                                        "batch mixing them (each world steps one), as training over several objects")
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
    pbtr.add_argument("--object", help="object folder(s), comma-separated (default: the packaged drawer); a second "
                                       "object of the same structure reuses the compiled program")
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
    pbl.add_argument("--seeds", help=f"default: the recorded curves', else {_show(LEARNING_SEEDS)}")
    pbl.add_argument("--tolerance", type=float, default=0.2, help="allowed drop of final training success")
    pbl.add_argument("--backend", default="mujoco", help="mjx | mujoco | auto")
    pbl.set_defaults(func=cmd_bench_learning)

    ptr = sub.add_parser("train", help="train a policy with PPO")
    ptr.add_argument("--method", help=f"default: {DEFAULT_METHOD} (a resumed run: its own) | recommended | "
                                      + " | ".join(METHODS))
    ptr.add_argument("--object", help="object folder")
    ptr.add_argument("--objects", nargs="+", metavar="FOLDER", help="several object folders: one policy over all of "
                                                                    "them (each world draws one at every reset)")
    ptr.add_argument("--dataset", help="a folder written by dataset build: its objects whose trajectory passed")
    ptr.add_argument("--holdout", type=NONNEGATIVE,
                     help="of several objects, the last this many are held aside: best_robust is chosen on them "
                          "(default: 0)")
    ptr.add_argument("--trajectory", help="trajectory file (default: generate one)")
    ptr.add_argument("--out", required=True, help="run folder")
    ptr.add_argument("--epochs", type=POSITIVE, help=f"default: {PPOConfig.epochs}, the paper's (a resumed run: "
                                                     "its own; more extends it)")
    ptr.add_argument("--num-envs", type=POSITIVE, help=f"parallel worlds (default: {PPOConfig.num_envs})")
    ptr.add_argument("--seed", type=int, help=f"default: {PPOConfig.seed}")
    ptr.add_argument("--seeds", help="several seeds as one program (e.g. 0,1,2), each in OUT/seed_N; sharded over "
                                     "the devices when they divide the count")
    ptr.add_argument("--lr-schedule", choices=["fixed", "adaptive"], help=f"default: {PPOConfig.lr_schedule}")
    ptr.add_argument("--save-every", type=POSITIVE,
                     help=f"epochs between checkpoints (default: {SAVE_EVERY}; a resumed run: its own)")
    ptr.add_argument("--resume", action="store_true", help="continue the run in --out exactly")
    ptr.add_argument("--robust-every", type=NONNEGATIVE,
                     help="epochs between robustness evaluations that select best_robust (0: off; default: "
                          f"{ROBUST_EVERY}; a resumed run: its own)")
    ptr.add_argument("--quiet", action="store_true")
    ptr.add_argument("--wandb", metavar="PROJECT", help="also log the scalars to this Weights & Biases project (the "
                                                         "wandb extra; WANDB_MODE=offline keeps them local)")
    _add_backend_args(ptr)
    # the engine and the run's own flags stand above; the effector is the parallel-jaw primitive's, not a policy's
    add_config_args(ptr, skip=("task.backend", "task.impl", "ppo.epochs", "ppo.num_envs", "ppo.seed",
                               "ppo.lr_schedule", "scene.effector"))
    ptr.set_defaults(func=cmd_train)

    pft = sub.add_parser("finetune", help="continue a trained run with a diagnostic preset (ARAM, Reconfig, ...)")
    pft.add_argument("--checkpoint", required=True,
                     help="a run's checkpoint, or the run folder (the checkpoint its method reads)")
    pft.add_argument("--recipe", required=True, help=" | ".join(FINETUNES))
    pft.add_argument("--out", required=True, help="run folder of the fine-tune")
    pft.add_argument("--epochs", type=POSITIVE, help="epochs to add (default: the preset's, 50)")
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
                                      "gripper primitive)")
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
    prp.add_argument("--epochs", type=POSITIVE, default=PPOConfig.epochs,
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
    prp.add_argument("--checkpoint", choices=CHECKPOINTS,
                     help="main/ablation: evaluate each run's best_robust checkpoint (the paper's selection) or its "
                          "final one (rows then read METHOD@EPOCHS) (default: each method's own rule: best_robust "
                          "for the paper's, final for the recipe)")
    prp.add_argument("--video-every", type=NONNEGATIVE, default=VIDEO_EVERY,
                     help="control steps between video frames of each method's video (0: no videos)")
    prp.add_argument("--out", default="out/reproduce", help="the reproduction's folder (resumable)")
    prp.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    prp.add_argument("--quiet", action="store_true")
    prp.add_argument("--tables-only", action="store_true",
                     help="run nothing: write the tables from the evaluations already done, each by the plan "
                          "recorded in --out (the other flags are not needed; partial tables say so, and a table "
                          "is never replaced by one with fewer cells)")
    prp.set_defaults(func=cmd_reproduce)

    pd = sub.add_parser("demo", help="the main job: trajectory, training the recipe, evaluation, report")
    pd.add_argument("--object", help="object folder (default: the packaged drawer cabinet)")
    pd.add_argument("--trajectory")
    pd.add_argument("--out", default="out/demo", help="the demo's run folder (a rerun resumes it)")
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

    pv = sub.add_parser("video", help="a trained policy's rollouts at several dampings, side by side")
    pv.add_argument("--checkpoint", required=True,
                    help="run folder (the checkpoint its method reads) or checkpoint file")
    pv.add_argument("--damping", help="damping multipliers, side by side (default: the run's method's cells, "
                                      f"the recipe's {_csv(RECIPE_DAMPINGS)}; else {_csv(PAPER.dampings)})")
    pv.add_argument("--out", default="policy.mp4", help=".mp4 (where mediapy and ffmpeg exist, else GIF) or .gif")
    pv.add_argument("--every", type=POSITIVE, default=VIDEO_EVERY, help="control steps between frames (played in real "
                                                                    "time: 2 is 30 frames a second)")
    _add_renderer_arg(pv)
    _add_backend_args(pv)
    pv.set_defaults(func=cmd_video)

    pw = sub.add_parser("view", help="MuJoCo's interactive viewer: a trained policy, or the expert drag, in real time "
                                     "(keys 1/2/4/8: damping; N: next episode)")
    pw.add_argument("--checkpoint", help="run folder (the checkpoint its method reads) or checkpoint")
    pw.add_argument("--object", help="object folder (with --checkpoint: the policy on another object)")
    pw.add_argument("--trajectory")
    pw.add_argument("--damping", type=_damping, default=1.0, help="the damping multiplier it starts at (> 0)")
    pw.add_argument("--steps", type=POSITIVE, help="close after this many control steps (default: when closed)")
    _add_backend_args(pw)
    pw.set_defaults(func=cmd_view)
    return p


def main(argv: list[str] | None = None) -> int:
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # --help (0) or a usage error (2, already reported)
        return int(e.code or 0)
    if "mjx" in str(getattr(args, "backend", "")):  # before anything starts JAX (jaxlib < 0.11 CPU deadlock)
        avoid_lapack_deadlock()
    try:
        return int(args.func(args) or 0)
    except DragMeshError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # what was written stands: a run resumes from its last checkpoint
        print("error: interrupted (a run continues from its last checkpoint with the same command and --resume)",
              file=sys.stderr)
        return 130
    except Exception as e:  # an operating-system fault, raised as such or wrapped by a library (Orbax, JAX)
        fault = _os_error(e)
        if fault is None:
            raise
        print(f"error: {os_error_line(fault)}", file=sys.stderr)
        return 2


def _os_error(e: BaseException) -> OSError | None:
    """The operating-system fault behind ``e`` (itself, or its cause or context), if there is one."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, OSError):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


if __name__ == "__main__":
    sys.exit(main())
