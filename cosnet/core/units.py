"""The values of a scene file: a TOML table that remembers which keys were read (so a
misspelt key is refused with a suggestion), the converters that check each value's type and
range, and the §5 unit conversion of a [scale] table. Every failure names file, table and key.
"""

from __future__ import annotations

import difflib
import json
import math
import reprlib
from typing import NamedTuple
from typing import Literal, overload

import numpy as np

from . import checks
from .scaling import Scale

_REQUIRED = object()


def one_line(e) -> str:
    """A message as one printable line: a control character or line separator (a scene may
    put one in a name) is shown escaped, never as a line break."""
    text = " ".join(str(e).split())
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxstring, _REPR.maxother = 3, 8, 6, 80, 80


def shown(v) -> str:
    """A value as quoted in a message: short, and safe for deeply nested or huge values
    (plain repr recurses without bound and can print megabytes)."""
    return _REPR.repr(v)


def quote_key(key) -> str:
    """A key as TOML writes it: bare when it may be, else quoted with escapes (so a name with
    a newline or control character cannot break a one-line message)."""
    key = str(key)
    if key and key.replace("_", "").replace("-", "").isalnum() and key.isascii():
        return key
    return json.dumps(key, ensure_ascii=False).translate(_LINE_BREAKS)


# characters str.splitlines breaks at that json.dumps leaves alone
_LINE_BREAKS = {0x85: "\\u0085", 0x2028: "\\u2028", 0x2029: "\\u2029"}


class BadValue(Exception):
    """A value of the wrong type or range (caught and re-raised with file/table/key)."""


# ---------------------------------------------------------------------- tables and values
class Table:
    """A TOML table being read: remembers which keys were used so ``done`` can refuse the rest."""

    def __init__(self, file: str, name: str, data, label: str | None = None):
        self.file, self.name = file, name
        self.label = f"[{name}]" if label is None else label   # how messages name the table
        if not isinstance(data, dict):
            raise ValueError(f"{file}: {self.label} must be a table, got {type(data).__name__}")
        self.data = data
        self.used: set = set()
        self.known: set | None = None

    def expect(self, *keys) -> Table:
        """Declare the table's keys, so a missing required key can be told from a misspelt one."""
        self.known = set(keys)
        return self

    def err(self, key, msg) -> ValueError:
        where = f"{self.label} {quote_key(key)}" if self.name else quote_key(key)
        return ValueError(f"{self.file}: {where}: {one_line(msg)}")

    def get(self, key, conv, default=_REQUIRED):
        self.used.add(key)
        if key not in self.data:
            if default is _REQUIRED:
                spare = [k for k in self.data if k not in (self.known or self.used)]
                near = difflib.get_close_matches(key, spare, n=1)
                if near:
                    raise self.err(near[0], f"unknown key; did you mean {key!r}?")
                raise self.err(key, "is required but missing")
            return default
        try:
            return conv(self.data[key])
        except BadValue as e:
            raise self.err(key, str(e)) from None

    @overload
    def sub(self, key, optional: Literal[False] = False) -> Table: ...

    @overload
    def sub(self, key, optional: bool) -> Table | None: ...

    def sub(self, key, optional=False) -> Table | None:
        self.used.add(key)
        if key not in self.data:
            if optional:
                return None
            raise self.err(key, f"the [{self._join(key)}] table is required but missing")
        return Table(self.file, self._join(key), self.data[key])

    def _join(self, key) -> str:
        k = quote_key(key)
        return f"{self.name}.{k}" if self.name else k

    def tables(self, key):
        """(name, Table) for each sub-table of [key] (in file order)."""
        t = self.sub(key, optional=True)
        if t is None:
            return []
        t.used.update(t.data)
        return [(n, Table(self.file, t._join(n), v)) for n, v in t.data.items()]

    def done(self, allowed=None):
        """Refuse every key that was not read (a misspelling gets a suggestion)."""
        known = set(allowed or ()) | self.used | (self.known or set())
        for key in self.data:
            if key not in known:
                near = difflib.get_close_matches(key, sorted(known), n=1)
                hint = f"; did you mean {near[0]!r}?" if near else f"; expected one of {sorted(known)}"
                raise self.err(key, f"unknown key{hint}")


