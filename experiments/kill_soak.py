"""A training killed with SIGKILL at random moments and resumed each time ends exactly where an uninterrupted one does.

Two runs of the same command (the generalist's method and network over several objects of different categories, a
smaller batch so that a CPU runs it in minutes): ``reference`` uninterrupted, ``killed`` killed ``--kills`` times at
moments drawn uniformly in ``[--min-s, --max-s]`` after each (re)start and resumed with ``--resume`` each time (the
same command without it while no checkpoint exists yet); every other kill waits, after its drawn moment, for a
checkpoint write to begin (its unfinished copy beside the checkpoints, polled every millisecond) and lands inside
it. A kill that lands during a write leaves that copy behind; those are counted. Then the final checkpoints are
compared file by file and the logs row by row, wall-clock columns aside.

    python experiments/kill_soak.py OUT [--epochs 500] [--kills 12] [--seed 0] [--save-every 2]

Writes ``OUT/soak.json`` and ``OUT/soak.md``; exit 1 when the runs differ.
"""

from __future__ import annotations

import argparse
import random
import subprocess
import sys
import time
from pathlib import Path

from dragmesh2_jax.assets.procedural import default_objects
from dragmesh2_jax.io import atomic_write_json, atomic_write_text
from dragmesh2_jax.ppo.checkpoint import ENV, LEARNER
from dragmesh2_jax.runs.rundir import RunDir

#: Columns of the log that read the wall clock (they differ between any two runs).
CLOCK = ("seconds",)


def command(out: Path, epochs: int, save_every: int, resume: bool) -> list[str]:
    cmd = [sys.executable, "-m", "dragmesh2_jax.cli", "train", "--out", str(out), "--quiet"]
    if resume:
        return [*cmd, "--resume"]
    return [*cmd, "--method", "generalist", "--objects", *map(str, default_objects()), "--backend", "mujoco",
            "--epochs", str(epochs), "--num-envs", "16", "--ppo.rollout-len", "16", "--save-every", str(save_every),
            "--robust-every", "50", "--robust-episodes", "4"]


def writing(run: Path, proc: subprocess.Popen, limit_s: float = 60.0) -> None:
    """Return once a checkpoint write has begun in ``run`` (its unfinished copy exists), the process has ended, or
    ``limit_s`` has passed."""
    end = time.time() + limit_s
    while time.time() < end and proc.poll() is None and not any(n.endswith(".tmp") for n in leftovers(run)):
        time.sleep(0.001)


def leftovers(run: Path) -> list[str]:
    return sorted(p.name for p in (run / "checkpoints").glob(".*")) if (run / "checkpoints").is_dir() else []


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--epochs", type=int, default=500)
    ap.add_argument("--kills", type=int, default=12)
    ap.add_argument("--min-s", type=float, default=5.0)
    ap.add_argument("--max-s", type=float, default=45.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--save-every", type=int, default=2, help="epochs between checkpoints (often: kills land in "
                                                              "writes)")
    a = ap.parse_args()
    rng = random.Random(a.seed)
    reference, killed = a.out / "reference", a.out / "killed"
    t0 = time.time()
    if not RunDir(reference).has_checkpoint("final"):
        subprocess.run(command(reference, a.epochs, a.save_every, RunDir(reference).exists()), check=True)
    reference_s = time.time() - t0
    kills = []
    t0 = time.time()
    while len(kills) < a.kills and not RunDir(killed).has_checkpoint("final"):
        delay = rng.uniform(a.min_s, a.max_s)
        proc = subprocess.Popen(command(killed, a.epochs, a.save_every, RunDir(killed).exists()),
                                stderr=subprocess.PIPE, text=True)
        in_write = len(kills) % 2 == 1
        try:
            if proc.wait(timeout=delay) == 0:
                break  # it finished before this kill
            raise SystemExit(f"the run failed ({proc.returncode}): {proc.stderr.read()[-2000:]}")
        except subprocess.TimeoutExpired:
            if in_write:
                writing(killed, proc)
            proc.kill()
            proc.wait()
        rows = RunDir(killed).log_rows() if (killed / "log.jsonl").exists() else []
        saved = sorted(RunDir(killed).epoch_checkpoints())[-1:] if RunDir(killed).exists() else []
        kills.append({"after_s": round(delay, 2), "aimed_at_a_write": in_write,
                      "logged_epoch": rows[-1]["epoch"] if rows else 0, "checkpoints": saved,
                      "left_beside": leftovers(killed)})
        print(f"kill {len(kills)}: after {delay:.1f} s, logged epoch {kills[-1]['logged_epoch']}, "
              f"left {kills[-1]['left_beside']}", file=sys.stderr)
    done = subprocess.run(command(killed, a.epochs, a.save_every, True), capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"the last resume failed: {done.stderr[-2000:]}")
    killed_s = time.time() - t0
    same_files = {f: (reference / "checkpoints" / "final" / f).read_bytes() ==
                  (killed / "checkpoints" / "final" / f).read_bytes() for f in (LEARNER, ENV)}
    strip = lambda rows: [{k: v for k, v in r.items() if k not in CLOCK} for r in rows]  # noqa: E731
    ref_rows, killed_rows = RunDir(reference).log_rows(), RunDir(killed).log_rows()
    differ = [r["epoch"] for r, k in zip(strip(ref_rows), strip(killed_rows), strict=False) if r != k]
    result = {"epochs": a.epochs, "kills": kills, "seed": a.seed, "objects": [p.name for p in default_objects()],
              "final_checkpoint_identical": same_files, "log_rows": [len(ref_rows), len(killed_rows)],
              "log_rows_differing": differ, "reference_s": round(reference_s), "killed_s": round(killed_s),
              "during_a_write": sum(bool(k["left_beside"]) for k in kills)}
    ok = all(same_files.values()) and not differ and len(ref_rows) == len(killed_rows) == a.epochs
    result["identical"] = ok
    atomic_write_json(a.out / "soak.json", result)
    lines = [f"# Kill soak: {a.epochs} epochs, {len(kills)} SIGKILLs, resumed each time", "",
             f"- objects: {', '.join(result['objects'])}; method generalist (its network), 16 worlds x 16 steps, "
             f"a checkpoint every {a.save_every} epochs, robustness checks every 50", "",
             "| kill | after (s) | logged epoch | newest epoch checkpoint | left beside the checkpoints |",
             "|---|---|---|---|---|"]
    lines += [f"| {i} | {k['after_s']}{' then at a write' if k['aimed_at_a_write'] else ''} | {k['logged_epoch']} | "
              f"{k['checkpoints']} | {', '.join(k['left_beside']) or '-'} |" for i, k in enumerate(kills, 1)]
    lines += ["", f"- kills during a checkpoint write (an unfinished copy left beside): {result['during_a_write']}",
              f"- final checkpoint byte-identical to the uninterrupted run's: {same_files}",
              f"- log rows: {len(ref_rows)} and {len(killed_rows)}; rows that differ (wall clock aside): "
              f"{differ or 'none'}",
              f"- wall time: uninterrupted {result['reference_s']} s, killed and resumed {result['killed_s']} s",
              f"- verdict: {'identical' if ok else 'DIFFERENT'}"]
    atomic_write_text(a.out / "soak.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
