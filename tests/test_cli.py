"""The command line: inspect on real folders, the demo main job."""

import json

from dragmesh2_jax.cli import main


def test_inspect_json_on_a_real_object(gapartnet_dir, capsys):
    assert main(["inspect", str(gapartnet_dir / "45261"), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["category"] == "StorageFurniture"
    assert info["target_joint"]["type"] == "prismatic" and info["target_joint"]["range"] == [0.0, 0.87]
    assert info["handle"]["source"] == "handle"
    assert info["scene"]["collision_pieces"] >= 1 and 4 <= info["scene"]["max_hull_vertices"] <= 32


def test_inspect_text_and_picture(gapartnet_dir, tmp_path, capsys):
    png = tmp_path / "a.png"
    assert main(["inspect", str(gapartnet_dir / "11712"), "--render", str(png)]) == 0
    out = capsys.readouterr().out
    assert "revolute" in out and "Refrigerator" in out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_demo_trains_evaluates_and_reports(tmp_path):
    """The main job end to end, with a 2-epoch preset (the real one is 60 epochs on a CPU)."""
    assert main(["demo", "--out", str(tmp_path), "--epochs", "2", "--quiet"]) == 0
    res = json.loads((tmp_path / "eval_final.json").read_text())
    assert [(c["damping"], c["mode"]) for c in res["cells"]] == [
        (d, m) for d in (1.0, 2.0, 4.0) for m in ("det", "stoch")]
    assert all(c["episodes"] == 20 for c in res["cells"])
    report = (tmp_path / "report.md").read_text()
    assert "| x1 | det |" in report and "success_vs_damping.png" in report
    for png in ("success_vs_damping.png", "grasp.png"):
        assert (tmp_path / png).read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "checkpoints" / "final.npz").is_file()
    assert main(["demo", "--out", str(tmp_path), "--epochs", "2", "--quiet"]) == 2  # never overwrites a run
