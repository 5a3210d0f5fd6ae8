"""A training run from start to finish: checkpoint selection by robustness and its curve, TensorBoard scalars,
every metric the epoch returns in the log, and the paper's diagnostic fine-tunes started from a checkpoint."""

import dataclasses
import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import jax
import numpy as np
import pytest
from tensorboardX.proto import event_pb2

from dragmesh2_jax.baselines.tracking import TRACKING
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.evaluation.protocol import SELECTION, EvalProtocol
from dragmesh2_jax.ppo.train import epoch_jit, init_jit
from dragmesh2_jax.runs import session
from dragmesh2_jax.runs.commands import evaluate_baseline, evaluate_checkpoint, finetune_run, load_run
from dragmesh2_jax.runs.finetunes import FINETUNES, get_finetune
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import robust_score, start_or_resume, training_success
from dragmesh2_jax.runs.spec import finetune_spec
from dragmesh2_jax.task.config import AramConfig, ReconfigConfig
from dragmesh2_jax.task.rewards import BASE_TERMS, TERM_PREFIX
from tests.conftest import TINY_RUNS, require_package, tiny_spec

pytestmark = pytest.mark.xdist_group(TINY_RUNS)  # its trained run is built once, beside the others

REPO = Path(__file__).resolve().parents[2]
WANDB_TIMEOUT_S = 600

SELECT = dataclasses.replace(SELECTION, episodes=2)
CHECKED = {"epochs": 4, "robust_every": 2}  # the trained run's schedule: a robustness check every other epoch


@pytest.fixture(scope="session")
def trained_run(tmp_path_factory):
    run = RunDir(tmp_path_factory.mktemp("runs") / "pica")
    start_or_resume(tiny_spec(schedule=CHECKED), [run], resume=False, selection=SELECT, progress=False)
    return run


def test_training_keeps_best_robust_and_its_evaluation_curve(trained_run):
    rows = trained_run.robust_rows()
    assert [r["epoch"] for r in rows] == [2, 4]
    assert {"mean_success", "worst_success", "clip099_active", "success_x1", "success_x2", "success_x4"} <= set(rows[0])
    assert rows[0]["selected"]  # the first evaluation is the best so far
    assert (trained_run.path / "robust.csv").is_file()
    assert trained_run.policy_checkpoint().name == "best_robust"  # evaluate/demo default
    _, ts, _, ck = load_run(trained_run.path)
    best = max(rows, key=robust_score)
    assert int(ts.epoch) == best["epoch"] and ck.name == "best_robust"


def test_the_log_keeps_every_metric_the_epoch_returns(trained_run):
    p = load_run(trained_run.path)[0]
    _, metrics = epoch_jit(p, p.task.data, init_jit(p, p.task.data, jax.random.PRNGKey(0)))
    row = trained_run.log_rows()[0]
    assert set(metrics) <= set(row) and {"epoch", "seconds", "env_steps"} <= set(row)
    header = (trained_run.path / "log.csv").read_text().splitlines()[0].split(",")
    assert set(header) == set(row)
    # every term of the reward, each its own column (Playground's reward/<name>)
    assert {TERM_PREFIX + t for t in BASE_TERMS} <= set(row) and len(BASE_TERMS) >= 8


def tensorboard_scalars(folder) -> dict[str, list[int]]:
    """tag -> steps as TensorBoard shows them, read from its event files (TFRecord framing: length, crc, event, crc):
    a resumed writer's purge (a session start at step s) drops the steps >= s written before it."""
    out: dict[str, list[int]] = {}
    for f in sorted(folder.glob("events.out.tfevents.*")):
        data, i = f.read_bytes(), 0
        while i < len(data):
            (n,) = struct.unpack("<Q", data[i:i + 8])
            event = event_pb2.Event.FromString(data[i + 12:i + 12 + n])
            i += 12 + n + 4
            if event.HasField("session_log") and event.session_log.status == event_pb2.SessionLog.START:
                out = {tag: [s for s in steps if s < event.step] for tag, steps in out.items()}
            for v in event.summary.value:
                out.setdefault(v.tag, []).append(event.step)
    return out


def test_tensorboard_scalars_beside_the_logs(trained_run):
    tags = tensorboard_scalars(trained_run.tensorboard)
    assert tags["train/reward"] == [1, 2, 3, 4] and tags["train/clip099"] == [1, 2, 3, 4]
    assert tags["robust/mean_success"] == [2, 4]
    assert tags["train/reward/task"] == [1, 2, 3, 4]


