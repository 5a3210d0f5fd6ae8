"""The generalist as part of the tool: ``train --generalist`` over the procedural mix of every category (trained,
resumed, its objects held aside across categories), its policy packaged as an exported actor that ``evaluate``,
``video``, ``finetune`` and ``open`` take as ``--checkpoint generalist``, and the packaged one that ships."""

import json
import math
from pathlib import Path

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.assets.procedural import (
    CATEGORIES,
    GENERALIST_MIX,
    default_object,
    held_aside_by_category,
    packaged_object,
)
from dragmesh2_jax.evaluation.protocol import EvalProtocol
from dragmesh2_jax.ppo.config import PPOConfig
from dragmesh2_jax.ppo.train import policy_params
from dragmesh2_jax.runs.commands import evaluate_checkpoint, load_run
from dragmesh2_jax.runs.generalist import AS_A_PERSON, GENERALIST, OPEN_EPISODES, generalist_objects, package_run
from dragmesh2_jax.runs.overrides import GENERALIST_ENV_STEPS, GENERALIST_EPOCHS, GENERALIST_ROBUST_EPISODES
from dragmesh2_jax.runs.rundir import ACTOR_NAME, PACKAGED, RunDir
from dragmesh2_jax.runs.spec import method_defaults
from dragmesh2_jax.task.mix import CURRICULUM_PRIOR, CURRICULUM_RATE
from dragmesh2_jax.trajectory.schema import read_trajectory
from tests.conftest import TINY_RUNS, installed_command, require_warp

pytestmark = pytest.mark.xdist_group(TINY_RUNS)  # beside the other tiny runs: the engine's programs compile once

dragmesh2 = installed_command()
SHIPPED = PACKAGED[GENERALIST]  # the packaged generalist (the fixtures below stand a tiny one in its place)
#: Two categories, three objects: one drawer cabinet trained on, a drawer cabinet and a door cabinet held aside.
TINY_MIX = {"drawer_cabinet": 2, "door_cabinet": 1}
TINY = ["--epochs", "2", "--num-envs", "2", "--ppo.rollout-len", "8", "--robust-every", "2", "--save-every", "2",
        "--network.state-sizes", "32,32", "--network.hist-dim", "16", "--network.heads", "2",
        "--network.critic-sizes", "32", "--backend", "mujoco", "--quiet"]


def test_the_mix_has_every_category_and_holds_one_of_each_aside():
    assert set(GENERALIST_MIX) == set(CATEGORIES)
    names = [f"{c}_{procedural.GENERALIST_SEED + i:04d}" for c, k in GENERALIST_MIX.items() for i in range(k)]
    objects, trajectories, held = held_aside_by_category(names, [f"{n}.json" for n in names])
    assert held == len(CATEGORIES) and sorted(objects) == sorted(names)
    assert [t[:-5] for t in trajectories] == objects  # each trajectory stays with its object
    assert {procedural.category_of(o) for o in objects[-held:]} == set(CATEGORIES)  # one of each, last
    assert all(objects.index(o) < len(objects) - held for o in names if o not in objects[-held:])


def test_the_budget_is_ten_million_env_steps_at_the_default_batch():
    batch = PPOConfig().num_envs * PPOConfig().rollout_len
    assert math.ceil(GENERALIST_ENV_STEPS / batch) == GENERALIST_EPOCHS
    spec = method_defaults(GENERALIST)
    assert spec.schedule.epochs == GENERALIST_EPOCHS and spec.task.observation == "handle"
    assert spec.schedule.checkpoint == "final" and spec.network.critic == "privileged"
    assert spec.schedule.robust_episodes == GENERALIST_ROBUST_EPISODES >= 4 * len(CATEGORIES)  # each held aside ~4x


@pytest.fixture(scope="module")
def generalist_run(tmp_path_factory, monkeypatch_module):
    monkeypatch_module.setattr(procedural, "GENERALIST_MIX", TINY_MIX)
    out = tmp_path_factory.mktemp("generalist") / "run"
    assert dragmesh2(["train", "--generalist", "--out", str(out), "--seed", "3", *TINY]) == 0
    return out


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        yield mp


