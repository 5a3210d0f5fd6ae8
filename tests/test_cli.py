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


def test_demo_writes_summary_and_picture(tmp_path):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    res = json.loads((tmp_path / "demo.json").read_text())
    assert res["rollout"]["finite"] and res["scene"]["nu"] == 51
    assert res["rollout"]["palm_handle_distance_m"] < 0.12  # the hand ends at the handle
    assert (tmp_path / "scene.png").stat().st_size > 1000
