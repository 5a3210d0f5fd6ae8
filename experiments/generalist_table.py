"""The generalist table (issue 36): generalist runs (one per seed), each evaluated zero-shot on the shared objects
(``dragmesh2 evaluate --checkpoint RUN --object ../shared/gapartnet/OID --damping 1,2,4,8 --episodes 20``), read
back from the runs' evaluation files: per object and mode, each damping's success as the mean ± standard error over
seeds with every seed's value; the four objects' average per seed, the same way; the physical figures (means over
seeds); and the issue's target checked (det >= 0.85 at x1 and >= 0.70 at x4 averaged, every object >= 0.5 at x4).

    python experiments/generalist_table.py runs/generalist_s0 runs/generalist_s1 runs/generalist_s2 [--out T.md] \
        [--finetuned FT]

Every run must hold the same protocol's evaluation of its policy checkpoint on every object (else one error line).
``--finetuned FT``: the fine-tuned rows too, from ``experiments/generalist_finetune.sh FT``'s evaluations
(``FT/ft_<object>_s<seed>.json``; the seeds found on every object), laid out alike.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

OBJECTS = ("45261", "45661", "45780", "11712")  # tuning (45261, 45661) and validation (45780, 11712)
TARGET_X1, TARGET_X4, TARGET_EACH_X4 = 0.85, 0.70, 0.5
FIGURES = (("wrist_load_peak_n", "wrist load p95 [N]", "{:.0f}"), ("palm_speed_peak_m_s", "palm p95 [m/s]", "{:.2f}"),
           ("steps_mean", "steps", "{:.0f}"), ("detach_rate", "detach", "{:.2f}"),
           ("clip099_active", "clip099 active", "{:.2f}"), ("penetration_max_mm", "penetration [mm]", "{:.1f}"))


def load(run: Path, objects: tuple[str, ...], checkpoint: str = "final") -> tuple[dict, str]:
    """{object: {(mode, damping): cell}} of ``run``'s zero-shot evaluation of ``checkpoint`` per object (the
    latest, where several protocols were run), and its protocol."""
    found, protocols = {}, set()
    for oid in objects:
        files = sorted((run / "evaluations").glob(f"{checkpoint}__*__on-{oid}.json"), key=lambda p: p.stat().st_mtime)
        if not files:
            raise ValueError(f"{run}: no zero-shot evaluation of {checkpoint} on {oid}")
        r = json.loads(files[-1].read_text())
        protocols.add(json.dumps(r["protocol"], sort_keys=True))
        found[oid] = {(c["mode"], c["damping"]): c for c in r["cells"]}
    if len(protocols) > 1:
        raise ValueError(f"{run}: evaluations of several protocols")
    return found, protocols.pop()


def load_finetuned(folder: Path, objects: tuple[str, ...]) -> list[dict]:
    """One ``{object: {(mode, damping): cell}}`` per seed that was fine-tuned on every object (its evaluations)."""
    seeds = [sorted(int(f.stem.rsplit("_s", 1)[1]) for f in folder.glob(f"ft_{oid}_s*.json")) for oid in objects]
    common = sorted(set(seeds[0]).intersection(*seeds[1:]))
    if not common:
        raise ValueError(f"{folder}: no seed fine-tuned on every one of {', '.join(objects)}")
    found = [{oid: json.loads((folder / f"ft_{oid}_s{seed}.json").read_text()) for oid in objects} for seed in common]
    if len({json.dumps(r.get("protocol"), sort_keys=True) for seed in found for r in seed.values()}) > 1:
        raise ValueError(f"{folder}: fine-tunes evaluated under several protocols")
    return [{oid: {(c["mode"], c["damping"]): c for c in r["cells"]} for oid, r in seed.items()} for seed in found]


def cell(values) -> str:
    v = np.asarray(values, float)
    se = v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0
    return f"{v.mean():.2f} ± {se:.2f} ({', '.join(f'{x:.2f}' for x in v)})"


def table(runs: list[dict], objects: tuple[str, ...]) -> str:
    """The markdown of ``runs`` (each ``load``'s first value, one per seed)."""
    keys = sorted(runs[0][objects[0]], key=lambda k: (k[0], k[1]))
    dampings = sorted({d for _, d in keys})
    modes = sorted({m for m, _ in keys})
    head = " | ".join(f"x{d:g}" for d in dampings)
    lines = [f"| object | mode | {head} |", "|---|---|" + "---|" * len(dampings)]
    for oid in (*objects, "average"):
        for mode in modes:
            per = [[np.mean([r[o][(mode, d)]["success_rate"] for o in objects]) if oid == "average"
                    else r[oid][(mode, d)]["success_rate"] for r in runs] for d in dampings]
            lines.append(f"| {oid} | {mode} | " + " | ".join(cell(v) for v in per) + " |")
    lines += ["", f"Physical figures, det, {' / '.join(f'x{d:g}' for d in dampings)} (means over seeds):", "",
              "| object | " + " | ".join(name for _, name, _ in FIGURES) + " |", "|---|" + "---|" * len(FIGURES)]
    for oid in objects:
        lines.append(f"| {oid} | " + " | ".join(" / ".join(fmt.format(np.mean(
            [r[oid][("det", d)][key] for r in runs])) for d in dampings) for key, _, fmt in FIGURES) + " |")
    return "\n".join(lines) + "\n"


def target(runs: list[dict], objects: tuple[str, ...]) -> str:
    """Whether the det means over seeds meet the issue's target."""
    mean = {(o, d): np.mean([r[o][("det", d)]["success_rate"] for r in runs]) for o in objects for d in (1.0, 4.0)}
    x1, x4 = np.mean([mean[o, 1.0] for o in objects]), np.mean([mean[o, 4.0] for o in objects])
    low = min(objects, key=lambda o: mean[o, 4.0])
    ok = x1 >= TARGET_X1 and x4 >= TARGET_X4 and mean[low, 4.0] >= TARGET_EACH_X4
    return (f"Target (det, means over {len(runs)} seeds): x1 {x1:.2f} (>= {TARGET_X1}), x4 {x4:.2f} (>= {TARGET_X4}), "
            f"lowest object at x4 {low} {mean[low, 4.0]:.2f} (>= {TARGET_EACH_X4}): {'met' if ok else 'not met'}\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--finetuned", type=Path)
    a = ap.parse_args(argv)
    try:
        loaded = [load(r, OBJECTS) for r in a.runs]
        finetuned = load_finetuned(a.finetuned, OBJECTS) if a.finetuned else None
    except (ValueError, KeyError, OSError, json.JSONDecodeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if len({p for _, p in loaded}) > 1:
        print("error: the runs were evaluated under different protocols", file=sys.stderr)
        return 2
    runs = [r for r, _ in loaded]
    text = table(runs, OBJECTS) + "\n" + target(runs, OBJECTS)
    if finetuned:
        text += f"\nFine-tuned 20 epochs on each object ({len(finetuned)} seeds):\n\n" + table(finetuned, OBJECTS)
    if a.out:
        a.out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