def test_train_generalist_trains_its_method_over_its_mix_and_resumes(generalist_run, capsys):
    spec = RunDir(generalist_run).spec()
    assert spec.method == GENERALIST and spec.schedule.seed == 3 and spec.schedule.epochs == 2
    assert [Path(o).name for o in spec.objects] == ["drawer_cabinet_2000", "door_cabinet_2000",
                                                    "drawer_cabinet_2001"]  # the last of each category held aside
    assert spec.holdout == 2 and (generalist_run / "objects" / "manifest.csv").is_file()
    assert RunDir(generalist_run).robust_rows()  # checked on the held-aside objects
    assert dragmesh2(["train", "--generalist", "--out", str(generalist_run), "--resume", "--epochs", "3",
                      "--backend", "mujoco", "--quiet"]) == 0
    assert RunDir(generalist_run).log_rows()[-1]["epoch"] == 3
    capsys.readouterr()
    for bad in (["--object", str(default_object())], ["--dataset", str(generalist_run / "objects")]):
        assert dragmesh2(["train", "--generalist", "--out", str(generalist_run / "x"), *bad]) == 2
        assert capsys.readouterr().err.startswith("error: --generalist trains over its own objects")


def test_train_generalist_trains_another_method_over_the_mix_under_that_method_s_own_grasp(tmp_path, monkeypatch):
    """``--method generalist_residual``: the residual over each object's expert drag, its expert's grasp seated
    (``task.expert_grasp``), so its trajectories are generated under that grasp, not taken from the mix's dataset
    (the generator's planned grasp); a resume keeps the recorded method without naming it."""
    monkeypatch.setattr(procedural, "GENERALIST_MIX", TINY_MIX)
    out = tmp_path / "run"
    assert dragmesh2(["train", "--generalist", "--method", "generalist_residual", "--out", str(out), "--seed", "3",
                      *TINY]) == 0
    run = RunDir(out)
    assert run.spec().method == "generalist_residual" and run.spec().holdout == 2 and len(run.spec().objects) == 3
    dataset = out / "objects" / "trajectories" / f"{Path(run.spec().objects[0]).name}.json"
    generated = {w: read_trajectory(path).header["generator"]["params"]
                 for w, path in (("dataset", dataset), ("run", run.trajectory_path))}
    assert generated["dataset"]["seat_depth"] is None and generated["dataset"]["placement_choice"] == "first"
    assert generated["run"]["seat_depth"] is not None and generated["run"]["placement_choice"] == "holds"
    assert dragmesh2(["train", "--generalist", "--out", str(out), "--resume", "--epochs", "3", "--backend",
                      "mujoco", "--quiet"]) == 0
    assert run.log_rows()[-1]["epoch"] == 3 and RunDir(out).spec().method == "generalist_residual"


def test_train_generalist_distils_from_a_specialist_on_its_training_object(tmp_path, monkeypatch):
    """``--method generalist_distilled --teachers RUN``: a generalist_residual specialist trained on the mix's one
    training object (a folder of its own: the same object by content) labels the student's every world; the record
    keeps it and a resume reads it back."""
    monkeypatch.setattr(procedural, "GENERALIST_MIX", TINY_MIX)
    student, teacher = tmp_path / "student", tmp_path / "teacher"
    objects = generalist_objects(tmp_path / "mix", progress=False)[0]
    assert dragmesh2(["train", "--method", "generalist_residual", "--object", objects[0], "--out", str(teacher),
                      *TINY]) == 0
    assert dragmesh2(["train", "--generalist", "--method", "generalist_distilled", "--teachers", str(teacher),
                      "--out", str(student), *TINY]) == 0
    run = RunDir(student)
    # pinned to the checkpoint that stood for the teacher (its last epoch's): extended later, it labels as it did
    assert run.spec().teachers == (str((teacher / "checkpoints" / "epoch_0002").resolve()),)
    assert run.spec().ppo.distill_coef > 0
    assert [r["taught"] for r in run.log_rows()] == [1.0, 1.0]  # its one training object is taught
    assert dragmesh2(["train", "--generalist", "--out", str(student), "--resume", "--epochs", "3", "--backend",
                      "mujoco", "--quiet"]) == 0
    assert run.log_rows()[-1]["taught"] == 1.0


