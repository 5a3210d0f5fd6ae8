"""Runs nothing can corrupt: one writer per run folder, a run stopped anywhere restarts with the same command, flags
a resume would silently drop are refused, and operating-system faults (not a folder, not creatable, read-only, a
full disk, an interrupt) are one ``error:`` line with nothing lost."""

import dataclasses
import errno
import json
import shutil
import sys
from pathlib import Path

import jax
import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.io import atomic_write_json
from dragmesh2_jax.ppo import train as train_module
from dragmesh2_jax.runs import session
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.spec import method_spec
from tests.conftest import TINY_RUNS, grow, installed_command, read_only, small_filesystem
from tests.runs.test_session import tensorboard_scalars
from tests.test_io import hold_lock, release

pytestmark = pytest.mark.xdist_group(TINY_RUNS)  # its trained run is built once, beside the others

dragmesh2 = installed_command()
TINY = ["--method", "pica", "--epochs", "2", "--num-envs", "4", "--ppo.rollout-len", "8", "--backend", "mujoco",
        "--quiet", "--robust-every", "0", "--network.state-sizes", "64,64", "--network.hist-dim", "32",
        "--network.heads", "2", "--network.critic-sizes", "64"]


def train(out, *more) -> int:
    return dragmesh2(["train", "--object", str(default_object()), "--out", str(out), *TINY, *more])


def one_error(capsys, fragment: str) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and fragment in err[0], err
    return err[0]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "pica"
    assert train(out, "--save-every", "1", "--robust-every", "1") == 0
    return out


@pytest.fixture
def run(trained, tmp_path):
    """A copy of the module's trained run (2 epochs, a checkpoint at each)."""
    return shutil.copytree(trained, tmp_path / "run")


def test_a_second_writer_is_refused_naming_the_first(run, capsys):
    before = (run / "log.jsonl").read_text()
    holder = hold_lock(run)
    try:
        assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3", "--quiet"]) == 2
        one_error(capsys, f"in use by another writer (process {holder.pid}")
        assert dragmesh2(["evaluate", "--checkpoint", str(run), "--episodes", "1", "--mode", "det"]) == 2
        one_error(capsys, f"process {holder.pid}")
        assert dragmesh2(["demo", "--out", str(run), "--epochs", "2"]) == 2
        assert f"process {holder.pid}" in capsys.readouterr().err
    finally:
        release(holder)
    assert (run / "log.jsonl").read_text() == before and not list(run.glob("evaluations/*"))


def test_an_out_that_is_a_file_or_cannot_be_made_is_one_line(tmp_path, capsys):
    (tmp_path / "file").write_text("not a folder")
    assert train(tmp_path / "file") == 2
    one_error(capsys, "exists and is not a folder")
    assert train(tmp_path / "file" / "run") == 2
    one_error(capsys, "cannot be created")


def test_a_full_disk_is_one_line_and_the_same_run_resumes_once_there_is_space(run, monkeypatch, capsys):
    full = {"left": 1}

    def write_log(self, rows):  # the disk fills up at the next epoch's log
        if full["left"] == 0:
            raise OSError(errno.ENOSPC, "No space left on device", str(self.path / "log.jsonl"))
        full["left"] -= 1
        real(self, rows)
    real = RunDir.write_log
    monkeypatch.setattr(RunDir, "write_log", write_log)
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "4", "--save-every", "1", "--quiet",
                      "--robust-every", "0"]) == 2
    one_error(capsys, "No space left on device; free some space and run the same command again")
    assert sorted(RunDir(run).epoch_checkpoints()) == [1, 2, 3]  # earlier checkpoints stand, readable
    assert not [p for p in run.rglob("*") if p.name.endswith(".tmp")]  # no temporary file left behind
    monkeypatch.undo()
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "4", "--quiet", "--robust-every", "0"]) == 0
    assert [r["epoch"] for r in RunDir(run).log_rows()] == [1, 2, 3, 4]


