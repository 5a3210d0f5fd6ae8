"""``dragmesh2``: the command-line entry point. Each subcommand is a thin shell over library functions.

Errors in input or configuration print one line ``error: ...`` and exit with status 2 (no traceback).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from dragmesh2_jax.errors import DragMeshError


def _scene_config(args):
    from dragmesh2_jax.scene import SceneConfig

    return SceneConfig(scale=args.scale, collide=args.collide)


def _add_scene_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scale", type=float, default=0.4, help="object scale (default 0.4, as the reference)")
    p.add_argument("--collide", choices=["target", "all"], default="target",
                   help="object pieces that collide with the hand (default: target part near the handle)")


def cmd_inspect(args) -> int:
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.scene import build_scene

    obj = load_gapartnet(args.folder)
    scene = build_scene(obj, _scene_config(args))
    info = obj.summary()
    info["scene"] = scene.stats
    info["handle_world"] = {"centre": [round(float(x), 5) for x in scene.handle.centre],
                            "thickness_m": round(scene.handle.thickness, 5)}
    if args.render:
        from dragmesh2_jax.render import render_png

        d = scene.initial_data()
        info["render"] = {"path": str(args.render),
                          "renderer": render_png(scene.model, d, args.render, target=scene.handle.centre)}
    if args.json:
        print(json.dumps(info, indent=2))
        return 0
    t, h = info["target_joint"], info["handle"]
    print(f"object        {info['object_id']} ({info['category']})  {info['folder']}")
    print(f"target part   {info['target_part']['link']} [{info['target_part']['category']}]")
    print(f"target joint  {t['name']} {t['type']} axis {t['axis']} origin {t['origin']} range {t['range']}")
    print(f"handle        {h['source']} {h['link']} centre {h['centre']} normal {h['normal']} long {h['long_axis']}")
    print(f"              thickness {h['thickness']} width {h['width']} length {h['length']} (object units)")
    s = scene.stats
    print(f"collision     {s['collision_pieces']} colliding pieces of {s['pieces']}, largest hull "
          f"{s['max_hull_vertices']} vertices, {s['contact_pairs']} hand-object geom pairs")
    print(f"model         nq {s['nq']} nv {s['nv']} nu {s['nu']} ngeom {s['ngeom']}, target part "
          f"{s['target_mass_kg']} kg")
    if args.render:
        print(f"picture       {info['render']['path']} ({info['render']['renderer']} renderer)")
    return 0


def cmd_objects(args) -> int:
    from dragmesh2_jax.assets import procedural

    if args.objects_cmd == "synth":
        cats = list(procedural.CATEGORIES) if args.category == "all" else [args.category]
        for c in cats:
            if c not in procedural.CATEGORIES:
                raise DragMeshError(f"unknown category {c!r} (choose from all, {', '.join(procedural.CATEGORIES)})")
        paths = [p for c in cats for p in procedural.synthesize(c, args.count, args.seed, args.out)]
        for p in paths:
            print(p)
        print(f"{len(paths)} objects in {args.out}", file=sys.stderr)
    else:
        print("categories:", ", ".join(procedural.CATEGORIES))
        for p in sorted(procedural.default_objects_dir().iterdir()):
            if p.is_dir():
                print(p)
    return 0


def cmd_demo(args) -> int:
    """The main job on the built-in default: inspect, place the hand at the handle, a short rollout, a picture."""
    import mujoco

    from dragmesh2_jax.assets.gapartnet import load_gapartnet, opening_direction
    from dragmesh2_jax.assets.procedural import default_object
    from dragmesh2_jax.io import atomic_write_json
    from dragmesh2_jax.render import render_png
    from dragmesh2_jax.scene import SceneConfig, build_scene
    from dragmesh2_jax.trajectory import grasp

    out = Path(args.out)
    folder = Path(args.object) if args.object else default_object()
    t0 = time.time()
    obj = load_gapartnet(folder)
    scene = build_scene(obj, SceneConfig())
    h, ids, m = scene.handle, scene.ids, scene.model
    open_dir = opening_direction(obj.target.part, obj.target.joint, obj.target.handle.centre)
    R = grasp.wrist_orientation(h, open_dir)
    wrist = grasp.wrist_position(grasp.palm_target(h, R), R)
    q_grasp = grasp.hand_q(wrist, R, grasp.grasp_pose(h.thickness))
    q_pre = grasp.hand_q(wrist + 0.08 * h.normal, R, grasp.open_pose())
    d = scene.initial_data()
    d.qpos[ids.hand_qpos] = q_pre
    d.ctrl[ids.hand_actuators] = q_pre
    mujoco.mj_forward(m, d)
    n = int(round(1.5 / m.opt.timestep))
    for k in range(n):  # approach over 0.75 s, then close the fingers
        a = min(1.0, 2 * k / n)
        target = q_pre + a * (np.r_[q_grasp[:6], q_pre[6:]] - q_pre)
        if a >= 1.0:
            target = q_grasp
        d.ctrl[ids.hand_actuators] = np.clip(target, ids.hand_range[:, 0], ids.hand_range[:, 1])
        mujoco.mj_step(m, d)
    palm = d.site_xpos[ids.palm_site]
    result = {
        "object": obj.summary(), "scene": scene.stats,
        "rollout": {"seconds": 1.5, "finite": bool(np.isfinite(d.qpos).all()),
                    "palm_handle_distance_m": round(float(np.linalg.norm(palm - d.site_xpos[ids.handle_site])), 4),
                    "target_q": round(float(d.qpos[ids.target_qpos]), 5), "ncon": int(d.ncon)},
    }
    result["picture"] = {"path": str(out / "scene.png"),
                         "renderer": render_png(m, d, out / "scene.png", target=h.centre)}
    result["wall_s"] = round(time.time() - t0, 2)
    atomic_write_json(out / "demo.json", result)
    print(json.dumps(result["rollout"]), file=sys.stderr)
    print(f"demo: {obj.object_id} ({obj.category}); hand placed at the handle and closed; "
          f"picture {result['picture']['path']} ({result['picture']['renderer']}); summary {out / 'demo.json'}")
    return 0


def cmd_trajectory(args) -> int:
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import write_trajectory

    if args.render and not args.render.endswith(".gif"):
        raise DragMeshError(f"{args.render}: only .gif videos are supported")
    obj = load_gapartnet(args.object)
    traj = generate(obj, seed=args.seed)
    write_trajectory(traj, args.out)
    q = traj.header["quality"]
    blocks = ", ".join(f"{p} {b - a}" for p, a, b in traj.phase_blocks())
    print(f"{args.out}: {len(traj.frames)} frames ({blocks}); target {traj.header['target']['joint_name']} "
          f"{traj.header['target']['type']}; q_start {traj.q_start:.4f} q_done {traj.q_done:.4f} "
          f"q_max {traj.q_max:.4f}; quality {'PASSED' if q['passed'] else 'FAILED: ' + '; '.join(q['reasons'])}")
    if args.render:
        from dragmesh2_jax.render import render_trajectory_gif

        used = render_trajectory_gif(obj, traj, args.render)
        print(f"video {args.render} ({used} renderer)")
    return 0 if q["passed"] else 1


def cmd_dataset(args) -> int:
    from dragmesh2_jax.trajectory.dataset import build_dataset

    res = build_dataset(args.objects, args.out, seed=args.seed, progress=not args.quiet)
    print(Path(res.summary).read_text())
    print(f"manifest {res.manifest}; {len(res.records) - len(res.failures)} of {len(res.records)} passed")
    return 0


def _floats_arg(text: str, what: str) -> list[float]:
    try:
        vals = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise DragMeshError(f"{what}: expected comma-separated numbers, got {text!r}") from None
    if not vals:
        raise DragMeshError(f"{what}: no values given")
    return vals


def load_task(object_dir: str, trajectory: str | None, backend: str = "auto", impl: str = "jax", **overrides):
    """Object + trajectory (generated when not given) -> PullTask."""
    from dragmesh2_jax.assets.gapartnet import load_gapartnet
    from dragmesh2_jax.scene import build_scene
    from dragmesh2_jax.task.config import TaskConfig
    from dragmesh2_jax.task.env import PullTask
    from dragmesh2_jax.trajectory.generator import generate
    from dragmesh2_jax.trajectory.schema import read_trajectory

    config = TaskConfig(backend=backend, impl=impl, **overrides)  # validated before anything compiles
    obj = load_gapartnet(object_dir)
    scene = build_scene(obj)
    traj = read_trajectory(trajectory) if trajectory else generate(obj, scene=scene)
    return PullTask(scene, traj, config)


def cmd_track(args) -> int:
    from dragmesh2_jax.baselines.tracking import track

    dampings = _floats_arg(args.damping, "--damping")
    task = load_task(args.object, args.trajectory, args.backend, args.impl)
    rows = track(task, dampings, seed=args.seed)
    if args.json:
        print(json.dumps({"object_id": task.scene.obj.object_id, "backend": task.backend.name, "results": rows}))
        return 0
    print(f"tracking baseline on {task.scene.obj.object_id} ({task.backend.name} backend); "
          f"q_start {task.traj.q_start:.4f}, q_done {task.traj.q_done:.4f}")
    print("| damping | success | final progress |\n|---|---|---|")
    for r in rows:
        print(f"| x{r['damping']:g} | {int(r['success'])} | {r['final_progress']:.3f} |")
    return 0


def _add_backend_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--backend", default="auto", help="mjx | mujoco | auto (MJX on an accelerator, C on a CPU)")
    p.add_argument("--impl", default="jax", help="MJX implementation: jax | warp")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="dragmesh2", description="DragMesh-2 in JAX/MuJoCo-MJX")
    sub = p.add_subparsers(dest="cmd", required=True)

    pi = sub.add_parser("inspect", help="describe a GAPartNet object folder: target, joint, handle, collision")
    pi.add_argument("folder")
    pi.add_argument("--json", action="store_true", help="machine-readable output")
    pi.add_argument("--render", metavar="FILE.png", help="write a picture of hand + object")
    _add_scene_args(pi)
    pi.set_defaults(func=cmd_inspect)

    po = sub.add_parser("objects", help="procedural GAPartNet-format objects")
    osub = po.add_subparsers(dest="objects_cmd", required=True)
    ps = osub.add_parser("synth", help="write procedural objects")
    ps.add_argument("--category", required=True, help="a category or 'all'")
    ps.add_argument("--count", type=int, default=1)
    ps.add_argument("--seed", type=int, default=0)
    ps.add_argument("--out", required=True)
    osub.add_parser("list", help="categories and the packaged default objects")
    po.set_defaults(func=cmd_objects)

    pt = sub.add_parser("trajectory", help="generate one reference trajectory (exit 1 if it fails the gate)")
    pt.add_argument("--object", required=True)
    pt.add_argument("--out", required=True)
    pt.add_argument("--seed", type=int, default=0)
    pt.add_argument("--render", metavar="FILE.gif", help="write a video of the executed trajectory")
    pt.set_defaults(func=cmd_trajectory)

    pds = sub.add_parser("dataset", help="trajectory datasets")
    dsub = pds.add_subparsers(dest="dataset_cmd", required=True)
    pb = dsub.add_parser("build", help="one trajectory per object folder; resumable")
    pb.add_argument("--objects", nargs="+", required=True, help="object folders or folders of object folders")
    pb.add_argument("--out", required=True)
    pb.add_argument("--seed", type=int, default=0)
    pb.add_argument("--quiet", action="store_true")
    pds.set_defaults(func=cmd_dataset)

    pk = sub.add_parser("track", help="trajectory-tracking baseline: success per damping multiplier")
    pk.add_argument("--object", required=True)
    pk.add_argument("--trajectory", help="trajectory file (default: generate one)")
    pk.add_argument("--damping", default="1,2,4")
    pk.add_argument("--seed", type=int, default=0)
    pk.add_argument("--json", action="store_true")
    _add_backend_args(pk)
    pk.set_defaults(func=cmd_track)

    pd = sub.add_parser("demo", help="the main job on the built-in default object")
    pd.add_argument("--object", help="object folder (default: the packaged drawer cabinet)")
    pd.add_argument("--out", default="out/demo")
    pd.set_defaults(func=cmd_demo)
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except DragMeshError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
