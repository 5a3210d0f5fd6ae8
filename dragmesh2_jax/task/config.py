"""Task configuration: the paper's values as defaults (Tables 7 and 8, Appendix A), everything switchable."""

from __future__ import annotations

import dataclasses
import importlib.util
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import jax

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.scene import RESET_SETTLE_SUBSTEPS
from dragmesh2_jax.trajectory.schema import RHO

Backend = Literal["auto", "mjx", "mujoco"]
BACKENDS = get_args(Backend)
MAX_ALPHA = 1.0  # the largest action increment (m or rad per control step); the paper's is 0.05
Impl = Literal["auto", "jax", "warp"]
IMPLS = get_args(Impl)
#: s_t's kinds (task/observation.py): the paper's, and one in the handle's frame that transfers across objects.
Observation = Literal["paper", "handle"]
OBSERVATIONS = get_args(Observation)


#: ARAM's response tests (AramConfig.response).
Response = Literal["raw", "normalized", "joint_aware"]


@dataclass(frozen=True)
class AramConfig:
    """ARAM-lite (the reference's v2d fine-tunes, design §5): an adaptive penalty on large actions that do not
    move the joint. stall counts consecutive steps with a low response q_t - q_{t-K}; once stall >= ``stall_steps``
    while in contact (d < ``d_contact``) and ||a|| > ``action_norm``, r_aram = -lambda mean(a^2). lambda starts at
    0 and moves once per epoch by ``lr (clip099 - target)`` when the epoch's success exceeds ``success_gate``."""

    response: Response = "raw"
    """the response test: raw |dq| < raw_eps, normalized |dq| / (q_goal - q_start) < frac, or joint_aware"""
    raw_eps: float = 0.005
    """m or rad"""
    frac: float = 0.01
    """normalized threshold (the joint-aware config's)"""
    stall_steps: int = 5
    d_contact: float = 0.10
    """m"""
    action_norm: float = 1.0
    """||a||_2"""
    lr: float = 0.005
    target: float = 0.7
    """clip099 the update steers towards"""
    success_gate: float = 0.7
    lambda_max: float = 1.0

    def __post_init__(self):
        if self.response not in get_args(Response):
            raise DragMeshError(f"ARAM response must be raw, normalized or joint_aware, got {self.response!r}")


@dataclass(frozen=True)
class ReconfigConfig:
    """Reconfig (design §5): a bonus for regaining contact and response after a stall, gated and with a
    cooldown: r = gate (w_contact max(0, d_{t-K} - d_t) + w_response max(0, dq_t - dq_{t-K})
    + w_slip max(0, max d_{t-2K..t-K} - max d_{t-K..t}))."""

    w_contact: float = 0.2
    w_response: float = 1.0
    w_slip: float = 0.5
    stall_frac: float = 0.02
    """|dq| / (q_goal - q_start) below this counts as a stall"""
    d_contact: float = 0.10
    """m"""
    action_norm: float = 1.0
    max_action_change: float = 4.0
    """||a_t - a_{t-1}||_2"""
    max_hand_speed: float = 8.0
    """||hand qd||_2"""
    cooldown: int = 10
    """steps"""


#: What a constraint bounds, per control step: the wrist's pull |F_wrist| (N) or the same in units of the expert drag's
#: peak pull on the object at the world's damping (``relative_load``: task/expert.py), how far the part trails the
#: expert drag at its own pace (``lag``: the plan's target joint at this step less the part's, as a fraction of q_goal -
#: q_start; negative when ahead) or leads it (``lead``, its negative: a pull faster than the expert's), the palm's speed
#: (m/s; ``settled_palm_speed``: 0 over an episode's first ``protocol.START_STEPS``, as the evaluation's settled figure;
#: ``relative_palm_speed``: that in units of the expert drag's settled palm peak at x1), the largest |a_i| over the DoFs
#: that move and over the wrist's six alone (action units; above CLIP_LEVEL the step is saturated: the expert's grip,
#: pressed deeper than alpha, saturates an active DoF in every step: RESULTS.md §3b), the deepest hand-object
#: penetration (m) and how far the applied action moved since the last step, mean |a_t - a_(t-1)| over the 51 channels
#: (action units, 0 at an episode's first step; the evaluation's ``action_smoothness`` per step).
Measure = Literal["load", "relative_load", "lag", "lead", "palm_speed", "settled_palm_speed", "relative_palm_speed",
                  "saturation", "wrist_saturation", "penetration", "action_change"]
