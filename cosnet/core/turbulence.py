"""A seeded turbulent series for a wind or current (cosnet.Fluid's ``turbulence_*`` keys).

The along-stream fluctuation u'(t) of a stationary Gaussian process with the Kaimal spectrum
(IEC 61400-1's longitudinal form, one-sided, per Hz)

    S(f) = sigma^2 4 (L/U) / (1 + 6 f L/U)^(5/3),      integral over f > 0: sigma^2,

sigma = intensity x U, L the integral length scale (L/U the integral time scale: S(0) =
4 sigma^2 L/U), synthesised over a record of length T as harmonics of 1/T with random phases
(numpy's generator from ``seed``):

    u'(t) = c sum_k sqrt(2 S(f_k) / T) cos(2 pi f_k t + phi_k),   f_k = k/T, 1 <= k < T/(2 dt),

sampled every dt. A finite record lacks the spectrum below 1/T and above the Nyquist
frequency, so c scales the record to the asked variance exactly: its mean square over the
record is sigma^2 and its mean zero. The record repeats with period T (its last sample is its
first). The fluid multiplies its velocity by 1 + u'(t)/U: one fluctuation for the whole medium
(fully coherent in space), the same relative intensity at every height of its profile.
"""

from __future__ import annotations

import math

import numpy as np

from . import checks

IEC_LENGTH = 340.2    # m: IEC 61400-1's L_u = 8.1 x 42 m above 60 m hub height


def kaimal(f, sigma: float, length: float, mean: float):
    """The one-sided Kaimal spectrum S(f) (m^2/s^2 per Hz) at frequencies f (Hz)."""
    a = length / mean
    return sigma * sigma * 4.0 * a / (1.0 + 6.0 * a * np.asarray(f, float)) ** (5.0 / 3.0)


def turbulent_series(mean: float, intensity: float, length: float = IEC_LENGTH, duration: float = 600.0,
                     step: float = 0.1, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(times, factors): 1 + u'(t)/mean at t = 0, step, ..., duration (module docstring) for a
    stream of mean speed ``mean`` (m/s), turbulence ``intensity`` (sigma/mean), integral
    length scale ``length`` (m), record ``duration`` (s) sampled every ``step`` (s), phases
    from ``seed``."""
    who = "turbulence"
    mean = checks.positive(who, "mean speed |velocity|", mean)
    intensity = checks.nonnegative(who, "turbulence_intensity", intensity)
    length = checks.positive(who, "turbulence_length", length)
    duration = checks.positive(who, "turbulence_duration", duration)
    step = checks.positive(who, "turbulence_step", step)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"turbulence: turbulence_seed must be an integer >= 0, got {seed!r}")
    n = int(round(duration / step))
    if n < 8 or abs(n * step - duration) > 1e-9 * duration:
        raise ValueError(f"turbulence: turbulence_duration ({duration:g} s) must be a whole number of at least 8 "
                         f"turbulence_steps ({step:g} s)")
    k = np.arange(1, (n + 1) // 2)                 # harmonics below the Nyquist frequency
    amplitude = np.sqrt(2.0 * kaimal(k / duration, 1.0, length, mean) / duration)
    phase = np.random.default_rng(int(seed)).uniform(0.0, 2.0 * math.pi, k.size)
    coefficients = np.zeros(n // 2 + 1, complex)
    coefficients[k] = 0.5 * n * amplitude * np.exp(1j * phase)
    u = np.fft.irfft(coefficients, n)              # sum_k amplitude cos(2 pi k j / n + phase)
    u *= intensity / math.sqrt(np.mean(u * u)) if intensity > 0.0 else 0.0
    times = np.arange(n + 1) * step
    return times, 1.0 + np.append(u, u[0])
