"""Unit-quaternion algebra on scalars (no allocation).

Convention: q = (w, x, y, z) maps body components to lab components, D = R(q) with columns
d1 d2 d3 (2.16)-(2.19). A body-frame rotation vector phi updates q <- q * exp(phi), so the
body-frame angular velocity w obeys q' = q * (0, w) / 2, i.e. Lambda(w^d) = D^T D' (2.26).
"""

import math

from numba import njit

OPTS = dict(cache=True, inline="always")


@njit(**OPTS)
def quat_mul(aw, ax, ay, az, bw, bx, by, bz):
    """Return the Hamilton product a * b."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@njit(**OPTS)
def quat_exp(px, py, pz):
    """Return exp(phi) for the rotation vector phi (angle |phi| about phi/|phi|)."""
    a2 = px * px + py * py + pz * pz
    if a2 < 1e-12:
        # cos(a/2), sin(a/2)/a to O(a^4)
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
        s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        a = math.sqrt(a2)
        c = math.cos(0.5 * a)
        s = math.sin(0.5 * a) / a
    return c, s * px, s * py, s * pz


@njit(**OPTS)
def quat_normalize(w, x, y, z):
    """Return q / |q|."""
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    return w * n, x * n, y * n, z * n


@njit(**OPTS)
def quat_log(w, x, y, z):
    """Return the rotation vector theta (|theta| <= pi) of the unit quaternion q."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s2 = x * x + y * y + z * z
    s = math.sqrt(s2)
    if s < 1e-4 * w:
        r = s2 / (w * w)
        f = (2.0 / w) * (1.0 - r / 3.0 + r * r / 5.0)
    else:
        f = 2.0 * math.atan2(s, w) / s
    return f * x, f * y, f * z


@njit(**OPTS)
def quat_rotate(w, x, y, z, vx, vy, vz):
    """Return R(q) v (body -> lab)."""
    # t = 2 q_vec x v ; v' = v + w t + q_vec x t
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty),
            vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


@njit(**OPTS)
def quat_rotate_inv(w, x, y, z, vx, vy, vz):
    """Return R(q)^T v (lab -> body)."""
    return quat_rotate(w, -x, -y, -z, vx, vy, vz)


@njit(**OPTS)
def cross(ax, ay, az, bx, by, bz):
    """Return a x b."""
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@njit(**OPTS)
def relative_rotation(aw, ax, ay, az, bw, bx, by, bz):
    """Return (theta, c): the rotation vector of A^T B (its components agree in both frames)
    and c(theta) = 1/theta^2 - (1 + cos theta)/(2 theta sin theta) of the inverse Jacobians."""
    rw, rx, ry, rz = quat_mul(aw, -ax, -ay, -az, bw, bx, by, bz)
    tx, ty, tz = quat_log(rw, rx, ry, rz)
    theta2 = tx * tx + ty * ty + tz * tz
    if theta2 < 1e-4:
        c = 1.0 / 12.0 + theta2 / 720.0 + theta2 * theta2 / 30240.0
    else:
        # with cos(theta/2) = |rw| and sin(theta/2) = s: (1 + cos)/(2 theta sin) = |rw|/(2 theta s)
        c = 1.0 / theta2 - abs(rw) / (2.0 * math.sqrt(theta2 * (rx * rx + ry * ry + rz * rz)))
    return tx, ty, tz, c
