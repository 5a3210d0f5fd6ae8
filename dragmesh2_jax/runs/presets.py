"""The catalogue of methods: every named method, each a set of overrides over one run's configuration
tree (``runs/spec.RunSpec``, dotted paths: ``task.*``, ``network.*``, ``ppo.*``, ``scene.*``, ``schedule.*``; as MuJoCo
Playground's ``config_overrides``), never a code fork, with its status and one pointer to its evidence:

- ``paper``: the paper's methods (Tables 2-3) and diagnostic fine-tunes (Tables 6-7);
- ``recommended``: the project's recipe for one object (``--method recommended``, what ``train`` trains by default);
- ``generalist``: the project's policy over many objects (``train --generalist``);
- ``experimental``: tried, not adopted (its evidence says how far it got);
- ``superseded``: a recipe a later one replaced; its runs still read back.

A new method is one entry in ``METHODS`` (a fine-tune one in ``runs/finetunes.FINETUNES``), a new knob one field of
a config dataclass (and so one flag).

PICA = GLA temporal encoder + the physical signals: contact/saturation regularisers (r_bound, r_contact), damping
randomisation and the causal-window auxiliary loss. Baselines use the same observation without the physical signals
(``NO_PHYSICAL_SIGNALS``); the two ablations remove one PICA component each. The task itself (action interface,
success threshold, damping multipliers, episode length) is the paper's for every method.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.runs.overrides import (
    CHANGE_BOUND,
    CHOSEN,
    CHOSEN_MARGIN,
    CHOSEN_TIGHT,
    DISTILLED,
    EASED,
    EASED_WRIST,
    EITHER_SEAT,
    FIRM_GRIP,
    FLOOR,
    FOLLOWING_INSIDE,
    FORCE_OBS,
    FROM_START,
    GENERALIST_SCHEDULE,
    HOLD,
    HOLD_BLIND,
    HORIZON_RESIDUAL,
    LEAD_BOUND,
    LOAD_BOUND,
    MEAN_COUNTED,
    NO_PHYSICAL_SIGNALS,
    ON_TARGET,
    OWN_PACE,
    OWN_PACE_HORIZON,
    OWN_PACE_PEAK,
    OWN_PACE_WIDER,
    OWN_START,
    PEAK_BOUND,
    READ_FINAL,
    RELATIVE_EXCESS_BOUND,
    RELATIVE_LOAD_BOUND,
    RESIDUAL,
    SATURATION_BUDGET,
    SEATED_HOLDS,
    SMOOTH,
    SOFT_SEAT,
    UNHURRIED,
    WIDE,
    WIDE_HAND,
    YIELDING,
    bounded,
    reach,
    within,
)
from dragmesh2_jax.task.config import Constraint, ResetNoise

#: A preset's status (the module docstring); ``--method`` offers the first three, ``--list-methods`` every one.
STATUSES = ("paper", "recommended", "generalist", "experimental", "superseded")
OFFERED = STATUSES[:3]


@dataclass(frozen=True)
class Method:
    name: str
    description: str
    overrides: Mapping[str, Any]  # dotted path into a run's spec -> value (runs/spec.apply_overrides)
    status: str = "experimental"  # one of STATUSES: a new method is experimental until its evidence says otherwise
    evidence: str = ""  # where its result is (RESULTS.md, results/archive.md) or why there is none


METHODS = {m.name: m for m in (
    Method("pica", "PICA: GLA contact-history encoder + physical signals (ours)", {},
           status="paper", evidence="paper Table 2; results/archive.md §2"),
    Method("state_only", "state-only PPO: MLP on s_t", {**NO_PHYSICAL_SIGNALS, "network.encoder": "none"},
           status="paper", evidence="paper Table 2; results/archive.md §2"),
    Method("flat_history", "flat-history PPO: s_t + flattened history",
           {**NO_PHYSICAL_SIGNALS, "network.encoder": "flat"},
           status="paper", evidence="paper Table 2; results/archive.md §2"),
    Method("gru", "GRU-PPO over the same history window", {**NO_PHYSICAL_SIGNALS, "network.encoder": "gru"},
           status="paper", evidence="paper Table 2; results/archive.md §2"),
    Method("transformer", "Transformer-PPO (1 causal block) over the history window",
           {**NO_PHYSICAL_SIGNALS, "network.encoder": "transformer"},
           status="paper", evidence="paper Table 2; results/archive.md §2"),
    Method("gla_only", "ablation w/o PICA: GLA encoder without the physical signals", NO_PHYSICAL_SIGNALS,
           status="paper", evidence="paper Table 3; results/archive.md §2"),
    Method("pica_flat", "ablation w/o GLA: physical signals with the flat-history encoder",
           {"network.encoder": "flat"},
           status="paper", evidence="paper Table 3; results/archive.md §2"),
    Method("pica_load", "load-aware PICA: contact-load observation, privileged critic, damping [1, 4], perturbed "
           "starts", {**FORCE_OBS, "network.critic": "privileged", "task.damping_range": (1.0, 4.0),
                     "task.reset_noise": ResetNoise()},
           status="superseded", evidence="results/archive.md §3 (by hold)"),
    Method("pica_grip", "grip-aware PICA: contact-load observation, privileged critic and a load budget reward (the "
           "arm's pull beyond what the grasp holds is penalised)",
           {**FORCE_OBS, "network.critic": "privileged", "task.reward.w_load": 5.0},
           status="superseded", evidence="results/archive.md §3 (by hold_grip)"),
    # the project's recipes for holding a part under load: trained where the load is
    Method("hold", "PICA-Hold: contact-load observation, privileged critic, damping randomised over [1, 8] (the "
           "evaluation's x8 inside the training range), perturbed starts", {**HOLD, **FORCE_OBS},
           status="superseded", evidence="results/archive.md §3 (by hold_blind)"),
    Method("hold_grip", "PICA-Hold with the load-budget reward of pica_grip (the arm's pull beyond what the grasp "
           "holds is penalised)", {**HOLD, **FORCE_OBS, "task.reward.w_load": 5.0},
           status="superseded", evidence="results/archive.md §3"),
    Method("hold_cmdp", "PICA-Hold with the wrist load as a CMDP constraint: a Lagrange multiplier, moved by dual "
           "ascent, weighs the pull beyond what the grasp holds",
           {**HOLD, **FORCE_OBS, "task.reward.constraints": (Constraint(),)},
           status="superseded", evidence="results/archive.md §3"),
    Method("hold_blind", "PICA-Hold without force or touch sensing (the paper's observation): privileged critic, "
           "damping [1, 8], perturbed starts; trained twice the paper's budget and read at its final checkpoint "
           "(best_robust's x1/x2/x4 saturates and keeps an early one)",
           HOLD_BLIND,
           status="superseded", evidence="results/archive.md §3 (by the residual recipes)"),
    Method("hold_blind_handle", "the recipe (hold_blind) with the transferable observation (the hand and the joint in "
           "the handle's frame, the part's state in task units, nothing that identifies the object), for policies "
           "over many objects",
           {**HOLD_BLIND, "task.observation": "handle"},
           status="superseded", evidence="results/archive.md §6 (by generalist)"),
    Method("generalist", "the project's generalist recipe: hold_blind_handle over many objects for 10 M env steps (at "
           "the default batch), checked on the held-aside objects every 100 epochs (40 episodes per damping: 4 per "
           "held-aside object on average), read at its final checkpoint (train --generalist: over the procedural "
           "mix of every category)",
           {**HOLD_BLIND, "task.observation": "handle", **GENERALIST_SCHEDULE},
           status="generalist", evidence="results/archive.md §6e"),
    Method("generalist_residual", "the generalist over the recipe's structure (hold_blind_residual_seated's expert "
           "drag plus a residual, its pull narrowed and bounded by each object's expert, the grasp that holds) with "
           "the handle-frame observation: the expert drag exists for every object a user opens; the generalist's "
           "budget",
           {**SEATED_HOLDS, "task.observation": "handle", **GENERALIST_SCHEDULE},
           status="experimental", evidence="results/generalist_residual/ (3 seeds; its rule did not adopt it)"),
    Method("generalist_distilled", "generalist_residual distilled from per-object specialists (DAgger: the student "
           "acts over the mix; each world's teacher, a generalist_residual run on its object, labels the step; the "
           "label loss falls to 0 over 600 epochs, PPO alone after): train --generalist --method "
           "generalist_distilled --teachers RUN ...",
           {**SEATED_HOLDS, "task.observation": "handle", **GENERALIST_SCHEDULE, **DISTILLED},
           status="experimental", evidence="none yet: built, not yet trained at its budget (issue 55)"),
    Method("hold_blind_residual", "the recipe (hold_blind) as a residual over the expert drag: the policy's action "
           "adds to the one that follows the drag at its own pace (its zero replays the expert), so it learns the "
           "corrections, not the pull", {**HOLD_BLIND, **RESIDUAL},
           status="superseded", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_load", "hold_blind_residual with the wrist load bounded from the start (at most 2% of "
           "steps past the 100 N the grasp holds, a CMDP constraint): the expert's pull, corrected within its force; "
           "the paper's budget (at 300 epochs the bound tightens until x16 is lost), read at its "
           "final checkpoint", {**HOLD, **READ_FINAL, **RESIDUAL, **LOAD_BOUND},
           status="superseded", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_smooth", "hold_blind_residual_load with the action mean kept smooth in time (PPO's "
           "temporal smoothness loss): the residual's jerk, not its pull, made the load peaks; 150 "
           "epochs, read at its final checkpoint", {**HOLD, **READ_FINAL, **RESIDUAL, **LOAD_BOUND, **SMOOTH},
           status="superseded", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_relative", "hold_blind_residual_smooth with the load bound relative to the object's "
           "expert: at most 2% of steps past the expert drag's own peak wrist load on the object at the world's "
           "damping (a light door is held to its expert's pull, not to 100 N); 150 epochs, read at its final "
           "checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **RELATIVE_LOAD_BOUND, **SMOOTH},
           status="superseded", evidence="results/archive.md §3b (the recipe before hold_blind_residual_pull)"),
    Method("hold_blind_residual_relative_own", "hold_blind_residual_relative with its unit the expert's peak from "
           "the episode's own start, not from the exact grasp: the bound asks no more than the expert pulls from "
           "there; 150 epochs, read at its final checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **RELATIVE_LOAD_BOUND, **SMOOTH, **OWN_START},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_peak", "hold_blind_residual_smooth with each episode's peak pull bounded: past 1.1x "
           "the expert's own peak from the episode's start and damping, every later step of the episode pays, on at "
           "most 5% of steps; 150 epochs, read at its final checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **PEAK_BOUND, **SMOOTH},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_peak_mean", "hold_blind_residual_peak with its budget counted on the policy's mean: "
           "an eighth of the worlds act on it, and their steps move the multiplier and train the critic alone; "
           "150 epochs, read at its final checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **PEAK_BOUND, **SMOOTH, **MEAN_COUNTED},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_horizon", "hold_blind_residual_peak_mean with the peak's cost charged to the "
           "horizon: an episode that succeeds after pulling past the bound pays for every step it had left, so a "
           "quick finish does not dodge it; 150 epochs, read at its final checkpoint",
           HORIZON_RESIDUAL,
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_fine", "hold_blind_residual_horizon with the residual's reach a quarter of the "
           "action range: the force it can add over the expert drag's at most 38 N; 150 epochs, "
           "read at its final checkpoint",
           {**HORIZON_RESIDUAL, **reach(0.25)},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_reach", "hold_blind_residual_horizon with the residual's reach half the action "
           "range: the force it can add over the expert drag's at most 75 N; 150 epochs, read at "
           "its final checkpoint",
           {**HORIZON_RESIDUAL, **reach(0.5)},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_pull", "hold_blind_residual_fine with only the wrist's translation narrowed: the "
           "arm's pull it can add at most 38 N, the grasp and the wrist's rotation at the whole action range; "
           "150 epochs, read at its final checkpoint",
           {**HORIZON_RESIDUAL, **reach(0.25, "translation")},
           status="superseded", evidence="RESULTS.md §3 (by hold_blind_residual_seated)"),
    Method("hold_blind_residual_holds", "hold_blind_residual_pull over the expert drag whose palm placement holds the "
           "most load (task.expert_placement holds): on the suite's hardest doors it holds x4 and x8 where "
           "hold_blind_residual_pull lets go, pulling 1.2-1.7x its load at x1; 150 epochs, read at its final "
           "checkpoint",
           {**HORIZON_RESIDUAL, **reach(0.25, "translation"), "task.expert_placement": "holds"},
           status="experimental", evidence="results/screen/RULE.md"),
    Method("hold_blind_residual_seated", "hold_blind_residual_pull over the expert grasp that holds the most load "
           "(task.expert_grasp seated, task.expert_placement holds: the seated grasp where it holds as much as a "
           "planned one, else the planned one that holds the most): on hard doors it holds x4-x8 where "
           "hold_blind_residual_pull lets go, and the hand is light where nothing resists; 150 epochs, read at its "
           "final checkpoint",
           SEATED_HOLDS, status="recommended", evidence="RESULTS.md §3, results/screen/RULE.md"),
    Method("hold_blind_residual_grip", "hold_blind_residual_seated on the hand's contacts (the fingers on the handle, "
           "not in it) with finger drives of 2 N m, twice the expert grasp's pressure, so the residual can close the "
           "grip as the load rises; 150 epochs, read at its final checkpoint",
           {**SEATED_HOLDS, **FIRM_GRIP}, status="experimental", evidence="results/screen/RULE.md (seventh lever)"),
    Method("hold_blind_residual_yield", "hold_blind_residual_seated whose prior waits for a part that lags (its drag "
           "target at most 0.2 of the range ahead of the part), so the hand does not speed up under load; 150 epochs, "
           "read at its final checkpoint",
           {**SEATED_HOLDS, **YIELDING}, status="experimental", evidence="results/screen/RULE.md (eighth lever)"),
    Method("hold_blind_residual_firm", "hold_blind_residual_yield on hold_blind_residual_grip's physics: the fingers "
           "on the handle, a grip the residual can tighten and a pace that yields; 150 epochs, read at its final "
           "checkpoint",
           {**SEATED_HOLDS, **FIRM_GRIP, **YIELDING}, status="experimental",
           evidence="results/screen/RULE.md (eighth lever)"),
    Method("hold_blind_residual_seat", "hold_blind_residual_grip over the recipe's own expert drag: its seat planned "
           "on MuJoCo's soft contacts and held on the hand's, so the fingers press the handle with the seat's "
           "preload and stay on its surface; 150 epochs, read at its final checkpoint",
           {**SEATED_HOLDS, **SOFT_SEAT}, status="experimental", evidence="results/screen/RULE.md (ninth lever)"),
    Method("hold_blind_residual_target", "hold_blind_residual_seat with a pace that yields and its residual "
           "offsetting the expert drag's PD target, which the action bound no longer cuts under load: on the suite's "
           "hardest doors its policy keeps what its expert holds at x8; 150 epochs, read at its final checkpoint",
           {**SEATED_HOLDS, **SOFT_SEAT, **YIELDING, **ON_TARGET}, status="experimental",
           evidence="results/screen/RULE.md (thirteenth lever)"),
    Method("hold_blind_residual_firm_target", "hold_blind_residual_firm with its residual offsetting the expert "
           "drag's PD target (the recipe's seat on the hand's contacts, a grip the residual tightens past the action "
           "bound); 150 epochs, read at its final checkpoint",
           {**SEATED_HOLDS, **FIRM_GRIP, **YIELDING, **ON_TARGET}, status="experimental",
           evidence="results/screen/RULE.md (fifteenth step)"),
    Method("hold_blind_residual_target_holds", "hold_blind_residual_target whose seat is planned on the contacts "
           "that hold the part (the hand's on a drawer, MuJoCo's soft ones on the doors only they hold); 150 "
           "epochs, read at its final checkpoint",
           {**SEATED_HOLDS, **EITHER_SEAT, **YIELDING, **ON_TARGET}, status="experimental",
           evidence="results/screen/RULE.md (seventeenth lever)"),
    Method("hold_blind_residual_target_within", "hold_blind_residual_target_holds with its own saturation (a fifth "
           "of the steps) and the hand's depth (2 mm in 5%) bounded; 150 epochs, read at its final checkpoint",
           {**SEATED_HOLDS, **EITHER_SEAT, **YIELDING, **ON_TARGET, **within(SATURATION_BUDGET)},
           status="experimental", evidence="results/screen/RULE.md (eighteenth lever)"),
    Method("hold_blind_residual_follow", "hold_blind_residual_target_within, its prior never behind the part "
           "(task.prior_floor), saturated in a tenth of the steps at most; 150 epochs, final checkpoint",
           {**SEATED_HOLDS, **EITHER_SEAT, **YIELDING, **ON_TARGET, **FLOOR, **within(0.1)}, status="experimental",
           evidence="results/screen/RULE.md (nineteenth lever)"),
    Method("hold_blind_residual_follow_inside", "hold_blind_residual_follow with its action mean kept inside 0.9 "
           "(ppo.bounds_at 0.9, bounds_coef 10); 150 epochs, read at its final checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1)}, status="experimental",
           evidence="results/screen/RULE.md (twentieth lever)"),
    Method("hold_blind_residual_paced_inside", "hold_blind_residual_follow_inside no faster than its expert: the part "
           "at most a fifth of its range ahead of the drag's schedule in all but 5% of steps; 150 epochs, final "
           "checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1, bounded("lead", 0.2, budget=0.05))},
           status="experimental", evidence="results/screen/RULE.md (twenty-first lever)"),
    Method("hold_blind_residual_paced_horizon", "hold_blind_residual_paced_inside, an episode whose part once leads "
           "its schedule by a quarter of its range charged to its horizon (in 1% of steps at most): x1's few worlds "
           "left the rate unpaid; 150 epochs, final checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1, bounded("lead", 0.25, "horizon", 0.01))},
           status="experimental", evidence="results/screen/RULE.md (twenty-second lever)"),
    Method("hold_blind_residual_unhurried", "hold_blind_residual_follow_inside at a person's pace: the settled palm "
           "past PALM_PACE (0.15 m/s) in at most 1% of steps; 150 epochs, final checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1, UNHURRIED)},
           status="experimental", evidence="results/screen/RULE.md (twenty-third lever)"),
    Method("hold_blind_residual_unhurried_log", "hold_blind_residual_unhurried with its dampings drawn log-uniform "
           "over [1, 8] (a third of the worlds below x2, where a door can be rushed); 150 epochs, final checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1, UNHURRIED), "task.damping_log": True},
           status="experimental", evidence="results/screen/RULE.md (twenty-fourth lever)"),
    Method("hold_blind_residual_wrapped", "hold_blind_residual_unhurried_log over the grasp that holds the most "
           "among the hooks and the wraps (the palm over the bar, the fingers around it), planned on the hand's "
           "contacts and rested there: its wrist's target where it rests, its fingers' grip_closure past; 150 "
           "epochs, final checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1, UNHURRIED), "task.damping_log": True, "task.expert_grasp": "planned",
            "task.expert_plan_contact": "scene", "task.expert_wrap": True, "task.expert_rest": True},
           status="experimental", evidence="results/screen/RULE.md (twenty-fifth lever)"),
    Method("hold_blind_residual_either", "hold_blind_residual_unhurried_log with the wraps among its expert's "
           "placements (the one that holds the most kept, on either contacts); 150 epochs, final checkpoint",
           {**FOLLOWING_INSIDE, **within(0.1, UNHURRIED), "task.damping_log": True, "task.expert_wrap": True},
           status="experimental", evidence="results/screen/RULE.md (twenty-fifth lever)"),
    Method("hold_blind_residual_chosen", "hold_blind_residual_either with its expert's grasp chosen from clear "
           "starts (task.expert_placement starts: within 2 mm, then the load held from every start, then the lighter "
           "pull); 150 epochs, final checkpoint", CHOSEN,
           status="experimental", evidence="results/screen/RULE.md (twenty-sixth lever)"),
    Method("hold_blind_residual_chosen_tight", "hold_blind_residual_chosen with a fifth of the load bound's budget: "
           "1% of steps after an episode first pulls past 1.1x its expert's peak from its start; 150 epochs, final "
           "checkpoint", CHOSEN_TIGHT, status="experimental", evidence="results/screen/RULE.md (twenty-seventh lever)"),
    Method("hold_blind_residual_chosen_margin", "hold_blind_residual_chosen_tight with its expert's grasp chosen "
           "within 1.5 mm (task.expert_depth), half a millimetre for the policy's own press below the 2 mm bound; 150 "
           "epochs, final checkpoint", CHOSEN_MARGIN,
           status="experimental", evidence="results/screen/RULE.md (twenty-eighth lever)"),
    Method("hold_blind_residual_from_start", "hold_blind_residual_chosen_margin with the margin ranked after the load "
           "held (task.expert_placement starts_hold) and the drag begun where the part began, then at its own pace "
           "(task.prior_from_start for task.prior_floor: a part pulled ahead does not take the drag along); 150 "
           "epochs, final checkpoint", FROM_START,
           status="experimental", evidence="results/screen/RULE.md (twenty-ninth lever)"),
    Method("hold_blind_residual_eased", "hold_blind_residual_from_start with the residual eased in over an episode's "
           "first 10 steps (task.residual_ramp); 150 epochs, final checkpoint", EASED,
           status="experimental", evidence="results/screen/RULE.md (thirtieth lever)"),
    Method("hold_blind_residual_eased_fine", "hold_blind_residual_eased with the residual's pull at an eighth of the "
           "action range (a quarter before); 150 epochs, final checkpoint", {**EASED, **reach(0.125, "translation")},
           status="experimental", evidence="results/screen/RULE.md (thirty-first lever)"),
    Method("hold_blind_residual_eased_wrist", "hold_blind_residual_eased_fine with the wrist's turn narrowed as its "
           "pull (reach 0.125 on the six wrist channels; the fingers keep the whole range); 150 epochs, final "
           "checkpoint", EASED_WRIST, status="experimental", evidence="results/screen/RULE.md (thirty-second lever)"),
    Method("hold_blind_residual_wide", "hold_blind_residual_eased_wrist with its expert's grasp chosen from 24 clear "
           "starts (8 before); 150 epochs, final checkpoint", WIDE,
           status="experimental", evidence="results/screen/RULE.md (thirty-third lever)"),
    Method("hold_blind_residual_wide_hand", "hold_blind_residual_wide with the fingers' residual at an eighth too "
           "(reach 0.125 on every channel); 150 epochs, final checkpoint", WIDE_HAND,
           status="experimental", evidence="results/screen/RULE.md (thirty-fourth lever)"),
    Method("hold_blind_residual_own_pace", "hold_blind_residual_wide_hand with its palm's pace bounded by its prior's "
           "own (1.1x the expert drag's settled palm peak at x1, not 0.15 m/s); 150 epochs, final checkpoint", OWN_PACE,
           status="experimental", evidence="results/screen/RULE.md (thirty-fifth lever)"),
    Method("hold_blind_residual_own_pace_peak", "hold_blind_residual_own_pace with its pace bound on each episode's "
           "peak (every step after the palm first passed 1.1x its prior's pace charged), not a rate of steps; 150 "
           "epochs, final checkpoint", OWN_PACE_PEAK,
           status="experimental", evidence="results/screen/RULE.md (thirty-sixth lever)"),
    Method("hold_blind_residual_own_pace_horizon", "hold_blind_residual_own_pace_peak with its pace bound charged to "
           "the horizon (an episode that succeeds after its palm passed 1.1x its prior's pace pays the steps it had "
           "left); 150 epochs, final checkpoint", OWN_PACE_HORIZON,
           status="experimental", evidence="results/screen/RULE.md (thirty-seventh lever)"),
    Method("hold_blind_residual_own_pace_wider", "hold_blind_residual_own_pace_horizon trained over x1-x12 "
           "(log-uniform), so that x8 lies inside its training range; 150 epochs, final checkpoint", OWN_PACE_WIDER,
           status="experimental", evidence="results/screen/RULE.md (thirty-eighth lever)"),
    Method("hold_blind_residual_relative_excess", "hold_blind_residual_relative with the cost the load's excess over "
           "the expert's peak, not the rate of steps past it: at most 1% past it on average; 150 "
           "epochs, read at its final checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **RELATIVE_EXCESS_BOUND, **SMOOTH},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_paced", "hold_blind_residual_smooth no faster than the expert: the part at most a "
           "tenth of its range ahead of the expert drag's schedule in all but 5% of steps (a second CMDP constraint); "
           "150 epochs, read at its final checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **LEAD_BOUND, **SMOOTH},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_residual_change", "hold_blind_residual_load with the applied action's change per step bounded "
           "(past 0.2 action units, a second CMDP constraint on the sampled actions): its multiplier reaches its cap "
           "and the budget is never met; 150 epochs, read at its final checkpoint",
           {**HOLD, **READ_FINAL, **RESIDUAL, **CHANGE_BOUND},
           status="experimental", evidence="results/archive.md §3b"),
    Method("hold_blind_cmdp", "PICA-Hold without force or touch sensing and with the wrist load as a CMDP constraint "
           "(the load is seen by the critic and the cost, never by the policy)",
           {**HOLD, "task.reward.constraints": (Constraint(),)},
           status="superseded", evidence="results/archive.md §3"),
)}
#: ``--method recommended``: the project's recipe for one object, wherever a method is taken.
RECOMMENDED = "hold_blind_residual_seated"
#: What ``train`` trains when no method is named.
DEFAULT_METHOD = RECOMMENDED


def resolve(name: str) -> str:
    """A method's name, ``recommended`` resolved (a run records the recipe it trained, not the alias)."""
    name = RECOMMENDED if name == "recommended" else name
    if name not in METHODS:
        raise DragMeshError(f"unknown method {name!r} (choose from recommended, {', '.join(METHODS)}; "
                            "dragmesh2 train --list-methods says what each is)")
    return name


def get_method(name: str) -> Method:
    return METHODS[resolve(name)]


def offered() -> list[str]:
    """The methods ``--method`` names in its help: the paper's, the recommended and the generalist."""
    return [m.name for m in METHODS.values() if m.status in OFFERED]
