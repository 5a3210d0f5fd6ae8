"""Per-object tables of evaluated runs: method x mode rows, one column per damping, each cell the mean ± standard
error over seeds with every seed's value (RESULTS.md's layout for the project's own tables).

    python experiments/seed_table.py OUT [OUT ...] [--methods hold,pica_load] [--out table.md] [--title TEXT]

OUT: a ``reproduce`` output folder (its ``runs/<object>/<method>_s<seed>/evaluations/*.json``) or a folder of
evaluation files (as committed under results/). Every evaluation file is read; evaluations of several protocols are
an error (the table would mix them).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np


def load(folders: list[Path]) -> tuple[dict, set]:
    """{object: {(method, mode): {damping: {seed: success}}}} and the protocols seen."""
    table: dict = defaultdict(lambda: defaultdict(lambda: defaultdict(dict)))
    protocols = set()
    for folder in folders:
        runs = (folder / "runs").is_dir()  # a reproduce folder: its own records (main.json, ...) are not evaluations
        for f in sorted(folder.glob("runs/*/*/evaluations/*.json" if runs else "*.json")):
            r = json.loads(f.read_text())
            p = r["protocol"]
            starts = "exact starts" if p["starts"] is None else (f"perturbed starts (bank {p['starts']['bank']}, "
                                                                 f"seed {p['starts']['seed']})")
            protocols.add(f"{p['episodes']} episodes per cell, {starts}, evaluation seed {p['seed']}")
            for c in r["cells"]:
                table[r["object"]][(r["label"], c["mode"])][c["damping"]][r["seed"]] = c["success_rate"]
    return table, protocols


def cell(by_seed: dict) -> str:
    v = np.array([by_seed[s] for s in sorted(by_seed)])
    se = v.std(ddof=1) / np.sqrt(len(v)) if len(v) > 1 else 0.0
    return f"{v.mean():.2f} ± {se:.2f} ({', '.join(f'{x:.2f}' for x in v)})"


def markdown(table: dict, methods: list[str] | None) -> str:
    lines = []
    for obj in sorted(table):
        rows = table[obj]
        dampings = sorted({d for cells in rows.values() for d in cells})
        lines += [f"**{obj}**", "", "| method | mode | " + " | ".join(f"x{d:g}" for d in dampings) + " |",
                  "|---|---|" + "---|" * len(dampings)]
        names = methods or sorted({m for m, _ in rows})
        for m in names:
            for mode in ("det", "stoch"):
                if (m, mode) in rows:
                    cells = rows[(m, mode)]
                    lines.append(f"| {m} | {mode} | " + " | ".join(cell(cells[d]) if d in cells else "-"
                                                                  for d in dampings) + " |")
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--methods", help="rows, in this order (default: every method found)")
    ap.add_argument("--title", default="")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    table, protocols = load(a.folders)
    if not table:
        print(f"error: no evaluations under {', '.join(map(str, a.folders))}", file=sys.stderr)
        return 2
    if len(protocols) > 1:
        print(f"error: evaluations of several protocols ({', '.join(sorted(protocols))})", file=sys.stderr)
        return 2
    text = (f"{a.title}\n\n" if a.title else "") + f"Protocol: {protocols.pop()}\n\n" + markdown(
        table, a.methods.split(",") if a.methods else None)
    if a.out:
        tmp = a.out.with_name(f".{a.out.name}.tmp")
        tmp.write_text(text)
        tmp.replace(a.out)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
