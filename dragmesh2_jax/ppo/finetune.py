"""The paper's diagnostic recipes (App. B.5-B.6; the reference's v2d/v2e configs, design §5 and §7) as presets:
each continues a trained run from one of its checkpoints for ``epochs`` more epochs with a changed reward or
damping range. Epochs count on from the checkpoint's (as rl_games restores epoch_num), so the aux warm-up
stays finished. A preset never forks the code: it is a set of TaskConfig overrides."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.ppo.config import PAPER_EPOCHS
from dragmesh2_jax.task.config import AramConfig, Constraint, ReconfigConfig, RewardConfig
from dragmesh2_jax.task.protocol import CLIP_LEVEL

#: ``plausible``'s bounds on how the part is opened (issue 33): the palm no faster than PALM_SPEED_LIMIT (the expert's
#: palm peaks at 0.09-0.19 m/s on every object, RESULTS.md §7), the wrist's pull within what the grasp holds
#: (RewardConfig.f_hold) and a saturated wrist DoF in at most SATURATION_BUDGET of the steps (the fingers saturate to
#: hold a grip, the expert's too: config.MEASURES); each a rate (the fraction of steps past its limit) whose budget
#: dual ascent meets, in the normalised Lagrangian (``config.LAGRANGIANS``), its multiplier moving slowly enough for a
#: policy that opens the part to learn to open it within them (from scratch, or moving 5x faster, the multipliers
#: reached their cap before the policy could open it: RESULTS.md §3b).
PALM_SPEED_LIMIT = 0.25  # m/s
SATURATION_BUDGET = 0.2
PLAUSIBLE = tuple(Constraint(measure, limit, "rate", budget=budget, lr=1.0, lambda_max=20.0)
                  for measure, limit, budget in (("palm_speed", PALM_SPEED_LIMIT, 0.02),
                                                 ("load", RewardConfig.f_hold, 0.02),
                                                 ("wrist_saturation", CLIP_LEVEL, SATURATION_BUDGET)))


@dataclass(frozen=True)
class Finetune:
    name: str
    description: str
    epochs: int = 50  # the v2d fine-tunes' length
    aram: AramConfig | None = None
    reconfig: ReconfigConfig | None = None
    damping_range: tuple[float, float] | None = None  # None: the run's own
    constraints: tuple[Constraint, ...] = ()  # CMDP constraints added to the run's reward
    lagrangian: str = "plain"  # how they enter it (RewardConfig.lagrangian)

    def task_overrides(self, reward) -> dict:
        """TaskConfig changes on top of the run's ``reward`` config."""
        out: dict = {}
        if self.aram is not None or self.reconfig is not None:
            reward = out["reward"] = dataclasses.replace(reward, aram=self.aram, reconfig=self.reconfig)
        if self.constraints:
            out["reward"] = dataclasses.replace(reward, constraints=self.constraints, lagrangian=self.lagrangian)
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
    # beyond the paper (issue 33): the recipe's run held within a person's reach for as many epochs again
    Finetune("plausible", "the palm's pace, the wrist load and saturation as CMDP constraints", epochs=PAPER_EPOCHS,
             constraints=PLAUSIBLE, lagrangian="normalized"),
    Finetune("plausible_cap100", "plausible with its multipliers capped at 100, not 20 (capped at 20, the costs were "
             "still over budget and falling)", epochs=PAPER_EPOCHS, lagrangian="normalized",
             constraints=tuple(dataclasses.replace(c, lambda_max=100.0) for c in PLAUSIBLE)),
)}


def get_finetune(name: str) -> Finetune:
    if name not in FINETUNES:
        raise DragMeshError(f"unknown fine-tune {name!r} (choose from {', '.join(FINETUNES)})")
    return FINETUNES[name]
