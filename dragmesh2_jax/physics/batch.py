"""Batch axes over engine states. A world's state is vmapped over worlds, and training states over runs (seeds); an
engine may keep leaves the whole batch shares: MJX-Warp's ``DataWarp`` holds one contact buffer (and its counts)
for every world, and vmap passes those leaves through unbatched (``mujoco.mjx.warp.types.DATA_NON_VMAP``). Code that
indexes, stacks or merges along a batch axis outside vmap goes through :func:`map_batched`."""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable
from typing import Any

import jax

with contextlib.redirect_stdout(io.StringIO()):  # mujoco.mjx says "Failed to import warp" when it is absent
    from mujoco.mjx.warp.types import DATA_NON_VMAP


def shared(path: jax.tree_util.KeyPath) -> bool:
    """Whether the leaf at ``path`` belongs to the whole batch (a field of MJX-Warp's data the batch shares)."""
    return (len(path) >= 2 and getattr(path[-2], "name", None) == "_impl"
            and getattr(path[-1], "name", None) in DATA_NON_VMAP)


def map_batched(f: Callable, *trees: Any) -> Any:
    """``f`` over the leaves of ``trees`` that carry the batch axis; a shared leaf is the first tree's."""
    return jax.tree_util.tree_map_with_path(lambda path, x, *xs: x if shared(path) else f(x, *xs), *trees)