MEASURES = get_args(Measure)
#: The unit of ``relative_load``: the expert drag's peak wrist load at the world's damping, replayed from its exact
#: grasp (``grasp``) or from the reset bank's start the world's episode began at (``start``: a start from which the
#: expert itself pulls harder is held to what the expert pulls there, so the residual's zero keeps the bound).
ExpertUnit = Literal["grasp", "start"]
#: The expert's grasp (``expert_grasp``): "planned", the pose the plan puts inside the handle (up to 33 mm for the
#: wrist, 1 rad for the fingers), which the drives press the hand into; "seated", where the handle stopped that pose,
#: the wrist's target there and the fingers' ``grip_closure`` past it (generator 1.2; RESULTS.md, penetration).
ExpertGrasp = Literal["seated", "planned"]
#: Which of the generator's palm placements the expert grasps with (``expert_placement``): "first", the first that
#: passes its gate and grips the handle; "holds", of those, the one whose drag opens the part at the highest damping
#: (``trajectory.generator.HOLD_DAMPINGS``), a planned one over the seated where it holds more (generator 1.4);
#: "starts", every placement in every physics, each replayed from clear starts (``task.choice``, RULE.md lever 26):
#: the depth, then the load held, then the lighter pull; "starts_hold", MAX_DEPTH, the load held, then expert_depth.
ExpertPlacement = Literal["first", "holds", "starts", "starts_hold"]
MAX_DEPTH = 0.002  # m: the deepest hand-object contact the issue "Hold on and follow" allows
#: The clear starts the choice replays each candidate from (8 kept a grasp 2.2 mm deep at x8 on door 111: lever 33).
CHOICE_STARTS = 8
#: The physics the generated trajectory is planned, seated and chosen in (``expert_plan_contact``): "scene", the run's
#: own; "mujoco", MuJoCo's default object contacts and the hand's default finger drives (``SceneConfig()``'s), whose
#: soft contacts seat the hand 4-9 mm into the handle: on the hand's stiff contacts a preload (RESULTS.md §3);
#: "holds", both, the run's own kept unless MuJoCo's, replayed on the run's physics, holds the part at a higher damping
#: (the firm seat on a drawer; the soft seat on a door the firm one lets go of: RULE.md, seventeenth lever).
ExpertPlanContact = Literal["scene", "mujoco", "holds"]
EXPERT_UNITS = get_args(ExpertUnit)
#: The channels ``residual_scale`` narrows: the whole hand's, the wrist's translation alone (the arm's pull; the
#: grasp and the wrist's rotation keep the policy's whole range), or the wrist's six (its turn too; the grasp free).
ResidualScope = Literal["hand", "translation", "wrist"]
RESIDUAL_SCOPES = get_args(ResidualScope)
#: What the residual adds to (``residual_on``): "action", the expert drag's increment toward this step's target, the
#: sum clipped to the action bound (so under load, where the hand lags its target by more than alpha, the expert's grip
#: and pull are cut to alpha's: its drag alone opens door 111 of the suite at x8 in 0.30 of the perturbed starts, as
#: PD targets in 0.94; RESULTS.md §3); "target", the drag's target itself, offset by the residual (the applied action,
#: the increment the target asks, may pass the bound), and PICA's action terms read the policy's own output.
ResidualOn = Literal["action", "target"]
RESIDUAL_ONS = get_args(ResidualOn)
#: How a step's measure x becomes its cost c_t: ``excess`` max(0, x - limit) / limit (how far past the limit, as a
#: fraction of it), ``rate`` 1[x > limit] (so E[c_t] is the fraction of steps past the limit), ``peak``
#: 1[max_{s<=t} x_s > limit] (the episode's running peak past it, so E[c_t] is the share of steps after an episode
#: first passed the limit: a bound on the episode's peak, which a rate leaves free for a step or two), ``horizon`` the
#: peak's cost charged to the episode's horizon: an episode that succeeds after passing the limit also pays, in r_t, the
#: T - t steps it had left (as it would have going on), so that a pass then a quick finish does not dodge the bound.
Cost = Literal["excess", "rate", "peak", "horizon"]
COSTS = get_args(Cost)
#: The costs that remember the episode's first pass (the env keeps it; a privileged critic sees it).
PEAK_COSTS = ("peak", "horizon")


