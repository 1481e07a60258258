"""Active lines: muscle torques along a line (docs/drives.md, "Active lines")."""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

from .effects import Effect
from .kernels.active import MuscleTorqueParams
from .net import Line

# scene keys of a muscle_torque table; their units are in cosnet.scene_values.DIM
MUSCLE_KEYS = ("line", "moment", "points", "direction", "period", "wavelength", "phase", "ramp_time")


class MuscleTorque(Effect):
    """An internal bending moment M(s, t) about the body direction ``direction`` (d1 by default)
    along ``line``, as PyElastica's MuscleTorques:

        M(s, t) = ramp(t) A(s) sin(2 pi (t / period - s / wavelength) + phase)

    A(s) is ``moment`` (N m): a number, or values at ``points`` (fractions of the line's rest
    length, increasing from 0 to 1) joined by a natural cubic spline. Without a period the
    moment is steady: M = ramp(t) A(s). ramp(t) = min(1, t / ramp_time) (1 without one). A line
    with free ends under a steady moment bends to the curvature M / EI about ``direction``.
    The work it does is not yet part of any energy account."""

    adds_energy = True

    def __init__(self, line: Line, moment, points=None, direction=(1.0, 0.0, 0.0), period=0.0,
                 wavelength=math.inf, phase=0.0, ramp_time=0.0):
        if not isinstance(line, Line):
            raise ValueError(f"MuscleTorque: line must be a cosnet Line, got {line!r}")
        who = f"MuscleTorque on {line!r}"
        self.line = line
        m = np.array(moment, dtype=float)
        if points is None:
            if m.ndim != 0 or not math.isfinite(m):
                raise ValueError(f"{who}: moment must be a finite number, or values at points, got {moment!r}")
            self.points, self.moment = np.array([0.0, 1.0]), np.array([float(m)] * 2)
        else:
            s = np.array(points, dtype=float)
            if s.ndim != 1 or s.size < 2 or np.any(np.diff(s) <= 0) or s[0] < 0 or s[-1] > 1:
                raise ValueError(f"{who}: points must increase strictly within [0, 1], got {points!r}")
            if m.shape != s.shape or not np.all(np.isfinite(m)):
                raise ValueError(f"{who}: moment must give one finite value per point ({s.size}), got {moment!r}")
            self.points, self.moment = s, m
        d = np.array(direction, dtype=float)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.any(d):
            raise ValueError(f"{who}: direction must be a nonzero 3-vector, got {direction!r}")
        self.direction = d / np.linalg.norm(d)
        for name, x, ok in (("period", period, period >= 0 and math.isfinite(period)),
                            ("wavelength", wavelength, wavelength > 0),
                            ("phase", phase, math.isfinite(phase)),
                            ("ramp_time", ramp_time, ramp_time >= 0 and math.isfinite(ramp_time))):
            if not ok:
                raise ValueError(f"{who}: {name} out of range, got {x!r}")
        self.period, self.wavelength, self.phase, self.ramp_time = (float(period), float(wavelength),
                                                                    float(phase), float(ramp_time))

    def bind(self, sim):
        sim.check_line(self.line, "MuscleTorque")
        m, l = sim.model, self.line.index
        lengths = m.element_rest_length[m.line_element_offsets[l]:m.line_element_offsets[l + 1]]
        s = np.concatenate([[0.0], np.cumsum(lengths)])
        frac = np.clip(s / s[-1], self.points[0], self.points[-1])
        amp = CubicSpline(self.points, self.moment, bc_type="natural")(frac)
        inside = (s / s[-1] >= self.points[0] - 1e-12) & (s / s[-1] <= self.points[-1] + 1e-12)
        amp = np.where(inside, amp, 0.0)
        wave = np.array([2 * math.pi / self.period if self.period > 0 else 0.0,
                         2 * math.pi / self.wavelength, self.phase, self.ramp_time])
        return MuscleTorqueParams(l, self.direction.copy(), amp, s, wave)

    def describe(self):
        return f"MuscleTorque({self.line.name!r}, moment={self.moment.tolist()})"
