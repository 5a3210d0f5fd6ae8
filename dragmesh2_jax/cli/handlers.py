"""Each subcommand's handler: its arguments to a library call, the result printed. Returns the exit status."""

from __future__ import annotations

import dataclasses
import json
import shutil
import sys
import tempfile
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
from dragmesh2_jax.cli.flags import (
    flag_value,
    parse_dampings,
    parse_tree,
    print_tree_help,
    tree_summary,
)
from dragmesh2_jax.demo import run_demo
from dragmesh2_jax.errors import DragMeshError, NotSaved
from dragmesh2_jax.evaluation.evaluate import envelope_figure, envelope_table, markdown_table
from dragmesh2_jax.evaluation.protocol import PAPER, EvalProtocol
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.ppo import distributed
from dragmesh2_jax.ppo.config import PAPER_EPOCHS
from dragmesh2_jax.reproduce import ReproduceConfig, reproduce
from dragmesh2_jax.runs.commands import (
    dataset_objects,
    describe_object,
    evaluate_baseline,
    evaluate_checkpoint,
    finetune_run,
    make_trajectory,
    object_envelope,
    parse_floats,
    run_dampings,
    train_defaults,
    train_run,
    video_of_run,
    view_run,
)
from dragmesh2_jax.runs.finetunes import catalogue
from dragmesh2_jax.runs.generalist import GENERALIST, generalist_run, open_object
from dragmesh2_jax.runs.session import training_success
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.trajectory.dataset import build_dataset

TRAIN_PROG = "dragmesh2 train"


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
    if args.objects_cmd == "twin":
        sizes = parse_floats(args.dims, "--dims", above=0.0)
        if len(sizes) != 3:
            raise DragMeshError(f"--dims takes W,D,H (three sizes), got {args.dims!r}")
        unscaled = 1.0 / SceneConfig().scale  # the generator's frame, which the scene scales
        twin = procedural.Twin(tuple(x * unscaled for x in sizes), args.handle_length * unscaled, args.handle_kind)
        print(procedural.write_object(procedural.make_object(args.category, args.seed, twin=twin), args.out,
                                      object_id=Path(args.out).name))
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
    objects = args.objects
    rows = bench_env_sweep(objects, args.trajectory, [b.strip() for b in args.backend.split(",")],
                           _counts(args.num_envs, "--num-envs"), args.steps, args.mjx_steps,
                           tuple(i.strip() for i in args.impl.split(",")), report=_print_env_row)
    if args.json:
        print(json.dumps(rows, indent=1))
    return 0