@pytest.mark.long
@pytest.mark.xdist_group("warp")
def test_train_generalist_on_mjx_steps_a_mix_of_categories_in_one_program(tmp_path, monkeypatch):
    """``--backend mjx``: the training mix (a drawer cabinet and a door cabinet) and the held-aside one are built on
    the one-structure template, one compiled program each (MJX-Warp: the cheaper compile on a CPU; MJX-JAX steps the
    same mix in tests/task/test_mix.py); the run records the mix's contact budget."""
    require_warp()
    monkeypatch.setattr(procedural, "GENERALIST_MIX", {"drawer_cabinet": 2, "door_cabinet": 2})
    out = tmp_path / "run"
    tiny = [*TINY[:TINY.index("--backend")], "--robust-episodes", "2", "--quiet"]
    assert dragmesh2(["train", "--generalist", "--out", str(out), "--seed", "3", "--backend", "mjx", "--impl", "warp",
                      *tiny]) == 0
    run = RunDir(out)
    assert run.spec().task.resolved_backend() == "mjx" and run.spec().task.impl == "warp"
    assert len(run.spec().objects) - run.spec().holdout == 2  # a drawer and a door trained in one batch
    rows = run.log_rows()
    assert [r["epoch"] for r in rows] == [1, 2] and all(np.isfinite(r["loss"]) and r["overflow"] == 0 for r in rows)
    assert run.robust_rows()[0]["epoch"] == 2  # checked on the held-aside mix, MJX too
    buffers = run.record()["buffers"]  # the mix's one budget, recorded
    assert buffers["contacts"] >= buffers["probed_contacts"] > 0 and buffers["constraints"] > 0


def test_a_new_generalist_into_a_run_is_refused_before_it_writes(generalist_run, capsys):
    objects = generalist_run / "objects"
    before = {p: p.stat().st_mtime_ns for p in objects.rglob("*")}
    capsys.readouterr()
    assert dragmesh2(["train", "--generalist", "--out", str(generalist_run), *TINY]) == 2
    assert capsys.readouterr().err.startswith(f"error: {generalist_run}: already holds a run")
    assert {p: p.stat().st_mtime_ns for p in objects.rglob("*")} == before  # its objects as they were


def test_the_object_curriculum_keeps_each_object_s_success_rate_across_a_resume(tmp_path, monkeypatch):
    """A generalist with the curriculum (``--task.object-curriculum``) over a drawer and a door: episodes of two
    steps end four times per world and epoch and never succeed, so each rate falls by the curriculum's rate every
    epoch, through a checkpoint and a resume."""
    monkeypatch.setattr(procedural, "GENERALIST_MIX", {"drawer_cabinet": 2, "door_cabinet": 2})
    out = tmp_path / "run"
    assert dragmesh2(["train", "--generalist", "--out", str(out), "--seed", "3", *TINY,
                      "--task.object-curriculum", "1", "--task.episode-length", "2"]) == 0
    assert dragmesh2(["train", "--generalist", "--out", str(out), "--resume", "--epochs", "3", "--quiet"]) == 0
    for epoch in (2, 3):
        _, ts, _, _ = load_run(out / "checkpoints" / f"epoch_{epoch:04d}")
        np.testing.assert_allclose(ts.object_success, [CURRICULUM_PRIOR * (1 - CURRICULUM_RATE) ** epoch] * 2,
                                   rtol=1e-5)
    assert [r["draw_peak"] for r in RunDir(out).log_rows()] == pytest.approx([1.0] * 3)  # both fail alike


@pytest.fixture(scope="module")
def packaged(generalist_run, tmp_path_factory, monkeypatch_module):
    dest = package_run(str(generalist_run), tmp_path_factory.mktemp("pkg") / "generalist", "dragmesh2 train ...")
    monkeypatch_module.setitem(PACKAGED, GENERALIST, dest)
    return dest


def test_a_packaged_run_is_its_record_and_its_actor_and_acts_as_the_run(generalist_run, packaged):
    assert sorted(p.name for p in packaged.iterdir()) == ["README.md", ACTOR_NAME, "run.json"]
    record = json.loads((packaged / "run.json").read_text())
    assert record["object"] == "drawer_cabinet_2000" and "dragmesh2 train" in (packaged / "README.md").read_text()
    obj = str(default_object())
    _, ts, run, ck = load_run(str(generalist_run), object_dir=obj)
    _, pts, prun, pck = load_run(GENERALIST)
    assert prun.packaged and pck == packaged / ACTOR_NAME and int(pts.epoch) == int(ts.epoch) == 3
    a, b = policy_params(ts), policy_params(pts)
    for name in ("state_mlp", "temporal", "mu", "log_std"):  # the policy's parameters, exactly
        for x, y in zip(jax.tree.leaves(a["net"]["params"][name]), jax.tree.leaves(b["net"]["params"][name]),
                        strict=True):
            np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(a["state_stats"].mean, b["state_stats"].mean)


