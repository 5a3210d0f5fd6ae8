"""A validation suite of procedural doors chosen by the expert's envelope (issue "Hold on and follow", item 1): doors,
microwaves and refrigerators on which today's expert drag lets go under load as it does on the paper's hardest
unseen doors, and thick handles on heavy doors.

    python experiments/door_suite.py --candidates 12 --seed 100 --out results/suite
    python experiments/door_suite.py --remeasure results/suite/suite.json --object-contact hand --expert-grasp seated \
        --out results/suite/seated_hand.jsonl
    python experiments/door_suite.py --remeasure results/suite/suite.json --object-contact hand --finger-force-limit 2 \
        --out results/suite/planned_hand_f2.jsonl
    python experiments/door_suite.py --remeasure results/suite/suite.json --expert-placement holds \
        --out results/suite/holds_mujoco.jsonl
    python experiments/door_suite.py --remeasure results/suite/suite.json --object-contact hand --finger-force-limit 2 \
        --expert-grasp seated --expert-placement holds --expert-plan-contact mujoco \
        --out results/suite/seat_hand_f2.jsonl
    python experiments/door_suite.py --table results/suite --out results/suite/table.md

Each candidate is a procedural object (``objects synth --category C --count 1 --seed S``) with its trajectory; its
envelope is the expert drag replayed on the C engine from its exact grasp at each pace x damping
(``task.expert.expert_replay``, within the task's episode). The rule, written before the runs:

  * ``lets_go``: not opened at x4 at the expert's own pace and at x8 at no pace (the paper's hardest cabinet door);
  * ``lags``: else not opened at x4 or at x8 at the expert's own pace (only slower, where at all);
  * ``thick_heavy``: a handle at least THICK m thick on a part of at least HEAVY kg (the microwave's 46 mm on 2 kg);
  * the suite: every ``lets_go``, ``lags`` and ``thick_heavy`` candidate whose trajectory passed its gate, then the
    heaviest of the rest, to SIZE objects.

Writes OUT/candidates.jsonl (every candidate: category, seed, mass, handle, gate, envelope, classes) and
OUT/suite.json (the chosen: category, seed and why), read by ``tests/experiments/test_door_suite.py``. With
``--remeasure SUITE`` it writes the suite's envelopes under other object contacts and expert grasp instead (a lever
on the expert, judged on the suite), each cell's peak wrist load and deepest penetration beside it, and at x16 at the
expert's pace (how much load the grasp holds); with ``--table DIR`` the table of the suite's envelopes, today's beside
each remeasured setting (DIR's ``*_*.jsonl``), and the table of what each remeasured setting's grasp holds."""

from __future__ import annotations

import argparse
import json
import tempfile
from dataclasses import replace
from pathlib import Path

from dragmesh2_jax.assets.hand import HandConfig
from dragmesh2_jax.assets.procedural import synthesize
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.runs.build import load_task
from dragmesh2_jax.scene import SceneConfig
from dragmesh2_jax.task.expert import expert_replay

CATEGORIES = ("door_cabinet", "microwave", "refrigerator")
PACES = (0.33, 0.5, 1.0)
DAMPINGS = (1.0, 4.0, 8.0)
#: Beyond the envelope, at the expert's pace only: the load a grasp holds (``remeasure``).
CAPACITY_DAMPINGS = (16.0,)
#: Today's settings remeasured with replays (``--remeasure`` at the defaults): the capacity table's base.
TODAY = "planned_mujoco"
THICK, HEAVY = 0.018, 1.0  # m (world: 46 mm at the paper's scale is 18 mm at the scene's 0.4), kg
SIZE = 24


def cells(capacity: bool = False) -> list[tuple[float, float]]:
    """The envelope's ``(pace, damping)`` cells, with the capacity's beyond it."""
    return [(p, d) for p in PACES for d in DAMPINGS] + ([(1.0, d) for d in CAPACITY_DAMPINGS] if capacity else [])


def replays(task, capacity: bool = False) -> dict[str, dict]:
    """The expert drag at each cell (keys ``"0.5@4"``) within the episode: whether it opens the part, its peak wrist
    load (N) and its deepest hand-object penetration (mm)."""
    out = {}
    for pace, damping in cells(capacity):
        r = expert_replay(task.scene, task.traj, task.config, task.substeps, damping, pace)
        out[f"{pace:g}@{damping:g}"] = {"opened": r.steps is not None, "load_n": round(r.peak_load, 1),
                                        "deepest_mm": round(1000 * r.deepest, 2)}
    return out


def envelope(task) -> dict[str, bool]:
    """Whether the expert drag opens the part at each ``pace x damping`` (keys ``"0.5@4"``) within the episode."""
    return {k: r["opened"] for k, r in replays(task).items()}


