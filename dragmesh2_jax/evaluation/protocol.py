"""The evaluation protocol (paper §4, Appendix A.2) as one value: which damping multipliers, which modes (det =
the Gaussian mean, stoch = a sample), how many episodes per cell, from which starts, with which seed. The CLI
defaults, the demo, ``reproduce`` and the checkpoint selection during training all take theirs from here, and an
evaluation's file is named by its protocol (one evaluation never overwrites another's).

Starts: by default each episode starts from a perturbed expert grasp (a seeded bank, ``ResetNoise``), so a
deterministic cell is a distribution over starts and its success a rate; ``starts=None`` is the paper's exact
reset (a det cell is then one episode repeated). The episodes of a cell start from distinct starts, the first
``episodes`` of the bank (which holds at least that many), so a det cell of n episodes is n distinct starts.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from dataclasses import dataclass

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.task.config import ResetNoise
from dragmesh2_jax.task.protocol import Env

MODES = ("det", "stoch")
PAPER_DAMPINGS = (1.0, 2.0, 4.0)  # paper §4: nominal, mild and strong (OOD) contact-load shift
#: The perturbed starts of the evaluation protocol (its own bank seed, apart from training's and selection's).
EVAL_RESET_NOISE = ResetNoise(seed=12345)


@dataclass(frozen=True)
class EvalProtocol:
    dampings: tuple[float, ...] = PAPER_DAMPINGS
    modes: tuple[str, ...] = MODES
    episodes: int = 20  # per cell (paper §4)
    starts: ResetNoise | None = EVAL_RESET_NOISE  # None: the paper's exact reset
    seed: int = 42  # the reference's evaluation seed

    def __post_init__(self):
        bad = [m for m in self.modes if m not in MODES]
        if bad or not self.modes:
            raise DragMeshError(f"unknown evaluation mode(s) {bad} (choose from {', '.join(MODES)})")
        if self.episodes < 1:
            raise DragMeshError("episodes per cell must be >= 1")
        if not self.dampings or min(self.dampings) < 0:
            raise DragMeshError(f"damping multipliers must be >= 0, got {self.dampings}")
        if self.starts is not None and self.starts.bank < self.episodes:  # one distinct start per episode
            object.__setattr__(self, "starts", dataclasses.replace(self.starts, bank=self.episodes))

    @property
    def name(self) -> str:
        """A file-name tag that tells protocols apart: ``x1-2-4_det-stoch_n20_exact_s42``, or with perturbed
        starts ``..._distinct-<hash of the ResetNoise>_...`` (each episode of a cell its own start)."""
        noise = {} if self.starts is None else dataclasses.asdict(self.starts)
        if not noise.get("seat", True):
            del noise["seat"]  # starts kept clear around the grasp as written keep the names they had before seating
        starts = "exact" if self.starts is None else "distinct-" + hashlib.sha1(
            json.dumps(noise, sort_keys=True).encode()).hexdigest()[:6]
        return (f"x{'-'.join(f'{d:g}' for d in self.dampings)}_{'-'.join(self.modes)}_n{self.episodes}_{starts}"
                f"_s{self.seed}")

    def task(self, task: Env, costs: bool = False) -> Env:
        """The protocol's task for ``task``'s object (or each object of a mix), trajectory and observation: its
        starts; the damping is fixed per cell by the evaluator (``reset(key, damping_scale)``). ``costs``: the
        constraints' costs measured on it as in training (an evaluation counts none)."""
        return task.with_starts(self.starts, costs)


#: The paper's protocol with the project's perturbed starts (the default of ``evaluate``, ``reproduce``, the demo).
PAPER = EvalProtocol()
#: Checkpoint selection during training (paper App. B.3-B.4): det success at x1/x2/x4, 8 episodes per cell from its
#: own bank of perturbed starts.
SELECTION = EvalProtocol(modes=("det",), episodes=8, starts=ResetNoise(seed=7), seed=7)
