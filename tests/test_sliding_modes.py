"""Sliders in the normal modes (§6 with §8's mobile nodes): a ring's translation is its line's
at its material coordinate, which becomes a coordinate of its own (engine/linearised._slide),
so the ring adds its mass to the line's motion across it and slides freely along it."""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import cosnet

E, RHO, RADIUS, LENGTH, ELEMENTS = 2e11, 7850.0, 0.01, 1.0, 40
TIP = 0.5   # the ring's mass over the rod's


def cantilever(ring=False, weld=False):
    """A steel cantilever along x; with ``ring`` a ring of TIP times its mass at its free tip,
    with ``weld`` the same mass as the tip node's own."""
    rod_mass = RHO * math.pi * RADIUS ** 2 * LENGTH
    net = cosnet.Net()
    a = net.add_node((0.0, 0.0, 0.0), fixed=True)
    b = net.add_node((LENGTH, 0.0, 0.0), mass=TIP * rod_mass if weld else 0.0)
    line = net.add_line(a, b, material=cosnet.Material(E=E, poisson=0.3, density=RHO),
                        section=cosnet.Circle(RADIUS), elements=ELEMENTS)
    if ring:
        net.add_ring(line, s=LENGTH, mass=TIP * rod_mass)
    return net


def tip_mass_beta():
    """The first root of the Euler-Bernoulli cantilever with a tip mass mu times its own:
    1 + cos b cosh b + mu b (cos b sinh b - sin b cosh b) = 0."""
    f = lambda b: 1 + math.cos(b) * math.cosh(b) + TIP * b * (math.cos(b) * math.sinh(b) - math.sin(b) * math.cosh(b))
    return brentq(f, 0.5, 1.875104)


def by_kind(res):
    """{"slide": omega of the sliding mode, "bend": the first bending omega, "axial": the first
    axial one} of a modes result."""
    out = {}
    for j, w in enumerate(res.omega):
        shares = res.energy_shares(j) if w > 0 else None
        kind = "slide" if w < 1e-6 * res.omega.max() else max(shares, key=shares.get)
        out.setdefault({"bend": "bend", "stretch": "axial"}.get(kind, kind), w)
    return out


def test_a_ring_at_the_tip_lowers_the_bending_mode_as_a_tip_mass_and_slides_freely_along():
    # across the rod the ring is a tip mass (Euler-Bernoulli's frequency equation with it, and
    # the same node mass welded on); along it, it slides: the axial mode keeps the bare rod's
    # quarter wave, where a welded mass lowers it to beta tan beta = 1 / mu's root
    c = math.sqrt(E / RHO)
    quarter_wave = 0.5 * math.pi * c / LENGTH
    carried = brentq(lambda b: b * math.tan(b) - 1.0 / TIP, 0.1, 0.5 * math.pi - 1e-9) * c / LENGTH

    def kinds(net, axial_near):
        return {**by_kind(cosnet.modes(net, count=3, sigma=axial_near)), **by_kind(cosnet.modes(net, count=3))}

    bare, ring = kinds(cantilever(), quarter_wave), kinds(cantilever(ring=True), quarter_wave)
    weld = kinds(cantilever(weld=True), carried)
    area = math.pi * RADIUS ** 2
    analytic = tip_mass_beta() ** 2 * math.sqrt(E * area * RADIUS ** 2 / 4 / (RHO * area * LENGTH ** 4))
    assert ring["slide"] < 1e-6 * ring["bend"]                           # the ring slides freely
    assert ring["bend"] == pytest.approx(analytic, rel=5e-3)
    assert ring["bend"] == pytest.approx(weld["bend"], rel=1e-9)
    assert bare["axial"] == pytest.approx(quarter_wave, rel=1e-3)
    assert ring["axial"] == pytest.approx(bare["axial"], rel=1e-9)
    assert weld["axial"] == pytest.approx(carried, rel=1e-3)


def test_an_eyelet_fixed_at_the_tip_props_the_cantilever_and_lets_it_slide_along():
    # the line passes through a fixed point at its tip: across, a pinned support (the clamped-
    # pinned rod's beta L = 3.9266); along, nothing (the quarter wave); no mode at zero frequency
    c = math.sqrt(E / RHO)
    quarter_wave = 0.5 * math.pi * c / LENGTH
    net = cantilever()
    net.add_eyelet(net.lines[0], s=LENGTH)
    low = cosnet.modes(net, count=3)
    area = math.pi * RADIUS ** 2
    beta = brentq(lambda b: math.tan(b) - math.tanh(b), 3.5, 4.5)
    propped = beta ** 2 * math.sqrt(E * area * RADIUS ** 2 / 4 / (RHO * area * LENGTH ** 4))
    assert low.omega[0] == pytest.approx(propped, rel=5e-3)
    assert by_kind(cosnet.modes(net, count=3, sigma=quarter_wave))["axial"] == pytest.approx(
        by_kind(cosnet.modes(cantilever(), count=3, sigma=quarter_wave))["axial"], rel=1e-9)


def test_an_eyelet_where_the_line_is_held_is_refused_in_one_line():
    net = cantilever()
    net.add_eyelet(net.lines[0], s=0.0)
    with pytest.raises(ValueError, match="^modes: a slider whose node and element are both held in space"):
        cosnet.modes(net, count=4)


def test_cosnet_modes_lists_the_ring_s_sliding_and_the_tip_mass_bending(tmp_path):
    import subprocess
    import sys
    scene = tmp_path / "ringed.toml"
    rod_mass = RHO * math.pi * RADIUS ** 2 * LENGTH
    scene.write_text(f"""
[materials.steel]
E = {E}
poisson = 0.3
density = {RHO}

[sections.rod]
kind = "circle"
radius = {RADIUS}

[nodes.root]
position = [0.0, 0.0, 0.0]
fixed = true

[nodes.tip]
position = [{LENGTH}, 0.0, 0.0]

[lines.rod]
start = "root"
end = "tip"
material = "steel"
section = "rod"
elements = {ELEMENTS}

[rings.collar]
line = "rod"
s = {LENGTH}
mass = {TIP * rod_mass}

[run]
until = 0.01
""")
    r = subprocess.run([sys.executable, "-m", "cosnet.cli", "modes", str(scene), "--count", "3", "--out",
                        str(tmp_path / "out"), "--frames", "2"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = (tmp_path / "out" / "spectrum.csv").read_text().splitlines()[1:]
    got = np.array([float(row.split(",")[1]) for row in rows])
    want = cosnet.modes(cantilever(ring=True), count=3).omega
    assert got[0] < 1e-6 * got[1]                     # the sliding mode, at zero frequency
    np.testing.assert_allclose(got[1:], want[1:], rtol=1e-9)
