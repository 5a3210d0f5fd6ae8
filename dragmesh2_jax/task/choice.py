"""The expert's grasp chosen by what the evaluation measures (``TaskConfig.expert_placement`` "starts"; beyond the
paper; results/screen/RULE.md, twenty-sixth lever).

The generator ranks its placements by the highest damping their drag opens the part at from the exact grasp
(``trajectory.generator.holds``). From there a wrap holds doors that it lets go of at x8 from perturbed starts, and it
is kept over a hook that holds them from every start (twenty-fifth lever). Here every candidate (each placement,
seated where it seats, planned in each physics the task plans in) is replayed as the prior replays it, from a few
clear starts of its own, and ranked: first whether its deepest contact at x1 stays within ``TaskConfig.expert_depth``
(the issue's ``task.config.MAX_DEPTH``, or below it a margin for the policy's own press), then the highest of
``CHOICE_DAMPINGS`` at which it opens the part from every start, then its lighter x1 pull. Ties keep the earlier
candidate (the run's own contacts before MuJoCo's; the hooks before the wraps). Under "starts_hold" the issue's
bound comes first, then the load held, then ``expert_depth``, then the pull: a margin that never costs the hold. The
scores are cached, the ranking is not: a run with another depth bound replays nothing."""

from __future__ import annotations

import contextlib
import json
from dataclasses import replace

import numpy as np

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_json, cache_dir, hash_files
from dragmesh2_jax.physics import contacts
from dragmesh2_jax.scene import Scene
from dragmesh2_jax.task.config import MAX_DEPTH, ResetNoise, TaskConfig
from dragmesh2_jax.task.env import substeps_of
from dragmesh2_jax.task.expert import reachable_targets
from dragmesh2_jax.task.starts import reset_starts
from dragmesh2_jax.trajectory.schema import Trajectory

#: The placements chosen here (``TaskConfig.expert_placement``).
PLACEMENTS = ("starts", "starts_hold")
#: The seed of the clear starts each candidate is replayed from (not the evaluation's bank, nor training's).
CHOICE_SEED = 7
#: The damping multipliers tried in order, up to the first at which a start is not opened.
CHOICE_DAMPINGS = (1.0, 2.0, 4.0, 8.0, 16.0)


def from_part(targets: np.ndarray, schedule: np.ndarray, obj_q: float) -> np.ndarray:
    """``targets`` from the first step whose planned part position reaches ``obj_q`` (a part-open start: the drag
    begun where the part is, as ``prior_from_start`` begins it and ``prior_floor`` holds it), the last one held to the
    same length."""
    k = min(int(np.searchsorted(np.maximum.accumulate(schedule), obj_q)), len(targets) - 1)
    return targets[np.minimum(np.arange(len(targets)) + k, len(targets) - 1)]


def score(scene: Scene, traj: Trajectory, config: TaskConfig) -> dict:
    """How ``traj``'s expert drag does from ``config.expert_choice_starts`` clear starts: its deepest contact and peak
    wrist load at x1 (the largest over the starts) and the highest damping it opens the part at from every start (0:
    not at x1)."""
    noise = replace(config.reset_noise or ResetNoise(), bank=config.expert_choice_starts, seed=CHOICE_SEED)
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
    return {"held": held, "deepest_m": round(depth, 6), "load_n": round(load, 2)}


def scores_of(scene: Scene, candidates: list[tuple[str, Trajectory]], config: TaskConfig) -> list[dict]:
    """Each candidate's :func:`score` with where it was planned, its placement and whether it is seated; cached on disk
    by the candidates, the scene and the config's fields the score reads."""
    key = hash_files([], extra="\0".join([
        *(repr(t.to_json()["header"]) + repr(t.hand_q.tobytes()) for _, t in candidates), scene.xml,
        repr((config.reset_noise, config.control_dt, config.episode_length, config.rho, config.settle_substeps,
              config.expert_choice_starts, CHOICE_SEED, CHOICE_DAMPINGS))]))
    cache = cache_dir() / "choice_scores" / f"{key}.json"
    with contextlib.suppress(OSError, ValueError):  # unreadable or torn: scored again
        cached = json.loads(cache.read_text())
        if isinstance(cached, list) and len(cached) == len(candidates):
            return cached
    scores = [{"planned_in": where, "placement": t.header["generator"]["placement_params"],
               "seated": t.header["generator"]["seated"], **score(scene, t, config)} for where, t in candidates]
    with contextlib.suppress(OSError):  # an unwritable cache only costs the next build the replays
        atomic_write_json(cache, scores)
    return scores


def chosen(scene: Scene, candidates: list[tuple[str, Trajectory]], config: TaskConfig) -> Trajectory:
    """The best of ``candidates`` (each named by the physics it was planned in) by :func:`scores_of` (module
    docstring), its header's ``generator.choice`` holding the depth bound and every candidate's score."""
    if not candidates:
        raise DragMeshError(f"{scene.obj.folder}: no placement passes the generator's gate to choose from")
    scores = [{**s, "within_depth": s["deepest_m"] <= config.expert_depth}
              for s in scores_of(scene, candidates, config)]
    def rank(i: int) -> tuple:
        s = scores[i]
        if config.expert_placement == "starts_hold":
            return s["deepest_m"] <= MAX_DEPTH, s["held"], s["within_depth"], -s["load_n"], -i
        return s["within_depth"], s["held"], -s["load_n"], -i
    best = max(range(len(candidates)), key=rank)
    traj = candidates[best][1]
    choice = {"kept": best, "depth_bound_m": config.expert_depth, "scores": scores}
    return Trajectory(frames=traj.frames, header={**traj.header, "generator": {**traj.header["generator"],
                                                                              "choice": choice}})
