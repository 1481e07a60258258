"""Active lines: muscle torques and a rest curvature changing in time (docs/drives.md)."""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import CubicSpline

from . import checks
from .registry import Binding, Effect, Key
from .scene_values import CURVATURE, LENGTH, TIME, TORQUE, array, direction, floats, nonnegative, number, positive, vec3
from .drives import PATH_UNITS, Path, path_table
from .kernels.active import ActiveCurvatureParams, MuscleTorqueParams
from .net import Line



def _number_or_floats(v):
    return floats(v) if isinstance(v, list) else number(v)


def _vec3_or_rows(v):
    return array((-1, 3))(v) if isinstance(v, list) and v and isinstance(v[0], list) else vec3(v)


WAVE_KEYS = (Key("points", floats, doc="fractions of the rest length where A(s) is given (increasing)"),
             Key("period", nonnegative, TIME, doc="period T of the travelling wave (0: none)"),
             Key("wavelength", positive, LENGTH, doc="wavelength along the line"),
             Key("phase", number, doc="phase (rad)"),
             Key("ramp_time", nonnegative, TIME, doc="time over which it is switched on linearly"),
             Key("schedule", path_table, PATH_UNITS["factor"],
                 doc="factor g(t) in time {rate, amplitude, omega, phase, times, values} (1 without)"))


class _Travelling(Effect):
    """A quantity along a line: ramp(t) g(t) A(s) sin(2 pi (t / period - s / wavelength) + phase),
    A(s) given at ``points`` (fractions of the rest length, increasing within [0, 1]) and joined
    by a natural cubic spline (zero outside them), or one value for the whole line; without a
    period, ramp(t) g(t) A(s). ramp(t) = min(1, t / ramp_time), 1 without one; g(t) the
    ``schedule``, a Path of one component (a table of times and values: the clamped cubic
    spline through them, held beyond them; a rate; a harmonic), 1 without one."""

    def _wave(self, line, what, value, k, points, period, wavelength, phase, ramp_time, schedule=None):
        if not (isinstance(line, Line) or (line is None and getattr(self, "lines", None))):
            raise ValueError(f"{type(self).__name__}: line must be a cosnet Line, got {line!r}")
        who = f"{type(self).__name__} on {line!r}" if line is not None else f"{type(self).__name__} on {self.lines!r}"
        self.line = line
        shape = (k,) if k > 1 else ()
        a = np.array(value, dtype=float)
        if points is None:
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{who}: {what} must be {k if k > 1 else 'a'} finite number{'s' if k > 1 else ''}"
                                 f", or values at points, got {value!r}")
            self.points, self.values = np.array([0.0, 1.0]), np.array([a, a]).reshape(2, k)
        else:
            s = np.array(points, dtype=float)
            if s.ndim != 1 or s.size < 2 or np.any(np.diff(s) <= 0) or s[0] < 0 or s[-1] > 1:
                raise ValueError(f"{who}: points must increase strictly within [0, 1], got {points!r}")
            if a.shape != (s.size,) + shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{who}: {what} must give one finite value per point ({s.size}), got {value!r}")
            self.points, self.values = s, a.reshape(s.size, k)
        for name, x, ok in (("period", period, period >= 0 and math.isfinite(period)),
                            ("wavelength", wavelength, wavelength > 0),
                            ("phase", phase, math.isfinite(phase)),
                            ("ramp_time", ramp_time, ramp_time >= 0 and math.isfinite(ramp_time))):
            if not ok:
                raise ValueError(f"{who}: {name} out of range, got {x!r}")
        self.wave = np.array([2 * math.pi / period if period > 0 else 0.0, 2 * math.pi / wavelength,
                              float(phase), float(ramp_time), float(schedule is not None)])
        rate, amp, turn, times, coef = (Path.of(schedule, f"{who}: schedule").arrays(1, f"{who}: schedule")
                                        if schedule is not None else Path().arrays(1, who))
        self.schedule = schedule
        self._sched = (rate, amp, turn, times, coef)

    def _schedule_arrays(self) -> tuple:
        """The schedule's arrays in the record's order (copies: the record owns them)."""
        rate, amp, turn, times, coef = self._sched
        return rate.copy(), amp.copy(), turn.copy(), times.copy(), coef.copy(), np.zeros(1), np.zeros(3)

    def _along(self, sim, line=None):
        """(A at the Voronoi points (n+1, k) of ``line`` (default: the effect's), their arc
        lengths (n+1,))."""
        line = self.line if line is None else line
        sim.check_line(line, type(self).__name__)
        m, l = sim.model, line.index
        lengths = m.element_rest_length[m.line_element_offsets[l]:m.line_element_offsets[l + 1]]
        s = np.concatenate([[0.0], np.cumsum(lengths)])
        frac = s / s[-1]
        inside = (frac >= self.points[0] - 1e-12) & (frac <= self.points[-1] + 1e-12)
        amp = CubicSpline(self.points, self.values, bc_type="natural", axis=0)(np.clip(frac, self.points[0],
                                                                                      self.points[-1]))
        return np.where(inside[:, None], amp, 0.0), s


