"""Active lines: muscle torques and a rest curvature changing in time (docs/drives.md)."""

from __future__ import annotations

import math

import numpy as np

from ..core import samples
from ..engine.bounds import index_error, offsets_error
from ..core import checks
from ..engine.registry import Binding, Effect, Key
from ..core.units import CURVATURE, LENGTH, TIME, TORQUE, array, direction, floats, nonnegative, number, positive, vec3
from .drives import PATH_UNITS, Path, path_table
from ..kernels.active import ActiveCurvatureParams, MuscleTorqueParams
from ..core.net import Line



def _number_or_floats(v):
    """a number, or a list of numbers (one per point)"""
    return floats(v) if isinstance(v, list) else number(v)


def _vec3_or_rows(v):
    """3 numbers, or a list of them (one per point)"""
    return array((-1, 3))(v) if isinstance(v, list) and v and isinstance(v[0], list) else vec3(v)


def _pair_or_rows(v):
    """2 numbers, or a list of them (one per point)"""
    return array((-1, 2))(v) if isinstance(v, list) and v and isinstance(v[0], list) else array((2,))(v)


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

    work_kind = "actuation"

    def _wave(self, line, what, value, k, points, period, wavelength, phase, ramp_time, schedule=None):
        if not (isinstance(line, Line) or (line is None and getattr(self, "lines", None))):
            raise ValueError(f"{type(self).__name__}: line must be a cosnet Line, got {line!r}")
        self.line = line
        if points is None:
            self.points = np.array([0.0, 1.0])
        else:
            s = np.array(points, dtype=float)
            if s.ndim != 1 or s.size < 2 or np.any(np.diff(s) <= 0) or s[0] < 0 or s[-1] > 1:
                raise ValueError(f"{self._who()}: points must increase strictly within [0, 1], got {points!r}")
            self.points = s
        self.values = None if value is None else self._amplitude(what, value, k, points is not None)
        who = self._who()
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

    def _who(self):
        return f"{type(self).__name__} on {self.line!r}"

    def _amplitude(self, what, value, k, at_points):
        """A(s) of ``what`` (k components) at self.points, (m, k), refused in one line unless
        it is finite and one value (or k-vector) for the line or one per point."""
        shape = (k,) if k > 1 else ()
        a = np.array(value, dtype=float)
        if not at_points:
            if a.shape != shape or not np.all(np.isfinite(a)):
                raise ValueError(f"{self._who()}: {what} must be {k if k > 1 else 'a'} finite "
                                 f"number{'s' if k > 1 else ''}, or values at points, got {value!r}")
            return np.array([a, a]).reshape(2, k)
        m = self.points.size
        if a.shape != (m,) + shape or not np.all(np.isfinite(a)):
            raise ValueError(f"{self._who()}: {what} must give one finite value per point ({m}), got {value!r}")
        return a.reshape(m, k)

    def _factor_range(self) -> tuple[float, float]:
        """(lowest, highest) value of the time law ramp(t) g(t) [sin(...)] over t >= 0 (bounds
        for a rate, which grows without end)."""
        lo = hi = 1.0
        if self.schedule is not None:
            rate, amp, turn, times, coef = (x[..., 0] if x.ndim == 3 else x for x in self._sched)
            sway = amp[0] * math.sin(turn[1])
            lo, hi = (-abs(amp[0]), abs(amp[0])) if turn[0] != 0.0 else (sway, sway)
            if times.size:
                ends = [coef[i, 3] + u * (coef[i, 2] + u * (coef[i, 1] + u * coef[i, 0]))
                        for i, h in enumerate(np.diff(times))
                        for u in [0.0, h] + [r.real for r in np.roots([3 * coef[i, 0], 2 * coef[i, 1], coef[i, 2]])
                                             if abs(r.imag) < 1e-12 and 0.0 < r.real < h]]
                lo, hi = lo + min(ends), hi + max(ends)
            lo, hi = (lo, math.inf) if rate[0] > 0.0 else (-math.inf, hi) if rate[0] < 0.0 else (lo, hi)
        if self.wave[3] > 0.0:  # the ramp starts from zero
            lo, hi = min(lo, 0.0), max(hi, 0.0)
        if self.wave[0] != 0.0:
            hi = max(abs(lo), abs(hi))
            lo = -hi
        return lo, hi

    def _schedule_arrays(self) -> tuple:
        """The schedule's arrays in the record's order (copies: the record owns them)."""
        rate, amp, turn, times, coef = self._sched
        return rate.copy(), amp.copy(), turn.copy(), times.copy(), coef.copy(), np.zeros(1), np.zeros(3)

    def _along(self, sim, line=None, values=None, midpoints=False):
        """(A at the Voronoi points (n+1, k) of ``line`` (default: the effect's), or with
        ``midpoints`` at its element midpoints (n, k), their arc lengths); values: A at the
        points (default: self.values)."""
        line = self.line if line is None else line
        values = self.values if values is None else values
        sim.check_line(line, type(self).__name__)
        m, l = sim.model, line.index
        lengths = m.element_rest_length[m.line_element_offsets[l]:m.line_element_offsets[l + 1]]
        s = np.concatenate([[0.0], np.cumsum(lengths)])
        if midpoints:
            s = 0.5 * (s[1:] + s[:-1])
        return self._spline(values, s / np.sum(lengths)), s

    def _spline(self, values, frac):
        """A at the fractions ``frac`` of the rest length: the natural cubic spline through
        ``values`` at the points, zero outside them."""
        from scipy.interpolate import CubicSpline   # (here: importing it costs every start of cosnet 0.2 s)
        inside = (frac >= self.points[0] - 1e-12) & (frac <= self.points[-1] + 1e-12)
        amp = CubicSpline(self.points, values, bc_type="natural", axis=0)(np.clip(frac, self.points[0],
                                                                                 self.points[-1]))
        return np.where(inside[:, None], amp, 0.0)


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

    @classmethod
    def example(cls):
        net, line = samples.rod()
        return net, [cls(line, moment=0.01, period=0.5, wavelength=0.3)]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        nl = model.line_vertex_offsets.shape[0] - 1
        m = p.lines.shape[0]
        if p.offsets.shape != (m + 1,) or p.s.shape != p.amplitude.shape:
            return "muscle torque: offsets need one entry per line and one more, s one per amplitude"
        return index_error("muscle_torque.lines", p.lines, nl) or offsets_error("muscle_torque.offsets", p.offsets,
                                                                                  p.amplitude.shape[0])

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

    def state_arrays(self, sim) -> dict:
        return {"work": self.params(sim).work}

    def describe(self):
        on = self.line.name if self.lines is None else [getattr(x, "name", x) for x in self.lines]
        return f"MuscleTorque({on!r}, moment={self.values[:, 0].tolist()})"


