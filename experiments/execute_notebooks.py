"""Store the notebooks executed: each run top to bottom by a fresh kernel (nbclient), its outputs saved in place and a
last cell saying where, when and on which commit it ran, and at which budget.

    python experiments/execute_notebooks.py [--tiny NAME ...] [NOTEBOOK ...]

Every notebook runs at its own default budget, except those named after ``--tiny``, which run at the tiny budget the
tests use (``DRAGMESH2_NOTEBOOK_TINY=1``): a notebook whose default is sized for an accelerator, on a CPU.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
#: The first words of the cell this script writes (replaced, not repeated, on the next run).
STAMP = "**Executed**"
TIMEOUT_S = 3600


def machine() -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in Path("/proc/cpuinfo").read_text().splitlines()
                if line.startswith("model name")), platform.processor()) if Path("/proc/cpuinfo").exists() else ""
    return f"{os.cpu_count()} cores of {cpu or platform.machine()}, Python {platform.python_version()}"


def execute(path: Path, tiny: bool) -> float:
    nb = nbformat.read(path, as_version=4)
    nb.cells = [c for c in nb.cells if not (c.cell_type == "markdown" and c.source.startswith(STAMP))]
    env_before = os.environ.get("DRAGMESH2_NOTEBOOK_TINY")
    os.environ["DRAGMESH2_NOTEBOOK_TINY"] = "1" if tiny else "0"
    t0 = time.time()
    try:
        with tempfile.TemporaryDirectory() as where:  # what a notebook writes stays out of the repository
            NotebookClient(nb, timeout=TIMEOUT_S, kernel_name="python3", resources={"metadata": {"path": where}}
                           ).execute()
    finally:
        if env_before is None:
            os.environ.pop("DRAGMESH2_NOTEBOOK_TINY", None)
        else:
            os.environ["DRAGMESH2_NOTEBOOK_TINY"] = env_before
    seconds = time.time() - t0
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                            text=True).stdout.strip()
    budget = "the tiny budget the tests use (DRAGMESH2_NOTEBOOK_TINY=1)" if tiny else "its default budget"
    nb.cells.append(nbformat.v4.new_markdown_cell(
        f"{STAMP} on {machine()}, commit {commit}, {time.strftime('%Y-%m-%d')}, at {budget}: {seconds:.0f} s "
        f"(`python experiments/execute_notebooks.py {' '.join(sys.argv[1:])}`)."))
    nbformat.write(nb, path)
    return seconds


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("notebooks", nargs="*", type=Path, default=NOTEBOOKS)
    ap.add_argument("--tiny", nargs="*", default=[], help="notebook names run at the tests' tiny budget")
    a = ap.parse_args()
    for path in a.notebooks:
        seconds = execute(path, path.stem in a.tiny)
        print(f"{path.name}: {seconds:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
