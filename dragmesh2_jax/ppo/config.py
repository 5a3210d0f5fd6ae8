"""PPO configuration: paper Table 11 (and design §7 for what the table leaves out) as defaults. How long a run
trains and from which seed is its schedule (``runs/spec.Schedule``): a compiled program never reads them."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import jax.numpy as jnp

from dragmesh2_jax.errors import DragMeshError

#: The paper's per-object training budget in epochs (paper Table 11: 150 epochs x 64 envs x 32 steps).
PAPER_EPOCHS = 150


@dataclass(frozen=True)
class PPOConfig:
    num_envs: int = 64
    """parallel worlds (Table 11)"""
    rollout_len: int = 32
    """control steps per world in one epoch's rollout (Table 11)"""
    gamma: float = 0.99
    """discount"""
    gae_lambda: float = 0.95
    """GAE's lambda"""
    lr: float = 3e-4
    """Adam's learning rate (Table 11)"""
    lr_schedule: Literal["fixed", "adaptive"] = "fixed"
    """fixed (paper Table 11), or adaptive (the reference's rl_games KL-adaptive)"""
    kl_threshold: float = 0.008
    """the adaptive schedule's KL target"""
    clip_eps: float = 0.2
    """PPO's ratio clip (and the value clip)"""
    update_epochs: int = 5
    """minibatch epochs per batch"""
    num_minibatches: int = 1
    """the reference's 2048-sample minibatch = the whole batch"""
    value_coef: float = 1.0
    """c_v (loss term 0.5 c_v (V - R)^2, clipped)"""
    clip_value: bool = True
    """the value prediction's change from the rollout's clipped to clip_eps"""
    entropy_coef: float = 0.0
    """entropy bonus (none in Table 11)"""
    bounds_coef: float = 0.01
    """c_b, actor bounds loss at |mu| > bounds_at"""
    bounds_at: float = 1.1
    """beyond the paper: |mu| past which the bounds loss acts (rl_games' 1.1; below the action bound 1, it keeps a
    residual's deterministic output off its bound)"""
    smooth_coef: float = 0.0
    """beyond the paper: c_s, the action mean's temporal smoothness loss c_s mean_i (mu_t,i - mu_(t-1),i)^2 over
    consecutive steps of an episode (CAPS's temporal term, Mysore et al. 2021), mu_(t-1) the rollout's; 0: none"""
    mean_share: float = 0.0
    """beyond the paper: this share of the worlds (``mean_worlds`` of them, rounded up) acts on the policy's mean,
    without exploration noise: the deployed policy, on which the constraints' costs are counted (the evaluation reads
    it; the sampled actions pass a limit more often than their mean does); their steps train the critic, not the actor.
    0: every world samples and the costs are counted on them all"""
    distill_coef: float = 0.0
    """beyond the paper: c_d, the teachers' label loss c_d mean_i (mu_i - mu_teacher,i)^2 on the student's own steps
    (DAgger, Ross et al. 2011: the student acts, each world's teacher, its object's specialist, labels the step with
    its action mean); 0: none. A run with it names its teachers (``RunSpec.teachers``)"""
    distill_epochs: int = 0
    """c_d falls linearly to 0 over this many epochs, PPO alone after (DAgger, then PPO); 0: c_d throughout"""
    aux_weight: float = 0.01
    """w_aux after warm-up (Table 10); 0: no auxiliary loss"""
    aux_warmup: tuple[int, int] = (10, 40)
    """w_aux = 0 before the first epoch, linear to aux_weight by the second"""
    aux_channel_weights: tuple[float, float, float, float] = (1.0, 1.0, 0.5, 0.5)
    """the auxiliary loss per channel"""
    max_grad_norm: float = 1.0
    """global gradient-norm clip"""
    normalize_obs: bool = True
    """running mean/std of state and history tokens (Welford)"""
    normalize_advantage: bool = True
    """advantages to zero mean, unit std per minibatch"""

    def __post_init__(self):
        if min(self.num_envs, self.rollout_len, self.update_epochs, self.num_minibatches) < 1:
            raise DragMeshError("num_envs, rollout_len, update_epochs and num_minibatches must be >= 1")
        if not (0 <= self.mean_share < 1 and self.mean_worlds < self.num_envs):
            raise DragMeshError(f"mean_share must be in [0, 1) and leave a world of the {self.num_envs} that samples, "
                                f"got {self.mean_share}")
        if (self.num_envs * self.rollout_len) % self.num_minibatches:
            raise DragMeshError(f"num_envs * rollout_len ({self.num_envs * self.rollout_len}) must divide into "
                                f"{self.num_minibatches} minibatches")
        if self.lr_schedule not in ("adaptive", "fixed"):
            raise DragMeshError(f"lr_schedule must be 'adaptive' or 'fixed', got {self.lr_schedule!r}")
        if not 0 < self.lr < math.inf:
            raise DragMeshError(f"lr must be finite and > 0, got {self.lr}")
        if not (0 <= self.gamma <= 1 and 0 <= self.gae_lambda <= 1):
            raise DragMeshError(f"gamma and gae_lambda must be in [0, 1], got {self.gamma} and {self.gae_lambda}")
        if not 0 < self.bounds_at < math.inf:
            raise DragMeshError(f"bounds_at must be finite and > 0, got {self.bounds_at}")
        if not 0 <= self.smooth_coef < math.inf:
            raise DragMeshError(f"smooth_coef must be finite and >= 0, got {self.smooth_coef}")
        if not (0 <= self.distill_coef < math.inf and self.distill_epochs >= 0):
            raise DragMeshError(f"distill_coef must be finite and >= 0 and distill_epochs >= 0, got "
                                f"{self.distill_coef} and {self.distill_epochs}")
        if self.distill_epochs and not self.distill_coef:
            raise DragMeshError("distill_epochs schedules the teachers' label loss: set distill_coef > 0 too")
        if not 0 < self.clip_eps < math.inf:
            raise DragMeshError(f"clip_eps must be finite and > 0, got {self.clip_eps}")

    @property
    def mean_worlds(self) -> int:
        """How many worlds act on the policy's mean (``mean_share`` of ``num_envs``, rounded up)."""
        return math.ceil(self.mean_share * self.num_envs)

    def aux_weight_at(self, epoch):
        """w_aux(epoch): 0 -> aux_weight, linear over ``aux_warmup`` (epochs counted from 0)."""
        a, b = self.aux_warmup
        return self.aux_weight * jnp.clip((epoch - a) / max(b - a, 1), 0.0, 1.0)

    def distill_coef_at(self, epoch):
        """c_d(epoch): ``distill_coef``, falling linearly to 0 at ``distill_epochs`` (0: constant)."""
        if not self.distill_epochs:
            return jnp.float32(self.distill_coef)
        return self.distill_coef * jnp.clip(1.0 - epoch / self.distill_epochs, 0.0, 1.0)