def test_checkpoint_generalist_in_evaluate_video_and_finetune(packaged, tmp_path, capsys):
    assert dragmesh2(["evaluate", "--checkpoint", "generalist", "--damping", "1", "--mode", "det", "--episodes", "2",
                      "--backend", "mujoco", "--json"]) == 0
    out = capsys.readouterr()
    (cell,) = json.loads(out.out)["cells"]
    assert cell["episodes"] == 2 and "not written" in out.err
    assert not list(packaged.glob("evaluations")) and not (packaged / ".lock").exists()  # never written
    video = tmp_path / "g.gif"
    assert dragmesh2(["video", "--checkpoint", "generalist", "--damping", "1", "--out", str(video), "--video-every",
                      "100", "--renderer", "matplotlib", "--backend", "mujoco"]) == 0
    assert video.is_file()
    assert dragmesh2(["finetune", "--checkpoint", "generalist", "--recipe", "continued", "--out", str(tmp_path / "ft"),
                      "--epochs", "1", "--robust-every", "0", "--seed", "7", "--backend", "mujoco", "--quiet"]) == 0
    tuned = RunDir(tmp_path / "ft").spec()
    assert tuned.parent == str(packaged / ACTOR_NAME) and tuned.schedule.seed == 7  # one fine-tune per seed


def test_open_writes_a_report_a_video_and_a_still(packaged, tmp_path, capsys):
    out = tmp_path / "open"
    assert dragmesh2(["open", "--object", str(default_object()), "--damping", "2", "--out", str(out), "--episodes",
                      "2", "--video-every", "100", "--renderer", "matplotlib", "--backend", "mujoco"]) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["damping"] == 2.0 and report["episodes"] == 2 and report["method"] == GENERALIST
    assert 0 <= report["success_rate"] <= 1 and report["wrist_load_peak_n"] >= 0
    assert {"report.md", "report.json", "still.png", "trajectory.json"} <= {p.name for p in out.iterdir()}
    assert Path(report["video"]).is_file() and "opened in" in (out / "report.md").read_text()
    # beside the policy, the expert drag from the same starts: whether the object was opened as a person would
    expert = report["expert"]
    assert set(expert) == {"success_rate", "successes", *AS_A_PERSON} and expert["successes"] == 2  # it opens it
    assert expert["wrist_load_peak_n"] > 0 and expert["steps_mean"] > 0
    # the penetration figure (p95 over episodes of each one's deepest contact) beside the deepest of all
    assert all(0 <= x["penetration_p95_mm"] <= x["penetration_max_mm"] for x in (report, expert))
    assert "| policy |" in (out / "report.md").read_text() and "| expert | 2/2 |" in (out / "report.md").read_text()
    printed = capsys.readouterr().out
    assert printed.startswith("drawer_cabinet_0000 at x2: opened ") and "(the expert drag: 2/2" in printed
    assert dragmesh2(["open", "--object", str(tmp_path / "nothing")]) == 2


def test_the_packaged_generalist_ships_under_five_mb_with_its_record_and_command():
    assert (SHIPPED / ACTOR_NAME).stat().st_size < 5 * 2**20
    assert RunDir(SHIPPED).spec().method == GENERALIST
    assert "dragmesh2 train --generalist" in (SHIPPED / "README.md").read_text()


def test_the_packaged_generalist_opens_the_packaged_drawer(monkeypatch):
    """The generalist that ships opens the built-in drawer at x1 on the C engine, by ``open``'s protocol: in at least
    9 of its 10 deterministic episodes from perturbed starts (it opened all 10 when this test was written; a policy
    with the same network, untrained, opens none). Nothing is written into the package."""
    monkeypatch.setitem(PACKAGED, GENERALIST, SHIPPED)  # the shipped one, where this module's fixtures put a tiny one
    protocol = EvalProtocol(dampings=(1.0,), modes=("det",), episodes=OPEN_EPISODES)
    result, written = evaluate_checkpoint(GENERALIST, protocol, "mujoco",
                                          object_dir=str(packaged_object("drawer_cabinet_0000")))
    (cell,) = result["cells"]
    assert result["backend"] == "mujoco" and written is None
    assert cell["damping"] == 1.0 and cell["episodes"] == OPEN_EPISODES == 10
    assert cell["success_rate"] >= 0.9, cell
