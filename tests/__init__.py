"""The test suite. Imported before any conftest, so XLA's flags for the tests are set before JAX starts a backend.

Tests run tiny batches for a few steps: their time is XLA compiling (about 1,100 of the suite's ~1,450 CPU-s on
CPU-2, by JAX's own compile events), not running. Two flags make it cheaper: LLVM's optimisation level 0 compiles MJX
20-35% faster (RESULTS.md §4), and XLA's older loop emitters instead of its fusion emitters halve a tiny training
epoch's compile (4.0-4.3 s -> 1.9-2.0 s). Neither changes what a test checks: no fast-math at either setting, and
every comparison in the suite is between programs compiled under the same flags. xdist workers and the commands the
tests start inherit them. XLA aborts a process on a flag it does not know, and its flags come and go between jaxlib
releases (the project asks only jax>=0.7), so a flag is set only where the installed jaxlib names it.
"""

import importlib.util
import mmap
import os
from pathlib import Path

TEST_XLA_FLAGS = ("--xla_backend_optimization_level=0", "--xla_cpu_use_fusion_emitters=false")


def known_to_xla(flag: str) -> bool:
    """Whether the installed jaxlib's libraries name ``flag`` (without importing jaxlib: nothing starts here)."""
    name = flag.lstrip("-").split("=", 1)[0].encode()
    for folder in importlib.util.find_spec("jaxlib").submodule_search_locations:
        for lib in Path(folder).glob("*.so"):
            with open(lib, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as m:
                if m.find(name) >= 0:
                    return True
    return False


os.environ["XLA_FLAGS"] = " ".join([os.environ.get("XLA_FLAGS", ""), *filter(known_to_xla, TEST_XLA_FLAGS)]).strip()