def _at(tree, path: str):
    for name in path.split("."):
        tree = getattr(tree, name)
    return tree


def test_every_finetune_preset_is_the_parents_run_with_the_recipes_task(trained_run):
    parent = trained_run.spec()
    for name in FINETUNES:
        spec = finetune_spec(parent, name, "ck", 9)
        assert spec.schedule == dataclasses.replace(parent.schedule, epochs=9)
        assert spec.finetune == name and spec.parent == "ck"
        assert (spec.ppo, spec.network, spec.scene) == (parent.ppo, parent.network, parent.scene)
        assert all(_at(spec, path) == value for path, value in get_finetune(name).overrides.items())
        # the recipes change the reward and the damping range, nothing else of the parent's task
        assert dataclasses.replace(spec.task, reward=parent.task.reward,
                                   damping_range=parent.task.damping_range) == parent.task
    assert finetune_spec(parent, "damp_2_4", "ck", 9).task.damping_range == (2.0, 4.0)
    assert finetune_spec(parent, "continued", "ck", 9, {"robust_every": 0}).schedule.robust_every == 0


def test_training_success_is_read_where_episodes_ended():
    """Worlds reset together finish together, so an epoch may end no episode (its success reads 0): what a command
    reports as the training success is the last epoch's in which episodes ended, or that none did."""
    rows = [{"epoch": 1, "episodes": 4, "success": 0.5}, {"epoch": 2, "episodes": 6, "success": 1.0},
            {"epoch": 3, "episodes": 0, "success": 0.0}]
    assert training_success(rows) == "training success 1.00 (epoch 2's episodes)"
    assert training_success(rows[2:]) == training_success([]) == "no training episode ended"


def test_aram_reconfig_finetune_runs_and_updates_lambda(trained_run, tmp_path, monkeypatch):
    """ARAM + Reconfig continue the run, and ARAM's lambda moves once per epoch by its rule (``aram_update``): where
    the epoch's episodes ended and succeeded more than the gate, lambda <- clip(lambda + lr (clip099 - target), 0,
    lambda_max), from the parent's lambda. The tiny run's episodes neither end within the fine-tune nor succeed, so
    the preset's gate would hold lambda at 0: here episodes last 4 steps (two end per world and epoch), the gate is
    below any success and the target below any clip099, so the rule raises lambda every epoch."""
    aram = AramConfig(success_gate=-1.0, target=-0.5)
    both = FINETUNES["both"]
    monkeypatch.setitem(FINETUNES, "both", dataclasses.replace(both, overrides={
        **both.overrides, "task.reward.aram": aram, "task.episode_length": 4}))
    parent, rows = finetune_run(str(trained_run.path), "both", str(tmp_path / "ft"), epochs=2,
                                schedule={"robust_every": 0}, progress=False)
    _, start, _, _ = load_run(parent)
    assert parent.name == "best_robust" and [r["epoch"] for r in rows] == [int(start.epoch) + 1, int(start.epoch) + 2]
    lam = np.float32(start.aram_lambda)
    assert lam == 0.0  # the parent had no ARAM: lambda starts where a new run's does
    for r in rows:
        assert r["episodes"] > 0 and r["success"] > aram.success_gate  # the gate opens
        lam = np.clip(lam + np.float32(aram.lr) * (np.float32(r["clip099"]) - np.float32(aram.target)), 0.0,
                      aram.lambda_max)
        assert r["aram_lambda"] == pytest.approx(lam, rel=1e-6), r["epoch"]
    assert 0.0 < rows[0]["aram_lambda"] < rows[1]["aram_lambda"]  # it rose every epoch
    assert all({"reward/aram", "reward/reconfig"} <= set(r) and r["reward/reconfig"] >= 0.0 for r in rows)
    ft = RunDir(tmp_path / "ft")
    spec = ft.spec()
    assert spec.finetune == "both" and spec.task.reward.aram == aram and spec.parent == str(parent.resolve())
    program, ts, _, _ = load_run(ft.path)  # the record rebuilds the fine-tune's task
    assert program.task.config.reward.reconfig == ReconfigConfig() and program.task.config.reward.aram == aram
    assert float(ts.aram_lambda) == pytest.approx(rows[-1]["aram_lambda"])  # and its lambda is kept


