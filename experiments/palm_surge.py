"""Where does a policy's palm surge? The run's det policy rolled out at one damping from the evaluation's starts
(``--bank``: the training bank's), each episode's settled palm peak (after ``protocol.START_STEPS``, as the
evaluation's figure) and, for the episodes that peak highest, the steps around their peak: palm speed, wrist load,
the part's progress, the palm-handle distance and the policy's own largest |a| on the wrist's translation and on the
fingers.

    python experiments/palm_surge.py RUN --damping 8 --episodes 50 --show 5

A diagnostic, not a judged run (RULE.md, lever 36: door 111's palm peeling off the bar in the last steps at x8).
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np

from dragmesh2_jax.assets.hand import NUM_VIRTUAL
from dragmesh2_jax.evaluation.protocol import PAPER
from dragmesh2_jax.ppo.train import policy_params
from dragmesh2_jax.runs.commands import load_run
from dragmesh2_jax.task.protocol import START_STEPS

TRANSLATION = 3  # the wrist's translation channels lead the action
AROUND = 4  # steps shown either side of an episode's peak


def traces(run: str, damping: float, episodes: int, bank: bool) -> dict[str, np.ndarray]:
    """Per step and episode (steps x episodes): palm speed (m/s), wrist load (N), live, progress, palm-handle
    distance (m) and the policy's own largest |a| on the translation and on the fingers."""
    program, ts, _, _ = load_run(run, "mujoco")
    task = program.task if bank else PAPER.task(program.task)
    policy, params = program.make_policy(True), policy_params(ts)
    reset = jax.vmap(lambda k, s: task.reset(k, damping, s))
    step, kin = jax.vmap(task.step), jax.vmap(task.kinematics)

    @jax.jit
    def roll(key):
        def body(carry, _):
            state, live = carry
            before = kin(state).palm
            a = jnp.clip(policy(params, state.obs, key), -1, 1)
            state = step(state, a)
            k = kin(state)
            return (state, live & ~state.done), {
                "speed": jnp.linalg.norm(k.palm - before, axis=-1) / task.config.control_dt,
                "load": jnp.linalg.norm(k.force[:, :3], axis=-1), "live": live,
                "progress": state.metrics["progress"], "distance": jnp.linalg.norm(k.handle_pos - k.palm, axis=-1),
                "translation": jnp.abs(a[:, :TRANSLATION]).max(-1), "fingers": jnp.abs(a[:, NUM_VIRTUAL:]).max(-1)}

        start = reset(jax.random.split(key, episodes), jnp.arange(episodes))
        return jax.lax.scan(body, (start, jnp.ones(episodes, bool)), None, length=task.config.episode_length)[1]

    return jax.tree.map(np.asarray, jax.device_get(roll(jax.random.PRNGKey(0))))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("run")
    p.add_argument("--damping", type=float, default=8.0)
    p.add_argument("--episodes", type=int, default=50)
    p.add_argument("--show", type=int, default=5, help="episodes shown, highest peak first")
    p.add_argument("--bank", action="store_true", help="the training bank's starts, not the evaluation's")
    p.add_argument("--above", type=float, default=0.1, help="m/s: count the episodes whose peak passes it")
    args = p.parse_args()
    t = traces(args.run, args.damping, args.episodes, args.bank)
    settled = t["speed"] * t["live"] * (np.arange(t["speed"].shape[0])[:, None] >= START_STEPS)
    peak = settled.max(0)
    print(f"settled palm peak p95 {np.percentile(peak, 95):.3f} m/s; {int((peak > args.above).sum())} of "
          f"{args.episodes} episodes past {args.above} m/s")
    for e in np.argsort(-peak)[:args.show]:
        at = int(settled[:, e].argmax())
        sl = slice(max(0, at - AROUND), at + AROUND)
        print(f"episode {e}: peak {peak[e]:.3f} m/s at step {at} of {int(t['live'][:, e].sum())}, progress "
              f"{t['progress'][at, e]:.2f}, load {t['load'][at, e]:.0f} N")
        for name, scale, digits in (("speed", 1, 3), ("load", 1, 0), ("progress", 1, 3), ("distance", 1000, 1),
                                    ("translation", 1, 2), ("fingers", 1, 2)):
            print(f"  {name:>11}", np.round(t[name][sl, e] * scale, digits))


if __name__ == "__main__":
    main()
