"""A seeded irregular sea for a fluid's waves (cosnet.Fluid's ``wave_spectrum`` keys).

The JONSWAP spectrum of the surface elevation (one-sided, per rad/s; DNV-RP-C205 3.5.5),

    S(w) = (5/16) Hs^2 wp^4 w^-5 exp(-5/4 (w/wp)^-4) gamma^exp(-(w - wp)^2 / (2 s^2 wp^2)),

wp = 2 pi / Tp, s = 0.07 for w <= wp and 0.09 above, gamma the peak enhancement (1: the
Pierson-Moskowitz spectrum), is cut into N equal bands of width dw over [lo wp, hi wp], each
a linear (Airy) component at its band's middle frequency w_k with amplitude
a_k = c sqrt(2 S(w_k) dw) and a random phase (numpy's generator from ``seed``). The spectrum's
tails beyond the band are left out, so c scales the components to the asked height exactly:
sum a_k^2 / 2 = Hs^2 / 16, the variance of the elevation over the sea's repeat period
2 pi / dw. The components share one heading (a long-crested sea).
"""

from __future__ import annotations

import math

import numpy as np

from . import checks


def jonswap(w, hs: float, tp: float, gamma: float = 3.3):
    """The one-sided JONSWAP spectrum S(w) (m^2 per rad/s) at angular frequencies w (rad/s)
    (module docstring; without the normalising factor A_gamma: the components are scaled to
    Hs themselves)."""
    w = np.asarray(w, float)
    wp = 2.0 * math.pi / tp
    s = np.where(w <= wp, 0.07, 0.09)
    pm = 5.0 / 16.0 * hs * hs * wp ** 4 * w ** -5.0 * np.exp(-1.25 * (w / wp) ** -4.0)
    return pm * gamma ** np.exp(-((w - wp) ** 2) / (2.0 * s * s * wp * wp))


def jonswap_components(hs: float, tp: float, gamma: float = 3.3, components: int = 50, band=(0.5, 3.0),
                       seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(amplitudes, periods, phases) of the ``components`` Airy waves of a JONSWAP sea of
    significant height ``hs`` (m) and peak period ``tp`` (s) (module docstring)."""
    who = "Fluid"
    hs, tp = checks.positive(who, "significant_height", hs), checks.positive(who, "peak_period", tp)
    gamma = checks.number(who, "peak_enhancement", gamma)
    if not 1.0 <= gamma < math.inf:
        raise ValueError(f"Fluid: peak_enhancement must be >= 1 (1: Pierson-Moskowitz), got {gamma!r}")
    if isinstance(components, bool) or not isinstance(components, (int, np.integer)) or components < 1:
        raise ValueError(f"Fluid: wave_components must be a positive integer, got {components!r}")
    b = np.asarray(band, dtype=object)
    lo, hi = (float(b[0]), float(b[1])) if b.shape == (2,) and all(checks.is_number(x) for x in b) else (0.0, 0.0)
    if not 0.0 < lo < hi < math.inf:
        raise ValueError(f"Fluid: wave_band must be two multiples of the peak frequency, 0 < low < high, got {band!r}")
    wp = 2.0 * math.pi / tp
    dw = (hi - lo) * wp / components
    w = lo * wp + (np.arange(components) + 0.5) * dw
    a = np.sqrt(2.0 * jonswap(w, hs, tp, gamma) * dw)
    a *= hs / 4.0 / math.sqrt(0.5 * np.sum(a * a))
    phases = np.random.default_rng(seed).uniform(0.0, 2.0 * math.pi, components)
    return a, 2.0 * math.pi / w, phases
