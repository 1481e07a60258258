"""Fast modes of slender lines: how each line's rotary inertia and stretch/shear stiffness are
set so that the stable step follows the motion that matters (docs/fast_modes.md).

Once an element is longer than the section's radius, the highest frequencies of a line are a
rotation of the section against its shear stiffness (omega ~ 2 sqrt(kG/rho)/r, whatever the
element length), then axial, shear and torsion waves over one element (omega ~ 2c/l); the
bending modes end near omega ~ 2 c r / l^2. A treatment changes the mass matrix (rotary
inertia times alpha) or the stretch and shear stiffnesses (times beta_a, beta_s): the scheme
itself, its symplecticity, exact junctions and momenta are untouched.

  "resolve"  every line as built (its own ``rotary_inertia_scale`` still applies)
  "rotary"   alpha: the rotational modes brought down to the line's axial/shear waves
  "soften"   beta_a, beta_s, then alpha: everything brought down toward the bending limit
  "auto"     "soften" on the lines where it gains a longer step, "resolve" elsewhere

Each treatment is bounded by what it may change: on the line's lowest ``MODES_KEPT`` bending
modes, the rotary inertia term alpha k^2 rho I / (rho A) of Timoshenko's frequency
(k = MODES_KEPT pi / L) stays below ROTARY_SHARE * MODE_TOLERANCE of omega^2 and the shear term
k^2 E I / (beta_s k G A) below MODE_TOLERANCE / 2. The rotary share is the smaller because the
rotary inertia also enters the slowest motion of a sagging line: its swing turns every section
(about its own axis at mid-span), so a scaled rotary inertia slows the swing and the lag grows
period after period (bench/fast_modes.py: the 10 m cable's midpoint path after three periods
moved 1.15 % of the swing amplitude with the share at 1/2, 0.86 % at 1/4, 0.70 % at 1/8, the
rest being the softened stretch);
a softened stretch or shear under the net's load scale stays below STRAIN_TARGET, and a softened line
whose strain passes STRAIN_GUARD during a run stops the run (``check_strain``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FAST_MODES = ("resolve", "rotary", "soften", "auto")
MODES_KEPT = 5
MODE_TOLERANCE = 1e-2   # relative change of omega^2 allowed on the highest kept bending mode
ROTARY_SHARE = 0.25     # of MODE_TOLERANCE, for the scaled rotary inertia (see above)
STRAIN_TARGET = 1e-4    # softened stretch under the net's load scale
STRAIN_GUARD = 1e-3     # a softened line past this strain cannot hold: the run stops
AUTO_MIN_GAIN = 1.5     # "auto" softens a line only if its step bound grows by at least this


class FastModesError(RuntimeError):
    """A line's fast-modes setting cannot hold (its softened strain passed STRAIN_GUARD)."""


def fast_modes_value(owner: str, value) -> str:
    """Return value if it names a treatment, else raise naming owner."""
    if not isinstance(value, str) or value not in FAST_MODES:
        raise ValueError(f"{owner}: fast_modes must be one of {list(FAST_MODES)}, got {value!r}")
    return value


@dataclass(frozen=True)
class Factors:
    """What a line's treatment does: rotary inertia times ``rotary``, the stretch stiffness
    E A times ``axial``, the shear stiffness k G A times ``shear``."""

    treatment: str = "resolve"
    rotary: float = 1.0
    axial: float = 1.0
    shear: float = 1.0

    @property
    def softened(self) -> bool:
        return self.axial < 1.0 or self.shear < 1.0


