"""Learning does not collapse on the heavy drawer: the paper's PICA, from the reference's initialisation, opens it
in its first epochs (the collapse to holding still needs every early episode to end detached)."""

import numpy as np

from dragmesh2_jax.assets.procedural import HEAVY_DRAWER, packaged_object
from dragmesh2_jax.ppo.runner import RobustSelection, train
from dragmesh2_jax.runs import make_trainer

EPOCHS = 6


def test_pica_opens_the_heavy_drawer_in_its_first_epochs(tmp_path):
    trainer = make_trainer(str(packaged_object(HEAVY_DRAWER)), None, "pica", backend="mujoco", epochs=EPOCHS,
                           seed=0)
    _, rows = train(trainer, tmp_path / "run", str(packaged_object(HEAVY_DRAWER)), progress=False,
                    save_every=EPOCHS, selection=RobustSelection(every=0))
    success = np.array([r["success"] for r in rows])
    detach = np.array([r["detach"] for r in rows])
    progress = np.array([r["progress"] for r in rows])
    assert success.max() >= 0.1, success  # under a fingertip grasp: 0.00 for 20 epochs, then a brace
    assert not np.any((detach < 0.05) & (progress < 0.05)), (detach, progress)  # holding still
