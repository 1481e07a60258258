"""Rotation matrices, unit quaternions (w, x, y, z) and rotation vectors, vectorised in numpy.

Stacks of any leading shape: matrices (..., 3, 3), quaternions (..., 4), rotation vectors
(..., 3); and the same algebra on column tuples, the form the diagnostics (cosnet.engine.measure)
use. Used when nets are built and read back, and between steps; the kernels have their own
scalar algebra (kernels/rotations.py). Kept here rather than taken from scipy.spatial.transform, whose import
alone costs about half a second at every start of the command line.
"""

from __future__ import annotations

import numpy as np


def quat_from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) (w, x, y, z) of rotation matrix/matrices m (..., 3, 3).

    Shepperd's method: the largest of 4w^2, 4x^2, 4y^2, 4z^2 (read off the diagonal) is
    computed first and the others from off-diagonal sums, so no component is found by
    dividing by a small one; a slightly non-orthogonal m gives its nearest rotation to first
    order (Markley 2008)."""
    m = np.asarray(m, dtype=float)
    d = np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]], axis=-1)
    tr = d.sum(axis=-1)
    choice = np.argmax(np.concatenate([d, tr[..., None]], axis=-1), axis=-1)
    # (x, y, z, w) of the four candidates, each scaled by 4 * (its chosen component)
    a = lambda i, j: m[..., i, j]
    cand = [
        (1 + 2 * a(0, 0) - tr, a(1, 0) + a(0, 1), a(2, 0) + a(0, 2), a(2, 1) - a(1, 2)),
        (a(1, 0) + a(0, 1), 1 + 2 * a(1, 1) - tr, a(2, 1) + a(1, 2), a(0, 2) - a(2, 0)),
        (a(2, 0) + a(0, 2), a(2, 1) + a(1, 2), 1 + 2 * a(2, 2) - tr, a(1, 0) - a(0, 1)),
        (a(2, 1) - a(1, 2), a(0, 2) - a(2, 0), a(1, 0) - a(0, 1), 1 + tr),
    ]
    stacked = np.stack([np.stack([w, x, y, z], axis=-1) for x, y, z, w in cand])   # (4, ..., 4)
    q = np.take_along_axis(stacked, choice[None, ..., None], axis=0)[0]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix/matrices R(q) (..., 3, 3) of quaternion(s) q (..., 4) in (w, x, y, z)
    order; q is normalised first."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - z * w)
    r[..., 0, 2] = 2 * (x * z + y * w)
    r[..., 1, 0] = 2 * (x * y + z * w)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - x * w)
    r[..., 2, 0] = 2 * (x * z - y * w)
    r[..., 2, 1] = 2 * (y * z + x * w)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def rotvec_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation vector(s) (..., 3), angle in [0, pi], of unit quaternion(s) q (..., 4)."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0.0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    small = angle < 1e-3
    a2 = angle * angle
    # angle / sin(angle/2), with its series below 1e-3 rad (no 0/0)
    scale = np.where(small, 2.0 + a2 / 12.0 + 7.0 * a2 * a2 / 2880.0,
                     angle / np.sin(0.5 * np.where(small, 1.0, angle)))
    return scale[..., None] * q[..., 1:]


def quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) (w, x, y, z) of rotation vector(s) v (..., 3)."""
    v = np.asarray(v, dtype=float)
    angle = np.linalg.norm(v, axis=-1)
    small = angle < 1e-3
    a2 = angle * angle
    # sin(angle/2) / angle, with its series below 1e-3 rad
    scale = np.where(small, 0.5 - a2 / 48.0 + a2 * a2 / 3840.0,
                     np.sin(0.5 * angle) / np.where(small, 1.0, angle))
    return np.concatenate([np.cos(0.5 * angle)[..., None], scale[..., None] * v], axis=-1)


