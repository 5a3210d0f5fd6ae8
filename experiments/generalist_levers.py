"""The generalist's levers in one table (issue 36 item 3): checkpoints of generalist runs at one budget, named
``ARM_sSEED``, each zero-shot on a held-out procedural test set (``--per-category`` objects of every category from
seed ``TEST_SEED``: no run trained on them, nor held them aside) and on the four shared objects, deterministic.

    python experiments/generalist_levers.py OUT ppo_s0=runs/generalist_s0/checkpoints/epoch_1000 \\
        curriculum_s0=runs/gcur_s0/checkpoints/epoch_1000 ... [--damping 1,4] [--episodes 10] [--per-category 2]

Builds the test set into ``OUT/test`` and the shared objects' trajectories into ``OUT/shared`` (resumable), evaluates
every policy on every object (only reading its checkpoint: a run still training is not disturbed), writes
``OUT/levers.json`` after each object (a rerun goes on where it stopped) and ``OUT/levers.md``: per arm, the mean
over the test set and over the shared objects at each damping, mean ± standard error over seeds with every seed's
value; then the shared objects one by one and the test set by category (means over seeds).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.evaluation.evaluate import evaluate
from dragmesh2_jax.evaluation.protocol import PAPER, EvalProtocol
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.runs.commands import dataset_objects, load_run
from dragmesh2_jax.trajectory.dataset import build_dataset

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "gapartnet"
SHARED_OBJECTS = ("45261", "45661", "45780", "11712")  # tuning (45261, 45661) and validation (45780, 11712)
#: The test set's first seed: the generalist's mix starts at procedural.GENERALIST_SEED (2000), reproduce's at 1000.
TEST_SEED = 3000


def test_objects(out: Path, per_category: int) -> list[tuple[str, str, str]]:
    """(object folder, trajectory, kind) of the test set and the shared objects whose trajectory passed its gate."""
    objects = procedural.synthesize_mix({c: per_category for c in procedural.CATEGORIES}, TEST_SEED,
                                        out / "test" / "objects")
    build_dataset(objects, out / "test", progress=False)
    build_dataset([SHARED / o for o in SHARED_OBJECTS], out / "shared", progress=False)
    return [(o, t, kind) for kind in ("test", "shared") for o, t in zip(*dataset_objects(out / kind), strict=True)]


def evaluate_policy(checkpoint: str, obj: str, traj: str, protocol: EvalProtocol) -> list[dict]:
    """The policy of ``checkpoint`` zero-shot on ``obj``: the protocol's cells."""
    program, ts, _, _ = load_run(checkpoint, "mujoco", object_dir=obj, trajectory=traj)
    return evaluate(protocol.task(program.task), program.controller(ts), protocol)["cells"]


def rates(cells: list[dict], dampings: tuple[float, ...]) -> list[float]:
    by = {c["damping"]: c["success_rate"] for c in cells}
    return [by[d] for d in dampings]


def cell(values: list[float]) -> str:
    v = np.asarray(values)
    se = v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0
    return f"{v.mean():.2f} ± {se:.2f} ({', '.join(f'{x:.2f}' for x in v)})"


def table(rows: dict, kinds: dict, dampings: tuple[float, ...]) -> str:
    """The markdown of ``rows`` ({policy: {object: cells}}) by arm (the policy's name before ``_s``)."""
    arms: dict = defaultdict(dict)
    for name, objects in rows.items():
        arm, seed = name.rsplit("_s", 1)
        arms[arm][seed] = {o: rates(c, dampings) for o, c in objects.items() if o in kinds}
    head = " / ".join(f"x{d:g}" for d in dampings)
    lines = ["| arm | seeds | " + " | ".join(f"{kind} x{d:g}" for kind in ("test set", "shared objects")
                                            for d in dampings) + " |", "|---|---|" + "---|" * 2 * len(dampings)]
    for arm, seeds in arms.items():
        cols = []
        for kind in ("test", "shared"):
            for i in range(len(dampings)):
                cols.append(cell([np.mean([r[i] for o, r in objs.items() if kinds[o] == kind])
                                  for objs in seeds.values()]))
        lines.append(f"| {arm} | {len(seeds)} | " + " | ".join(cols) + " |")
    lines += ["", f"Shared objects, {head}, mean ± SE over seeds (every seed):", "",
              "| arm | " + " | ".join(SHARED_OBJECTS) + " |", "|---|" + "---|" * len(SHARED_OBJECTS)]
    for arm, seeds in arms.items():
        lines.append(f"| {arm} | " + " | ".join(
            " / ".join(cell([objs[o][i] for objs in seeds.values()]) for i in range(len(dampings)))
            for o in SHARED_OBJECTS) + " |")
    categories = sorted({procedural.category_of(o) for o, k in kinds.items() if k == "test"})
    lines += ["", f"Test set by category, {head}, the mean over its objects and seeds:", "",
              "| arm | " + " | ".join(categories) + " |", "|---|" + "---|" * len(categories)]
    for arm, seeds in arms.items():
        lines.append(f"| {arm} | " + " | ".join(" / ".join(
            f"{np.mean([r[i] for objs in seeds.values() for o, r in objs.items() if kinds[o] == 'test' and procedural.category_of(o) == c]):.2f}"  # noqa: E501
            for i in range(len(dampings))) for c in categories) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("policies", nargs="+", help="ARM_sSEED=CHECKPOINT")
    p.add_argument("--damping", default="1,4")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--per-category", type=int, default=2)
    args = p.parse_args()
    protocol = dataclasses.replace(PAPER, dampings=tuple(float(d) for d in args.damping.split(",")),
                                   modes=("det",), episodes=args.episodes)
    objects = test_objects(args.out, args.per_category)
    kinds = {Path(o).name: kind for o, _, kind in objects}
    dest = args.out / "levers.json"
    saved = json.loads(dest.read_text()) if dest.is_file() else {}
    if saved and saved["protocol"] != protocol.name:
        raise SystemExit(f"error: {dest} holds another protocol ({saved['protocol']}); use another OUT")
    rows = saved.get("policies", {})
    policies = {}
    for arg in args.policies:
        name, sep, checkpoint = arg.partition("=")
        if not sep or "_s" not in name or not name.rsplit("_s", 1)[1].isdigit():
            raise SystemExit(f"error: {arg!r}: a policy is ARM_sSEED=CHECKPOINT")
        if saved.get("checkpoints", {}).get(name, checkpoint) != checkpoint:
            raise SystemExit(f"error: {name} was evaluated from {saved['checkpoints'][name]} in {dest}, not "
                             f"{checkpoint}")
        policies[name] = checkpoint
    checkpoints = saved.get("checkpoints", {}) | policies
    for name, checkpoint in policies.items():
        done = rows.setdefault(name, {})
        for obj, traj, _ in objects:
            if Path(obj).name not in done:
                done[Path(obj).name] = evaluate_policy(checkpoint, obj, traj, protocol)
                atomic_write_json(dest, {"protocol": protocol.name, "checkpoints": checkpoints, "policies": rows})
        print(name, " ".join(f"x{d:g} {np.mean([rates(c, protocol.dampings)[i] for c in done.values()]):.2f}"
                             for i, d in enumerate(protocol.dampings)), flush=True)
    text = table({n: rows[n] for n in policies}, kinds, protocol.dampings)
    atomic_write_text(args.out / "levers.md", f"Protocol: {protocol.name}\n\n{text}")
    print(text)


if __name__ == "__main__":
    main()
