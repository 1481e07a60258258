"""Kernels of the medium's Airy waves: the surface elevation and the particle velocity and
acceleration of a sum of linear components at the vertices of a line (kernels/fluid.py takes
them into its sample), in passes over a line's vertices that LLVM vectorises.

A component's kinematics take a sine, a cosine and an exponential at every vertex and kick,
kernels/elementary.py's (the C library's are calls a loop cannot vectorise, which cost
several times a dry line's whole step)."""

import math

from numba import njit

from .backend import PASS
from .compiler import CACHED_INLINE, CACHED_LANES
from .elementary import PIO2_1, PIO2_2, PIO2_3, TWO_OVER_PI, exp_nonpositive, sin_cos
from .layout import uint


@njit(**CACHED_INLINE)
def depth_factors(k, zs, e2, inv_s):
    """Return cosh(k (zs + d)) / sinh(k d) and sinh(k (zs + d)) / sinh(k d) at zs <= 0 below
    the still surface over depth d, given e2 = exp(-2 k d) and inv_s = 1 / (1 - e2) (constants
    of the component: FluidParams.wave_depth; e2 = 0, inv_s = 1 in deep water), written with
    one exponential, which neither overflows in deep water nor loses the finite-depth term."""
    e = exp_nonpositive(k * zs)
    r = e2 / e
    return (e + r) * inv_s, (e - r) * inv_s


@njit(**CACHED_LANES)
def wave_phase(w, phase, t):
    """Return phase - w t reduced to [-pi, pi]: the time's share of a component's argument, so
    that the argument at a vertex stays small however long the run (the same angle to two
    ulps up to 2^18 turns, 24 days of an 8 s wave; beyond, a bit fewer for every doubling)."""
    a = phase - w * t
    n = math.floor(a * (0.25 * TWO_OVER_PI) + 0.5)   # whole turns: 2 pi = 4 (pi/2), in the parts above
    return ((a - n * (4.0 * PIO2_1)) - n * (4.0 * PIO2_2)) - n * (4.0 * PIO2_3)


@njit(**PASS)
def add_elevation(x, y, eta, lo, n, a, kx, ky, phi):
    """Update eta at the n vertices lo.. by one component's elevation a cos(kx x + ky y + phi)
    (x, y: the position columns)."""
    for k in range(n):
        i = lo + uint(k)
        eta[i] += a * sin_cos(kx * x[i] + ky * y[i] + phi)[1]


@njit(**CACHED_INLINE)
def stretched(zeta, eta, depth, stretch):
    """Return the height below the still surface at which the waves' kinematics are taken at
    a wet point zeta above it under the waved surface eta: Wheeler's (stretch 1: the wet
    column [-depth, eta] mapped onto [-depth, 0]) or zeta held at the still surface above it."""
    if stretch == 1:
        s = zeta - eta if math.isinf(depth) else depth * (zeta - eta) / (depth + eta)
    else:
        s = zeta
    return min(s, 0.0)


@njit(**CACHED_INLINE)
def component(a, w, k, cos_h, sin_h, th, zs, e2, inv_s):
    """Return the velocity and acceleration (ux, uy, uz, ax, ay, az) of one Airy component
    (amplitude a, angular frequency w, wave number k, heading (cos_h, sin_h); e2, inv_s:
    depth_factors) at a point of argument th at the height zs (stretched)."""
    st, ct = sin_cos(th)
    ch, sh = depth_factors(k, zs, e2, inv_s)
    uh, ah = a * w * ch * ct, a * w * w * ch * st
    return uh * cos_h, uh * sin_h, a * w * sh * st, ah * cos_h, ah * sin_h, -a * w * w * sh * ct


@njit(**PASS)
def sample_depths(z, eta, wet, zs, lo, n, surface, depth, stretch):
    """Update wet (1 below the waved surface eta, else 0) and zs (stretched: the height at
    which the waves' kinematics are taken, 0 where dry) at the n vertices lo.. given their
    heights z."""
    for k in range(n):
        i = lo + uint(k)
        zeta = z[i] - surface
        under = zeta <= eta[i]
        wet[i] = 1.0 if under else 0.0
        zs[i] = stretched(zeta, eta[i], depth, stretch) if under else 0.0


@njit(**PASS)
def add_kinematics(x, y, zs, wet, U, A, lo, n, a, w, k, cos_h, sin_h, phi, e2, inv_s):
    """Update U and A (three columns each: the medium's velocity and acceleration) at the n
    vertices lo.. by one component's (component; phi its phase at this time, wave_phase) where
    they are wet, at the heights zs (sample_depths)."""
    kx, ky = k * cos_h, k * sin_h
    for j in range(n):
        i = lo + uint(j)
        ux, uy, uz, ax, ay, az = component(a, w, k, cos_h, sin_h, kx * x[i] + ky * y[i] + phi, zs[i], e2, inv_s)
        m = wet[i]
        U[0][i] += ux * m
        U[1][i] += uy * m
        U[2][i] += uz * m
        A[0][i] += ax * m
        A[1][i] += ay * m
        A[2][i] += az * m
