"""The numpy rotation conversions agree with scipy's independent implementation, including
angles near zero (series branches) and near pi (where the rotation vector's direction is read
off the symmetric part)."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from cosnet.core.rotations import (matrix_from_quat, matrix_from_rotvec, quat_from_matrix, rotvec_from_matrix)


def _rotvecs():
    rng = np.random.default_rng(7)
    axes = rng.standard_normal((300, 3))
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    angles = np.concatenate([rng.uniform(0, np.pi, 200), 10.0 ** rng.uniform(-12, -2, 60),
                             np.pi - 10.0 ** rng.uniform(-12, -3, 40)])
    return axes * angles[:, None]


def test_matrix_and_rotation_vector_round_trip_as_scipy():
    v = _rotvecs()
    m = Rotation.from_rotvec(v).as_matrix()
    assert np.abs(matrix_from_rotvec(v) - m).max() < 1e-14
    # near pi the axis is only defined to O(eps / (pi - angle)): compare the rotations
    back = rotvec_from_matrix(m)
    assert np.abs(Rotation.from_rotvec(back).as_matrix() - m).max() < 1e-14
    small = np.linalg.norm(v, axis=1) < 1.0
    assert np.abs(back[small] - v[small]).max() < 1e-14


def test_quaternions_match_scipy_sign_and_all():
    m = Rotation.random(500, random_state=3).as_matrix()
    xyzw = Rotation.from_matrix(m).as_quat()
    q = quat_from_matrix(m)
    assert np.abs(q - np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)).max() < 4e-15
    assert np.abs(matrix_from_quat(q) - m).max() < 1e-14
    # one matrix and a stack agree; empty stacks keep their shape
    assert np.array_equal(quat_from_matrix(m[4]), q[4])
    assert quat_from_matrix(np.zeros((0, 3, 3))).shape == (0, 4)
    assert rotvec_from_matrix(np.zeros((0, 3, 3))).shape == (0, 3)


@pytest.mark.parametrize("axis", range(3))
def test_half_turns_about_each_axis(axis):
    """Trace -1: the candidate with the largest diagonal entry carries the quaternion."""
    v = np.pi * np.eye(3)[axis]
    m = Rotation.from_rotvec(v).as_matrix()
    assert np.abs(np.abs(rotvec_from_matrix(m)) - np.abs(v)).max() < 1e-14
    assert np.abs(matrix_from_quat(quat_from_matrix(m)) - m).max() < 4e-15


def test_the_kernels_logarithm_is_scipys_rotation_vector_and_its_arctangent_the_librarys():
    """kernels.rotations.quat_log, which takes the vectorisable atan_ratio for the library's
    atan2 (kernels/elementary.py): the rotation vector scipy finds, to 1e-15 rad, from angles of
    1e-12 rad to pi, with either sign of the quaternion; atan_ratio within two ulps of atan2 over
    twenty decades of the ratio and at its reduction's seam, tan(pi/8)."""
    from numba import njit

    from cosnet.kernels.elementary import TAN_PI_8, atan_ratio
    from cosnet.kernels.rotations import quat_log

    @njit
    def logs(q, out):   # (quat_log has no Python entry: kernels call it)
        for i in range(q.shape[0]):
            out[i, 0], out[i, 1], out[i, 2] = quat_log(q[i, 0], q[i, 1], q[i, 2], q[i, 3])
    v = _rotvecs()
    q = Rotation.from_rotvec(v).as_quat()[:, [3, 0, 1, 2]]
    for sign in (1.0, -1.0):
        got = np.empty_like(v)
        logs(sign * q, got)
        assert np.abs(got - v).max() < 1e-15 * (1.0 + np.pi)
    rng = np.random.default_rng(3)
    y = rng.uniform(0.0, 1.0, 3000) * 10.0 ** rng.uniform(-10, 10, 3000)
    x = rng.uniform(0.0, 1.0, 3000) * 10.0 ** rng.uniform(-10, 10, 3000)
    x[:300] = y[:300] / (TAN_PI_8 * (1.0 + rng.uniform(-1e-9, 1e-9, 300)))
    for a, b in zip(y, x):
        want = np.arctan2(a, b)
        assert abs(atan_ratio(a, b) - want) <= 2.0 * np.spacing(want), (a, b)
    assert atan_ratio(0.0, 0.0) == 0.0 and atan_ratio(1.0, 0.0) == np.pi / 2 and atan_ratio(0.0, 1.0) == 0.0
