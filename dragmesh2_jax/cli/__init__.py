"""``dragmesh2``: the command-line entry point. Each subcommand is a thin shell over library functions: ``parser``
declares the subcommands and their help (``flags``: the flags' types, every config field as a flag), ``handlers``
runs each one and prints what it returns.

Errors in input or configuration print one line ``error: ...`` and exit with status 2 (no traceback).
"""

from __future__ import annotations

import sys

from dragmesh2_jax.cli.handlers import join
from dragmesh2_jax.cli.parser import build_parser
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import os_error_line
from dragmesh2_jax.physics.engines import avoid_lapack_deadlock


def main(argv: list[str] | None = None) -> int:
    """``dragmesh2`` with ``argv`` (default: the command line's); returns the exit status."""
    parser = build_parser()
    try:  # a command that takes a run's configuration tree parses those flags itself (flags.parse_tree)
        args, rest = parser.parse_known_args(argv)
        if rest and not getattr(args, "tree", False):
            parser.error(f"unrecognized arguments: {' '.join(rest)}")
    except SystemExit as e:  # --help (0) or a usage error (2, already reported)
        return int(e.code or 0)
    args.rest = rest
    try:
        if getattr(args, "coordinator", None):  # before anything starts JAX's backends
            join(args)
        if "mjx" in str(getattr(args, "backend", "")):  # before anything starts JAX (jaxlib < 0.11 CPU deadlock)
            avoid_lapack_deadlock()
        return int(args.func(args) or 0)
    except DragMeshError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # what was written stands: a run resumes from its last checkpoint
        print("error: interrupted (a run continues from its last checkpoint with the same command and --resume)",
              file=sys.stderr)
        return 130
    except Exception as e:  # an operating-system fault, raised as such or wrapped by a library (Orbax, JAX)
        fault = _os_error(e)
        if fault is None:
            raise
        print(f"error: {os_error_line(fault)}", file=sys.stderr)
        return 2


def _os_error(e: BaseException) -> OSError | None:
    """The operating-system fault behind ``e`` (itself, or its cause or context), if there is one."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, OSError):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None