#: How the constraints' penalty enters r_t. ``plain``: r_t - sum_i lambda_i c_i. ``normalized``: (r_t - sum_i lambda_i
#: c_i - detach sum_i lambda_i (T - t)) / (1 + sum_i lambda_i), PPO-Lagrangian's normalisation, so the reward keeps the
#: task's scale however large the multipliers grow, with a detached episode charged as past every limit for each
#: step it had left: ending an episode never dodges the costs its remaining steps would pay (with the plain form a
#: policy whose multipliers outgrew what it could yet meet learnt to detach at once: RESULTS.md §3b).
Lagrangian = Literal["plain", "normalized"]
LAGRANGIANS = get_args(Lagrangian)


@dataclass(frozen=True)
class Constraint:
    """Beyond the paper, in its CMDP framing (§3): a physical quantity as a constraint E[c_t] <= ``budget`` per step,
    not a fixed penalty. Its Lagrange multiplier lambda weighs -lambda c_t in r_t; it starts at 0 and moves once per
    epoch by dual ascent on the epoch's mean cost J_c: lambda <- clip(lambda + lr (J_c - budget), 0, lambda_max). The
    penalty grows only while the policy breaks the budget and relaxes once it keeps it (``RewardConfig.lagrangian``
    says how the penalty enters r_t). The defaults are the wrist load of ``hold_cmdp``: the pull beyond what the grasp
    holds (RewardConfig.f_hold)."""

    measure: Measure = "load"
    """what the constraint bounds, per control step (MEASURES' comment says each one's unit)"""
    limit: float = 100.0
    """in the measure's units (N, progress, m/s, action units, m)"""
    cost: Cost = "excess"
    """how a step's measure becomes its cost (COSTS' comment)"""
    budget: float = 0.01
    """allowed mean cost per step"""
    lr: float = 50.0
    """lambda per unit of mean cost over budget, per epoch"""
    lambda_max: float = 20.0
    """a bound that keeps the multiplier finite; a budget met leaves it below"""

    def __post_init__(self):
        if self.measure not in MEASURES or self.cost not in COSTS:
            raise DragMeshError(f"constraint: measure must be one of {', '.join(MEASURES)} and cost one of "
                                f"{', '.join(COSTS)}, got {self.measure!r} and {self.cost!r}")
        if not (0 < self.limit < math.inf and 0 <= self.budget < math.inf and 0 < self.lr < math.inf
                and 0 < self.lambda_max < math.inf):
            raise DragMeshError(f"{self.measure} constraint: limit, lr and lambda_max must be finite and > 0 and "
                                "budget finite and >= 0")


@dataclass(frozen=True)
class RewardConfig:
    """r = r_task + r_dist + r_act + r_time + r_detach + r_success + r_bound + r_contact (paper eq. totalreward).

    Each term has a weight; a weight of 0 switches the term off (the "w/o PICA" variant sets w_bound and
    w_contact to 0)."""

    w_task: float = 250.0
    """per m or rad of target-joint progress"""
    w_dist: float = 0.25
    """linear palm-handle distance penalty (per m)"""
    w_near: float = 0.10
    """near-distance bonus, w_near exp(-kappa d)"""
    kappa: float = 5.0
    """1/m, the near bonus's decay"""
    w_act: float = 0.002
    """action energy, mean(a^2)"""
    w_time: float = 0.05
    """per step"""
    r_detach: float = -50.0
    """one-shot, on detachment failure"""
    r_success: float = 100.0
    """one-shot, on reaching q_done"""
    w_bound: float = 20.0
    """PICA: mean(max(|a| - a_sat, 0)^2)"""
    a_sat: float = 0.90
    """PICA: |a| above this pays the bound penalty"""
    w_contact: float = 0.5
    """PICA: max(d - d_safe, 0)^2"""
    d_safe: float = 0.08
    """m: the palm-handle distance past which PICA's contact penalty starts"""
    w_load: float = 0.0
    """beyond the paper, a load budget: -w_load max(0, |F| - f_hold) / f_hold (scripted pulls show the grip fails once
    the arm's pull passes ~100-120 N, whatever the speed or damping); 0, off, in the paper's methods"""
    f_hold: float = 100.0
    """N, wrist force the grasp holds (measured on the tuning door)"""
    constraints: tuple[Constraint, ...] = ()
    """CMDP constraints, one per measure (none in the paper's methods)"""
    lagrangian: Lagrangian = "plain"
    """how the constraints enter r_t (LAGRANGIANS' comment)"""
    aram: AramConfig | None = None
    """ARAM-lite, a diagnostic fine-tune's adaptive penalty (paper App. B.5; AramConfig): off in the main recipe"""
    reconfig: ReconfigConfig | None = None
    """Reconfig, a diagnostic fine-tune's bonus for regaining contact after a stall (paper App. B.6; ReconfigConfig):
    off in the main recipe"""

    @staticmethod
    def upgrade(data: dict) -> dict:
        """A record from before ``constraints``: its single ``load_constraint`` (f_limit, budget, lr, lambda_max) is
        the load constraint with an excess cost."""
        old = data.pop("load_constraint", None)
        if isinstance(old, dict):
            data["constraints"] = [{"measure": "load", "limit": old.get("f_limit", Constraint.limit), "cost": "excess",
                                    **{k: v for k, v in old.items() if k != "f_limit"}}]
        return data

    def __post_init__(self):
        if self.lagrangian not in LAGRANGIANS:
            raise DragMeshError(f"lagrangian must be one of {', '.join(LAGRANGIANS)}, got {self.lagrangian!r}")
        measures = [c.measure for c in self.constraints]
        if len(set(measures)) != len(measures):
            raise DragMeshError(f"one constraint per measure, got {', '.join(measures)}")


