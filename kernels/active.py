"""Kernels of active lines: muscle torques, an internal bending moment prescribed along a line
and in time (PyElastica's MuscleTorques: a travelling wave with a spline amplitude), and a
rest curvature and rest strain changing in time (ActiveCurvature), set after every drift at the stage's time
like a driven node's pose (compose.constraint_kernels): the energy that change puts into the
strain energy at the current shape is the work of the actuation.

The moment M(s, t) d acts at the interior Voronoi points as an extra internal moment: element
k - 1 and element k receive the couple -M, +M about the body direction d, so a line with free
ends and a constant M takes the shape B (u - u0) = M d (curvature M / EI about d).
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import STEP
from .compose import account_kernel, constraint_kernels, load_kernel
from .drives import eval_path
from .rotations import quat_rotate_inv, relative_rotation


class MuscleTorqueParams(NamedTuple):
    lines: np.ndarray       # (m,) int64 the lines driven, each by the same wave on its own arc length
    direction: np.ndarray   # (3,) unit body-frame direction of the moment
    offsets: np.ndarray     # (m + 1,) int64 CSR offsets of each line's rows in amplitude and s
    amplitude: np.ndarray   # A(s) at each line's Voronoi points (ends unused)
    s: np.ndarray           # their arc length from the line's start
    wave: np.ndarray        # (5,) 2 pi / period (0: no wave, factor 1), 2 pi / wavelength, phase, ramp time,
                            # 1 with a schedule g(t) (0 without)
    work: np.ndarray        # (1,) work done by the moment so far
    # the schedule g(t), a path of one component as kernels.drives.eval_path reads it
    sched_rate: np.ndarray  # (1,)
    sched_amp: np.ndarray   # (1,)
    sched_wave: np.ndarray  # (2,) omega, phase
    sched_times: np.ndarray  # (m,) spline knots (m = 0: no table)
    sched_coef: np.ndarray  # (max(m-1, 0), 4, 1)
    sched_zero: np.ndarray  # (1,) zero: nothing is subtracted from g
    sched_out: np.ndarray   # (3,) scratch: g, g', g''
    wave_cos: np.ndarray    # cos(2 pi s / lambda) at each row (1 without a wave)
    wave_sin: np.ndarray    # sin(2 pi s / lambda) at each row (0 without a wave)
    moment: np.ndarray      # scratch: M at each row, as the last load set it (its account reads it)


@njit(**STEP)
def time_factor(p, t):
    """Return ramp(t) g(t): the ramp min(1, t / ramp time) (1 without one) times the
    schedule's value (1 without one)."""
    ramp = 1.0 if p.wave[3] <= 0.0 else min(1.0, t / p.wave[3])
    if p.wave[4] == 0.0:
        return ramp
    eval_path(t, p.sched_rate, p.sched_amp, p.sched_wave, p.sched_times, p.sched_coef, p.sched_zero,
              p.sched_out, np.int64(0))   # (an int64 as the drives pass it: one compilation of eval_path)
    return ramp * p.sched_out[0]


@njit(**STEP)
def muscle_factor(p, t, s, g):
    """Return g sin(2 pi (t / T - s / lambda) + phase), or g without a wave (g: time_factor)."""
    if p.wave[0] == 0.0:
        return g
    return g * math.sin(p.wave[0] * t - p.wave[1] * s + p.wave[2])


