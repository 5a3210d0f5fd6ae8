"""Collision pieces: bounded hulls, boxes for degenerate meshes, decomposition of concave handles, caching."""

import numpy as np
import pytest

from dragmesh2_jax.assets import collision


def _l_shape():
    """An L-shaped solid (two boxes) as a triangle mesh."""
    import trimesh

    move = trimesh.transformations.translation_matrix
    a = trimesh.creation.box(extents=[0.1, 0.02, 0.02], transform=move([0.05, 0, 0]))
    b = trimesh.creation.box(extents=[0.02, 0.08, 0.02], transform=move([0.01, 0.05, 0]))
    m = trimesh.util.concatenate([a, b])
    return np.asarray(m.vertices), np.asarray(m.faces)


def test_coplanar_mesh_becomes_a_thin_box():
    v = np.random.default_rng(0).uniform(-1, 1, (50, 3)) * [1, 1, 0]
    p = collision.convex_piece(v, 32)
    assert p.is_box and p.box_half[2] == collision.MIN_BOX_HALF


def test_hull_vertex_count_is_bounded():
    v = np.random.default_rng(0).normal(size=(500, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    p = collision.convex_piece(v, 32)
    assert not p.is_box and 4 <= p.num_vertices <= 32


def test_concavity_separates_convex_from_l_shaped():
    import trimesh

    v, f = _l_shape()
    box = trimesh.creation.box(extents=[0.1, 0.05, 0.02])
    assert collision.concavity(np.asarray(box.vertices)) < 1e-9
    assert collision.concavity(v) > 0.1


def test_l_shaped_handle_is_decomposed_into_several_pieces():
    v, f = _l_shape()
    parts = collision._decompose(v, f, max_pieces=4, threshold=0.05)
    assert len(parts) >= 2


def test_hull_distance_is_surface_to_surface():
    """A large flat panel is near a knob in front of it, though its corners and its centre are far."""
    s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)
    panel = s * [0.005, 1.0, 1.0]  # 2 m x 2 m, 1 cm thick, centred at the origin
    knob = s * 0.02 + [-0.1, 0.9, -0.9]  # 4 cm cube 10 cm in front of the panel, near one corner
    assert np.linalg.norm(panel - knob.mean(0), axis=1).min() > 0.1  # every panel vertex is farther
    assert collision.hull_distance(panel, knob) == pytest.approx(0.1 - 0.02 - 0.005, abs=1e-4)
    assert collision.hull_distance(panel, s * 0.01) == pytest.approx(0.0, abs=1e-6)  # overlapping
