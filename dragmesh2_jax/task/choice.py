"""The expert's grasp chosen by what the evaluation measures (``TaskConfig.expert_placement`` "starts"; beyond the
paper; results/screen/RULE.md, twenty-sixth lever).

The generator ranks its placements by the highest damping their drag opens the part at from the exact grasp
(``trajectory.generator.holds``). From there a wrap holds doors that it lets go of at x8 from perturbed starts, and it
is kept over a hook that holds them from every start (twenty-fifth lever). Here every candidate (each placement,
seated where it seats, planned in each physics the task plans in) is replayed as the prior replays it, from a few
clear starts of its own, and ranked: first whether its deepest contact at x1 stays within ``MAX_DEPTH``, then the
highest of ``CHOICE_DAMPINGS`` at which it opens the part from every start, then its lighter x1 pull. Ties keep the
earlier candidate (the run's own contacts before MuJoCo's; the hooks before the wraps)."""

from __future__ import annotations

import contextlib
from dataclasses import replace

import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import cache_dir, hash_files
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import ResetNoise, TaskConfig
from dragmesh2_jax.task.env import substeps_of
from dragmesh2_jax.task.expert import reachable_targets
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.schema import Trajectory, read_trajectory, write_trajectory

#: The clear starts each candidate is replayed from, and their seed (not the evaluation's bank, nor training's).
CHOICE_STARTS, CHOICE_SEED = 8, 7
#: The damping multipliers tried in order, up to the first at which a start is not opened.
CHOICE_DAMPINGS = (1.0, 2.0, 4.0, 8.0, 16.0)
#: m: the deepest hand-object contact a candidate may reach at x1 ("Hold on and follow": 2 mm).
MAX_DEPTH = 0.002


def from_part(targets: np.ndarray, schedule: np.ndarray, obj_q: float) -> np.ndarray:
    """``targets`` from the first step whose planned part position reaches ``obj_q`` (a part-open start: the drag
    never behind the part, as ``prior_floor`` holds it), the last one held to the same length."""
    k = min(int(np.searchsorted(np.maximum.accumulate(schedule), obj_q)), len(targets) - 1)
    return targets[np.minimum(np.arange(len(targets)) + k, len(targets) - 1)]


def score(scene: Scene, traj: Trajectory, config: TaskConfig) -> dict:
    """How ``traj``'s expert drag does from ``CHOICE_STARTS`` clear starts: its deepest contact and peak wrist load at
    x1 (the largest over the starts) and the highest damping it opens the part at from every start (0: not at x1)."""
    noise = replace(config.reset_noise or ResetNoise(), bank=CHOICE_STARTS, seed=CHOICE_SEED)
    targets = reachable_targets(scene, traj, config)
    schedule = traj.drag_schedule(config.control_dt, config.episode_length)
    substeps = substeps_of(scene, config)
    until = traj.q_done_at(config.rho)
    starts = reset_starts(scene, traj, noise)
    held, depth, load = 0.0, 0.0, 0.0
    for damping in CHOICE_DAMPINGS:
        runs = [contacts.replay(scene, s, from_part(targets, schedule, s[1]), substeps, config.settle_substeps, until,
                                damping) for s in starts]
        if damping == CHOICE_DAMPINGS[0]:
            depth, load = max(r.deepest for r in runs), max(r.peak_load for r in runs)
        if any(r.steps is None for r in runs):
            break
        held = damping
    return {"within_depth": depth <= MAX_DEPTH, "held": held, "deepest_m": round(depth, 6),
            "load_n": round(load, 2)}


def chosen(scene: Scene, candidates: list[tuple[str, Trajectory]], config: TaskConfig) -> Trajectory:
    """The best of ``candidates`` (each named by the physics it was planned in) by :func:`score` (module docstring),
    its header's ``generator.choice`` holding every candidate's score; cached on disk by the candidates, the scene and
    the config's fields the score reads."""
    if not candidates:
        raise DragMeshError(f"{scene.obj.folder}: no placement passes the generator's gate to choose from")
    key = hash_files([], extra="\0".join([
        *(repr(t.to_json()["header"]) + repr(t.hand_q.tobytes()) for _, t in candidates), scene.xml,
        repr((config.reset_noise, config.control_dt, config.episode_length, config.rho, config.settle_substeps,
              CHOICE_STARTS, CHOICE_SEED, CHOICE_DAMPINGS, MAX_DEPTH))]))
    cache = cache_dir() / "choices" / f"{key}.json"
    if cache.is_file():
        try:
            return read_trajectory(cache)
        except DragMeshError:
            cache.unlink(missing_ok=True)
    scores = [{"planned_in": where, "placement": t.header["generator"]["placement_params"],
               "seated": t.header["generator"]["seated"], **score(scene, t, config)} for where, t in candidates]
    best = max(range(len(candidates)), key=lambda i: (scores[i]["within_depth"], scores[i]["held"],
                                                      -scores[i]["load_n"], -i))
    traj = candidates[best][1]
    header = {**traj.header, "generator": {**traj.header["generator"], "choice": {"kept": best, "scores": scores}}}
    traj = Trajectory(frames=traj.frames, header=header)
    with contextlib.suppress(DragMeshError):  # an unwritable cache only costs the next build the replays
        write_trajectory(traj, cache)
    return traj
