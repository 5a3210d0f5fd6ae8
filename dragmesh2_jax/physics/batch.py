"""Batch axes over engine states. A world's state is vmapped over worlds, and training states over runs (seeds); an
engine may keep leaves the whole batch shares: MJX-Warp's ``DataWarp`` holds one contact buffer (and its counts)
for every world, and vmap passes those leaves through unbatched (``mujoco.mjx.warp.types.DATA_NON_VMAP``). Code that
indexes, stacks or merges along a batch axis outside vmap goes through :func:`map_batched`.

A state holds MJX-Warp's data only once its module is imported, so the names are read from that module where it is
loaded and never import it (``task/env.py`` says why MJX is imported only when chosen)."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

import jax

WARP_TYPES = "mujoco.mjx.warp.types"  # where MJX-Warp's data types and DATA_NON_VMAP live


def shared(path: jax.tree_util.KeyPath) -> bool:
    """Whether the leaf at ``path`` belongs to the whole batch (a field of MJX-Warp's data the batch shares)."""
    if len(path) < 2 or getattr(path[-2], "name", None) != "_impl" or WARP_TYPES not in sys.modules:
        return False
    return getattr(path[-1], "name", None) in sys.modules[WARP_TYPES].DATA_NON_VMAP


def map_batched(f: Callable, *trees: Any) -> Any:
    """``f`` over the leaves of ``trees`` that carry the batch axis; a shared leaf is the first tree's."""
    return jax.tree_util.tree_map_with_path(lambda path, x, *xs: x if shared(path) else f(x, *xs), *trees)