def cmd_bench_soak(args) -> int:
    rows = bench_soak_sweep(args.objects, parse_dampings(args.damping), args.num_envs, args.steps, args.seed,
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
    objects = args.objects
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
                differ.append(f"--{k} {flag_value(v)} (recorded {flag_value(want)})")
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


def _read_json(path: str) -> dict:
    try:
        return json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise DragMeshError(f"{path}: cannot read recorded curves ({e})") from None


def join(args) -> None:
    """``train --coordinator``: this process joins the others (``ppo/distributed.py``) before JAX starts; a process
    other than 0 computes the run whole but writes it into a private copy of --out (process 0 writes --out)."""
    n, i = args.num_processes, args.process_id
    if n is None or i is None or not 0 <= int(i) < int(n):
        raise DragMeshError(f"--coordinator needs --num-processes N and --process-id 0..N-1, got {n} and {i}")
    distributed.initialize(args.coordinator, int(n), int(i))
    if not distributed.writer() and args.out:
        shadow = Path(tempfile.mkdtemp(prefix="dragmesh2_process_")) / "run"
        if Path(args.out).is_dir():  # a resume reads the run as process 0 does
            shutil.copytree(args.out, shadow)
        args.out, args.quiet = str(shadow), True


def cmd_train(args) -> int:
    if args.list_methods:
        print(catalogue())
        return 0
    seeds = None
    if args.seeds is not None:
        seeds = parse_floats(args.seeds, "--seeds", minimum=0)
        if any(s != int(s) for s in seeds) or len(set(seeds)) < len(seeds):
            raise DragMeshError(f"--seeds: distinct whole numbers expected, got {args.seeds!r}")
        seeds = [int(s) for s in seeds]
    if args.generalist:
        given = [f for f, v in (("--object", args.object), ("--objects", args.objects), ("--dataset", args.dataset),
                                ("--trajectory", args.trajectory), ("--holdout", args.holdout)) if v is not None]
        if given:
            raise DragMeshError(f"--generalist trains over its own objects: drop {', '.join(given)}")
    method = args.method or GENERALIST if args.generalist else args.method
    default = train_defaults(args.out, method, args.resume, seeds)
    if args.help_tree:
        print_tree_help(default, TRAIN_PROG)
        return 0
    if args.help:
        print(args.usage())
        print(tree_summary(default, TRAIN_PROG))
        return 0
    if not args.out:
        raise DragMeshError(f"{TRAIN_PROG}: --out is required (the run folder)")
    tree = parse_tree(args.rest, default, TRAIN_PROG)
    if args.generalist:
        program, logs = generalist_run(args.out, seeds, args.resume, args.backend, args.impl, tree,
                                       progress=not args.quiet, wandb=args.wandb, overwrite=args.overwrite,
                                       method=args.method, teachers=args.teachers)
        _print_trained(args.out, program, logs)
        return 0
    objects, trajectory = args.object, args.trajectory
    if args.objects or args.dataset:
        if args.object:
            raise DragMeshError("give --object (one object), or --objects / --dataset (several), not both")
        objects, trajectory = list(args.objects or []), [None] * len(args.objects or [])
        if args.dataset:
            more, trajs = dataset_objects(args.dataset)
            objects, trajectory = objects + more, trajectory + trajs
    program, logs = train_run(args.out, objects, trajectory, args.method, tree, args.backend, args.impl, seeds,
                              args.resume, progress=not args.quiet, wandb=args.wandb, holdout=args.holdout,
                              overwrite=args.overwrite, teachers=args.teachers)
    _print_trained(args.out, program, logs)
    return 0


def _print_trained(out: str, program, logs) -> None:
    for seed, rows in logs:
        last = rows[-1] if rows else {}
        print(f"{out}: {program.name} seed {seed} on {program.task.object_id} ({program.task.engine}), "
              f"{last.get('epoch', 0)} epochs, {training_success(rows)}, reward {last.get('reward', 0):.2f}, "
              f"{last.get('seconds', 0):.0f} s")


def cmd_open(args) -> int:
    out = args.out or f"open_{Path(args.object).name}"
    r = open_object(args.object, args.damping, out, args.checkpoint, args.episodes, _engine(args.backend),
                    args.renderer, args.video_every)
    e = r["expert"]
    print(f"{Path(args.object).name} at x{r['damping']:g}: opened {r['successes']}/{r['episodes']}, "
          f"{r['steps_mean']:.0f} steps, wrist load p95 {r['wrist_load_peak_n']:.0f} N (the expert drag: "
          f"{e['successes']}/{r['episodes']}, {e['steps_mean']:.0f} steps, {e['wrist_load_peak_n']:.0f} N)")
    where = f"  evaluation: {r['evaluation']}" if r["evaluation"] else ""
    _err(f"report: {Path(out) / 'report.md'}  video: {r['video']}  still: {r['still']}{where}")
    if r["evaluation_not_in_run"]:
        _err(f"note: the run folder did not get the evaluation ({r['evaluation_not_in_run']}); it is in "
             f"{r['evaluation']}")
    return 0


def cmd_finetune(args) -> int:
    schedule = {"save_every": args.save_every, "robust_every": args.robust_every}
    if args.seed is not None:
        schedule["seed"] = args.seed
    parent, rows = finetune_run(args.checkpoint, args.recipe, args.out, _engine(args.backend), args.impl, args.epochs,
                                schedule, progress=not args.quiet, object_dir=args.object,
                                trajectory=args.trajectory, overwrite=args.overwrite, lr=args.lr)
    last = rows[-1] if rows else {}
    print(f"{args.out}: {args.recipe} fine-tune of {parent} to epoch {last.get('epoch', 0)}, {training_success(rows)}, "
          f"clip099 {last.get('clip099', 0):.2f}, {last.get('seconds', 0):.0f} s")
    return 0


def _protocol(args) -> EvalProtocol:
    return dataclasses.replace(PAPER, dampings=_cells(args.damping, args.checkpoint), modes=tuple(_modes(args.mode)),
                               episodes=args.episodes, seed=args.seed,
                               starts=None if args.exact_reset else PAPER.starts)


def _cells(damping: str | None, checkpoint: str | None) -> tuple[float, ...]:
    """``--damping``, else a run's method's cells (the recipe's x1-x16), else the paper's x1/x2/x4."""
    if damping is not None:
        return tuple(parse_dampings(damping))
    return run_dampings(checkpoint) if checkpoint else PAPER.dampings


def _engine(backend: str) -> str | None:
    """A trained run's engine: the one it trained on unless a flag names another."""
    return None if backend == "auto" else backend


def cmd_evaluate(args) -> int:
    protocol = _protocol(args)
    if not (args.checkpoint or args.method):
        raise DragMeshError("give --checkpoint (a trained run), --method with --object (a controller), or both (the "
                            "controller on the run's task)")
    if args.checkpoint:
        try:
            result, path = evaluate_checkpoint(args.checkpoint, protocol, _engine(args.backend), args.impl,
                                               args.object, args.trajectory, progress=not args.quiet,
                                               baseline=args.method)
        except NotSaved as e:  # computed, not saved: printed whole, then the one error line
            print(json.dumps(e.result, indent=1) if args.json else markdown_table(e.result))
            raise
        _err(f"evaluation: {path or 'not written (a packaged run is read, never written)'}")
    else:
        result = evaluate_baseline(args.method, args.object, args.trajectory, protocol, args.backend, args.impl,
                                   progress=not args.quiet)
    print(json.dumps(result, indent=1) if args.json else markdown_table(result))
    return 0


def cmd_envelope(args) -> int:
    paces = parse_floats(args.paces, "--paces", minimum=0.01)
    rows = object_envelope(args.object, args.trajectory, paces, parse_dampings(args.damping), args.backend, args.impl)
    print(json.dumps(rows, indent=1) if args.json else envelope_table(rows))
    if args.plot:
        _err(f"figure: {envelope_figure(rows, args.plot, f'envelope of {Path(args.object).name}')}")
    return 0


def cmd_reproduce(args) -> int:
    seeds = [int(s) for s in parse_floats(args.seeds, "--seeds", minimum=0)]
    config = ReproduceConfig(objects=tuple(args.objects or [str(procedural.default_object())]), seeds=tuple(seeds),
                             epochs=args.epochs, num_envs=args.num_envs, episodes=args.episodes, backend=args.backend,
                             methods=tuple(args.methods.split(",")) if args.methods else None,
                             dampings=None if args.damping is None else tuple(parse_dampings(args.damping)),
                             train_objects=args.train_objects,
                             dataset=args.dataset, holdout=args.holdout, video_every=args.video_every,
                             scaling=tuple(int(n) for n in parse_floats(args.scaling, "--scaling", minimum=1)),
                             modes=tuple(_modes(args.mode)), checkpoint=args.checkpoint_rule, contacts=args.contacts)
    for path in reproduce(args.tables, config, args.out, progress=not args.quiet, run=not args.tables_only):
        print(path.read_text())
        _err(f"table: {path}")
    return 0


def cmd_demo(args) -> int:
    """The main job on the built-in default: trajectory -> the recipe's training -> evaluation x1/x2/x4 -> report."""
    report = run_demo(args.out, args.object, args.trajectory, args.epochs, args.backend, args.seed, args.renderer,
                      args.video_every, args.method, progress=not args.quiet, episodes=args.episodes,
                      overwrite=args.overwrite)
    print(report.read_text())
    _err(f"report: {report}")
    return 0


def cmd_video(args) -> int:
    dampings = _cells(args.damping, args.checkpoint)
    path, used, ck = video_of_run(args.checkpoint, dampings, args.out, args.video_every, _engine(args.backend),
                                  args.impl, args.renderer)
    print(f"{path}: det policy of {ck} at damping {', '.join(f'x{d:g}' for d in dampings)} ({used} renderer)")
    return 0


def cmd_view(args) -> int:
    shown = view_run(args.checkpoint, args.object, args.trajectory, args.damping, args.steps, _engine(args.backend),
                     args.impl)
    _err(f"view: {shown} control steps shown")
    return 0
