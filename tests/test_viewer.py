"""``dragmesh2 view`` opens MuJoCo's interactive viewer: the README's two view commands run on a virtual screen in
tests/test_readme.py (Xvfb, which CI installs); here, what it refuses before anything is loaded."""

from dragmesh2_jax.assets.procedural import default_object
from tests.conftest import installed_command


def test_view_without_a_checkpoint_or_an_object_is_one_error_line(capsys):
    assert installed_command()(["view"]) == 2
    assert capsys.readouterr().err.startswith("error: give --checkpoint")


def test_view_without_a_display_is_one_line(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert installed_command()(["view", "--object", str(default_object()), "--steps", "1"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == ("error: view needs a display (DISPLAY is not set): run it on a desktop or under xvfb-run, or "
                    "write a video with dragmesh2 video")