def test_a_run_stopped_before_its_first_checkpoint_restarts_with_the_same_command(trained, tmp_path, monkeypatch,
                                                                                  capsys):
    def interrupt(self, rows):
        raise KeyboardInterrupt
    traj = ["--trajectory", str(trained / "trajectory.json")]  # the packaged drawer's, made once
    monkeypatch.setattr(RunDir, "write_log", interrupt)
    assert train(tmp_path / "run", *traj) == 130
    one_error(capsys, "interrupted")
    assert RunDir(tmp_path / "run").exists() and not RunDir(tmp_path / "run").epoch_checkpoints()
    monkeypatch.undo()
    assert train(tmp_path / "run", *traj) == 0  # the same command
    assert RunDir(tmp_path / "run").trained_epochs() == 2
    # and --resume of such a folder starts it again from its record
    monkeypatch.setattr(RunDir, "write_log", interrupt)
    assert train(tmp_path / "other", "--seed", "7", "--epochs", "1", *traj) == 130
    monkeypatch.undo()
    assert dragmesh2(["train", "--out", str(tmp_path / "other"), "--resume", "--quiet"]) == 0
    assert RunDir(tmp_path / "other").spec().schedule.seed == 7 and RunDir(tmp_path / "other").trained_epochs() == 1


def test_wandb_missing_is_refused_before_anything_is_written(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "wandb", None)  # as if the extra were not installed
    assert train(tmp_path / "run", "--wandb", "project") == 2
    one_error(capsys, "--wandb needs the wandb package")
    assert not (tmp_path / "run").exists()


def test_a_resume_refuses_changed_flags_and_a_longer_schedule_extends_the_record(run, capsys):
    changed = ["--method", "state_only", "--num-envs", "8", "--task.alpha", "0.03", "--seed", "3"]
    assert dragmesh2(["train", "--out", str(run), "--resume", *changed]) == 2
    line = one_error(capsys, "--resume continues the recorded run exactly")
    for what in ("method state_only (recorded pica)", "ppo.num_envs 8 (recorded 4)", "task.alpha 0.03 (recorded 0.05)",
                 "schedule.seed 3 (recorded 42)"):
        assert what in line
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "1"]) == 2
    one_error(capsys, "already trained 2 epochs")
    assert dragmesh2(["train", "--out", str(run), "--resume", "--holdout", "1"]) == 2
    one_error(capsys, "holdout 1 (recorded 0)")
    assert dragmesh2(["train", "--out", str(run), "--resume", "--trajectory", str(run / "trajectory.json")]) == 2
    one_error(capsys, "drop --trajectory")
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3", "--method", "pica", "--quiet",
                      "--robust-every", "0"]) == 0
    assert RunDir(run).spec().schedule.epochs == 3 and RunDir(run).trained_epochs() == 3
    assert RunDir(run).spec().schedule.robust_every == 0  # the resume's interval, revised in the record


def test_train_into_a_run_that_has_checkpoints_is_refused(run, capsys):
    assert train(run) == 2
    one_error(capsys, "already holds a run's products (checkpoints/best, checkpoints/best_robust, "
                      "checkpoints/epoch_0001 and 2 more): --resume continues it, --overwrite removes them")


def test_a_pruned_run_is_never_wiped_and_overwrite_says_what_it_removes(run, capsys):
    """A finished run whose epoch checkpoints were deleted to free disk (final, best, best_robust and evaluations
    kept): --resume, a plain rerun and the demo's rerun (resume when it can) refuse it, naming --overwrite, and
    leave every file as it was; --overwrite starts it again and says what it removed."""
    assert dragmesh2(["evaluate", "--checkpoint", str(run), "--damping", "1", "--mode", "det", "--episodes", "2"]) == 0
    for ck in RunDir(run).epoch_checkpoints().values():
        shutil.rmtree(ck)
    capsys.readouterr()
    before = {p: p.read_bytes() for p in run.rglob("*") if p.is_file() and p.name != ".lock"}
    assert {"checkpoints/final", "checkpoints/best_robust", "checkpoints/best"} <= set(RunDir(run).products())
    for command in (["train", "--out", str(run), "--resume", "--epochs", "3", "--quiet"], ["train", "--object",
                    str(default_object()), "--out", str(run), *TINY]):
        assert dragmesh2(command) == 2
        one_error(capsys, "with no epoch checkpoint to resume from, --overwrite removes them and starts again")
    with pytest.raises(DragMeshError, match="--overwrite"):
        session.start_or_resume(RunDir(run).spec(), [RunDir(run)], trajectory=str(run / "trajectory.json"),
                                resume=None, progress=False)
    assert {p: p.read_bytes() for p in run.rglob("*") if p.is_file() and p.name != ".lock"} == before
    assert dragmesh2(["train", "--out", str(run), "--resume", "--overwrite"]) == 2
    one_error(capsys, "--overwrite starts the run again: drop --resume")
    assert train(run, "--overwrite", "--epochs", "1") == 0
    err = capsys.readouterr().err
    assert ("note: --overwrite: removed run.json, trajectory.json, tb, checkpoints, evaluations, log.jsonl, log.csv, "
            f"robust.jsonl, robust.csv from {run}") in err
    assert RunDir(run).trained_epochs() == 1 and not (run / "evaluations").exists()