def holds(rows: dict) -> tuple[float | None, float | None]:
    """From a remeasured object's replays: the load its grasp held (the peak wrist load of the hardest cell opened at
    the expert's pace) and the load at which it let go (of the easiest cell not opened there); None where none."""
    own = sorted(((float(k.split("@")[1]), r) for k, r in rows.items() if k.startswith("1@")), key=lambda x: x[0])
    held = [r["load_n"] for _, r in own if r["opened"]]
    lost = [r["load_n"] for _, r in own if not r["opened"]]
    return (held[-1] if held else None), (lost[0] if lost else None)


def classes(env: dict[str, bool], mass: float, thickness: float) -> list[str]:
    """The rule's classes of a candidate (the module's text) from its envelope, part mass (kg) and handle (m)."""
    out = []
    if not env["1@4"] and not any(env[f"{p:g}@8"] for p in PACES):
        out.append("lets_go")
    elif not env["1@4"] or not env["1@8"]:
        out.append("lags")
    if thickness >= THICK and mass >= HEAVY:
        out.append("thick_heavy")
    return out


def _opened(env: dict[str, bool]) -> str:
    """x1 / x4 / x8 at the expert's own pace, then at any pace: "yyn/yyy"."""
    yn = lambda b: "y" if b else "n"  # noqa: E731
    own = "".join(yn(env.get(f"1@{d:g}", False)) for d in DAMPINGS)
    return own + "/" + "".join(yn(any(env.get(f"{p:g}@{d:g}", False) for p in PACES)) for d in DAMPINGS)


def table(folder: Path) -> str:
    """Per suite object: its classes, mass and handle, and where the expert opens it (x1/x4/x8 at its own pace, then
    at any pace) today and under each remeasured setting; then how many open at x4 and x8 under each."""
    suite = json.loads((folder / "suite.json").read_text())["objects"]
    today = {(r["category"], r["seed"]): r for r in map(json.loads, (folder / "candidates.jsonl").open())}
    others = {f.stem: {(r["category"], r["seed"]): r for r in map(json.loads, f.open())}
              for f in sorted(folder.glob("*_*.jsonl"))}
    sets = {"today": today, **others}
    lines = ["| object | classes | part [kg] | handle [mm] | " + " | ".join(sets) + " |",
             "|---" * (4 + len(sets)) + "|"]
    for o in suite:
        key = (o["category"], o["seed"])
        cells = [_opened(s[key]["envelope"]) if s[key]["gate"] else "gate fails" for s in sets.values()]
        lines.append(f"| {o['category']} {o['seed']} | {', '.join(o['classes'])} | {o['mass_kg']:.2f} | "
                     f"{1000 * o['handle_thickness_m']:.0f} | " + " | ".join(cells) + " |")
    for d in (4.0, 8.0):
        counts = [sum(bool(s[(o["category"], o["seed"])]["envelope"].get(f"1@{d:g}")) for o in suite)
                  for s in sets.values()]
        lines.append(f"| opened at x{d:g}, own pace | | | | " + " | ".join(f"{c}/{len(suite)}" for c in counts) + " |")
    return "\n".join(lines) + "\n"


def capacity_table(folder: Path) -> str:
    """Per suite object, under each remeasured setting with replays (DIR's ``*_*.jsonl``): the load its grasp held at
    the expert's pace (x1-x16) and the load at which it let go, and the deepest penetration of the cells it opened;
    then the objects whose grasp held twice the load at which today's (``TODAY``, remeasured with replays) let go."""
    suite = json.loads((folder / "suite.json").read_text())["objects"]
    sets = {f.stem: {(r["category"], r["seed"]): r for r in map(json.loads, f.open())}
            for f in sorted(folder.glob("*_*.jsonl"))}
    sets = {k: v for k, v in sets.items() if all("replays" in r for r in v.values())}
    if TODAY not in sets:
        return ""
    sets = {TODAY: sets.pop(TODAY), **sets}
    lines = ["| object | " + " | ".join(sets) + " |", "|---" * (1 + len(sets)) + "|"]
    base = sets[TODAY]
    doubled = dict.fromkeys(sets, 0)
    for o in suite:
        key = (o["category"], o["seed"])
        lost = holds(base[key]["replays"])[1] if base[key]["gate"] else None
        row = []
        for name, s in sets.items():
            if not s[key]["gate"]:
                row.append("gate fails")
                continue
            held, let_go = holds(s[key]["replays"])
            deepest = max((r["deepest_mm"] for r in s[key]["replays"].values() if r["opened"]), default=0.0)
            doubled[name] += bool(lost is not None and held is not None and held >= 2 * lost)
            row.append(f"{held or 0:.0f} / {'-' if let_go is None else f'{let_go:.0f}'} N, {deepest:.1f} mm")
        lines.append(f"| {o['category']} {o['seed']} | " + " | ".join(row) + " |")
    lines.append(f"| held twice the load {TODAY} lets go at | " + " | ".join(f"{doubled[n]}" for n in sets) + " |")
    return "\n".join(lines) + "\n"