def number(v) -> float:
    if not checks.is_number(v):
        raise BadValue(f"must be a number, got {shown(v)}")
    if not math.isfinite(v):
        raise BadValue(f"must be finite, got {shown(v)}")
    return float(v)


def positive(v) -> float:
    x = number(v)
    if x <= 0:
        raise BadValue(f"must be positive, got {shown(v)}")
    return x


def nonnegative(v) -> float:
    x = number(v)
    if x < 0:
        raise BadValue(f"must be >= 0, got {shown(v)}")
    return x


def mass_value(v) -> float:
    if isinstance(v, str) and v.strip().lower() == "inf":
        return math.inf
    try:
        return nonnegative(v)
    except BadValue:
        raise BadValue(f'must be a number >= 0 or "inf", got {shown(v)}') from None


def integer(v) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        raise BadValue(f"must be a positive integer, got {shown(v)}")
    return v


def boolean(v) -> bool:
    if not isinstance(v, bool):
        raise BadValue(f"must be true or false, got {shown(v)}")
    return v


def seed(v) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise BadValue(f"must be an integer >= 0, got {shown(v)}")
    return v


def string(v) -> str:
    if not isinstance(v, str):
        raise BadValue(f"must be a string, got {shown(v)}")
    return v


def choice(*options):
    def conv(v):
        if v not in options:
            raise BadValue(f"must be one of {list(options)}, got {shown(v)}")
        return v
    conv.options = options
    return conv


def array(shape, allow_inf=False):
    """Numbers of the given shape (-1: any length >= 2 along that axis)."""
    def conv(v):
        if not isinstance(v, list):
            raise BadValue(f"must be a list of numbers of shape {tuple(shape)}, got {shown(v)}")

        def walk(x, depth):
            if isinstance(x, list):
                if depth == len(shape):   # deeper than the shape: refuse before recursing on
                    raise BadValue(f"must have shape {tuple(shape)} (a nested list), got {shown(v)}")
                return [walk(y, depth + 1) for y in x]
            if allow_inf and isinstance(x, str) and x.strip().lower() == "inf":
                return math.inf
            return number(x)
        try:
            a = np.array(walk(v, 0), dtype=float)
        except ValueError:
            raise BadValue(f"must be numbers of shape {shape}, got {shown(v)}") from None
        ok = a.ndim == len(shape) and all(s == -1 and n >= 2 or s == n for s, n in zip(shape, a.shape))
        if not ok:
            raise BadValue(f"must have shape {tuple(shape)} (a nested list), got {shown(v)}")
        return a
    # (the scene reference's type column)
    conv.__doc__ = f"{shape[0]} numbers" if len(shape) == 1 and shape[0] > 0 else f"numbers of shape {tuple(shape)}"
    return conv


vec3 = array((3,))


def direction(v):
    """A non-zero 3-vector (a direction hint)."""
    a = vec3(v)
    if not np.any(a):
        raise BadValue(f"must be a non-zero vector, got {shown(v)}")
    return a


def floats(v):
    if not isinstance(v, list) or not v:
        raise BadValue(f"must be a non-empty list of numbers, got {shown(v)}")
    return np.array([number(x) for x in v])


def coefficients(v):
    """A number >= 0, or three of them (friction: forward, backward, lateral)."""
    a = array((3,))(v) if isinstance(v, list) else np.array(number(v))
    if np.any(a < 0):
        raise BadValue(f"must be >= 0, got {shown(v)}")
    return a


def pair(v):
    """Two numbers >= 0 (coefficients normal and tangential to a line)."""
    a = array((2,))(v)
    if np.any(a < 0):
        raise BadValue(f"must be two numbers >= 0, got {shown(v)}")
    return a


