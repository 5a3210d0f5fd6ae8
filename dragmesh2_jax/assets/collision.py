"""Collision geometry MJX can afford, derived from an object's meshes and cached on disk by content.

Each mesh file of a link becomes convex pieces (object frame, unscaled):
  * a convex hull with at most ``max_hull_vertices`` vertices (MJX's SAT wants < 32 for convex-convex);
  * a thin oriented box where the hull cannot be computed (coplanar or degenerate meshes);
  * for handles (non-convex pieces that matter for grasping), an approximate convex decomposition (CoACD),
    so fingers can wrap behind a bar instead of meeting a filled hull.
"""

from __future__ import annotations

import dataclasses
import io
from dataclasses import dataclass, field

import coacd
import numpy as np
from scipy.optimize import nnls
from scipy.spatial import ConvexHull, QhullError

from dragmesh2_jax.assets.urdf import Link, load_mesh, mesh_files, transform_points
from dragmesh2_jax.io import atomic_write_bytes, cache_dir, hash_files

GEOMETRY_VERSION = "2"
MIN_BOX_HALF = 0.002  # m (unscaled object units): half-thickness of boxes built for flat pieces
BOX_FIT_TOL = 1e-6  # m (unscaled): how far a hull's vertex may lie off the box that stands for it (``as_box``)


@dataclass(frozen=True)
class ConvexPiece:
    """A convex hull (``vertices``, object frame) or, when ``box_half`` is set, an oriented box with centre
    ``box_pos``, rotation ``box_rot`` (3x3) and half sizes ``box_half``."""

    vertices: np.ndarray = field(repr=False)
    box_pos: np.ndarray | None = None
    box_rot: np.ndarray | None = field(default=None, repr=False)
    box_half: np.ndarray | None = None

    @property
    def is_box(self) -> bool:
        return self.box_half is not None

    @property
    def num_vertices(self) -> int:
        return 8 if self.is_box else len(self.vertices)

    def corners(self) -> np.ndarray:
        """Points spanning the piece (hull vertices or the 8 box corners), object frame."""
        if not self.is_box:
            return self.vertices
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=np.float64)
        return self.box_pos + (s * self.box_half) @ self.box_rot.T


def hull_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Euclidean distance between the convex hulls of the point sets ``a`` and ``b`` (0 where they overlap): the
    distance from the origin to hull(a - b), the closest convex combination found by non-negative least squares
    with the weights' sum pinned to 1 by a heavy extra row."""
    d = (a[:, None, :] - b[None, :, :]).reshape(-1, 3)
    w = 1e3 * max(1.0, float(np.abs(d).max()))
    weights, _ = nnls(np.vstack([d.T, np.full(len(d), w)]), np.array([0.0, 0.0, 0.0, w]))
    return float(np.linalg.norm(d.T @ weights))


def oriented_box(v: np.ndarray) -> ConvexPiece:
    """PCA-oriented bounding box with a minimum half thickness (for flat/degenerate pieces)."""
    c = v.mean(axis=0)
    if len(v) >= 3:
        _, _, vt = np.linalg.svd(v - c, full_matrices=False)
        R = vt.T
        if np.linalg.det(R) < 0:
            R[:, 2] = -R[:, 2]
    else:
        R = np.eye(3)
    local = (v - c) @ R
    lo, hi = local.min(axis=0), local.max(axis=0)
    half = np.maximum((hi - lo) / 2, MIN_BOX_HALF)
    pos = c + R @ ((hi + lo) / 2)
    return ConvexPiece(vertices=np.zeros((0, 3)), box_pos=pos, box_rot=R, box_half=half)


def as_box(piece: ConvexPiece, tol: float = BOX_FIT_TOL) -> ConvexPiece | None:
    """``piece`` as an oriented box where its hull is one (its vertices the box's 8 corners, within ``tol``), else
    None. A box is tried axis-aligned in the object frame first (a cube has no principal axes), then on the
    vertices' principal axes."""
    if piece.is_box:
        return piece
    v = piece.vertices
    if len(v) != 8:
        return None
    lo, hi = v.min(0), v.max(0)
    for box in (ConvexPiece(np.zeros((0, 3)), (lo + hi) / 2, np.eye(3), (hi - lo) / 2), oriented_box(v)):
        corners = box.corners()
        nearest = np.linalg.norm(v[:, None] - corners[None], axis=-1).min(1)
        if nearest.max() <= tol and np.all(box.box_half > 0):
            return box
    return None


def _reduce(points: np.ndarray, k: int) -> np.ndarray:
    """Farthest-point subset of ``points`` of size ``k`` (keeps the extreme vertices of a hull)."""
    idx = [int(np.argmax(np.linalg.norm(points - points.mean(0), axis=1)))]
    d = np.linalg.norm(points - points[idx[0]], axis=1)
    for _ in range(k - 1):
        i = int(np.argmax(d))
        idx.append(i)
        d = np.minimum(d, np.linalg.norm(points - points[i], axis=1))
    return points[idx]