def remeasure(objects: list[dict], object_contact: str, expert_grasp: str, expert_placement: str,
              finger_force_limit: float, out: Path, expert_plan_contact: str = "scene") -> None:
    """The envelopes of ``objects`` (a suite's) under ``object_contact``, ``expert_grasp``, ``expert_placement``,
    the finger drives' torque limit and the contacts the expert is planned on (``TaskConfig.expert_plan_contact``),
    with each cell's replay and the capacity's cells, as JSON lines."""
    rows = []
    hand = HandConfig()
    hand = replace(hand, finger=replace(hand.finger, force_limit=finger_force_limit))
    with tempfile.TemporaryDirectory() as tmp:
        for o in objects:
            (folder,) = synthesize(o["category"], 1, o["seed"], Path(tmp) / o["category"])
            scene = SceneConfig(object_contact=object_contact, hand=hand)
            task = load_task(str(folder), None, backend="mujoco", scene_config=scene, expert_grasp=expert_grasp,
                             expert_placement=expert_placement, expert_plan_contact=expert_plan_contact)
            passed = bool(task.traj.header["quality"]["passed"])
            runs = replays(task, capacity=True) if passed else {}
            rows.append({**o, "object_contact": object_contact, "expert_grasp": expert_grasp,
                         "expert_placement": expert_placement, "placement": task.traj.header["generator"]["placement"],
                         "finger_force_limit": finger_force_limit, "expert_plan_contact": expert_plan_contact,
                         "gate": passed,
                         "envelope": {f"{p:g}@{d:g}": runs[f"{p:g}@{d:g}"]["opened"] for p, d in cells()} if passed
                         else {}, "replays": runs})
            print(json.dumps(rows[-1]), flush=True)
    atomic_write_text(out, "".join(json.dumps(r) + "\n" for r in rows))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--candidates", type=int, default=12, help="per category")
    ap.add_argument("--seed", type=int, default=100)
    ap.add_argument("--out", required=True)
    ap.add_argument("--remeasure", help="a suite.json: its objects' envelopes under the settings below")
    ap.add_argument("--table", help="a suite folder: the table of its envelopes")
    ap.add_argument("--object-contact", default="mujoco", choices=("mujoco", "hand"))
    ap.add_argument("--expert-grasp", default="planned", choices=("planned", "seated"))
    ap.add_argument("--expert-placement", default="first", choices=("first", "holds"))
    ap.add_argument("--finger-force-limit", type=float, default=HandConfig().finger.force_limit,
                    help="the finger drives' torque limit (N m)")
    ap.add_argument("--expert-plan-contact", default="scene", choices=("scene", "mujoco"),
                    help="the contacts the expert is planned on: the scene's, or MuJoCo's default (soft) ones")
    args = ap.parse_args()
    if args.table:
        atomic_write_text(args.out, table(Path(args.table)) + "\n" + capacity_table(Path(args.table)))
        return
    if args.remeasure:
        remeasure(json.loads(Path(args.remeasure).read_text())["objects"], args.object_contact, args.expert_grasp,
                  args.expert_placement, args.finger_force_limit, Path(args.out), args.expert_plan_contact)
        return
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for category in CATEGORIES:
            for folder in synthesize(category, args.candidates, args.seed, Path(tmp) / category):
                task = load_task(str(folder), None, backend="mujoco")
                mass, thickness = task.scene.stats["target_mass_kg"], float(task.scene.handle.thickness)
                passed = bool(task.traj.header["quality"]["passed"])
                env = envelope(task) if passed else {}
                rows.append({"category": category, "seed": int(folder.name.rsplit("_", 1)[1]), "mass_kg": mass,
                             "handle_thickness_m": round(thickness, 4), "gate": passed, "envelope": env,
                             "classes": classes(env, mass, thickness) if passed else []})
                print(json.dumps(rows[-1]), flush=True)
    atomic_write_text(out / "candidates.jsonl", "".join(json.dumps(r) + "\n" for r in rows))
    chosen = [r for r in rows if r["gate"] and r["classes"]]
    rest = sorted((r for r in rows if r["gate"] and not r["classes"]), key=lambda r: -r["mass_kg"])
    suite = (chosen + rest)[:max(SIZE, len(chosen))]
    atomic_write_json(out / "suite.json", {
        "rule": {"paces": PACES, "dampings": DAMPINGS, "thick_m": THICK, "heavy_kg": HEAVY, "size": SIZE},
        "objects": [{k: r[k] for k in ("category", "seed", "mass_kg", "handle_thickness_m", "classes")}
                    for r in suite]})


if __name__ == "__main__":
    main()