def rotvec_from_matrix(m: np.ndarray) -> np.ndarray:
    """Rotation vector(s) (..., 3) of rotation matrix/matrices m (..., 3, 3): the matrix
    logarithm, angle in [0, pi]."""
    return rotvec_from_quat(quat_from_matrix(m))


def matrix_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Rotation matrix/matrices (..., 3, 3) of rotation vector(s) v (..., 3): exp of [v]x."""
    return matrix_from_quat(quat_from_rotvec(v))


def frame_from_tangent(t: np.ndarray, d1_hint: np.ndarray | None = None) -> np.ndarray:
    """Return a rotation whose third column is the unit tangent t and whose first column is
    the hint projected perpendicular to t (or a fixed perpendicular when no hint)."""
    d3 = t / np.linalg.norm(t)
    if d1_hint is None:
        # the lab axis least aligned with d3 gives a well-conditioned perpendicular
        d1_hint = np.eye(3)[int(np.argmin(np.abs(d3)))]
    d1 = d1_hint - np.dot(d1_hint, d3) * d3
    n = np.linalg.norm(d1)
    if n < 1e-9:
        raise ValueError("d1 hint is parallel to the line's tangent")
    d1 /= n
    d2 = np.cross(d3, d1)
    return np.column_stack([d1, d2, d3])


def skew(v) -> np.ndarray:
    """Cross-product matrices [v]x (..., 3, 3) of vectors v (..., 3): [v]x a = v x a."""
    v = np.asarray(v, dtype=float)
    s = np.zeros(v.shape[:-1] + (3, 3))
    s[..., 0, 1], s[..., 0, 2] = -v[..., 2], v[..., 1]
    s[..., 1, 0], s[..., 1, 2] = v[..., 2], -v[..., 0]
    s[..., 2, 0], s[..., 2, 1] = -v[..., 1], v[..., 0]
    return s


def inertia_shift(x: np.ndarray) -> np.ndarray:
    """|x|^2 1 - x x^T: the inertia of a unit point mass at x about the origin (the
    parallel-axis shift)."""
    return np.dot(x, x) * np.eye(3) - np.outer(x, x)


# --------------------------------------------------- quaternions and vectors as column tuples
# A quaternion stack is a tuple of four 1-D arrays (w, x, y, z), a vector stack a tuple of
# three: the per-element arrays of the model and state are column-major, so each component
# runs contiguously and every operation below is a plain vectorised loop.
def cols(a) -> tuple:
    """The columns of a (n, k) array, as a tuple of k 1-D arrays."""
    return tuple(a[:, k] for k in range(a.shape[1]))


def qmul(a, b):
    """Hamilton products a b."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def qrot(q, v, inverse=False):
    """R(q) v (body -> lab), or R(q)^T v with inverse=True."""
    w, u = (-q[0] if inverse else q[0]), q[1:]
    t = tuple(2.0 * c for c in cross(u, v))
    ut = cross(u, t)
    return tuple(v[k] + w * t[k] + ut[k] for k in range(3))


def qlog(q):
    """Rotation vectors, |theta| <= pi, of unit quaternions q."""
    sign = np.where(q[0] < 0.0, -1.0, 1.0)
    w, x, y, z = (sign * c for c in q)
    s = np.sqrt(x * x + y * y + z * z)
    turned = s > 0.0
    f = np.where(turned, 2.0 * np.arctan2(s, w) / np.where(turned, s, 1.0), 2.0 / w)
    return f * x, f * y, f * z


def qexp(theta):
    """Unit quaternions exp(theta) of rotation vectors theta."""
    tx, ty, tz = theta
    a = np.sqrt(tx * tx + ty * ty + tz * tz)
    turned = a > 0.0
    s = np.where(turned, np.sin(0.5 * a) / np.where(turned, a, 1.0), 0.5)
    return np.cos(0.5 * a), s * tx, s * ty, s * tz


def conj(q):
    return q[0], -q[1], -q[2], -q[3]
