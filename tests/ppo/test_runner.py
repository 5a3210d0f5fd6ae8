"""The training run: checkpoint selection by robustness, its evaluation curve, and the paper's diagnostic
fine-tunes started from a checkpoint."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.ppo.finetune import FINETUNES
from dragmesh2_jax.ppo.runner import RobustSelection, train
from dragmesh2_jax.runs import load_run, make_finetune, make_trainer, resolve_checkpoint
from dragmesh2_jax.task.config import AramConfig, ReconfigConfig
from dragmesh2_jax.task.rewards import aram_penalty, reconfig_bonus

OBJ = str(default_object())


@pytest.fixture(scope="module")
def trained_run(tmp_path_factory):
    run = tmp_path_factory.mktemp("runs") / "pica"
    trainer = make_trainer(OBJ, None, "pica", "mujoco", num_envs=4, rollout_len=8, epochs=4)
    train(trainer, run, OBJ, progress=False, selection=RobustSelection(every=2, episodes=2))
    return run


def test_training_keeps_best_robust_and_its_evaluation_curve(trained_run):
    rows = [json.loads(x) for x in (trained_run / "robust.jsonl").read_text().splitlines()]
    assert [r["epoch"] for r in rows] == [2, 4]
    assert {"mean_success", "worst_success", "clip099_active", "success_x1", "success_x2", "success_x4"} <= set(rows[0])
    assert rows[0]["selected"]  # the first evaluation is the best so far
    assert (trained_run / "robust.csv").is_file()
    assert resolve_checkpoint(trained_run).name == "best_robust"  # evaluate/demo default
    _, ts, _, ck = load_run(trained_run, backend="mujoco")
    best = max(rows, key=lambda r: (r["mean_success"], r["worst_success"], -r["clip099_active"]))
    assert int(ts.epoch) == best["epoch"] and ck.name == "best_robust"


def _tensorboard_scalars(folder) -> dict[str, list[int]]:
    """tag -> steps, read from TensorBoard event files (TFRecord framing: length, crc, event, crc)."""
    import struct

    from tensorboardX.proto import event_pb2

    out: dict[str, list[int]] = {}
    for f in sorted(folder.glob("events.out.tfevents.*")):
        data, i = f.read_bytes(), 0
        while i < len(data):
            (n,) = struct.unpack("<Q", data[i:i + 8])
            event = event_pb2.Event.FromString(data[i + 12:i + 12 + n])
            i += 12 + n + 4
            for v in event.summary.value:
                out.setdefault(v.tag, []).append(event.step)
    return out


def test_tensorboard_scalars_beside_the_logs(trained_run):
    tags = _tensorboard_scalars(trained_run / "tb")
    assert tags["train/reward"] == [1, 2, 3, 4] and tags["train/clip099"] == [1, 2, 3, 4]
    assert tags["robust/mean_success"] == [2, 4]


def test_every_finetune_preset_builds_from_a_checkpoint(trained_run):
    for name in FINETUNES:
        trainer, start, parent = make_finetune(trained_run, name, backend="mujoco", epochs=1)
        assert trainer.config.epochs == int(start.epoch) + 1 and parent.name == "best_robust"
    trainer, _, _ = make_finetune(trained_run, "damp_2_4", backend="mujoco")
    assert trainer.task.config.damping_range == (2.0, 4.0) and trainer.config.epochs == int(start.epoch) + 50


def test_aram_reconfig_finetune_runs_and_updates_lambda(trained_run, tmp_path):
    trainer, start, parent = make_finetune(trained_run, "both", backend="mujoco", epochs=2)
    assert trainer.task.config.reward.aram is not None and trainer.task.config.reward.reconfig is not None
    _, rows = train(trainer, tmp_path / "ft", OBJ, progress=False, selection=RobustSelection(every=0),
                    start=start, meta={"finetune": "both", "parent": str(parent)})
    assert [r["epoch"] for r in rows] == [int(start.epoch) + 1, int(start.epoch) + 2]
    assert all("aram_lambda" in r and 0.0 <= r["aram_lambda"] <= 1.0 for r in rows)
    meta = json.loads((tmp_path / "ft" / "run.json").read_text())
    assert meta["finetune"] == "both" and meta["task"]["reward"]["aram"]["stall_steps"] == 5
    trainer2, ts2, _, _ = load_run(tmp_path / "ft", backend="mujoco")  # the record rebuilds the fine-tune task
    assert trainer2.task.config.reward.reconfig == ReconfigConfig()


def test_aram_penalises_large_actions_only_after_a_stall():
    cfg = AramConfig()
    a = jnp.full(51, 0.5)  # ||a|| = 3.6 > 1
    stall, pens = jnp.int32(0), []
    for _ in range(6):
        pen, stall = aram_penalty(cfg, 0.5, stall, 0.05, a, 0.0, 0.3, revolute=False)
        pens.append(float(pen))
    assert pens[:4] == [0.0] * 4 and pens[4] == pytest.approx(-0.5 * 0.25)  # gate opens at stall >= 5
    pen, stall = aram_penalty(cfg, 0.5, stall, 0.05, a, 0.02, 0.3, revolute=False)  # the joint moved
    assert float(pen) == 0.0 and int(stall) == 0


def test_reconfig_rewards_regained_contact_then_cools_down():
    cfg, K = ReconfigConfig(), 5
    # d over the last 2K+1 steps: slipping (0.095 -> 0.09), then contact regained (0.09 -> 0.05)
    d = jnp.asarray(np.r_[np.full(K, 0.095), 0.09, np.linspace(0.08, 0.05, K)], jnp.float32)
    q = jnp.zeros(2 * K + 1)
    a = jnp.full(51, 0.3)
    bonus, cooldown = reconfig_bonus(cfg, jnp.int32(0), d, q, a, a, jnp.zeros(51), 0.3, K)
    assert float(bonus) == pytest.approx(0.2 * 0.04 + 0.5 * 0.005, rel=1e-3) and int(cooldown) == cfg.cooldown
    bonus, cooldown = reconfig_bonus(cfg, cooldown, d, q, a, a, jnp.zeros(51), 0.3, K)
    assert float(bonus) == 0.0 and int(cooldown) == cfg.cooldown - 1