class ActiveCurvature(_Travelling):
    """Rest curvature and twist, and rest stretch and shear, of ``line`` changing in time:
    u0(s, t) = u0 as built + the 3-vector ``curvature`` (1/m, principal frame: bending about
    d1, d2, twist) as A(s) of _Travelling, at the line's interior Voronoi points; v0(s, t) =
    d3 + (``shear``, ``stretch``) (shear along d1, d2 and the stretch e: the rest length
    becomes 1 + e times the length as built) as A(s), at its element midpoints; each set at
    every stage time. 1 + e must stay positive for every value the time law can take. The work
    it does (the strain energy each change adds at the current shape) is ``work(sim)``, part of
    ``sim.actuation_work()``."""

    kind = "active_curvature"
    record = ActiveCurvatureParams
    keys = (Key("line", "line", required=True, doc="the line"),
            Key("curvature", _vec3_or_rows, CURVATURE,
                doc="A(s): bending about d1, d2 and twist, one triple or one per point"),
            Key("stretch", _number_or_floats,
                doc="A(s): rest stretch e (rest length 1 + e times as built), one value or one per point"),
            Key("shear", _pair_or_rows, doc="A(s): rest shear along d1, d2, one pair or one per point"),
            ) + WAVE_KEYS
    adds_energy = True

    @classmethod
    def example(cls):
        net, line = samples.rod()
        return net, [cls(line, curvature=(0.0, 1.0, 0.0), ramp_time=0.1)]

    def __init__(self, line: Line, curvature=None, points=None, period=0.0, wavelength=math.inf, phase=0.0,
                 ramp_time=0.0, schedule=None, stretch=None, shear=None):
        self._wave(line, "curvature", curvature, 3, points, period, wavelength, phase, ramp_time, schedule)
        if curvature is None and stretch is None and shear is None:
            raise ValueError(f"{self._who()}: give curvature, stretch or shear (or several)")
        self.strain = None
        self.changes_rest_strain = stretch is not None or shear is not None   # the model must carry v0
        if self.changes_rest_strain:
            at = points is not None
            self.strain = np.zeros((self.points.size, 3))
            if shear is not None:
                self.strain[:, :2] = self._amplitude("shear", shear, 2, at)
            if stretch is not None:
                self.strain[:, 2] = self._amplitude("stretch", stretch, 1, at)[:, 0]
                frac = np.union1d(np.linspace(self.points[0], self.points[-1], 1001), self.points)
                self._check_stretch(self._spline(self.strain, frac)[:, 2], frac)

    def _check_stretch(self, e, frac):
        """Refuse, in one line, a stretch amplitude e (at the fractions ``frac`` of the length)
        for which the rest stretch 1 + e f(t) reaches zero for a value f of the time law."""
        lo, hi = self._factor_range()
        with np.errstate(invalid="ignore"):
            least = 1.0 + np.where(e == 0.0, 0.0, np.minimum(e * lo, e * hi))
        if np.any(least <= 0.0):
            k = int(np.argmin(least))
            raise ValueError(f"{self._who()}: stretch {e[k]:g} at {frac[k]:g} of the length, with the time law "
                             f"between {lo:g} and {hi:g}, makes the rest stretch 1 + e = {least[k]:g} <= 0")

    def bind(self, on: Binding):
        from ..engine import measure
        on.check_line(self.line, type(self).__name__)
        m, l = on.model, self.line.index
        none = np.zeros((0, 3))
        amp, s, base, u = none, np.zeros(0), none, none
        if self.values is not None:
            amp, s = self._along(on)
            base = m.voronoi_rest_curvature[m.line_vertex_offsets[l]:m.line_vertex_offsets[l + 1]].copy()
            u = measure.vertex_fields(m, on.state, l, l + 1)["curvature"] + base   # theta / l now
        strain, ss, rest, v = none, np.zeros(0), none, none
        if self.strain is not None:
            if m.element_rest_strain.shape[0] != m.element_rest_length.shape[0]:
                raise ValueError(f"{self._who()}: this model carries no rest strain (flatten(..., rest_strain=True))")
            elements = slice(m.line_element_offsets[l], m.line_element_offsets[l + 1])
            strain, ss = self._along(on, values=self.strain, midpoints=True)
            self._check_stretch(strain[:, 2], ss / np.sum(m.element_rest_length[elements]))
            rest = m.element_rest_strain[elements].copy()
            v = np.column_stack(measure.element_stretch(m, on.state, measure.block_of(m, l, l + 1))) + rest
        return ActiveCurvatureParams(l, base, np.ascontiguousarray(amp), s, self.wave.copy(), np.zeros(1), u,
                                     rest, np.ascontiguousarray(strain), ss, v, *self._schedule_arrays())

    def work(self, sim) -> float:
        return float(self.params(sim).work[0])

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"work": p.work, "last": p.last, "strain_last": p.strain_last}

    def describe(self):
        given = [(n, a.tolist()) for n, a in (("curvature", self.values),
                                              ("strain", self.strain)) if a is not None]
        return f"ActiveCurvature({self.line.name!r}, " + ", ".join(f"{n}={a}" for n, a in given) + ")"