def string_list(v):
    if not isinstance(v, list):
        raise BadValue(f"must be a list of strings, got {shown(v)}")
    return [string(x) for x in v]


def step_value(v):
    """[run] dt: "auto" (the stable bound), "tight" (the highest mode's step) or seconds."""
    if v in ("auto", "tight"):
        return v
    try:
        return positive(v)
    except BadValue as e:
        raise BadValue(f'must be "auto", "tight" or a positive number of seconds ({e})') from None


def frame(v):
    """A rotation: matrix rows, or a table with two or three of d1, d2, d3 (lab columns)."""
    if isinstance(v, list):
        return array((3, 3))(v)
    if not isinstance(v, dict):
        raise BadValue(f"must be a 3x3 matrix (rows) or a table of d1, d2, d3, got {shown(v)}")
    bad = set(v) - {"d1", "d2", "d3"}
    if bad:
        raise BadValue(f"unknown key {sorted(bad)[0]!r} (a frame table takes d1, d2, d3)")
    if len(v) < 2:
        raise BadValue("a frame table needs at least two of d1, d2, d3")
    d = {k: vec3(x) for k, x in v.items()}
    if "d1" not in d:
        d["d1"] = np.cross(d["d2"], d["d3"])
    if "d2" not in d:
        d["d2"] = np.cross(d["d3"], d["d1"])
    if "d3" not in d:
        d["d3"] = np.cross(d["d1"], d["d2"])
    return np.column_stack([d["d1"], d["d2"], d["d3"]])


# ---------------------------------------------------------------------- units (§5)
class Unit(NamedTuple):
    """A physical unit: its SI ``symbol`` and the exponents of length, mass and time."""

    symbol: str
    length: int = 0
    mass: int = 0
    time: int = 0


LENGTH = Unit("m", 1)
TIME = Unit("s", time=1)
RATE = Unit("1/s", time=-1)                    # decay rates, angular frequencies
ANGULAR_VELOCITY = Unit("rad/s", time=-1)
VELOCITY = Unit("m/s", 1, 0, -1)
ACCELERATION = Unit("m/s^2", 1, 0, -2)
FORCE = Unit("N", 1, 1, -2)
TORQUE = Unit("N m", 2, 1, -2)
FORCE_PER_LENGTH = Unit("N/m", 0, 1, -2)
TORQUE_PER_LENGTH = Unit("N m/m", 1, 1, -2)
STIFFNESS = Unit("N/m", 0, 1, -2)              # a spring: force per displacement
DAMPING = Unit("N s/m", 0, 1, -1)
SOIL_STIFFNESS = Unit("N/m^3", -2, 1, -2)        # a soft soil: pressure per penetration
SOIL_DAMPING = Unit("N s/m^3", -2, 1, -1)
STRAIN_DAMPING = Unit("N s", 1, 1, -1)          # a dashpot in strain: force per strain rate
CURVATURE = Unit("1/m", -1)
ROTARY_STIFFNESS = Unit("N m/rad", 2, 1, -2)   # a torque spring: torque per angle
ROTARY_DAMPING = Unit("N m s/rad", 2, 1, -1)


class Units:
    """Conversion of scene numbers to SI: identity without [scale]."""

    def __init__(self, scale: Scale | None):
        self.L, self.M, self.T = (1.0, 1.0, 1.0) if scale is None else scale._units()

    def factor(self, length=0, mass=0, time=0) -> float:
        return self.L**length * self.M**mass * self.T**time

    def si(self, unit: Unit | dict | None, value):
        """``value`` (scaled units) in SI; None and unit-less values pass unchanged."""
        if unit is None or value is None:
            return value
        if isinstance(unit, dict):   # an inline table: a unit per key of it
            return {k: self.si(unit.get(k), x) for k, x in value.items()}
        return value * self.factor(unit.length, unit.mass, unit.time)