def test_a_checkpoint_whose_replacement_a_kill_interrupted_is_read_and_put_back(run, capsys):
    """Where two folders cannot be swapped, a kill between a replacement's two renames leaves best_robust aside:
    evaluation reads it there, saying so (not final, without a word), and the next start puts it back."""
    ck = RunDir(run).checkpoint("best_robust")
    ck.rename(ck.with_name(".best_robust.old"))
    shutil.copytree(RunDir(run).checkpoint("final"), ck.with_name(".best_robust.tmp"))  # the new copy, unfinished
    assert dragmesh2(["evaluate", "--checkpoint", str(run), "--damping", "1", "--mode", "det", "--episodes", "2",
                      "--json"]) == 0
    out, err = capsys.readouterr()
    assert json.loads(out)["checkpoint"].endswith(".best_robust.old")
    assert f"note: {ck}: its replacement was interrupted; read from its previous copy .best_robust.old" in err
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3", "--quiet", "--robust-every", "0"]) == 0
    err = capsys.readouterr().err
    assert f"note: {ck}: restored (a kill interrupted its replacement)" in err
    assert f"note: {ck.with_name('.best_robust.tmp')}: removed (a replacement a kill left unfinished)" in err
    assert RunDir(run).has_checkpoint("best_robust")
    assert sorted(p.name for p in ck.parent.iterdir() if p.name.startswith(".")) == []


def test_a_full_disk_during_a_checkpoint_is_one_line_and_the_run_resumes_once_there_is_room(tmp_path, capsys):
    """On a real filesystem too small for the run (no patched write): one error line, no traceback from a writer
    thread, no temporary left, every checkpoint written loads; given room, the same run resumes to its end."""
    with small_filesystem(tmp_path / "disk", "1m") as disk:
        assert train(disk / "run", "--save-every", "1", "--epochs", "4") == 2
        one_error(capsys, "No space left on device; free some space and run the same command again")
        run = RunDir(disk / "run")
        assert not [p for p in disk.rglob("*") if p.name.endswith((".tmp", ".old"))]
        for ck in run.epoch_checkpoints().values():
            assert dragmesh2(["evaluate", "--checkpoint", str(ck), "--damping", "1", "--mode", "det",
                              "--episodes", "1", "--json"]) in (0, 2)  # 2: loaded, evaluated, not saved (full)
        capsys.readouterr()
        grow(disk, "64m")
        assert dragmesh2(["train", "--out", str(run.path), "--resume", "--quiet"]) == 0
        assert [r["epoch"] for r in run.log_rows()] == [1, 2, 3, 4]


def test_learning_that_goes_non_finite_stops_and_keeps_the_last_good_checkpoint(tmp_path, monkeypatch, capsys):
    """A NaN in the parameters at epoch 2: one error line naming the last good checkpoint (epoch 1) and the fine-tune
    that continues it at a lower learning rate; nothing of epoch 2 is saved; that fine-tune runs and is recorded."""
    real = train_module.epoch_runs

    def diverging(program, data, ts, mesh=None, teachers=None):
        ts, m = real(program, data, ts, mesh, teachers)
        if int(ts.epoch[0]) == 2:
            ts = ts.replace(params=jax.tree.map(lambda x: x * np.nan, ts.params))
        return ts, m
    monkeypatch.setattr(train_module, "epoch_runs", diverging)
    assert train(tmp_path / "run", "--save-every", "1", "--epochs", "3") == 2
    good = RunDir(tmp_path / "run").checkpoint("epoch_0001")
    line = one_error(capsys, "epoch 2: learning went non-finite (loss")
    assert f"its last good checkpoint is {good}: continue from it at a lower learning rate with dragmesh2 finetune " \
           f"--checkpoint {good} --recipe continued --ppo.lr 3e-05" in line
    assert sorted(RunDir(tmp_path / "run").epoch_checkpoints()) == [1]
    assert not RunDir(tmp_path / "run").has_checkpoint("final")
    assert [r["epoch"] for r in RunDir(tmp_path / "run").log_rows()] == [1]
    monkeypatch.undo()
    assert dragmesh2(["finetune", "--checkpoint", str(good), "--recipe", "continued", "--ppo.lr", "3e-5", "--epochs",
                      "1", "--out", str(tmp_path / "ft"), "--quiet", "--backend", "mujoco", "--robust-every", "0"]) == 0
    spec = RunDir(tmp_path / "ft").spec()
    assert spec.ppo.lr == 3e-5 and spec.finetune == "continued" and spec.parent == str(good.resolve())
    assert RunDir(tmp_path / "ft").log_rows()[0]["lr"] == pytest.approx(3e-5, rel=0.6)  # the adaptive rate from it


