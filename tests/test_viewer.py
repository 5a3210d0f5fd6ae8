"""``dragmesh2 view`` opens MuJoCo's interactive viewer, steps the expert drag (or a policy) in real time and closes
cleanly: launched on a virtual screen (Xvfb, which CI installs) as a user would, for a few control steps."""

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dragmesh2_jax.assets.procedural import default_object
from tests.conftest import in_ci, installed_command


@pytest.fixture
def display():
    xvfb = shutil.which("Xvfb")
    if xvfb is None:
        if in_ci():
            pytest.fail("Xvfb is not installed (CI installs it: apt-get install xvfb)")
        pytest.skip("no Xvfb here")
    number = 90 + os.getpid() % 9
    server = subprocess.Popen([xvfb, f":{number}", "-screen", "0", "1024x768x24", "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    time.sleep(1.0)
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def test_view_runs_the_expert_drag_in_the_viewer_and_closes(display):
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}  # the viewer's own (GLFW) context on the display
    env["DISPLAY"] = display
    cmd = [str(Path(sys.executable).parent / "dragmesh2"), "view", "--object", str(default_object()), "--steps", "5",
           "--damping", "4", "--backend", "mujoco"]
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "view: damping x4" in out.stderr and "view: 5 control steps shown" in out.stderr


def test_view_without_a_checkpoint_or_an_object_is_one_error_line(capsys):
    assert installed_command()(["view"]) == 2
    assert capsys.readouterr().err.startswith("error: give --checkpoint")
