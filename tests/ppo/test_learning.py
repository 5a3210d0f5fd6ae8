"""Learning does not collapse on the heavy drawer: the paper's PICA, from the reference's initialisation, opens it
in its first epochs (the collapse to holding still needs every early episode to end detached)."""

import numpy as np

from dragmesh2_jax.assets.procedural import HEAVY_DRAWER, packaged_object
from dragmesh2_jax.runs.rundir import RunDir
from dragmesh2_jax.runs.session import start_or_resume
from dragmesh2_jax.runs.spec import method_spec

EPOCHS = 6


def test_pica_opens_the_heavy_drawer_in_its_first_epochs(tmp_path):
    """The paper's PICA, network and batch (64 worlds x 32 steps), from seed 0."""
    spec = method_spec("pica", str(packaged_object(HEAVY_DRAWER)), backend="mujoco",
                       schedule={"epochs": EPOCHS, "seed": 0, "save_every": EPOCHS, "robust_every": 0})
    _, _, (rows,) = start_or_resume(spec, [RunDir(tmp_path / "run")], resume=False, progress=False)
    success = np.array([r["success"] for r in rows])
    detach = np.array([r["detach"] for r in rows])
    progress = np.array([r["progress"] for r in rows])
    assert success.max() >= 0.1, success  # under a fingertip grasp: 0.00 for 20 epochs, then a brace
    assert not np.any((detach < 0.05) & (progress < 0.05)), (detach, progress)  # holding still
