"""The README's picture: the expert grasp on the packaged procedural door, MuJoCo-rendered (OSMesa on a CPU).

    MUJOCO_GL=osmesa python experiments/readme_picture.py docs/grasp.png
"""

from __future__ import annotations

import sys

from dragmesh2_jax.assets.gapartnet import load_gapartnet
from dragmesh2_jax.assets.procedural import packaged_object
from dragmesh2_jax.render import Painter, View
from dragmesh2_jax.scene import build_scene
from dragmesh2_jax.trajectory.generator import generate


def main(path: str) -> None:
    scene = build_scene(load_gapartnet(packaged_object("door_cabinet_0000")))
    traj = generate(scene.obj, scene=scene)
    grasp = traj.frames[traj.drag_start]
    pose = grasp.hand_q, grasp.joint_positions[traj.target_index]
    with Painter(scene, 560, 420) as p:
        p.pose(*pose)
        view = View.of(scene, p.palm(), side=-40.0, elevation=-18.0, distance=0.7)  # the hinge side, nearer
        p.image(*pose, view).save(path)
        print(f"{path} ({p.used} renderer)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/grasp.png")