@dataclass(frozen=True)
class ResetNoise:
    """A seeded perturbation of the expert grasp each episode starts from (not in the paper, whose reset is
    exact: design §4). ``bank`` perturbed starts are drawn once from ``seed`` and settled on the host like the
    exact one; each reset picks one at random. Normal noise is truncated at 2 standard deviations, so every
    start is within 2 sigma of the expert grasp; the object joint only opens (it starts at its closed limit)."""

    wrist_pos: float = 0.003
    """m, std per virtual slide"""
    wrist_rot: float = 0.02
    """rad, std per wrist hinge"""
    fingers: float = 0.05
    """rad, std per active finger joint (the 24 locked axes stay)"""
    object_q: float = 0.05
    """the object starts up to this fraction of (q_done - q_start) open, uniform"""
    bank: int = 32
    """perturbed starts"""
    seed: int = 0
    """seed of the perturbed starts' bank"""
    clear: bool = True
    """keep the hand out of the part: the wrist moved with a part-open start as the expert drag moves it, and a
    perturbation that reaches into the part eased back out (``task/starts.py``); off: as drawn (records before
    format 6)"""
    seat: bool = True
    """under clear: the unperturbed grasp itself eased out of the part first, to within ``starts.SEATED_DEPTH``, so
    the perturbations are kept clear around a hand resting on the handle (a seat planned on soft contacts lies 4.7 mm
    inside door 101's handle on the hand's contacts, which every episode's first steps read); off: around the
    grasp as the trajectory writes it (records before format 7)"""

    def __post_init__(self):
        if min(self.wrist_pos, self.wrist_rot, self.fingers, self.object_q) < 0 or self.object_q >= 1:
            raise DragMeshError("reset noise magnitudes must be >= 0 (and object_q < 1)")
        if self.bank < 1:
            raise DragMeshError(f"reset noise bank must be >= 1, got {self.bank}")
        if self.seat and not self.clear:
            raise DragMeshError("reset noise seat needs clear (it seats the grasp perturbations are cleared around)")


#: TaskConfig's fields that size buffers or threads: how a run is computed, not what it learns, so a resume may change
#: them (an MJX contact overflow's advice, ``--task.contacts N``).
RESIZABLE = ("contacts", "nthread")