@njit(**STEP)
def set_muscle_moments(p, model, t, tau):
    """Update p.moment at each line's interior Voronoi points to M(s, t) = A(s) ramp g(t)
    sin(2 pi (t / T - s / lambda) + phase), and tau (ne,3) by -M d on the element before
    each point and +M d on the one after (body frames). The sine of each point is that of
    the wave's phase at t and of its own static phase 2 pi s / lambda, combined: one sine per
    call, not one per point."""
    g = time_factor(p, t)
    sw, cw = 1.0, 0.0   # no wave: the factor is g alone (wave_cos = 1, wave_sin = 0)
    if p.wave[0] != 0.0:
        a = p.wave[0] * t + p.wave[2]
        sw, cw = math.sin(a), math.cos(a)
    d = p.direction
    nl = model.line_element_offsets.shape[0] - 1
    for j in range(p.lines.shape[0]):
        l = p.lines[j]
        if l < 0 or l >= nl:
            continue
        e0 = model.line_element_offsets[l]
        n = model.line_element_offsets[l + 1] - e0
        r0 = p.offsets[j]
        for k in range(1, min(n, p.offsets[j + 1] - r0 - 1)):
            r = r0 + k
            m = p.amplitude[r] * (g * (sw * p.wave_cos[r] - cw * p.wave_sin[r]))
            p.moment[r] = m
            a, b = e0 + k - 1, e0 + k
            for c in range(3):
                tau[a, c] -= m * d[c]
                tau[b, c] += m * d[c]


@load_kernel(MuscleTorqueParams)
@njit(**STEP)
def add_muscle_torques(p, model, state, loads):
    """Update loads.tau (ne,3) and p.moment given the muscle moment M(s, t) d at the interior
    Voronoi points of each line: -M d on the element before each point, +M d on the one after
    (body frames)."""
    set_muscle_moments(p, model, state.clock[0], loads.tau)


@account_kernel(MuscleTorqueParams)
@njit(**STEP)
def account_muscle_work(p, model, state, hh):
    """Update p.work by hh times the moment's power at the current angular velocities,
    sum M d . (w_k - w_(k-1)) over each line's interior Voronoi points (body frames), M the
    moments the kick's load set (p.moment): taken on both sides of a kick of 2 hh, the work
    the kick's share of the moment gives the kinetic energy."""
    d, w = p.direction, state.w
    nl = model.line_element_offsets.shape[0] - 1
    power = 0.0
    for j in range(p.lines.shape[0]):
        l = p.lines[j]
        if l < 0 or l >= nl:
            continue
        e0 = model.line_element_offsets[l]
        n = model.line_element_offsets[l + 1] - e0
        r0 = p.offsets[j]
        for k in range(1, min(n, p.offsets[j + 1] - r0 - 1)):
            m = p.moment[r0 + k]
            a, b = e0 + k - 1, e0 + k
            power += m * (d[0] * (w[b, 0] - w[a, 0]) + d[1] * (w[b, 1] - w[a, 1]) + d[2] * (w[b, 2] - w[a, 2]))
    p.work[0] += hh * power


class ActiveCurvatureParams(NamedTuple):
    line: int
    base: np.ndarray        # (n+1, 3) the line's rest curvature as built, principal frame (0 rows: not changed)
    amplitude: np.ndarray   # (n+1, 3) A(s) at the Voronoi points (ends unused)
    s: np.ndarray           # (n+1,) their arc length from the line's start
    wave: np.ndarray        # (5,) as MuscleTorqueParams.wave
    work: np.ndarray        # (1,) work done by the actuation so far
    last: np.ndarray        # (n+1, 3) curvature theta / l at the end of the previous drift
    strain_base: np.ndarray  # (n, 3) the line's rest strain v0 as built, principal frame (0 rows: not changed)
    strain_amplitude: np.ndarray  # (n, 3) A(s) of shear d1, shear d2, stretch at the element midpoints
    strain_s: np.ndarray    # (n,) their arc length from the line's start
    strain_last: np.ndarray  # (n, 3) strain v = D^T r' / l at the end of the previous drift
    sched_rate: np.ndarray  # the schedule, as MuscleTorqueParams'
    sched_amp: np.ndarray
    sched_wave: np.ndarray
    sched_times: np.ndarray
    sched_coef: np.ndarray
    sched_zero: np.ndarray
    sched_out: np.ndarray


