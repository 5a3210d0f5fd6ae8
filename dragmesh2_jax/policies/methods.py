"""Named methods of the paper (Tables 2 and 3) as presets over one network and one PPO: never code forks.

PICA = GLA temporal encoder + the physical signals: contact/saturation regularisers (r_bound, r_contact),
damping randomisation and the causal-window auxiliary loss. Baselines use the same observation without the
physical signals; the two ablations remove one PICA component each.
"""

from __future__ import annotations

from dataclasses import dataclass

from dragmesh2_jax.errors import DragMeshError


@dataclass(frozen=True)
class Method:
    name: str
    encoder: str  # none | flat | gla | gru | transformer
    physical_signals: bool  # r_bound + r_contact, damping randomisation, aux loss
    description: str


METHODS = {m.name: m for m in (
    Method("pica", "gla", True, "PICA: GLA contact-history encoder + physical signals (ours)"),
    Method("state_only", "none", False, "state-only PPO: MLP on s_t"),
    Method("flat_history", "flat", False, "flat-history PPO: s_t + flattened history"),
    Method("gru", "gru", False, "GRU-PPO over the same history window"),
    Method("transformer", "transformer", False, "Transformer-PPO (1 causal block) over the history window"),
    Method("gla_only", "gla", False, "ablation w/o PICA: GLA encoder without the physical signals"),
    Method("pica_flat", "flat", True, "ablation w/o GLA: physical signals with the flat-history encoder"),
)}


def get_method(name: str) -> Method:
    if name not in METHODS:
        raise DragMeshError(f"unknown method {name!r} (choose from {', '.join(METHODS)})")
    return METHODS[name]


def task_overrides(method: Method) -> dict:
    """TaskConfig changes for a method: without physical signals, no PICA reward terms and nominal damping."""
    from dragmesh2_jax.task.config import RewardConfig

    if method.physical_signals:
        return {}
    return {"reward": RewardConfig(w_bound=0.0, w_contact=0.0), "damping_range": (1.0, 1.0)}