@dataclass(frozen=True)
class TaskConfig:
    """The contact-driven pulling task (paper §3.1, Appendix A.1-A.2)."""

    alpha: float = 0.05
    """action-to-PD-target increment (m or rad per step)"""
    control_dt: float = 1.0 / 60.0
    """s: 60 Hz control, as the reference (no decimation)"""
    episode_length: int = 300
    """T_max (a truncation, not a failure)"""
    history_len: int = 16
    """L"""
    aux_window: int = 5
    """K"""
    rho: float = RHO
    """success threshold: q_done = q_min + rho (q_max - q_min) over the trajectory"""
    d_detach: float = 0.10
    """m: the palm farther than this from the handle ends the episode as a detachment"""
    settle_substeps: int = RESET_SETTLE_SUBSTEPS
    """physics steps from rest after writing the start (design §4)"""
    damping_range: tuple[float, float] = (1.0, 2.0)
    """the target joint's damping, x nominal, sampled per reset (an evaluation cell fixes its own)"""
    damping_log: bool = False
    """beyond the paper, draw the damping log-uniform over damping_range (as many worlds in [1, 2] as in [4, 8], as the
    evaluation's doublings weigh them); off: uniform (the paper's), where [1, 8] puts 1 world in 14 below x1.5"""
    friction_range: tuple[float, float] | None = None
    """the object's friction scale, sampled per reset; None: off"""
    reset_noise: ResetNoise | None = None
    """a seeded perturbation of the expert grasp each episode starts from (ResetNoise); off: the paper's exact
    expert-grasp reset"""
    force_obs: bool = False
    """beyond the paper: contact-load sensors in s_t and in every history token"""
    observation: Observation = "paper"
    """s_t: the paper's, or handle (in the handle's frame: transfers across objects)"""
    backend: Backend = "auto"
    """the engine: auto is MJX on an accelerator, the C engine (mujoco) on a CPU"""
    impl: Impl = "auto"
    """MJX's implementation: auto is Warp on an accelerator where warp-lang is installed (its kernels step the task
    3.7x MJX-JAX's rate there: RESULTS.md §4), else JAX"""
    contacts: int | None = None
    """MJX contact slots per world (None: sized from a probe, physics/contacts.py)"""
    nthread: int | None = None
    """C backend threads (default: all cores)"""
    object_curriculum: float = 0.0
    """beyond the paper, for an object mix: the share of resets drawn towards the objects the policy fails (each object
    weighed by 1 - its success, tracked per epoch; task/mix.py), the rest uniform; 0: every reset uniform"""
    expert_prior: bool = False
    """beyond the paper, residual learning over the expert drag: the applied action is the policy's plus the one that
    moves the hand to the drag's target for this step at its own pace (the tracking_delta baseline's action), both
    clipped to [-1, 1]; a policy that outputs zeros replays the expert (the hand only: the drag is the hand's)"""
    residual_scale: float = 1.0
    """beyond the paper, under expert_prior: the policy's action scaled by this before it adds to the expert's, so that
    its full range moves the hand's target residual_scale x alpha from the drag's (with the wrist's stiffness, the force
    a residual can add; its exploration noise scaled alike); 1: the policy's whole action range"""
    residual_scope: ResidualScope = "hand"
    """beyond the paper, the channels residual_scale narrows (RESIDUAL_SCOPES' comment)"""
    residual_on: ResidualOn = "action"
    """beyond the paper, under expert_prior: what the policy's residual adds to (ResidualOn's comment)"""
    residual_ramp: int = 0
    """control steps, beyond the paper, under expert_prior: the residual eased in from each episode's start, its gain
    rising linearly to 1 over these steps (0: at once; a constant offset applied at once jolts the wrist: lever 30)"""
    prior_lead: float | None = None
    """beyond the paper, under expert_prior: a pace that yields, the drag's step held back to the first whose planned
    joint lies this fraction of the part's range past the part's joint now, so the hand's target waits for a part that
    lags instead of running ahead of it (results/pace/RULE.md); None: the drag at its own pace (time-indexed)"""
    prior_floor: bool = False
    """beyond the paper, under expert_prior: the drag's step never behind the part (at least the plan's first whose
    planned joint reaches the part's joint now), so a part-open start is not pulled back to the closed part's grasp
    (door 101 at x8 from clear starts: 3.5 -> 1.9 mm in the first steps; results/screen/RULE.md, lever 19)"""
    prior_from_start: bool = False
    """beyond the paper, under expert_prior: the drag begun where the part began, then at its own pace: a part pulled
    ahead does not take the drag along, as prior_floor (also set) would (a rush on a light drawer: RULE.md, lever 29)"""
    expert_load_unit: ExpertUnit = "grasp"
    """beyond the paper, the start relative_load's and relative_palm_speed's units are probed from (EXPERT_UNITS')"""
    expert_grasp: ExpertGrasp = "planned"
    """beyond the paper, the grasp the generated trajectory holds the handle with (ExpertGrasp's comment)"""
    expert_placement: ExpertPlacement = "first"
    """beyond the paper, which palm placement the generated trajectory grasps with (ExpertPlacement's comment)"""
    expert_depth: float = MAX_DEPTH
    """m, beyond the paper, under expert_placement "starts" or "starts_hold": the deepest contact at x1 a kept grasp
    may reach from the choice's starts (below MAX_DEPTH: a margin for the policy's own press; RULE.md, lever 28)"""
    expert_choice_starts: int = CHOICE_STARTS
    """under expert_placement "starts" or "starts_hold": the clear starts each candidate grasp is replayed from"""
    expert_plan_contact: ExpertPlanContact = "scene"
    """beyond the paper, the physics the generated trajectory is planned in (ExpertPlanContact's comment)"""
    expert_wrap: bool = False
    """beyond the paper: the generator also tries the wraps (trajectory.grasp.WRAPS: the palm over the bar, the
    fingers around it) after the hooks, the placement kept as expert_placement says"""
    expert_rest: bool = False
    """beyond the paper: the generated grasp rested on the run's own contacts (the fingers under light drives), the
    drag starting there, the fingers grip_closure past it (trajectory.rest; RULE.md, twenty-fifth lever)"""
    grip_closure: float = 0.04
    """rad, under the seated or rested grasp: how far past where the handle stopped them the fingers' targets close
    (the grip's force, at most the finger drives' limit; below alpha, so that the expert's own action stays inside its
    bound)"""
    reward: RewardConfig = field(default_factory=RewardConfig)

    @staticmethod
    def upgrade(data: dict) -> dict:
        """A record from before the damping was fixed one way (``reset(key, damping_scale)``): its
        ``damping_fixed`` multiplier x is the range (x, x), which every reset samples as x."""
        fixed = data.pop("damping_fixed", None)
        if fixed is not None:
            data["damping_range"] = [fixed, fixed]
        if data.pop("expert_load_starts", 1) != 1:
            raise DragMeshError("this run's relative_load unit (expert_load_starts, the largest over the reset bank's "
                                "first starts) was replaced by expert_load_unit: read it with commit 40e6904")
        return data

    def __post_init__(self):
        if not 0 < self.alpha <= MAX_ALPHA:
            raise DragMeshError(f"alpha must be in (0, {MAX_ALPHA:g}] (m or rad per step), got {self.alpha}")
        if not (0 < self.control_dt < math.inf and 0 < self.d_detach < math.inf):
            raise DragMeshError(f"control_dt and d_detach must be finite and > 0, got {self.control_dt} and "
                                f"{self.d_detach}")
        if self.backend not in BACKENDS:
            raise DragMeshError(f"unknown backend {self.backend!r} (choose from {', '.join(BACKENDS)})")
        if self.observation not in OBSERVATIONS:
            raise DragMeshError(f"unknown observation {self.observation!r} (choose from {', '.join(OBSERVATIONS)})")
        if self.impl not in IMPLS:
            raise DragMeshError(f"unknown MJX impl {self.impl!r} (choose from {', '.join(IMPLS)})")
        if self.episode_length < 1 or self.history_len < 1 or self.aux_window < 1:
            raise DragMeshError("episode_length, history_len and aux_window must be >= 1")
        lo, hi = self.damping_range
        if not 0 <= lo <= hi:
            raise DragMeshError(f"damping_range must satisfy 0 <= lo <= hi, got {self.damping_range}")
        if not all(math.isfinite(x) for x in self.damping_range):
            raise DragMeshError(f"damping_range must be finite, got {self.damping_range}")
        if self.damping_log and lo <= 0:
            raise DragMeshError(f"damping_log needs damping_range above 0, got {self.damping_range}")
        if self.friction_range is not None and not (
                all(math.isfinite(x) for x in self.friction_range) and 0 <= self.friction_range[0]
                <= self.friction_range[1]):
            raise DragMeshError(f"friction_range must satisfy 0 <= lo <= hi, got {self.friction_range}")
        if self.contacts is not None and self.contacts < 1:
            raise DragMeshError(f"contacts per world must be >= 1, got {self.contacts}")
        if not (0 < self.expert_depth < math.inf and self.expert_choice_starts >= 1):
            raise DragMeshError(f"expert_depth must be finite and > 0 m, expert_choice_starts >= 1, got "
                                f"{self.expert_depth} and {self.expert_choice_starts}")
        if not 0 <= self.grip_closure < math.inf:
            raise DragMeshError(f"grip_closure must be finite and >= 0 rad, got {self.grip_closure}")
        if not 0 < self.residual_scale <= 1 or (self.residual_scale != 1 and not self.expert_prior):
            raise DragMeshError(f"residual_scale must be in (0, 1] and below 1 only with expert_prior, got "
                                f"{self.residual_scale}")
        if self.prior_lead is not None and not (0 < self.prior_lead < math.inf and self.expert_prior):
            raise DragMeshError(f"prior_lead must be finite and > 0, and only with expert_prior, got {self.prior_lead}")
        if self.residual_ramp < 0 or (self.residual_ramp and not self.expert_prior):
            raise DragMeshError(f"residual_ramp must be >= 0, and above 0 only with expert_prior: {self.residual_ramp}")
        if (self.prior_floor or self.prior_from_start) and not self.expert_prior:
            raise DragMeshError("prior_floor and prior_from_start only with expert_prior (they move the drag's step)")
        if self.residual_on not in RESIDUAL_ONS or (self.residual_on != "action" and not self.expert_prior):
            raise DragMeshError(f"residual_on must be one of {', '.join(RESIDUAL_ONS)}, and other than action only "
                                f"with expert_prior, got {self.residual_on!r}")
        if self.residual_scope not in RESIDUAL_SCOPES:
            raise DragMeshError(f"unknown residual_scope {self.residual_scope!r} (choose from "
                                f"{', '.join(RESIDUAL_SCOPES)})")
        if not 0 <= self.object_curriculum <= 1:
            raise DragMeshError(f"object_curriculum must be in [0, 1], got {self.object_curriculum}")
        if not 0 < self.rho <= 1:
            raise DragMeshError(f"rho must be in (0, 1], got {self.rho}")
        if self.expert_load_unit not in EXPERT_UNITS:
            raise DragMeshError(f"unknown expert_load_unit {self.expert_load_unit!r} (choose from "
                                f"{', '.join(EXPERT_UNITS)})")

    def resolved_backend(self) -> str:
        if self.backend != "auto":
            return self.backend
        return "mjx" if on_accelerator() else "mujoco"

    def resolved_impl(self) -> str:
        if self.impl != "auto":
            return self.impl
        return "warp" if on_accelerator() and importlib.util.find_spec("warp") is not None else "jax"


