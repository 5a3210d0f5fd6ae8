"""The paper's diagnostic recipes (App. B.5-B.6; the reference's v2d/v2e configs, facts §5 and §7) as presets:
each continues a trained run from one of its checkpoints for ``epochs`` more epochs with a changed reward or
damping range. Epochs count on from the checkpoint's (as rl_games restores epoch_num), so the aux warm-up
stays finished. A preset never forks the code: it is a set of TaskConfig overrides."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.task.config import AramConfig, ReconfigConfig


@dataclass(frozen=True)
class Finetune:
    name: str
    description: str
    epochs: int = 50  # the v2d fine-tunes' length
    aram: AramConfig | None = None
    reconfig: ReconfigConfig | None = None
    damping_range: tuple[float, float] | None = None  # None: the run's own

    def task_overrides(self, reward) -> dict:
        """TaskConfig changes on top of the run's ``reward`` config."""
        out: dict = {}
        if self.aram is not None or self.reconfig is not None:
            out["reward"] = dataclasses.replace(reward, aram=self.aram, reconfig=self.reconfig)
        if self.damping_range is not None:
            out["damping_range"] = self.damping_range
        return out


FINETUNES = {f.name: f for f in (
    Finetune("continued", "continued training, nothing changed (paper Table 6)"),
    Finetune("aram", "ARAM-lite: adaptive penalty on large actions that do not move the joint", aram=AramConfig()),
    Finetune("reconfig", "Reconfig: bonus for regaining contact and response after a stall",
             reconfig=ReconfigConfig()),
    Finetune("both", "ARAM + Reconfig", aram=AramConfig(), reconfig=ReconfigConfig()),
    Finetune("both_jointaware", "ARAM (joint-type-aware response test) + Reconfig",
             aram=AramConfig(response="joint_aware"), reconfig=ReconfigConfig()),
    Finetune("damp_1_4", "damping range [1, 4] (paper Table 7)", damping_range=(1.0, 4.0)),
    Finetune("damp_1_2.5", "damping range [1, 2.5] (paper Table 7)", damping_range=(1.0, 2.5)),
    Finetune("damp_2_4", "damping range [2, 4] (paper Table 7)", damping_range=(2.0, 4.0)),
)}


def get_finetune(name: str) -> Finetune:
    if name not in FINETUNES:
        raise DragMeshError(f"unknown fine-tune {name!r} (choose from {', '.join(FINETUNES)})")
    return FINETUNES[name]