def test_a_resume_may_size_the_buffers_otherwise_and_records_it(run, capsys):
    """The advice of an MJX contact overflow, --task.contacts N, is accepted on resume (buffers do not change what a
    run learns) and recorded; a field that changes what it learns is still refused."""
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3", "--task.contacts", "96",
                      "--quiet", "--robust-every", "0"]) == 0
    assert RunDir(run).spec().task.contacts == 96 and RunDir(run).trained_epochs() == 3
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "4", "--task.contacts", "128",
                      "--task.alpha", "0.03"]) == 2
    one_error(capsys, "task.alpha 0.03 (recorded 0.05)")


def test_an_evaluation_that_cannot_be_saved_is_printed_whole(run, capsys):
    with read_only(run):
        assert dragmesh2(["evaluate", "--checkpoint", str(run), "--damping", "1,2", "--mode", "det", "--episodes",
                          "2", "--json"]) == 2
    out, err = capsys.readouterr()
    result = json.loads(out)
    assert [c["damping"] for c in result["cells"]] == [1.0, 2.0] and result["cells"][0]["episodes"] == 2
    *progress, line = err.strip().splitlines()
    assert line.startswith("error: the evaluation was not saved") and "cannot be written" in line
    assert all(p.startswith("evaluate: ") for p in progress) and not (run / "evaluations").exists()


def test_open_keeps_its_result_when_the_run_folder_cannot_take_the_evaluation(run, tmp_path, capsys):
    """``open --checkpoint RUN`` writes its report, video, still and trajectory whatever the run folder does: a run
    another process writes, or one on read-only storage, does not get the evaluation; open's folder does, and one
    stderr line says so. A run folder that can take it gets it, and open says where."""
    def open_(out) -> int:
        return dragmesh2(["open", "--checkpoint", str(run), "--object", str(default_object()), "--out", str(out),
                          "--episodes", "1", "--video-every", "100", "--renderer", "matplotlib", "--backend", "mujoco"])

    def kept(out, fragment: str) -> None:
        report = json.loads((out / "report.json").read_text())
        assert {"report.md", "still.png", "trajectory.json"} <= {p.name for p in out.iterdir()}
        assert Path(report["video"]).is_file() and report["episodes"] == 1
        assert report["evaluation"] == str(out / "evaluation.json")
        assert json.loads((out / "evaluation.json").read_text())["cells"][0]["episodes"] == 1
        (note,) = [x for x in capsys.readouterr().err.splitlines() if x.startswith("note:")]
        assert note.startswith(f"note: the run folder did not get the evaluation ({run}: {fragment}")
        assert note.endswith(f"; it is in {out / 'evaluation.json'}")
        assert not (run / "evaluations").exists()

    holder = hold_lock(run)
    try:
        assert open_(tmp_path / "busy") == 0
    finally:
        release(holder)
    kept(tmp_path / "busy", f"in use by another writer (process {holder.pid}")
    with read_only(run):
        assert open_(tmp_path / "read-only") == 0
    kept(tmp_path / "read-only", "cannot be written")
    assert open_(tmp_path / "free") == 0
    (saved,) = (run / "evaluations").glob("*.json")
    assert json.loads((tmp_path / "free" / "report.json").read_text())["evaluation"] == str(saved)
    assert f"evaluation: {saved}" in capsys.readouterr().err
    assert not (tmp_path / "free" / "evaluation.json").exists()


def test_seed_folders_that_disagree_do_not_resume_as_one_program(trained, tmp_path, capsys):
    for seed in (0, 1):
        shutil.copytree(trained, tmp_path / "runs" / f"seed_{seed}")
    for seed, alpha in ((0, 0.05), (1, 0.03)):  # seed 1 was trained with another task
        path = tmp_path / "runs" / f"seed_{seed}" / "run.json"
        record = json.loads(path.read_text())
        record["schedule"]["seed"], record["task"]["alpha"] = seed, alpha
        path.write_text(json.dumps(record))
    assert dragmesh2(["train", "--out", str(tmp_path / "runs"), "--seeds", "0,1", "--resume", "--epochs", "3"]) == 2
    one_error(capsys, "differs from")