def test_the_robustness_checks_run_the_schedules_episodes(tmp_path, monkeypatch):
    """Without a protocol given, a check is the selection protocol at the schedule's ``robust_episodes``."""
    seen, check = [], session.selection_check
    monkeypatch.setattr(session, "selection_check", lambda program, p, heldout: seen.append(p) or check(program, p,
                                                                                                     heldout))
    run = RunDir(tmp_path / "run")
    start_or_resume(tiny_spec(schedule={"epochs": 1, "robust_every": 1, "robust_episodes": 3}), [run], resume=False,
                    progress=False)
    assert seen == [dataclasses.replace(SELECTION, episodes=3)] and run.spec().schedule.robust_episodes == 3
    assert [r["epoch"] for r in run.robust_rows()] == [1]


def test_a_finetune_seed_starts_its_own_stream_and_is_recorded(trained_run, tmp_path):
    """Fine-tunes of one checkpoint under two seeds: each recorded, each its own worlds and sampling; without a seed
    the run's seed, continuing the checkpoint's stream."""
    logs = {}
    for seed in (None, 5, 6):
        out = tmp_path / f"ft_{seed}"
        schedule = {"robust_every": 0} | ({} if seed is None else {"seed": seed})
        _, logs[seed] = finetune_run(str(trained_run.path), "continued", str(out), epochs=1, schedule=schedule,
                                     progress=False)
        assert RunDir(out).spec().schedule.seed == (trained_run.spec().schedule.seed if seed is None else seed)
    assert len({logs[s][0]["reward"] for s in logs}) == 3


def test_the_same_scalars_go_to_weights_and_biases_offline(tmp_path, monkeypatch):
    """``--wandb PROJECT``: training hands the project to the run's scalar writer, which logs the TensorBoard scalars
    (training and robustness) to W&B too, here offline. The writer runs on a trained run's rows in a process of its
    own: W&B's service threads outlive ``finish()`` and must not share a worker with MuJoCo's."""
    require_package("wandb")
    projects = []

    class Recorder(session._Scalars):
        def __init__(self, run, resumed_from, wandb_project):
            projects.append(wandb_project)
            super().__init__(run, resumed_from, None)

    monkeypatch.setattr(session, "_Scalars", Recorder)
    run = RunDir(tmp_path / "run")
    start_or_resume(tiny_spec(schedule=CHECKED), [run], resume=False, selection=SELECT, progress=False,
                    wandb="dragmesh2-test")  # the trained_run fixture's program: compiled already
    assert projects == ["dragmesh2-test"]
    script = ("from dragmesh2_jax.runs.rundir import RunDir\n"
              "from dragmesh2_jax.runs.session import _Scalars\n"
              f"run = RunDir({str(run.path)!r})\n"
              "with _Scalars(run, None, 'dragmesh2-test') as board:\n"
              "    for row in run.log_rows():\n"
              "        board.write('train', row)\n"
              "    for row in run.robust_rows():\n"
              "        board.write('robust', row)\n")
    env = {**os.environ, "WANDB_MODE": "offline", "WANDB_SILENT": "true"}
    subprocess.run([sys.executable, "-c", script], env=env, cwd=REPO, check=True, timeout=WANDB_TIMEOUT_S)
    (log,) = (run.path / "wandb").glob("offline-run-*/run-*.wandb")
    data = log.read_bytes()
    assert all(key.encode() in data for key in ("train/success", "train/loss", "robust/mean_success"))
    assert b"dragmesh2-test" in data and b"pica" in data  # the project, and the run record as its config


def test_a_runs_expert_is_evaluated_on_the_runs_own_task_from_the_same_starts(trained_run, tmp_path):
    """``evaluate --checkpoint RUN --method tracking``: the expert drag the run trained over (its trajectory, grasp and
    contacts), replayed from the protocol's starts, is the same evaluation as the controller on the run's object and
    trajectory, written beside the policy's under the controller's name."""
    run = shutil.copytree(trained_run.path, tmp_path / "run")
    protocol = EvalProtocol(dampings=(1.0,), modes=("det",), episodes=2)
    result, path = evaluate_checkpoint(str(run), protocol, "mujoco", baseline=TRACKING)
    assert path == RunDir(run).evaluation_path(run / "checkpoints" / TRACKING, protocol)
    alone = evaluate_baseline(TRACKING, RunDir(run).spec().object, str(run / "trajectory.json"), protocol, "mujoco")
    for key in ("success_rate", "wrist_load_peak_n", "penetration_max_mm"):
        assert result["cells"][0][key] == alone["cells"][0][key]
    with pytest.raises(DragMeshError, match="unknown controller"):
        evaluate_checkpoint(str(run), protocol, "mujoco", baseline="teleport")
