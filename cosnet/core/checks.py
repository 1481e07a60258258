"""Checks of the numbers a user hands to the library's constructors.

Each raises ValueError with one line "{owner}: {name} must be ..., got {value!r}", so a message
names the object and the parameter; scene files are checked earlier, key by key, by the
converters of cosnet.core.units. Both hold a value to one rule, ``is_number``: a real number,
not a truth value and not a string ("3" and True are refused alike in a scene and in Python).
"""

import math
import numbers

import numpy as np


def is_number(value) -> bool:
    """Whether value is a real number (a Python or numpy int or float), not a bool or a string."""
    return isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_))


def number(owner: str, name: str, value) -> float:
    """Return value as a float, or raise if it is not a number (is_number)."""
    if not is_number(value):
        raise ValueError(f"{owner}: {name} must be a number, got {value!r}")
    return float(value)


def numbers_array(owner: str, name: str, value, what: str) -> np.ndarray:
    """value as a float array, or raise ("{name} must be {what}") if an entry is not a number
    (is_number: a bool or a string among them)."""
    a = np.asarray(value, dtype=object) if not isinstance(value, np.ndarray) else value
    if a.dtype.kind not in "iuf" and not all(is_number(x) for x in np.ravel(a)):
        raise ValueError(f"{owner}: {name} must be {what}, got {value!r}")
    try:
        return np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: {name} must be {what}, got {value!r}") from None


def positive(owner: str, name: str, value, allow_zero: bool = False) -> float:
    """Return value as a finite float > 0 (>= 0 with allow_zero), or raise."""
    x = number(owner, name, value)
    if not math.isfinite(x) or x < 0 or (x == 0 and not allow_zero):
        need = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{owner}: {name} must be a finite number {need}, got {value!r}")
    return x


def nonnegative(owner: str, name: str, value) -> float:
    """Return value as a finite float >= 0, or raise."""
    return positive(owner, name, value, allow_zero=True)


def vec3(owner: str, name: str, value) -> np.ndarray:
    """Return value as a (3,) float array of finite numbers, or raise."""
    a = numbers_array(owner, name, value, "3 finite numbers")
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{owner}: {name} must be 3 finite numbers, got {value!r}")
    return a


def is_positive(x) -> bool:
    """Whether x is a Python int or float, finite and > 0 (a time, a scale, ...)."""
    return isinstance(x, (int, float)) and math.isfinite(x) and x > 0


def direction(owner: str, name: str, value) -> np.ndarray:
    """Return value scaled to unit length, or raise unless it is 3 finite numbers of nonzero
    length (a length that underflows to 0 is refused: it cannot be normalised)."""
    a = numbers_array(owner, name, value, "a nonzero 3-vector")
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0.0:
        raise ValueError(f"{owner}: {name} must be a nonzero 3-vector, got {value!r}")
    return a / np.linalg.norm(a)
