"""Airy waves (kernels/waves.py): the elementary functions the vectorised passes take
(kernels/elementary.py), held to the C library's, and the medium a line's vertices and a
buoy sample, held to linear wave theory evaluated with numpy, over finite and deep water,
stretched and not; an irregular sea drawn from a spectrum (cosnet/core/sea_state.py)."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.core.samples import cantilever_scene
from cosnet.core.sea_state import jonswap, jonswap_components
from cosnet.kernels import elementary, waves

RHO, G = 1025.0, 9.81


def test_the_vectorisable_sine_cosine_and_exponential_are_the_libraries_to_two_ulps():
    rng = np.random.default_rng(7)
    wide = elementary.REDUCED_RANGE
    xs = np.concatenate([rng.uniform(-10.0, 10.0, 4000), rng.uniform(-wide, wide, 4000),
                         np.arange(-40, 41) * math.pi / 4])
    for x in xs:
        s, c = elementary.sin_cos(x)
        for got, want in ((s, math.sin(x)), (c, math.cos(x))):
            # two ulps of the value, or of the reduction's residue where the value is near a zero
            assert abs(got - want) <= 2.0 * max(np.spacing(abs(want)), 1e-30 * max(1.0, abs(x))), x
    for x in np.concatenate([rng.uniform(-720.0, 0.0, 4000), rng.uniform(-1.0, 0.0, 4000), [0.0, -708.0]]):
        want = math.exp(max(x, elementary.EXP_FLOOR))
        assert abs(elementary.exp_nonpositive(x) - want) <= np.spacing(want), x
    for t in (0.0, 1.0, 1e3, 1e6, 2e6):   # a component's phase within [-pi, pi], the same angle to two ulps
        a = waves.wave_phase(0.785, 0.3, t)   # (up to 2^18 turns: 24 days of an 8 s wave)
        assert abs(a) <= math.pi + 1e-12
        assert abs(math.cos(a) - math.cos(0.3 - 0.785 * t)) <= 4.5e-16
        assert abs(math.sin(a) - math.sin(0.3 - 0.785 * t)) <= 4.5e-16


def airy(x, y, z, t, amps, periods, headings, depth, stretch):
    """(wet, U, A) of linear waves at the points (x, y, z) under a still surface at z = 0, as
    the theory gives them (numpy's hyperbolic functions)."""
    k = np.array([cosnet.wave_number(2 * math.pi / T, depth, G) for T in periods])
    w = 2 * math.pi / np.asarray(periods)
    h = np.radians(headings)
    th = k[:, None] * (np.cos(h)[:, None] * x + np.sin(h)[:, None] * y) - w[:, None] * t
    eta = np.sum(np.asarray(amps)[:, None] * np.cos(th), axis=0)
    wet = z <= eta
    if stretch:
        zs = depth * (z - eta) / (depth + eta) if math.isfinite(depth) else z - eta
    else:
        zs = np.minimum(z, 0.0)
    kz = k[:, None] * zs
    if math.isfinite(depth):
        ch = np.cosh(k[:, None] * depth + kz) / np.sinh(k * depth)[:, None]
        sh = np.sinh(k[:, None] * depth + kz) / np.sinh(k * depth)[:, None]
    else:
        ch = sh = np.exp(kz)
    a = np.asarray(amps)[:, None]
    uh, ah = a * w[:, None] * ch * np.cos(th), a * w[:, None] ** 2 * ch * np.sin(th)
    U = np.stack([np.sum(uh * np.cos(h)[:, None], 0), np.sum(uh * np.sin(h)[:, None], 0),
                  np.sum(a * w[:, None] * sh * np.sin(th), 0)])
    A = np.stack([np.sum(ah * np.cos(h)[:, None], 0), np.sum(ah * np.sin(h)[:, None], 0),
                  -np.sum(a * w[:, None] ** 2 * sh * np.cos(th), 0)])
    return wet, U * wet, A * wet


PROFILE = dict(profile_heights=[-30.0, -5.0, 0.0, 5.0], profile_factors=[0.2, 0.8, 1.0, 1.0])
POWER = dict(power_law=0.3, reference_height=10.0, ground=-40.0)


def current_factor(z, shape):
    """The current's factor over height at heights z (numpy)."""
    if "profile_heights" in shape:
        return np.interp(z, shape["profile_heights"], shape["profile_factors"])
    if "power_law" in shape:
        return (np.maximum(z - shape["ground"], 0.0) / shape["reference_height"]) ** shape["power_law"]
    return np.zeros_like(z)


@pytest.mark.parametrize("depth, stretching, shape", [(30.0, "wheeler", PROFILE), (30.0, "none", {}),
                                                      (None, "wheeler", POWER)],
                         ids=["finite-wheeler-profile", "finite-plain", "deep-wheeler-power-law"])
def test_a_line_and_a_buoy_sample_the_waves_kinematics_of_linear_theory(depth, stretching, shape):
    # a line from 12 m down up through the surface to 1.5 m above it, across two components
    # of other headings, sampled late in a run (the phase's reduction over time), in a current
    # shaped over height, and a buoy on its own node (the medium at a point: kernels/fluid.medium_at)
    mat = cosnet.Material(E=1e9, G=4e8, density=2000.0)
    net = cosnet.Net()
    a, b = net.add_node((-40.0, -3.0, -12.0)), net.add_node((25.0, 7.0, 1.5))
    buoy = net.add_node((3.0, 1.0, -2.5))
    net.add_line(a, b, material=mat, section=cosnet.Circle(0.02), elements=300)
    net.add_line(a, buoy, material=mat, section=cosnet.Circle(0.02), elements=2)
    amps, periods, headings = [1.1, 0.4], [9.0, 4.5], [20.0, -65.0]
    current = np.array([0.3, -0.1, 0.05]) if shape else np.zeros(3)
    fluid = cosnet.Fluid(RHO, current, **shape, drag=(1.2, 0.0), added_mass=(1.0, 0.0), buoyancy=True, surface=0.0,
                         depth=depth, wave_amplitudes=amps, wave_periods=periods, wave_headings=headings,
                         stretching=stretching, buoys=[buoy], buoy_volumes=[0.01])
    sim = cosnet.Simulation(net, [cosnet.Gravity(), fluid])
    t = 123456.7
    sim.state.clock[0] = t
    fluid.start(sim)
    p, x = fluid.params(sim), sim.state.x
    wet, U, A = airy(x[:, 0], x[:, 1], x[:, 2], t, amps, periods, headings, math.inf if depth is None else depth,
                     stretching == "wheeler")
    U += current[:, None] * (current_factor(x[:, 2], shape) * wet)
    lo, hi = sim.model.line_vertex_offsets[0], sim.model.line_vertex_offsets[1]
    assert 0 < np.sum(wet[lo:hi]) < hi - lo   # the line crosses the waved surface
    S = p.sample
    np.testing.assert_array_equal(S[0, lo:hi], wet[lo:hi])
    # both round w t, about 8.6e4 rad here, to its ulp: each component's phase may differ by two
    atol = 2 * len(amps) * np.spacing(2 * math.pi / min(periods) * t) * max(np.abs(U).max(), np.abs(A).max())
    np.testing.assert_allclose(S[1:4, lo:hi], U[:, lo:hi], rtol=0, atol=atol)
    np.testing.assert_allclose(S[4:7, lo:hi], A[:, lo:hi], rtol=0, atol=atol)
    # the medium's inertia force on the interior vertices, from the sampled acceleration (the
    # passes' scratch rows are the force's)
    tan, wl = S[7:10, lo + 1:hi - 1], S[0, lo + 1:hi - 1] * sim.model.voronoi_rest_length[lo + 1:hi - 1]
    along = np.sum(S[4:7, lo + 1:hi - 1] * tan, axis=0) * tan
    force = wl * (p.inertia_n[0] * (S[4:7, lo + 1:hi - 1] - along) + p.inertia_t[0] * along)
    np.testing.assert_allclose(S[10:13, lo + 1:hi - 1], force, rtol=1e-12, atol=1e-12 * np.abs(force).max())
    assert not np.any(S[10:13, [lo, hi - 1]])
    nb = sim.node_position(buoy)
    wb, Ub, Ab = airy(nb[0:1], nb[1:2], nb[2:3], t, amps, periods, headings, math.inf if depth is None else depth,
                      stretching == "wheeler")
    assert wb[0]
    Ub += current[:, None] * current_factor(nb[2:3], shape)
    np.testing.assert_allclose(p.buoy_sample[0, 1:4], Ub[:, 0], rtol=0, atol=atol)
    np.testing.assert_allclose(p.buoy_sample[0, 4:7], Ab[:, 0], rtol=0, atol=atol)


# ------------------------------------------------------------------ an irregular sea from a spectrum
def test_a_pierson_moskowitz_sea_cut_into_bands_has_the_spectrums_own_height():
    # the spectrum's analytic integral is Hs^2 / 16 (gamma = 1): bands over all of it need no
    # scaling, and the components then follow the spectrum's shape band by band
    hs, tp = 2.5, 9.0
    a, T, _ = jonswap_components(hs, tp, gamma=1.0, components=4000, band=(0.3, 12.0))
    w = 2 * math.pi / T
    scale = a / np.sqrt(2 * jonswap(w, hs, tp, 1.0) * (w[1] - w[0]))
    assert np.ptp(scale) < 1e-12 * scale[0]
    assert scale[0] == pytest.approx(1.0, abs=1e-3)
    assert 16 * np.sum(a * a / 2) == pytest.approx(hs * hs, rel=1e-12)


def test_a_jonswap_sea_peaks_at_its_period_with_the_usual_normalisation_and_its_seeded_phases():
    hs, tp, gamma = 3.0, 10.0, 3.3
    a, T, phases = jonswap_components(hs, tp, gamma, components=200, band=(0.2, 8.0), seed=4)
    w = 2 * math.pi / T
    # the peak enhancement takes the spectrum's integral to about Hs^2 / 16 / A_gamma,
    # A_gamma = 1 - 0.287 ln gamma (DNV-RP-C205 3.5.5.4, itself a fit of a few %)
    scale = a[0] / math.sqrt(2 * jonswap(w[0], hs, tp, gamma) * (w[1] - w[0]))
    assert scale ** 2 == pytest.approx(1 - 0.287 * math.log(gamma), rel=0.03)
    assert abs(w[np.argmax(a)] - 2 * math.pi / tp) <= (w[1] - w[0]) / 2
    assert 16 * np.sum(a * a / 2) == pytest.approx(hs * hs, rel=1e-12)
    again = jonswap_components(hs, tp, gamma, components=200, band=(0.2, 8.0), seed=4)[2]
    other = jonswap_components(hs, tp, gamma, components=200, band=(0.2, 8.0), seed=5)[2]
    assert np.array_equal(phases, again) and not np.allclose(phases, other)
    assert np.all((phases >= 0) & (phases < 2 * math.pi))


def test_the_scene_draws_its_waves_from_the_spectrum_and_refuses_bad_ones_in_one_line(tmp_path):
    sea = """[[effects]]
kind = "fluid"
density = 1025.0
surface = 0.0
depth = 60.0
drag = [1.2, 0.0]
wave_spectrum = "jonswap"
significant_height = {hs}
peak_period = 8.0
wave_components = 30
wave_headings = [40.0]
wave_seed = 3
[run]
until = 0.1
"""
    path = tmp_path / "sea.toml"
    path.write_text(cantilever_scene("a rod in a sea", rest=sea.format(hs=2.0)))
    sim = cosnet.load_scene(path).simulation()
    (fluid,) = [e for e in sim.effects if isinstance(e, cosnet.Fluid)]
    a, T, headings, phases = fluid.waves
    want = jonswap_components(2.0, 8.0, components=30, seed=3)
    assert all(np.array_equal(x, y) for x, y in zip((a, T, phases), want)) and np.all(headings == 40.0)
    path.write_text(cantilever_scene("a rod in a sea", rest=sea.format(hs=-2.0)))
    with pytest.raises(ValueError) as e:
        cosnet.load_scene(path).simulation()
    assert "sea.toml" in str(e.value) and "significant_height" in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("kwargs, words", [
    (dict(wave_spectrum="jonswap", significant_height=2.0, peak_period=8.0, peak_enhancement=0.5), "peak_enhancement"),
    (dict(wave_spectrum="jonswap", significant_height=2.0, peak_period=8.0, wave_components=0), "wave_components"),
    (dict(wave_spectrum="jonswap", significant_height=2.0, peak_period=8.0, wave_band=(3.0, 0.5)), "wave_band"),
    (dict(wave_spectrum="jonswap", significant_height=2.0), "peak_period"),
    (dict(wave_spectrum="jonswap", significant_height=2.0, peak_period=8.0, wave_amplitudes=[1.0],
          wave_periods=[5.0]), "not both"),
    (dict(wave_spectrum="jonswap", significant_height=2.0, peak_period=8.0, wave_headings=[0.0, 90.0]),
     "one heading"),
    (dict(wave_spectrum="bretschneider", significant_height=2.0, peak_period=8.0), "wave_spectrum"),
    (dict(significant_height=2.0, peak_period=8.0), "need wave_spectrum"),
])
def test_bad_spectra_are_refused_in_one_line(kwargs, words):
    with pytest.raises(ValueError) as e:
        cosnet.Fluid(RHO, surface=0.0, **kwargs)
    assert words in str(e.value) and "\n" not in str(e.value)