@njit(**STEP)
def change_rest_curvature(p, model, state, t, g):
    """Update model.voronoi_rest_curvature at the line's interior Voronoi points to
    u0 = base + A(s) factor(s, t) (muscle_factor; g: time_factor at t), and p.work by the
    strain energy that change adds, sum 1/2 l B ((u - u0_new)^2 - (u - u0_old)^2), averaged
    over the shapes u at the drift's two ends (p.last, then now): the splitting holds u0 from
    one kick to the middle of the next drift, so a change taken at either end alone is first
    order."""
    v0 = model.line_vertex_offsets[p.line]
    e0 = model.line_element_offsets[p.line]
    n = model.line_element_offsets[p.line + 1] - e0
    q = state.q
    u0 = model.voronoi_rest_curvature
    rows = min(p.amplitude.shape[0], p.base.shape[0], p.s.shape[0], p.last.shape[0])   # a record edited by hand
    for k in range(1, min(n, rows - 1)):
        a, b, vt = e0 + k - 1, e0 + k, v0 + k
        theta = relative_rotation(q[a, 0], q[a, 1], q[a, 2], q[a, 3], q[b, 0], q[b, 1], q[b, 2], q[b, 3])
        f = muscle_factor(p, t, p.s[k], g)
        lv = model.voronoi_rest_length[vt]
        inv = model.voronoi_inv_rest_length[vt]
        for c in range(3):
            new, old = p.base[k, c] + p.amplitude[k, c] * f, u0[vt, c]
            u, w = theta[c] * inv, p.last[k, c]
            bk = model.voronoi_stiffness[vt, c]
            p.work[0] += 0.25 * lv * bk * ((u - new) ** 2 - (u - old) ** 2 + (w - new) ** 2 - (w - old) ** 2)
            u0[vt, c] = new
            p.last[k, c] = u


@njit(**STEP)
def change_rest_strain(p, model, state, t, g):
    """Update model.element_rest_strain of the line's elements to v0 = base + A(s) factor(s, t)
    and p.work by the strain energy that change adds, sum 1/2 l K ((v - v0_new)^2 -
    (v - v0_old)^2), averaged over the strains v = D^T r' / l at the drift's two ends, as
    change_rest_curvature."""
    v0 = model.line_vertex_offsets[p.line]
    e0 = model.line_element_offsets[p.line]
    n = model.line_element_offsets[p.line + 1] - e0
    x, q = state.x, state.q
    rest = model.element_rest_strain
    if rest.shape[0] != model.element_rest_length.shape[0]:
        return
    rows = min(p.strain_amplitude.shape[0], p.strain_base.shape[0], p.strain_s.shape[0], p.strain_last.shape[0])
    for k in range(min(n, rows)):
        e, a, b = e0 + k, v0 + k, v0 + k + 1
        sx, sy, sz = quat_rotate_inv(q[e, 0], q[e, 1], q[e, 2], q[e, 3],
                                     x[b, 0] - x[a, 0], x[b, 1] - x[a, 1], x[b, 2] - x[a, 2])
        il, le = model.element_inv_rest_length[e], model.element_rest_length[e]
        f = muscle_factor(p, t, p.strain_s[k], g)
        for c in range(3):
            new, old = p.strain_base[k, c] + p.strain_amplitude[k, c] * f, rest[e, c]
            v, w = (sx if c == 0 else sy if c == 1 else sz) * il, p.strain_last[k, c]
            kk = model.element_stiffness[e, c]
            p.work[0] += 0.25 * le * kk * ((v - new) ** 2 - (v - old) ** 2 + (w - new) ** 2 - (w - old) ** 2)
            rest[e, c] = new
            p.strain_last[k, c] = v


@njit(**STEP)
def set_rest_shape(p, model, state, h):
    """Update the line's rest curvature and rest strain (change_rest_curvature,
    change_rest_strain) and p.work at t = state.clock[0]."""
    if p.line < 0 or p.line >= model.line_element_offsets.shape[0] - 1:
        return
    t = state.clock[0]
    g = time_factor(p, t)
    change_rest_curvature(p, model, state, t, g)
    change_rest_strain(p, model, state, t, g)


@njit(**STEP)
def keep_rest_shape(p, model, state, arg):
    """Leave everything as it is: a kick does not change the rest curvature or strain."""


constraint_kernels(ActiveCurvatureParams, set_rest_shape, keep_rest_shape)
