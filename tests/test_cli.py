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


def test_evaluate_reports_rates_and_exact_reset_keeps_the_paper_protocol(tmp_path, capsys):
    from dragmesh2_jax.assets.procedural import default_object

    run = tmp_path / "run"
    assert main(["train", "--object", str(default_object()), "--out", str(run), "--epochs", "2", "--num-envs", "4",
                 "--robust-every", "1", "--backend", "mujoco", "--quiet"]) == 0
    capsys.readouterr()
    assert main(["evaluate", "--checkpoint", str(run), "--damping", "1,4", "--mode", "det", "--episodes", "4",
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["checkpoint"].endswith("best_robust") and isinstance(res["starts"], dict)
    assert {"success_ci95", "clip099", "clip099_active", "steps_mean", "action_l2_mean"} <= set(res["cells"][0])
    assert main(["evaluate", "--checkpoint", str(run), "--damping", "1", "--mode", "det", "--episodes", "3",
                 "--exact-reset", "--json"]) == 0
    exact = json.loads(capsys.readouterr().out)
    assert exact["starts"] == "exact" and exact["cells"][0]["success_rate"] in (0.0, 1.0)  # one episode, repeated
    assert (run / "eval_best_robust_exact.json").is_file()
    for bad in (["--damping", "-1"], ["--damping", "nan"], ["--episodes", "0"]):
        assert main(["evaluate", "--checkpoint", str(run), *bad]) == 2


def test_demo_trains_evaluates_and_reports(tmp_path):
    """The main job end to end, with a 2-epoch preset (the real one is 60 epochs on a CPU)."""
    assert main(["demo", "--out", str(tmp_path), "--epochs", "2", "--quiet"]) == 0
    res = json.loads((tmp_path / "eval_best_robust.json").read_text())  # the checkpoint selected by robustness
    assert res["checkpoint"].endswith("best_robust") and res["starts"]["bank"] >= 1  # perturbed starts
    assert sorted((c["damping"], c["mode"]) for c in res["cells"]) == sorted(
        (d, m) for d in (1.0, 2.0, 4.0) for m in ("det", "stoch"))
    assert all(c["episodes"] == 20 and len(c["success_ci95"]) == 2 for c in res["cells"])
    assert (tmp_path / "robust.csv").is_file()
    report = (tmp_path / "report.md").read_text()
    assert "| x1 | det |" in report and "success_vs_damping.png" in report
    for png in ("success_vs_damping.png", "grasp.png"):
        assert (tmp_path / png).read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "checkpoints" / "final" / "learner").is_dir()
    frames, width, height = _gif(tmp_path / "policy.gif")
    assert "policy.gif" in report and frames >= 2 and width == 3 * height * 4 // 3  # three panels: x1, x2, x4
    assert main(["demo", "--out", str(tmp_path), "--epochs", "2", "--quiet"]) == 2  # never overwrites a run
    # the same run's policy as a video, two dampings side by side (MP4 asked: GIF where no ffmpeg)
    assert main(["video", "--checkpoint", str(tmp_path), "--damping", "1,4", "--out", str(tmp_path / "v.mp4"),
                 "--every", "100", "--backend", "mujoco"]) == 0
    video = next(p for p in (tmp_path / "v.mp4", tmp_path / "v.gif") if p.is_file())
    assert video.suffix == ".mp4" or _gif(video)[1:] == (720, 270)


def _gif(path) -> tuple[int, int, int]:
    """(frames, width, height) of a GIF file."""
    from PIL import Image

    with Image.open(path) as im:
        assert im.format == "GIF"
        return im.n_frames, *im.size