def on_accelerator() -> bool:
    """Whether JAX computes on a GPU or TPU here."""
    return jax.default_backend() in ("gpu", "tpu", "cuda", "rocm")


def apply_overrides(tree, overrides: Mapping[str, Any], where: str = ""):
    """``tree`` (a frozen dataclass whose fields may be frozen dataclasses: a :class:`TaskConfig`, a run's spec
    ``runs/spec.RunSpec``) with each dotted path of ``overrides`` (``"task.reward.w_bound"``) set to its value: one
    ``dataclasses.replace`` per node that changes, so each config checks its new values together; a path onto a value
    already given (``"task.reward"`` and ``"task.reward.w_load"``) refines that value. An unknown path is one error
    line naming it. It lives here, below both, so that the task's envs (``task/playground.py``) and the run tree share
    one reading of a dotted path."""
    if not overrides:
        return tree
    direct: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {}
    for path, value in overrides.items():
        head, _, rest = path.partition(".")
        if rest:
            nested.setdefault(head, {})[rest] = value
        else:
            direct[head] = value
    names = {f.name for f in dataclasses.fields(tree)}
    unknown = [f"{where}{k}" for k in [*direct, *nested] if k not in names]
    if unknown:
        raise DragMeshError(f"unknown setting {', '.join(unknown)} (a {type(tree).__name__} has "
                            f"{', '.join(sorted(names))})")
    changes = dict(direct)
    for head, sub in nested.items():
        node = changes.get(head, getattr(tree, head))
        if not dataclasses.is_dataclass(node):
            raise DragMeshError(f"unknown setting {where}{head}.{next(iter(sub))} ({where}{head} is "
                                f"{type(node).__name__}, not a config)")
        changes[head] = apply_overrides(node, sub, f"{where}{head}.")
    return dataclasses.replace(tree, **changes)