class _Rows:
    """Per-element quantities of a line grid behind the Gershgorin rows of measure.bound_max_omega2."""

    def __init__(self, grid):
        self.l = grid.rest_length
        self.m = grid.element_mass
        self.ks = np.maximum(grid.stiffness[:, 0], grid.stiffness[:, 1])
        self.ka = grid.stiffness[:, 2]
        self.jb = np.minimum(grid.inertia[:, 0], grid.inertia[:, 1])
        self.jmax = np.maximum(grid.inertia[:, 0], grid.inertia[:, 1])
        self.j3 = grid.inertia[:, 2]
        bend = np.maximum(grid.bend[:, 0], grid.bend[:, 1])
        self.bb = np.maximum(bend[:-1], bend[1:])
        self.bt = np.maximum(grid.bend[:-1, 2], grid.bend[1:, 2])

    def translation(self, axial=1.0, shear=1.0) -> np.ndarray:
        """omega^2 bound of the axial and shear waves over each element (vertex rows)."""
        return 4.0 * np.maximum(axial * self.ka, shear * self.ks) / (self.l * self.m)

    def bending_limit(self) -> np.ndarray:
        """omega^2 of the shortest bending wave an element carries, 16 E I / (rho A l^4)."""
        return 16.0 * self.bb / (self.m * self.l ** 3)

    def rotation(self, alpha=1.0, shear=1.0) -> np.ndarray:
        """omega^2 bound of the section rotations (element rows: shear on the rotation, its
        coupling to the vertices, bending and twist springs to the neighbours)."""
        ks = shear * self.ks
        a = ks * self.l / self.jb + 4.0 * self.bb / (self.l * self.jb)
        b = 2.0 * ks / np.sqrt(self.jb * self.m)
        bend = a / alpha + b / math.sqrt(alpha)
        return np.maximum(bend, 4.0 * self.bt / (self.l * self.j3 * alpha))

    def alpha_for(self, target: np.ndarray, shear=1.0) -> float:
        """The smallest alpha >= 1 bringing every element's rotation bound to target."""
        ks = shear * self.ks
        a = ks * self.l / self.jb + 4.0 * self.bb / (self.l * self.jb)
        b = 2.0 * ks / np.sqrt(self.jb * self.m)
        y = (-b + np.sqrt(b * b + 4.0 * a * target)) / (2.0 * a)     # y = 1 / sqrt(alpha)
        alpha = max(float(np.max(1.0 / (y * y))), float(np.max(4.0 * self.bt / (self.l * self.j3 * target))))
        return max(1.0, alpha)


def auto_rotary_scale(grid) -> float:
    """The smallest rotary-inertia factor >= 1 that brings the rotational modes' frequency
    bound down to the line's axial/shear one."""
    rows = _Rows(grid)
    return rows.alpha_for(rows.translation())


def line_factors(line, grid, setting: str, load: float) -> Factors:
    """The factors of line's treatment (its own fast_modes, else setting) given its grid
    (unscaled) and the net's load scale (N) that a softened stretch must carry."""
    setting = line.fast_modes or setting
    rows = _Rows(grid)
    user = line.rotary_inertia_scale
    base = auto_rotary_scale(grid) if user == "auto" else float(user)
    if setting == "resolve":
        return Factors("resolve", base)
    k2 = (MODES_KEPT * math.pi / line.length) ** 2
    alpha_max = max(1.0, ROTARY_SHARE * MODE_TOLERANCE / (k2 * float(np.max(rows.jmax / rows.m))))
    if setting == "rotary":
        return Factors("rotary", max(base, min(rows.alpha_for(rows.translation()), alpha_max)))
    shear_min = min(1.0, max(k2 * float(np.max(rows.bb / rows.ks)) / (0.5 * MODE_TOLERANCE),
                             load / (float(np.min(rows.ks)) * STRAIN_TARGET)))
    axial_min = min(1.0, load / (float(np.min(rows.ka)) * STRAIN_TARGET))
    limit = rows.bending_limit()
    top = float(np.max(limit))
    axial = min(1.0, max(axial_min, float(np.min(top * rows.l * rows.m / (4.0 * rows.ka)))))
    shear = min(1.0, max(shear_min, float(np.min(top * rows.l * rows.m / (4.0 * rows.ks)))))
    target = np.maximum(top, rows.translation(axial, shear))
    alpha = max(base, min(rows.alpha_for(target, shear), alpha_max))
    soft = Factors("soften", alpha, axial, shear)
    if setting == "soften":
        return soft
    before = np.max(np.maximum(rows.translation(), rows.rotation(base)))
    after = np.max(np.maximum(rows.translation(axial, shear), rows.rotation(alpha, shear)))
    if before < AUTO_MIN_GAIN ** 2 * after:
        return Factors("resolve", base)
    return soft


def apply_factors(grid, f: Factors):
    """Update grid's rotary inertia and stretch/shear stiffnesses by the factors f."""
    grid.inertia *= f.rotary
    grid.stiffness[:, :2] *= f.shear
    grid.stiffness[:, 2] *= f.axial
