"""The dataset builder: manifest, summary by category, failures isolated and explained, resumable."""

import csv
import shutil
from pathlib import Path

from dragmesh2_jax.assets import procedural
from dragmesh2_jax.runs.commands import dataset_objects
from dragmesh2_jax.trajectory.dataset import build_dataset
from tests.conftest import installed_command

dragmesh2 = installed_command()


def test_build_resume_and_isolated_failure(tmp_path):
    objs = tmp_path / "objs"
    procedural.synthesize("drawer_cabinet", 2, seed=20, out=objs)
    procedural.synthesize("microwave", 1, seed=20, out=objs)
    broken = objs / "zz_broken"
    shutil.copytree(objs / "microwave_0020", broken)
    (broken / "mobility_annotation_gapartnet.urdf").write_text("<robot><link name='base'/></rob")
    out = tmp_path / "ds"
    res = build_dataset([objs], out, progress=False)
    assert len(res.records) == 4 and len(res.failures) == 1
    assert "malformed XML" in res.failures[0]["reason"]
    rows = list(csv.DictReader(res.manifest.open()))
    assert list(rows[0])[:4] == ["sample_id", "object_id", "trajectory", "enabled"]
    assert [r["enabled"] for r in rows] == ["1", "1", "1", "0"]
    assert (out / rows[0]["trajectory"]).is_file()
    summary = res.summary.read_text()
    assert "StorageFurniture" in summary and "Microwave" in summary and "zz_broken" in summary
    # resume: nothing is regenerated
    mtime = (out / rows[0]["trajectory"]).stat().st_mtime_ns
    assert len(build_dataset([objs], out, progress=False).records) == 4
    assert (out / rows[0]["trajectory"]).stat().st_mtime_ns == mtime


def test_cli_trajectory_and_dataset(tmp_path, capsys):
    obj = procedural.synthesize("oven", 1, seed=3, out=tmp_path / "o")[0]
    assert dragmesh2(["trajectory", "--object", str(obj), "--out", str(tmp_path / "t.json")]) == 0
    assert "PASSED" in capsys.readouterr().out
    assert dragmesh2(["dataset", "build", "--objects", str(tmp_path / "nope"), "--out", str(tmp_path / "d")]) == 2


def test_the_paper_category_mix():
    """277 procedural objects are the paper's Table 1 counts per GAPartNet category."""
    mix = procedural.table1_mix(277)
    by_gapartnet = {}
    for cat, k in mix.items():
        g = procedural.CATEGORIES[cat][0]
        by_gapartnet[g] = by_gapartnet.get(g, 0) + k
    assert by_gapartnet == procedural.PAPER_TABLE1
    small = procedural.table1_mix(50)
    assert sum(small.values()) == 50 and small["drawer_cabinet"] + small["door_cabinet"] == 46  # 256/277 of 50


def test_cli_dataset_of_procedural_objects_resumes(tmp_path, capsys):
    out = tmp_path / "d"
    assert dragmesh2(["dataset", "build", "--procedural", "3", "--out", str(out)]) == 0
    printed = capsys.readouterr()
    assert "3 of 3 passed" in printed.out
    # stderr is not a terminal here: one plain progress line per trajectory, with elapsed and estimated time left
    lines = [ln for ln in printed.err.splitlines() if ln.startswith("dataset build: ")]
    assert [ln.split()[2] for ln in lines] == ["1/3", "2/3", "3/3"] and all("left ~" in ln for ln in lines)
    objects, trajectories = dataset_objects(out)  # what train --dataset trains on
    assert len(objects) == 3 and all(Path(t).is_file() for t in trajectories)
    summary = (out / "summary.md").read_text()
    assert "| StorageFurniture | 3 | 3 | 0 | 1.00 |" in summary and "| 256 |" in summary
    records = sorted((out / "records").iterdir())
    mtimes = [p.stat().st_mtime_ns for p in records]
    assert dragmesh2(["dataset", "build", "--procedural", "3", "--out", str(out), "--quiet"]) == 0  # resumed
    assert [p.stat().st_mtime_ns for p in sorted((out / "records").iterdir())] == mtimes
    assert dragmesh2(["dataset", "build", "--procedural", "-1", "--out", str(out)]) == 2
