"""``dragmesh2 reproduce``: every table's plan (with stand-ins for training and evaluation) writes the paper's layout,
an interrupted reproduction resumes without redoing finished steps, and one real table runs on a tiny preset."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.reproduce import (
    PAPER_CELLS,
    PAPER_OBJECTS,
    TABLES,
    Eval,
    ReproduceConfig,
    Run,
    executor,
    plan,
    reproduce,
)
from dragmesh2_jax.reproduce.report import physical_table, write_table
from dragmesh2_jax.runs.presets import RECOMMENDED
from tests.conftest import installed_command

TINY = ReproduceConfig(objects=(str(default_object()),), seeds=(0,), epochs=2, num_envs=2, episodes=2,
                       backend="mujoco")


def test_plans_follow_the_paper():
    main = plan("main", ReproduceConfig(objects=("a", "b"), epochs=150))
    runs = [s for s in main if isinstance(s, Run)]
    assert {r.method for r in runs} == {"state_only", "flat_history", "gru", "transformer", "pica"}
    assert len(runs) == 2 * 5 * 3 and all(r.epochs == 150 for r in runs)  # objects x methods x seeds
    controllers = [s.controller for s in main if isinstance(s, Eval) and s.run is None]
    assert controllers == ["tracking", "parallel_jaw"] * 2  # per object
    def labels(table):
        return {s.label for s in plan(table, ReproduceConfig(objects=("a",), seeds=(0,))) if isinstance(s, Eval)}

    ood = labels("ood")
    assert {"pica@150", "pica+continued@200", "pica+continued@300", "pica+continued@500", "pica+aram@200",
            "pica+reconfig@200", "pica+both@200"} <= ood
    cont = labels("continued")
    assert {"pica+both@200", "pica+both+continued@250", "pica+both+continued@300", "pica+both+continued@400"} <= cont
    damp = labels("damping-range")
    assert "pica+both+damp_1_4@225" in damp  # paper Table 7: Both + damping [1, 4] for 25 epochs
    with pytest.raises(DragMeshError):
        plan("table-9", TINY)
    # other rows, a preset beyond the paper among them: the same plan for those rows only
    extra = ("tracking", "tracking_delta", "state_only", "pica_load")
    rows = ReproduceConfig(objects=("a",), seeds=(0,), methods=extra)
    for table in ("main", "ablation"):
        assert {s.label for s in plan(table, rows) if isinstance(s, Eval)} == set(extra)
    with pytest.raises(DragMeshError, match="pica_typo"):
        ReproduceConfig(objects=("a",), methods=("pica_typo",))
    # the final checkpoint instead of the paper's selection: rows read METHOD@EPOCHS
    final = ReproduceConfig(objects=("a",), seeds=(0,), methods=("pica_load",), epochs=300, checkpoint="final")
    (ev,) = [s for s in plan("main", final) if isinstance(s, Eval)]
    assert (ev.checkpoint, ev.at, ev.label) == ("final", 300, "pica_load@300")
    with pytest.raises(DragMeshError, match="checkpoint"):
        ReproduceConfig(objects=("a",), checkpoint="best")


def test_the_generalist_plan_gives_one_policy_the_specialists_budget():
    """One policy per seed over the training objects, for as many epochs as the specialists of every object
    together; evaluated zero-shot on each object (best_robust and final, in files of their own), fine-tuned onto
    each for 20 epochs, beside each object's specialist. Without --methods it is the project's recipe; without
    --episodes each cell has the project's 100 episodes (the paper's tables keep its 20)."""
    c = ReproduceConfig(objects=("a", "b"), seeds=(0, 1, 2), epochs=150)
    steps = plan("generalist", c)
    runs = [s for s in steps if isinstance(s, Run)]
    general = [r for r in runs if r.generalist]
    assert len(general) == 3 and {(r.method, r.epochs) for r in general} == {(RECOMMENDED, 300)}
    tuned = {(r.object, r.epochs, r.recipe) for r in runs if r.parent is not None}
    assert tuned == {("a", 320, "continued"), ("b", 320, "continued")}
    assert {(r.object, r.epochs) for r in runs if not r.generalist and r.parent is None} == {("a", 150), ("b", 150)}
    evals = [s for s in steps if isinstance(s, Eval)]
    r = RECOMMENDED
    assert {s.label for s in evals} == {r, f"generalist_{r}", f"generalist_{r}@300", f"generalist_{r}+continued@320"}
    assert all(s.project and "_n100_" in s.path(Path("rep"), c).name for s in evals)
    assert not any(s.project for s in plan("main", c) if isinstance(s, Eval)) and c.protocol().episodes == 20
    zero = [s for s in evals if s.zero_shot]
    assert len(zero) == 3 * 2 * 2  # seeds x objects x (best_robust, final)
    out = Path("rep")
    assert len({s.path(out, c) for s in zero}) == len(zero)  # one file each: none overwrites another
    assert all(s.path(out, c).name.endswith(f"__on-{s.object}.json") for s in zero)
    with pytest.raises(DragMeshError, match="holdout"):
        ReproduceConfig(objects=("a",), train_objects=2, holdout=2)


def test_the_scaling_plan_trains_every_size_for_one_budget_and_reads_it_along_the_way():
    """Per seed and training-set size one policy for the generalist's budget, whatever the size; its checkpoints at
    a third, two thirds and all of it evaluated zero-shot on every object, each in a file of its own; every size of
    a seed before the next seed."""
    c = ReproduceConfig(objects=("a", "b"), seeds=(0, 1), epochs=150, scaling=(1, 8, 32))
    steps = plan("scaling", c)
    runs = [s for s in steps if isinstance(s, Run)]
    assert [(r.seed, r.train_objects) for r in runs] == [(0, 1), (0, 8), (0, 32), (1, 1), (1, 8), (1, 32)]
    assert {r.epochs for r in runs} == {300} and c.scaling_epochs == [100, 200, 300]
    evals = [s for s in steps if isinstance(s, Eval)]
    assert len(evals) == len(runs) * 3 * 2 and all(s.zero_shot for s in evals)
    assert {s.label for s in evals if s.run.train_objects == 8} == {
        f"generalist_{RECOMMENDED}_n8@{e}" for e in (100, 200, 300)}
    out = Path("rep")
    assert len({s.path(out, c) for s in evals}) == len(evals)
    assert len({s.checkpoint_path(out) for s in evals}) == len(evals) // 2  # one checkpoint, every object
    with pytest.raises(DragMeshError, match="scaling"):
        ReproduceConfig(objects=("a",), scaling=(8, 8))
    with pytest.raises(DragMeshError, match="modes"):
        ReproduceConfig(objects=("a",), modes=("greedy",))


def test_the_scaling_sizes_are_nested_subsets_of_one_table1_mix(tmp_path):
    c = ReproduceConfig(objects=("a",), scaling=(1, 3))
    one, _ = executor._scaling_subset(c, tmp_path, 1)
    three, trajectories = executor._scaling_subset(c, tmp_path, 3)
    assert [Path(o).name for o in one] == ["drawer_cabinet_1000"]  # the Table 1 mix of one object: a drawer
    assert set(one) < set(three) and len(three) == len(trajectories) == 3
    assert {Path(o).name.rsplit("_", 1)[0] for o in three} == {"drawer_cabinet", "door_cabinet"}


class FakeSteps:
    """Stand-ins for training and evaluation that leave what the real ones leave (a run's log and checkpoints, an
    evaluation's result), so the plan, the skipping of done steps and the tables run without computing."""

    def __init__(self):
        self.trained, self.evaluated = [], []

    def train(self, run: Run, c, out) -> None:
        self.trained.append(run)
        folder = run.folder(out)
        for name in ("final", f"epoch_{run.epochs:04d}", "best_robust"):
            (folder.checkpoint(name) / "learner").mkdir(parents=True, exist_ok=True)
        folder.write_log([{"epoch": e} for e in range(1, run.epochs + 1)])

    def evaluate(self, ev: Eval, c, out) -> dict:
        self.evaluated.append(ev)
        modes = ("det",) if ev.run is None else ("det", "stoch")
        result = {"label": ev.label, "seed": ev.seed, "object": Path(ev.object).name,
                  "run_epochs": None if ev.run is None else ev.run.epochs,
                  "cells": [{"damping": d, "mode": m, "success_rate": 0.5, "clip099": 0.1, "progress_mean": 0.5,
                             "return_mean": 1.0, "detach_rate": 0.0} for d in c.dampings for m in modes]}
        ev.path(out, c).parent.mkdir(parents=True, exist_ok=True)
        ev.path(out, c).write_text(json.dumps(result))
        return result


def test_every_table_runs_its_plan_and_an_interrupted_reproduction_resumes(tmp_path, monkeypatch):
    fake = FakeSteps()
    monkeypatch.setattr(executor, "_train", fake.train)
    monkeypatch.setattr(executor, "_evaluate", fake.evaluate)
    out = tmp_path / "rep"
    done: list = []

    def interrupt(step):
        done.append(step)
        if len(done) == 9:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        reproduce(["all"], TINY, out, progress=False, on_step=interrupt)
    first = len(fake.trained) + len(fake.evaluated)
    assert first == 9
    paths = reproduce(["all"], TINY, out, progress=False)
    steps = list(dict.fromkeys(s for t in TABLES for s in plan(t, TINY)))
    assert len(fake.trained) + len(fake.evaluated) == len(steps)  # every step once: nothing done is redone
    assert [p.name for p in paths] == [f"{t}.md" for t in TABLES]
    main = (out / "main.md").read_text()
    assert "| tracking | x1 |" in main and "| parallel_jaw | x1 |" in main and "| pica | x4 |" in main
    assert "(0.89/0.82)" in main  # the paper's Avg beside ours
    assert (out / "figure2_main.png").read_bytes()[:4] == b"\x89PNG"
    res = json.loads((out / "ablation.json").read_text())["results"]
    assert {r["label"] for r in res} == {"gla_only", "pica_flat", "pica"}
    assert "pica+both+continued" in (out / "continued.md").read_text()
    assert "| pica+continued (7 ep) |" in (out / "train-length.md").read_text()  # 500 epochs at 2/150 scale
    assert f"| generalist_{RECOMMENDED}+continued@22 | x4 |" in (out / "generalist.md").read_text()
    scaling = (out / "scaling.md").read_text()
    assert f"| generalist_{RECOMMENDED}_n277@2 | x4 |" in scaling
    assert (out / "scaling.png").read_bytes()[:4] == b"\x89PNG"
    # a larger budget: the runs are trained on and evaluated again, the controllers' evaluations are kept
    bigger = dataclasses.replace(TINY, epochs=3)
    n_train, n_eval = len(fake.trained), len(fake.evaluated)
    reproduce(["main"], bigger, out, progress=False)
    runs = [s for s in plan("main", bigger) if isinstance(s, Run)]
    assert len(fake.trained) - n_train == len(runs)
    assert len(fake.evaluated) - n_eval == len(runs)  # the controllers' results are current


def test_one_real_table_on_a_tiny_preset(tmp_path):
    """The main table's real steps: a controller evaluated, PICA trained and evaluated (x1/x2/x4/x8), its video and
    training curve."""
    c = dataclasses.replace(TINY, methods=("tracking", "pica"), dampings=(1.0, 2.0, 4.0, 8.0), video_every=60)
    [path] = reproduce(["main"], c, tmp_path, progress=False)
    table = path.read_text()
    assert "| pica | x8 |" in table and "| tracking | x8 | 1.00" in table
    assert "![training curves](curves_main.png)" in table and (tmp_path / "curves_main.png").is_file()
    video = next((tmp_path / "videos").glob(f"{Path(c.objects[0]).name}_pica.*"))  # GIF where no ffmpeg
    assert f"videos/{video.name}" in table and video.stat().st_size > 0
    run = Run(c.objects[0], 0, c.epochs, method="pica").folder(tmp_path)
    assert run.trained_epochs() == 2 and run.spec().method == "pica"
    result = run.evaluation(run.checkpoint("best_robust"), c.protocol())
    assert [cell["damping"] for cell in result["cells"]] == [1.0, 2.0, 4.0, 8.0] * 2


def test_on_the_hands_contacts_every_row_trains_and_is_evaluated_on_the_firm_grip(tmp_path, monkeypatch):
    """``--contacts hand``: each trained row's run records the firm grip's scene (the hand's object contacts, 2 N m
    finger drives) and each controller is evaluated on it; the default keeps MuJoCo's; the table says which; an unknown
    physics is one error line."""
    trained, scenes = [], []
    monkeypatch.setattr(executor, "start_or_resume", lambda spec, *a, **k: trained.append(spec.scene))
    real_load = executor.load_task
    monkeypatch.setattr(executor, "load_task", lambda *a, **k: scenes.append(k["scene_config"]) or real_load(*a, **k))
    hand = dataclasses.replace(TINY, methods=("tracking", "pica"), contacts="hand")
    for c in (hand, dataclasses.replace(hand, contacts="mujoco")):
        for step in plan("main", c):
            if isinstance(step, Run):
                executor._train(step, c, tmp_path / c.contacts)
            elif step.run is None:
                executor._evaluate(step, c, tmp_path / c.contacts)
    (firm, firm_tracked), (default, default_tracked) = zip(trained, scenes, strict=True)
    assert firm.object_contact == firm_tracked.object_contact == "hand"
    assert firm.hand.finger.force_limit == firm_tracked.hand.finger.force_limit == 2.0
    assert default == default_tracked == executor.SceneConfig()
    tracked = [executor._evaluate(e, hand, tmp_path / "hand") for e in plan("main", hand) if isinstance(e, Eval)
               and e.run is None]
    assert "hand's contacts" in write_table("main", hand, tracked, tmp_path / "hand").read_text()
    with pytest.raises(DragMeshError, match="contacts"):
        dataclasses.replace(TINY, contacts="soft")


def test_the_physical_table_reads_an_evaluation_made_before_the_settled_palm_figure():
    """Cells written before the settled figures existed keep their other figures; those columns read '-'."""
    figures = {"wrist_load_peak_n": 50.0, "palm_speed_peak_m_s": 0.2, "part_speed_peak": 0.4,
               "penetration_max_mm": 3.0, "action_smoothness": 0.01, "clip099_active": 0.5}
    old = {"label": "pica", "seed": 0, "object": "a",
           "cells": [{"damping": 1.0, "mode": "det", "success_rate": 1.0, **figures}]}
    new = {**old, "seed": 1, "cells": [{**old["cells"][0], "palm_speed_settled_peak_m_s": 0.1}]}
    table = physical_table([old], ["pica"], ["x/a"], (1.0,))
    assert "| pica | x1 | 0.50 | - | 50 | 0.20 | - | 0.40 | 3.0 | - | 0.010 |" in table
    assert "| 0.20 | 0.10 | 0.40 |" in physical_table([old, new], ["pica"], ["x/a"], (1.0,))


def test_the_command(tmp_path, capsys):
    dragmesh2 = installed_command()
    assert dragmesh2(["reproduce", "main", "--objects", str(default_object()), "--seeds", "0", "--epochs", "0",
                      "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_tables_only_writes_what_is_done_and_names_what_is_not(tmp_path):
    c = ReproduceConfig(objects=("a", "b"), seeds=(0, 1), epochs=2)
    for step in plan("main", c):
        if isinstance(step, Eval) and step.object == "a":
            rate = 1.0 if step.seed == 0 else 0.5
            cells = [{"damping": d, "mode": m, "success_rate": rate} for d in (1.0, 2.0, 4.0) for m in ("det", "stoch")]
            step.path(tmp_path, c).parent.mkdir(parents=True, exist_ok=True)
            step.path(tmp_path, c).write_text(json.dumps({"label": step.label, "seed": step.seed, "object": "a",
                                                          "cells": cells, "run_epochs": 2}))
    [path] = reproduce(["main"], c, tmp_path, progress=False, run=False)
    table = path.read_text()
    assert "| pica | x1 | 0.75±0.25 / 0.75±0.25" in table  # seeds 0 and 1 of object a
    assert "| pica | x4 | stoch | 1.00, 0.50 | - |" in table  # and each seed's own value beside the mean
    assert "| - |" in table  # object b has nothing yet
    assert "b/pica (seed 0,1)" in table and "a/pica" not in table.split("**Partial**")[1].split("\n")[0]
    assert not list(tmp_path.glob("runs/*/*/checkpoints"))  # nothing trained

    # the same runs planned at a larger budget: their evaluations are stale, so that table would have fewer cells
    # than the one written: it is kept, never replaced by a smaller one
    [path] = reproduce(["main"], dataclasses.replace(c, epochs=3), tmp_path, progress=False, run=False)
    assert path.read_text() == table


def test_tables_only_reads_the_plan_the_reproduction_recorded(tmp_path, monkeypatch):
    """``--tables-only`` without the run's other flags writes each table by the plan recorded when it ran, not by
    the defaults: the rows and seeds of the run stay in the table."""
    fake = FakeSteps()
    monkeypatch.setattr(executor, "_train", fake.train)
    monkeypatch.setattr(executor, "_evaluate", fake.evaluate)
    c = dataclasses.replace(TINY, methods=("tracking", "state_only", "pica"))
    reproduce(["main"], c, tmp_path, progress=False)
    written = json.loads((tmp_path / "main.json").read_text())["results"]
    defaults = ReproduceConfig(objects=(str(default_object()),))  # what the command's defaults would plan
    [path] = reproduce(["main"], defaults, tmp_path, progress=False, run=False)
    again = json.loads((tmp_path / "main.json").read_text())
    assert again["results"] == written and again["config"]["methods"] == ["tracking", "state_only", "pica"]
    assert "| state_only | x1 |" in path.read_text() and "**Partial**" not in path.read_text()
    # a folder reproduced before plans were kept per table (one config, its tables) reads the same
    (tmp_path / "reproduce_run.json").write_text(json.dumps({"tables": ["main"], "seconds": 1.0,
                                                             "config": dataclasses.asdict(c)}))
    reproduce(["main"], defaults, tmp_path, progress=False, run=False)
    assert json.loads((tmp_path / "main.json").read_text())["results"] == written


def test_tables_only_over_a_folder_without_the_tables_runs_is_one_error_line_and_creates_nothing(tmp_path, capsys):
    """A mistyped ``--out`` (no such folder, or one with no runs of the table) is refused, not written an empty
    table: one ``error:`` line, exit 2, and the folder as it was."""
    dragmesh2 = installed_command()
    typo = tmp_path / "rpe"
    assert dragmesh2(["reproduce", "main", "--tables-only", "--out", str(typo)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"error: {typo}: no such folder") and not typo.exists()
    (tmp_path / "other").mkdir()
    assert dragmesh2(["reproduce", "main", "--tables-only", "--out", str(tmp_path / "other")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"error: {tmp_path / 'other'}: holds no runs or evaluations of main")
    assert not list((tmp_path / "other").iterdir())


def test_tables_only_all_writes_the_tables_the_folder_holds(tmp_path, monkeypatch):
    """``all`` with ``--tables-only`` is every table the folder holds a reproduction of, not an empty one for each
    table never run there."""
    fake = FakeSteps()
    monkeypatch.setattr(executor, "_train", fake.train)
    monkeypatch.setattr(executor, "_evaluate", fake.evaluate)
    reproduce(["main"], TINY, tmp_path, progress=False)
    written = {p.stem for p in reproduce(["all"], TINY, tmp_path, progress=False, run=False)}
    assert "main" in written and "ablation" in written  # PICA's runs are the ablation's too
    for table in ("generalist", "scaling"):  # none of their runs are there
        assert table not in written and not (tmp_path / f"{table}.md").exists()


def test_the_papers_cells_cover_its_seven_objects_and_average_to_its_avg_column():
    """Every row of paper Tables 2 and 3 has all seven objects; the Avg column is their mean (to the paper's
    rounding), which catches a mistyped cell."""
    for method, row in PAPER_CELLS.items():
        assert set(row) == {*PAPER_OBJECTS, "Avg"}, method
        for k in range(3):  # x1, x2, x4
            for mode in range(2):  # det, stoch
                vals = [row[o][k][mode] for o in PAPER_OBJECTS]
                if row["Avg"][k][mode] is not None:
                    assert np.mean(vals) == pytest.approx(row["Avg"][k][mode], abs=0.0051), (method, k, mode)
