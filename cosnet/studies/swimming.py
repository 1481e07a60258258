"""Resistive-force theory of a planar swimmer whose shape is prescribed: the reference a
simulated filament in Stokes flow (cosnet.Fluid with ``resistance``) is held to.

A filament of length L whose curvature is kappa(s, t) (s its arc length) takes the shape that
integrating the curvature twice gives, its frame moving so that it is free of force and of
moment: with the local drag f = -(c_n (1 - t t^T) + c_t t t^T) v of resistive-force theory
(Gray & Hancock; Lighthill), the velocity v of each point is that of the frame (w, Omega) plus
the shape's own change, and the three conditions sum f = 0, sum (x - x_c) x f = 0 give w and
Omega at each instant. Integrated over whole periods of the stroke they give the swimming
velocity, recoil (the sideways and yawing motion of a finite swimmer) included. Inertia is
absent, as in Stokes flow; the shape is the prescribed one, as for a filament much stiffer
than the drag bending it.
"""

from __future__ import annotations

import math

import numpy as np


def _shape(curvature, length: float, t: float, points: int):
    """(X, tangents) of the shape at time t in its own frame: X (points, 2) about its centroid."""
    s = np.linspace(0.0, length, points)
    ds = s[1] - s[0]
    k = curvature(s, t)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (k[1:] + k[:-1]) * ds)])
    tangent = np.column_stack([np.cos(theta), np.sin(theta)])
    x = np.concatenate([[[0.0, 0.0]], np.cumsum(0.5 * (tangent[1:] + tangent[:-1]) * ds, axis=0)])
    weights = np.full(points, ds)
    weights[[0, -1]] *= 0.5
    return x - weights @ x / length, tangent, weights


def _frame_velocity(curvature, length, t, c_n, c_t, points, h):
    """(w (2,), Omega): the frame's velocity and turning rate at time t that leave the swimmer
    free of force and moment (in the frame's own axes)."""
    x, tangent, weights = _shape(curvature, length, t, points)
    dx = (_shape(curvature, length, t + h, points)[0] - _shape(curvature, length, t - h, points)[0]) / (2.0 * h)

    def drag(v):   # f = -(c_n v + (c_t - c_n) (t.v) t), per point
        return -(c_n * v + (c_t - c_n) * np.sum(tangent * v, axis=1)[:, None] * tangent)

    def totals(v):
        f = drag(v) * weights[:, None]
        return np.array([f[:, 0].sum(), f[:, 1].sum(), np.sum(x[:, 0] * f[:, 1] - x[:, 1] * f[:, 0])])

    spin = np.column_stack([-x[:, 1], x[:, 0]])       # Omega z x X
    columns = [totals(np.tile(e, (points, 1))) for e in ((1.0, 0.0), (0.0, 1.0))] + [totals(spin)]
    w0, w1, om = np.linalg.solve(np.column_stack(columns), -totals(dx))
    return np.array([w0, w1]), om


def swimming_velocity(curvature, length: float, c_n: float, c_t: float, period: float, *, periods: int = 2,
                      points: int = 801, steps: int = 400) -> float:
    """The mean speed (m/s) over ``periods`` whole periods of a planar filament of ``length``
    whose curvature is ``curvature(s, t)`` (vectorised over s, periodic in t with
    ``period``), by resistive-force theory with coefficients c_n, c_t (module docstring).
    The frame's heading and position are integrated by the midpoint rule, ``steps`` per
    period."""
    dt = period / steps
    h = 1e-6 * period
    phi, c = 0.0, np.zeros(2)
    for n in range(periods * steps):
        w, om = _frame_velocity(curvature, length, (n + 0.5) * dt, c_n, c_t, points, h)
        mid = phi + 0.5 * dt * om
        c += dt * np.array([math.cos(mid) * w[0] - math.sin(mid) * w[1], math.sin(mid) * w[0] + math.cos(mid) * w[1]])
        phi += dt * om
    return float(np.linalg.norm(c)) / (periods * period)
