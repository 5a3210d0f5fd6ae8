"""``dragmesh2 reproduce``: every table's plan runs on a tiny preset, writes the paper's layout, and an
interrupted reproduction resumes without redoing finished runs."""

import dataclasses
import json

import pytest

from dragmesh2_jax.assets.procedural import default_object
from dragmesh2_jax.errors import DragMeshError
from dragmesh2_jax.reproduce import TABLES, Eval, ReproduceConfig, Run, plan, reproduce
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


def test_every_table_on_a_tiny_preset_and_an_interrupted_run_resumes(tmp_path):
    out = tmp_path / "rep"
    done: list = []

    def interrupt(step):
        done.append(step)
        if len(done) == 9:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        reproduce(["all"], TINY, out, progress=False, on_step=interrupt)
    finished = [s for s in done if isinstance(s, Run)]
    stamps = {s: (s.folder(out) / "checkpoints" / "final").stat().st_mtime_ns for s in finished}
    # the next run was stopped after it logged an epoch but before its first checkpoint: it starts again
    steps = [s for t in TABLES for s in plan(t, TINY)]
    stopped = next(s for s in steps if isinstance(s, Run) and s not in finished).folder(out)
    stopped.mkdir(parents=True)
    (stopped / "log.jsonl").write_text(json.dumps({"epoch": 1}) + "\n")
    paths = reproduce(["all"], TINY, out, progress=False)
    assert [p.name for p in paths] == [f"{t}.md" for t in TABLES]
    assert all((s.folder(out) / "checkpoints" / "final").stat().st_mtime_ns == t for s, t in stamps.items())
    main = (out / "main.md").read_text()
    assert "| tracking | x1 |" in main and "| parallel_jaw | x1 |" in main and "| pica | x4 |" in main
    assert "(0.89/0.82)" in main  # the paper's Avg beside ours
    assert (out / "figure2_main.png").read_bytes()[:4] == b"\x89PNG"
    res = json.loads((out / "ablation.json").read_text())["results"]
    assert {r["label"] for r in res} == {"gla_only", "pica_flat", "pica"}
    assert all(len(r["cells"]) == 6 for r in res)  # x1/x2/x4 x det/stoch
    assert "pica+both+continued" in (out / "continued.md").read_text()
    assert "| pica+continued (7 ep) |" in (out / "train-length.md").read_text()  # 500 epochs at 2/150 scale


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
            step.path(tmp_path).parent.mkdir(parents=True, exist_ok=True)
            step.path(tmp_path).write_text(json.dumps({"label": step.label, "seed": step.seed, "object": "a",
                                                       "cells": cells, "run_epochs": 2}))
    [path] = reproduce(["main"], c, tmp_path, progress=False, run=False)
    table = path.read_text()
    assert "| pica | x1 | 0.75±0.25 / 0.75±0.25" in table  # seeds 0 and 1 of object a
    assert "| - |" in table  # object b has nothing yet
    assert "b/pica (seed 0,1)" in table and "a/pica" not in table.split("**Partial**")[1].split("\n")[0]
    assert not list(tmp_path.glob("runs/*/*/checkpoints"))  # nothing trained

    # the same runs planned at a larger budget: their evaluations are stale, the controllers' are not
    [path] = reproduce(["main"], dataclasses.replace(c, epochs=3), tmp_path, progress=False, run=False)
    table = path.read_text()
    assert "| tracking | x1 | 1.00" in table and "a/pica (seed 0,1)" in table
