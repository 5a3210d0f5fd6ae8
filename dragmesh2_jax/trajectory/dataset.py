"""The interaction dataset (paper §3.3, Table 1): one trajectory per object folder, built resumably.

Layout of ``out``:
    trajectories/<sample_id>.json   the trajectory (schema.py)
    records/<sample_id>.json        one record per object: status, quality, timing (what resume reads)
    manifest.csv                    sample_id,object_id,trajectory,enabled + category, joint type, quality
    summary.md                      counts by category (like the paper's Table 1) and every failure explained
"""

from __future__ import annotations

import csv
import io
import json
import time
import traceback
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import PAPER_TABLE1, synthesize_table1
from dragmesh2_jax.assets.urdf import URDF_CANDIDATES
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.progress import LogLines, to_log
from dragmesh2_jax.trajectory.generator import GeneratorParams, generate
from dragmesh2_jax.trajectory.schema import write_trajectory

MANIFEST_COLUMNS = ("sample_id", "object_id", "trajectory", "enabled", "category", "joint_type", "passed",
                    "achieved_opening", "max_penetration_m", "seconds", "reason")


def find_object_folders(paths: list[str | Path]) -> list[Path]:
    """Each path is an object folder (it holds a URDF) or a folder of object folders."""
    found = []
    for p in map(Path, paths):
        if not p.is_dir():
            raise DragMeshError(f"{p}: no such folder")
        if any((p / n).is_file() for n in URDF_CANDIDATES):
            found.append(p)
            continue
        subs = sorted(q for q in p.iterdir() if q.is_dir() and not q.name.startswith("."))
        if not subs:
            raise DragMeshError(f"{p}: neither an object folder nor a folder of object folders")
        found.extend(subs)
    return found


def _sample_ids(folders: list[Path]) -> list[str]:
    seen: Counter = Counter()
    out = []
    for f in folders:
        base = f.name
        seen[base] += 1
        out.append(base if seen[base] == 1 else f"{base}_{seen[base]}")
    return out


@dataclass(frozen=True)
class DatasetResult:
    records: list[dict]
    manifest: Path
    summary: Path

    @property
    def failures(self) -> list[dict]:
        return [r for r in self.records if not r["enabled"]]


def _build_one(folder: Path, sample_id: str, out: Path, params: GeneratorParams) -> dict:
    t0 = time.time()
    rec = {"sample_id": sample_id, "object_id": folder.name, "folder": str(folder), "trajectory": "",
           "enabled": False, "category": "", "joint_type": "", "passed": False, "achieved_opening": "",
           "max_penetration_m": "", "reason": ""}
    try:
        obj = load_gapartnet(folder)
        rec.update(object_id=obj.object_id, category=obj.category,
                   joint_type="revolute" if obj.target.joint.is_revolute else "prismatic")
        traj = generate(obj, params)
        q = traj.header["quality"]
        path = out / "trajectories" / f"{sample_id}.json"
        write_trajectory(traj, path)
        rec.update(trajectory=str(path.relative_to(out)), passed=q["passed"], enabled=q["passed"],
                   achieved_opening=q["achieved_opening"], max_penetration_m=q["max_penetration_m"],
                   reason="; ".join(q["reasons"]))
    except DragMeshError as e:
        rec["reason"] = str(e)
    except Exception as e:  # one object's failure never stops the build
        rec["reason"] = f"{type(e).__name__}: {e}".splitlines()[0]
        rec["traceback"] = traceback.format_exc(limit=3)
    rec["seconds"] = round(time.time() - t0, 3)
    return rec


def build_dataset(objects: list[str | Path], out: str | Path, params: GeneratorParams = GeneratorParams(),
                  progress: bool = True, procedural: int = 0, seed: int = 0) -> DatasetResult:
    """Generate a trajectory for every object folder, and with ``procedural`` that many procedural objects in the
    paper's Table 1 category mix (written under ``out/objects``, seeds from ``seed``); objects already recorded in
    ``out`` are skipped, so an interrupted build resumes."""
    out = Path(out)
    objects = list(objects)
    if procedural:
        objects += synthesize_table1(procedural, seed, out / "objects")
    if not objects:
        raise DragMeshError("no objects given (object folders and/or a number of procedural objects)")
    folders = find_object_folders(objects)
    ids = _sample_ids(folders)
    records = []
    todo = []
    for folder, sid in zip(folders, ids, strict=True):
        rpath = out / "records" / f"{sid}.json"
        if rpath.is_file():
            records.append(json.loads(rpath.read_text()))
        else:
            todo.append((folder, sid, rpath))
    if todo:
        lines = LogLines("dataset build", len(todo), every=max(1, len(todo) // 20), enabled=progress)
        with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
                      disable=not progress or to_log(), transient=False) as bar:
            task = bar.add_task("trajectories", total=len(todo))
            for k, (folder, sid, rpath) in enumerate(todo, 1):
                bar.update(task, description=f"trajectories [{sid}]")
                rec = _build_one(folder, sid, out, params)
                atomic_write_json(rpath, rec)
                records.append(rec)
                bar.advance(task)
                lines(k, f"{k}/{len(todo)} trajectories ({sid}: {'passed' if rec['passed'] else 'failed'})")
    order = {sid: i for i, sid in enumerate(ids)}
    records.sort(key=lambda r: order.get(r["sample_id"], len(order)))
    manifest, summary = write_manifest(records, out), write_summary(records, out)
    return DatasetResult(records, manifest, summary)


def write_manifest(records: list[dict], out: Path) -> Path:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=MANIFEST_COLUMNS, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in records:
        w.writerow({**r, "enabled": int(bool(r["enabled"])), "passed": int(bool(r["passed"]))})
    return atomic_write_text(out / "manifest.csv", buf.getvalue())


def write_summary(records: list[dict], out: Path) -> Path:
    by_cat: dict[str, list[dict]] = defaultdict(list)
    for r in records:
        by_cat[r["category"] or "(unreadable)"].append(r)
    lines = ["# Trajectory dataset", "", "| Category | #Objects | #Traj. (passed) | #Failed | pass rate | s / traj. | "
             "paper (Table 1) |", "|---|---|---|---|---|---|---|"]
    for cat in sorted(by_cat, key=lambda c: -len(by_cat[c])):
        rs = by_cat[cat]
        ok = sum(bool(r["enabled"]) for r in rs)
        secs = sum(float(r.get("seconds", 0)) for r in rs) / len(rs)
        lines.append(f"| {cat} | {len(rs)} | {ok} | {len(rs) - ok} | {ok / len(rs):.2f} | {secs:.2f} | "
                     f"{PAPER_TABLE1.get(cat, '-')} |")
    ok = sum(bool(r["enabled"]) for r in records)
    secs = sum(float(r.get("seconds", 0)) for r in records) / max(len(records), 1)
    lines.append(f"| **Total** | {len(records)} | {ok} | {len(records) - ok} | {ok / max(len(records), 1):.2f} | "
                 f"{secs:.2f} | {sum(PAPER_TABLE1.values())} |")
    fails = [r for r in records if not r["enabled"]]
    lines += ["", f"## Failures ({len(fails)})", ""]
    lines += [f"- `{r['sample_id']}` ({r['folder']}): {r['reason'] or 'failed the quality gate'}" for r in fails]
    if not fails:
        lines.append("None.")
    return atomic_write_text(out / "summary.md", "\n".join(lines) + "\n")
