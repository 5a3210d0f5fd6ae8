"""The test suite. Imported before any conftest, so XLA's flags for the tests are set before JAX starts a backend.

Tests run tiny batches for a few steps: their time is XLA compiling (MJX's step takes minutes per scene on 2
cores), not running. LLVM's optimisation level 0 compiles MJX 20-35% faster (RESULTS.md §4) and computes the same
floating-point operations (no fast-math at either level). xdist workers and the commands the tests start inherit it.
"""

import os

TEST_XLA_FLAGS = "--xla_backend_optimization_level=0"
os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {TEST_XLA_FLAGS}".strip()
