"""Materials and cross-sections of the lines of a net.

A line's Kirchhoff constitutive law (Gratus & Tucker (3.22)-(3.24)) needs, per unit length,
the stretch and shear stiffnesses ``K = diag(k G A, k G A, E A)``, the bend and twist
stiffnesses ``B = [[E I11, E I12, 0], [E I12, E I22, 0], [0, 0, G J]]`` and the mass and
rotary inertia ``rho A`` and ``rho [[I11, I12, 0], [I12, I22, 0], [0, 0, I11 + I22]]`` (3.4).
Second moments are taken in the director frame (d1, d2); ``I11 = int x2^2 dA`` resists
bending about d1. A section may carry its rotary inertia per length ``rho I`` on its own (as
published benchmarks give it), independently of the second moments that set its stiffness.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import checks


def _check_positive(owner: str, name: str, value, allow_zero: bool = False) -> float:
    v = checks.number(owner, name, value)
    if not math.isfinite(v):
        raise ValueError(f"{owner}: {name} must be finite, got {v}")
    if v < 0 or (v == 0 and not allow_zero):
        expected = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{owner}: {name} must be {expected}, got {v}")
    return v


@dataclass(frozen=True)
class Material:
    """An isotropic elastic material: Young's modulus E, shear modulus G (or Poisson's ratio),
    mass density. SI units unless the whole net is given in scaled units (§5)."""

    E: float
    density: float
    G: float | None = None
    poisson: float | None = None
    name: str = "material"

    def __post_init__(self):
        who = f"Material {self.name!r}"
        object.__setattr__(self, "E", _check_positive(who, "E", self.E))
        object.__setattr__(self, "density", _check_positive(who, "density", self.density))
        if (self.G is None) == (self.poisson is None):
            raise ValueError(f"{who}: give exactly one of G (shear modulus) or poisson (ratio)")
        if self.G is None:
            nu = float(self.poisson)
            if not (-1.0 < nu < 0.5) or not math.isfinite(nu):
                raise ValueError(f"{who}: poisson must lie in (-1, 0.5), got {self.poisson}")
            object.__setattr__(self, "G", self.E / (2.0 * (1.0 + nu)))
        else:
            object.__setattr__(self, "G", _check_positive(who, "G", self.G))


def rotary_inertia_triple(owner: str, value) -> tuple[float, float, float]:
    """Return value as three positive rotary inertias per length (kg m), or raise naming owner."""
    try:
        vals = [checks.number(owner, "rotary_inertia", v) for v in value]
    except (TypeError, ValueError):
        raise ValueError(f"{owner}: rotary_inertia must be three numbers (kg m), got {value!r}") from None
    if len(vals) != 3:
        raise ValueError(f"{owner}: rotary_inertia must be three numbers (kg m), got {len(vals)}")
    a, b, c = (_check_positive(owner, "rotary_inertia", v) for v in vals)
    return a, b, c


def rotary_inertia_scale_value(owner: str, value) -> float | str:
    """Return value as a rotary-inertia scale (a finite float >= 1, or "auto"), or raise
    naming owner."""
    if isinstance(value, str):
        if value == "auto":
            return value
        raise ValueError(f"{owner}: rotary_inertia_scale must be a number >= 1 or \"auto\", got {value!r}")
    if isinstance(value, bool):
        raise ValueError(f"{owner}: rotary_inertia_scale must be a number >= 1 or \"auto\", got {value!r}")
    v = _check_positive(owner, "rotary_inertia_scale", value)
    if v < 1.0:
        raise ValueError(f"{owner}: rotary_inertia_scale must be >= 1 (a smaller rotary inertia "
                         f"only shortens the stable step), got {v}")
    return v


@dataclass(frozen=True)
class Section:
    """Explicit cross-section: area A, second moments I11, I22, product I12 (3.4), torsion
    constant J, and the shear correction factor applied to G A (1 in the paper's (3.23)).
    ``radius`` is the contact radius (used by rod-rod contact and rendering).
    ``rotary_inertia``: None (derived: density times (I1, I2, I1 + I2)) or the rotary inertia
    per length (kg m) about the section's first and second principal axes and its axis."""

    A: float
    I11: float
    I22: float
    J: float
    I12: float = 0.0
    shear_coefficient: float = 1.0
    radius: float | None = None
    kind: str = "section"
    rotary_inertia: tuple | None = None

    def __post_init__(self):
        who = f"{self.kind} section"
        for name in ("A", "I11", "I22", "J", "shear_coefficient"):
            object.__setattr__(self, name, _check_positive(who, name, getattr(self, name)))
        i12 = float(self.I12)
        if not math.isfinite(i12):
            raise ValueError(f"{who}: I12 must be finite, got {self.I12}")
        if self.I11 * self.I22 - i12 * i12 <= 0.0:
            raise ValueError(f"{who}: second moments must be positive definite (I11*I22 > I12^2), "
                             f"got I11={self.I11}, I22={self.I22}, I12={i12}")
        object.__setattr__(self, "I12", i12)
        r = math.sqrt(self.A / math.pi) if self.radius is None else _check_positive(who, "radius", self.radius)
        object.__setattr__(self, "radius", r)
        if self.rotary_inertia is not None:
            object.__setattr__(self, "rotary_inertia", rotary_inertia_triple(who, self.rotary_inertia))

    def principal(self) -> tuple[float, float, float]:
        """Return (I1, I2, phi): principal second moments and the angle phi (about d3) from d1
        to the first principal axis."""
        if self.I12 == 0.0:
            return self.I11, self.I22, 0.0
        phi = 0.5 * math.atan2(2.0 * self.I12, self.I11 - self.I22)
        c, s = math.cos(phi), math.sin(phi)
        t = np.array([[self.I11, self.I12], [self.I12, self.I22]])
        r = np.array([[c, -s], [s, c]])  # columns: the principal axes in (d1, d2)
        tp = r.T @ t @ r
        return float(tp[0, 0]), float(tp[1, 1]), phi


def Circle(radius: float, shear_coefficient: float = 1.0) -> Section:
    """Solid circular section of the given radius."""
    r = _check_positive("Circle section", "radius", radius)
    i = math.pi * r**4 / 4.0
    return Section(A=math.pi * r * r, I11=i, I22=i, J=2.0 * i, radius=r,
                   shear_coefficient=shear_coefficient, kind="Circle")


def Tube(radius: float, thickness: float, shear_coefficient: float = 1.0) -> Section:
    """Thin or thick circular tube: outer radius, wall thickness."""
    ro = _check_positive("Tube section", "radius", radius)
    t = _check_positive("Tube section", "thickness", thickness)
    if t >= ro:
        raise ValueError(f"Tube section: thickness {t} must be below the radius {ro}")
    ri = ro - t
    i = math.pi * (ro**4 - ri**4) / 4.0
    return Section(A=math.pi * (ro * ro - ri * ri), I11=i, I22=i, J=2.0 * i, radius=ro,
                   shear_coefficient=shear_coefficient, kind="Tube")


def Rectangle(width: float, height: float, shear_coefficient: float = 1.0) -> Section:
    """Solid rectangle: width along d1, height along d2. Saint-Venant torsion constant."""
    b = _check_positive("Rectangle section", "width", width)
    h = _check_positive("Rectangle section", "height", height)
    a, c = max(b, h), min(b, h)
    J = a * c**3 * (1.0 / 3.0 - 0.21 * (c / a) * (1.0 - c**4 / (12.0 * a**4)))
    return Section(A=b * h, I11=b * h**3 / 12.0, I22=h * b**3 / 12.0, J=J,
                   radius=0.5 * math.hypot(b, h), shear_coefficient=shear_coefficient,
                   kind="Rectangle")


def Ellipse(a: float, b: float, shear_coefficient: float = 1.0) -> Section:
    """Solid ellipse: semi-axis a along d1, b along d2."""
    a = _check_positive("Ellipse section", "a", a)
    b = _check_positive("Ellipse section", "b", b)
    return Section(A=math.pi * a * b, I11=math.pi * a * b**3 / 4.0, I22=math.pi * a**3 * b / 4.0,
                   J=math.pi * a**3 * b**3 / (a * a + b * b), radius=max(a, b),
                   shear_coefficient=shear_coefficient, kind="Ellipse")
