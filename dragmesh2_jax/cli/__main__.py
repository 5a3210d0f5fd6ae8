"""``python -m dragmesh2_jax.cli``: the ``dragmesh2`` command."""

import sys

from dragmesh2_jax.cli import main

sys.exit(main())