def convex_piece(v: np.ndarray, max_vertices: int) -> ConvexPiece:
    """Hull of ``v`` with at most ``max_vertices`` vertices, or a thin box if the hull is degenerate."""
    if len(v) < 4:
        return oriented_box(v) if len(v) else oriented_box(np.zeros((1, 3)))
    c = v - v.mean(axis=0)
    spread = np.linalg.svd(c, compute_uv=False)
    if spread[-1] < 1e-3 * spread[0]:  # (nearly) coplanar: no usable hull
        return oriented_box(v)
    try:
        pts = v[ConvexHull(v).vertices]
        if len(pts) > max_vertices:
            pts = _reduce(pts, max_vertices)
            pts = pts[ConvexHull(pts).vertices]
    except (QhullError, ValueError):
        return oriented_box(v)
    return ConvexPiece(vertices=pts)


def _decompose(v: np.ndarray, f: np.ndarray, max_pieces: int, threshold: float) -> list[np.ndarray]:
    """CoACD approximate convex decomposition; falls back to the whole piece if it fails."""
    try:
        coacd.set_log_level("error")
        parts = coacd.run_coacd(coacd.Mesh(v, f), threshold=threshold, max_convex_hull=max_pieces,
                                preprocess_resolution=20, seed=0)
        out = [np.asarray(p[0], dtype=np.float64) for p in parts if len(p[0]) >= 4]
        return out or [v]
    except Exception:  # degenerate input: the hull (or box) is the best we can do
        return [v]


def concavity(v: np.ndarray) -> float:
    """Depth of the deepest vertex inside the convex hull of the piece's silhouette (projected onto its two
    principal axes), relative to the second-largest extent: about 0 for convex pieces, > 0.1 for an L- or
    U-shaped handle seen side-on. Uses vertices only, so open (non-watertight) meshes are fine."""
    if len(v) < 4:
        return 0.0
    c = v - v.mean(axis=0)
    _, sv, vt = np.linalg.svd(c, full_matrices=False)
    if sv[1] < 1e-9:
        return 0.0
    p = c @ vt[:2].T
    try:
        eq = ConvexHull(p).equations
    except (QhullError, ValueError):
        return 0.0
    depth = -(p @ eq[:, :2].T + eq[:, 2]).max(axis=1)  # >= 0 inside the silhouette hull
    ext = np.ptp(p, axis=0)
    return float(depth.max() / max(ext.min(), 1e-9))


@dataclass(frozen=True)
class GeometryConfig:
    """How link meshes become collision pieces."""

    max_hull_vertices: int = 32
    """vertices of a convex piece at most (MJX's limit for fast collisions)"""
    decompose_handles: bool = True
    """concave handles into convex pieces by CoACD"""
    max_handle_pieces: int = 4
    """CoACD's pieces per handle at most"""
    coacd_threshold: float = 0.05
    """CoACD's concavity threshold"""
    concavity_tolerance: float = 0.1
    """decompose only pieces whose deepest vertex lies this far inside the hull"""

    def key(self) -> str:
        """The collision cache's key part: the version and every field (any change rebuilds the pieces)."""
        return "-".join([f"v{GEOMETRY_VERSION}", *(str(v) for v in dataclasses.astuple(self))])


def link_pieces(link: Link, decompose: bool, config: GeometryConfig = GeometryConfig(),
                use_cache: bool = True) -> list[ConvexPiece]:
    """Convex pieces of one link, object frame; cached on disk keyed by mesh contents, pose and config."""
    refs = mesh_files(link)
    if not refs:
        return []
    key = hash_files([m.path for m in refs],
                     extra=config.key() + str(decompose) + "".join(np.round(link.pose @ m.transform, 9).tobytes().hex()
                                                                   for m in refs))
    cache = cache_dir() / "geometry" / f"{key}.npz"
    if use_cache and cache.is_file():
        try:
            return _unpack(np.load(cache))
        except Exception:
            cache.unlink(missing_ok=True)
    pieces: list[ConvexPiece] = []
    for m in refs:
        v, f = load_mesh(m.path)
        if len(v) == 0:
            continue
        v = transform_points(v, link.pose @ m.transform)
        concave = decompose and len(f) and concavity(v) > config.concavity_tolerance
        chunks = _decompose(v, f, config.max_handle_pieces, config.coacd_threshold) if concave else [v]
        pieces.extend(convex_piece(c, config.max_hull_vertices) for c in chunks)
    if use_cache:
        buf = io.BytesIO()
        np.savez(buf, **_pack(pieces))
        atomic_write_bytes(cache, buf.getvalue())
    return pieces


def _pack(pieces: list[ConvexPiece]) -> dict:
    out = {"n": np.array(len(pieces))}
    for i, p in enumerate(pieces):
        if p.is_box:
            out[f"b{i}"] = np.concatenate([p.box_pos, p.box_rot.ravel(), p.box_half])
        else:
            out[f"v{i}"] = p.vertices
    return out


def _unpack(z) -> list[ConvexPiece]:
    pieces = []
    for i in range(int(z["n"])):
        if f"b{i}" in z:
            b = z[f"b{i}"]
            pieces.append(ConvexPiece(np.zeros((0, 3)), b[:3], b[3:12].reshape(3, 3), b[12:15]))
        else:
            pieces.append(ConvexPiece(z[f"v{i}"]))
    return pieces
