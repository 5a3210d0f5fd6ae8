"""The dataset builder: manifest, summary by category, failures isolated and explained, resumable."""

import csv
import shutil

from dragmesh2_jax.assets import procedural
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