class MuscleTorque(_Travelling):
    """An internal bending moment M(s, t) (N m) about the body direction ``direction`` (d1 by
    default) along ``line``, as PyElastica's MuscleTorques; ``moment`` is A(s) of _Travelling.
    A line with free ends under a steady moment bends to the curvature M / EI about
    ``direction``. ``lines`` instead of ``line``: several lines, each driven alike along its own
    arc length, in one kernel call (a crowd of snakes). The work it does is ``work(sim)``, part
    of ``sim.actuation_work()``."""

    kind = "muscle_torque"
    record = MuscleTorqueParams
    keys = (Key("line", "line", doc="the line (or give lines)"),
            Key("lines", "lines", doc="several lines, each driven alike (instead of line)"),
            Key("moment", _number_or_floats, TORQUE, required=True, doc="A(s): one value, or one per point"),
            Key("direction", direction, doc="body direction of the moment (default d1)")) + WAVE_KEYS
    adds_energy = True

    def __init__(self, line: Line | None = None, moment=None, points=None, direction=(1.0, 0.0, 0.0), period=0.0,
                 wavelength=math.inf, phase=0.0, ramp_time=0.0, lines=None, schedule=None):
        if (line is None) == (lines is None):
            raise ValueError(f"MuscleTorque: give line or lines, one of them, got line={line!r}, lines={lines!r}")
        if lines is not None:
            if isinstance(lines, (str, Line)) or not len(lines):
                raise ValueError(f"MuscleTorque: lines must be a non-empty list of lines or line names, got {lines!r}")
            lines = list(lines)
        self.lines = lines
        if moment is None:
            raise ValueError("MuscleTorque: moment is required")
        self._wave(line, "moment", moment, 1, points, period, wavelength, phase, ramp_time, schedule)
        self.direction = checks.direction(f"{self._who()}", "direction", direction)

    def _who(self):
        return f"MuscleTorque on {self.line!r}" if self.lines is None else f"MuscleTorque on {len(self.lines)} lines"

    def bind(self, on: Binding):
        from .contact import chosen_lines
        lines = [self.line] if self.lines is None else chosen_lines(on, self.lines, self._who())
        amps, ss = zip(*(self._along(on, line) for line in lines))
        offsets = np.concatenate([[0], np.cumsum([a.shape[0] for a in amps])]).astype(np.int64)
        s = np.concatenate(ss)
        # each point's static phase of the wave (kernels.active.set_muscle_moments)
        phase = self.wave[1] * s if self.wave[0] != 0.0 else np.zeros_like(s)
        return MuscleTorqueParams(np.array([x.index for x in lines], np.int64), self.direction.copy(), offsets,
                                  np.concatenate(amps)[:, 0].copy(), s, self.wave.copy(),
                                  np.zeros(1), *self._schedule_arrays(), np.cos(phase), np.sin(phase),
                                  np.zeros_like(s))

    def work(self, sim) -> float:
        return float(self.params(sim).work[0])

    def describe(self):
        on = self.line.name if self.lines is None else [getattr(x, "name", x) for x in self.lines]
        return f"MuscleTorque({on!r}, moment={self.values[:, 0].tolist()})"


class ActiveCurvature(_Travelling):
    """Rest curvature and twist of ``line`` changing in time: u0(s, t) = u0 as built + the
    3-vector ``curvature`` (1/m, principal frame: bending about d1, d2, twist) as A(s) of
    _Travelling, at the line's interior Voronoi points, set at every stage time. The work it
    does (the strain energy each change adds at the current shape) is ``work(sim)``, part of
    ``sim.actuation_work()``."""

    kind = "active_curvature"
    record = ActiveCurvatureParams
    keys = (Key("line", "line", required=True, doc="the line"),
            Key("curvature", _vec3_or_rows, CURVATURE, required=True,
                doc="A(s): bending about d1, d2 and twist, one triple or one per point"),) + WAVE_KEYS
    adds_energy = True

    def __init__(self, line: Line, curvature, points=None, period=0.0, wavelength=math.inf, phase=0.0,
                 ramp_time=0.0, schedule=None):
        self._wave(line, "curvature", curvature, 3, points, period, wavelength, phase, ramp_time, schedule)

    def bind(self, on: Binding):
        from . import measure
        amp, s = self._along(on)
        m, l = on.model, self.line.index
        base = m.voronoi_rest_curvature[m.line_vertex_offsets[l]:m.line_vertex_offsets[l + 1]].copy()
        u = measure.vertex_fields(m, on.state, l, l + 1)["curvature"] + base   # theta / l now
        return ActiveCurvatureParams(l, base, np.ascontiguousarray(amp), s, self.wave.copy(), np.zeros(1), u,
                                     *self._schedule_arrays())

    def work(self, sim) -> float:
        return float(self.params(sim).work[0])

    def describe(self):
        return f"ActiveCurvature({self.line.name!r}, curvature={self.values.tolist()})"