def test_a_resume_after_a_lost_checkpoint_purges_tensorboard_and_carries_best_robust(run):
    """A run stopped after its epoch-2 log but before that checkpoint resumes from epoch 1: the scalars past it are
    dropped and written again, and best_robust is chosen over the robustness rows before and after the resume."""
    shutil.rmtree(RunDir(run).checkpoint("epoch_0002"))
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3", "--quiet"]) == 0
    tags = tensorboard_scalars(run / "tb")
    assert tags["train/reward"] == [1, 2, 3] and tags["robust/mean_success"] == [1, 2, 3]
    rows = RunDir(run).robust_rows()
    assert [r["epoch"] for r in rows] == [1, 2, 3]
    best = max(rows, key=lambda r: (r["mean_success"], r["worst_success"], -r["clip099_active"]))
    assert [r["epoch"] for r in rows if r["selected"]][-1] == best["epoch"]
    assert rows[0]["selected"] and sum(r["selected"] for r in rows) == 1 + sum(
        (r["mean_success"], r["worst_success"], -r["clip099_active"]) >
        max((q["mean_success"], q["worst_success"], -q["clip099_active"]) for q in rows[:i]) for i, r in
        enumerate(rows) if i)


def test_a_run_folder_on_read_only_storage_is_one_line(run, capsys):
    with read_only(run):
        assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3"]) == 2
    one_error(capsys, "cannot be written (")


def test_a_run_whose_worlds_an_earlier_version_saved_continues_from_its_policy(run, monkeypatch, capsys):
    """Worlds saved in another state layout (an earlier version's sensors) cannot continue exactly: the run goes on
    from its policy with fresh worlds and says so, instead of stopping at a run it could continue."""
    real = session.load_checkpoint

    def earlier(template, path, keep_env=False):
        if not keep_env:
            raise DragMeshError(f"{path}: checkpoint does not match this method/config or is damaged (env)")
        return real(template, path, keep_env=True)
    monkeypatch.setattr(session, "load_checkpoint", earlier)
    assert dragmesh2(["train", "--out", str(run), "--resume", "--epochs", "3", "--quiet", "--robust-every", "0"]) == 0
    assert "its worlds could not be restored" in capsys.readouterr().err
    assert RunDir(run).trained_epochs() == 3


def test_a_resume_that_revises_the_schedule_keeps_the_checkpoint_rule(tmp_path):
    """The recipe's runs are read at their final checkpoint; a resume that trains further rewrites the record's
    schedule and must keep that rule (the recipe's train-then-evaluate with no flags: tests/test_readme.py)."""
    spec = method_spec("recommended", str(default_object()))
    assert spec.schedule.checkpoint == "final"
    run = RunDir(tmp_path / "run")
    atomic_write_json(run.record_path, spec.record("mujoco"))
    given = method_spec("pica", str(default_object()), schedule={"epochs": 400, "save_every": 5, "seed": 1})
    run.revise(session._continued(run.spec(), given))
    assert run.spec().schedule == dataclasses.replace(spec.schedule, epochs=400, save_every=5)
def test_a_fine_tune_stopped_before_its_first_checkpoint_is_not_restarted_from_scratch(run, tmp_path, monkeypatch,
                                                                                        capsys):
    def interrupt(self, rows):
        raise KeyboardInterrupt
    monkeypatch.setattr(RunDir, "write_log", interrupt)
    assert dragmesh2(["finetune", "--checkpoint", str(run), "--recipe", "continued", "--epochs", "1", "--out",
                      str(tmp_path / "ft"), "--quiet", "--backend", "mujoco", "--robust-every", "0"]) == 130
    monkeypatch.undo()
    capsys.readouterr()
    assert dragmesh2(["train", "--out", str(tmp_path / "ft"), "--resume"]) == 2
    one_error(capsys, "run its finetune command again")
    assert dragmesh2(["finetune", "--checkpoint", str(run), "--recipe", "continued", "--epochs", "1", "--out",
                      str(tmp_path / "ft"), "--quiet", "--backend", "mujoco", "--robust-every", "0"]) == 0  # again
