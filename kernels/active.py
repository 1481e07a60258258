"""Kernels of active lines: muscle torques, an internal bending moment prescribed along a line
and in time (PyElastica's MuscleTorques: a travelling wave with a spline amplitude).

The moment M(s, t) d acts at the interior Voronoi points as an extra internal moment: element
k - 1 and element k receive the couple -M, +M about the body direction d, so a line with free
ends and a constant M takes the shape B (u - u0) = M d (curvature M / EI about d).
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import STEP
from .compose import load_kernel


class MuscleTorqueParams(NamedTuple):
    line: int
    direction: np.ndarray   # (3,) unit body-frame direction of the moment
    amplitude: np.ndarray   # (n+1,) A(s) at the line's Voronoi points (ends unused)
    s: np.ndarray           # (n+1,) their arc length from the line's start
    wave: np.ndarray        # (4,) 2 pi / period (0: no wave, factor 1), 2 pi / wavelength, phase, ramp time


@njit(**STEP)
def muscle_factor(p, t, s):
    """Return ramp(t) sin(2 pi (t / T - s / lambda) + phase), or ramp(t) without a wave."""
    ramp = 1.0 if p.wave[3] <= 0.0 else min(1.0, t / p.wave[3])
    if p.wave[0] == 0.0:
        return ramp
    return ramp * math.sin(p.wave[0] * t - p.wave[1] * s + p.wave[2])


@load_kernel(MuscleTorqueParams)
@njit(**STEP)
def add_muscle_torques(p, model, state, loads):
    """Update loads.tau (ne,3) given the muscle moment M(s, t) d at the interior Voronoi points
    of the line: -M d on the element before each point, +M d on the one after (body frames)."""
    t = state.clock[0]
    e0 = model.line_element_offsets[p.line]
    n = model.line_element_offsets[p.line + 1] - e0
    d = p.direction
    for k in range(1, min(n, p.amplitude.shape[0] - 1)):
        m = p.amplitude[k] * muscle_factor(p, t, p.s[k])
        for c in range(3):
            loads.tau[e0 + k - 1, c] -= m * d[c]
            loads.tau[e0 + k, c] += m * d[c]
