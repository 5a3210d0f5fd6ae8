"""Task configuration: the paper's values as defaults (Tables 7 and 8, Appendix A), everything switchable."""

from __future__ import annotations

from dataclasses import dataclass, field

from dragmesh2_jax.errors import DragMeshError

BACKENDS = ("auto", "mjx", "mujoco")
IMPLS = ("jax", "warp")


@dataclass(frozen=True)
class RewardConfig:
    """r = r_task + r_dist + r_act + r_time + r_detach + r_success + r_bound + r_contact (paper eq. totalreward).

    Each term has a weight; a weight of 0 switches the term off (the "w/o PICA" variant sets w_bound and
    w_contact to 0)."""

    w_task: float = 250.0  # per m or rad of target-joint progress
    w_dist: float = 0.25  # linear palm-handle distance penalty (per m)
    w_near: float = 0.10  # near-distance bonus, w_near exp(-kappa d)
    kappa: float = 5.0
    w_act: float = 0.002  # action energy, mean(a^2)
    w_time: float = 0.05  # per step
    r_detach: float = -50.0  # one-shot, on detachment failure
    r_success: float = 100.0  # one-shot, on reaching q_done
    w_bound: float = 20.0  # PICA: mean(max(|a| - a_sat, 0)^2)
    a_sat: float = 0.90
    w_contact: float = 0.5  # PICA: max(d - d_safe, 0)^2
    d_safe: float = 0.08  # m


@dataclass(frozen=True)
class TaskConfig:
    """The contact-driven pulling task (paper §3.1, Appendix A.1-A.2)."""

    alpha: float = 0.05  # action-to-PD-target increment (m or rad per step)
    control_dt: float = 1.0 / 60.0  # s: 60 Hz control, as the reference (no decimation)
    episode_length: int = 300  # T_max (a truncation, not a failure)
    history_len: int = 16  # L
    aux_window: int = 5  # K
    rho: float = 0.5  # success-threshold fraction
    d_detach: float = 0.10  # m
    settle_substeps: int = 4  # physics steps from rest after writing the expert grasp (facts §4)
    damping_range: tuple[float, float] = (1.0, 2.0)  # x nominal, sampled per reset (training)
    damping_fixed: float | None = None  # evaluation: a fixed multiplier (x1, x2, x4, ...) instead
    friction_range: tuple[float, float] | None = None  # object friction scale; off by default
    backend: str = "auto"  # "mjx" | "mujoco" | "auto" (MJX on an accelerator, the C engine on a CPU)
    impl: str = "jax"  # MJX implementation: "jax" | "warp"
    nthread: int | None = None  # C backend threads (default: all cores)
    reward: RewardConfig = field(default_factory=RewardConfig)

    def __post_init__(self):
        if not self.alpha > 0:
            raise DragMeshError(f"alpha must be > 0, got {self.alpha}")
        if self.backend not in BACKENDS:
            raise DragMeshError(f"unknown backend {self.backend!r} (choose from {', '.join(BACKENDS)})")
        if self.impl not in IMPLS:
            raise DragMeshError(f"unknown MJX impl {self.impl!r} (choose from {', '.join(IMPLS)})")
        if self.episode_length < 1 or self.history_len < 1 or self.aux_window < 1:
            raise DragMeshError("episode_length, history_len and aux_window must be >= 1")
        lo, hi = self.damping_range
        if not 0 <= lo <= hi:
            raise DragMeshError(f"damping_range must satisfy 0 <= lo <= hi, got {self.damping_range}")
        if self.damping_fixed is not None and self.damping_fixed < 0:
            raise DragMeshError(f"damping multiplier must be >= 0, got {self.damping_fixed}")
        if not 0 < self.rho <= 1:
            raise DragMeshError(f"rho must be in (0, 1], got {self.rho}")

    def resolved_backend(self) -> str:
        if self.backend != "auto":
            return self.backend
        import jax

        return "mjx" if jax.default_backend() in ("gpu", "tpu", "cuda", "rocm") else "mujoco"
