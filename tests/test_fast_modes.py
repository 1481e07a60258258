"""Fast modes (docs/fast_modes.md): rotary inertia as its own property and the treatments
that slow a slender line's rotational, stretch and shear modes. Physics: bending frequencies
of a treated line against Euler-Bernoulli and their n^-2 convergence, second-order bounded
energy, exact junctions, conserved momenta; a setting that cannot hold stops with a clear
error; the default changes nothing."""

import dataclasses
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import cosnet
from cosnet.core.fast_modes import (AUTO_MIN_GAIN, FastModesError, MODE_TOLERANCE, MODES_KEPT, ROTARY_SHARE,
                                    STRAIN_GUARD, _Rows, auto_rotary_scale)
from cosnet.core.grid import build_line_grid
from cosnet.engine.flatten import flatten
from cosnet.studies.modes import bending_omegas
from cosnet.scene.loader import build_scene
from nets import STEEL

REPO = Path(__file__).resolve().parents[1]
CLAMPED_FREE = (1.8751040687, 4.6940911330, 7.8547574382)


def rod(n=20, r=1e-3, L=1.0, **line):
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True, name="root")
    b = net.add_node((L, 0, 0), name="tip")
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(r), elements=n, name="rod", **line)
    return net


def euler_bernoulli(betas, L, r):
    c = math.sqrt(STEEL.E * r * r / 4.0 / STEEL.density)
    return np.array([(b / L) ** 2 * c for b in betas])


# ------------------------------------------------------------------ rotary inertia
def test_rotary_inertia_given_separately_and_scaled():
    sec = dataclasses.replace(cosnet.Circle(1e-3), rotary_inertia=(2e-6, 3e-6, 4e-6))
    net = cosnet.Net()
    a, b = net.add_node((0, 0, 0), fixed=True), net.add_node((1, 0, 0))
    net.add_line(a, b, material=STEEL, section=sec, elements=4, rotary_inertia_scale=5.0)
    J = flatten(net)[0].element_inertia
    # per length times l = 0.25 m times the scale; the end elements keep 3/4 (a quarter is the node's)
    np.testing.assert_allclose(J[1], 5.0 * 0.25 * np.array([2e-6, 3e-6, 4e-6]), rtol=1e-14)
    np.testing.assert_allclose(J[0], 0.75 * J[1], rtol=1e-14)
    line = rod(n=4, rotary_inertia=(1e-6, 1e-6, 2e-6))
    np.testing.assert_allclose(flatten(line)[0].element_inertia[1], 0.25 * np.array([1e-6, 1e-6, 2e-6]))


def test_default_is_the_derived_rotary_inertia_unchanged():
    net = rod(n=8)
    model = flatten(net)[0]
    I = math.pi * 1e-3 ** 4 / 4
    np.testing.assert_allclose(model.element_inertia[3], STEEL.density * 0.125 * np.array([I, I, 2 * I]), rtol=1e-14)
    sim = cosnet.Simulation(net)
    assert sim.fast_modes == "resolve" and all(f == cosnet.core.fast_modes.Factors() for f in sim.line_factors)


def test_auto_rotary_scale_brings_the_rotation_bound_to_the_translation_bound():
    slender = rod(n=100)
    grid = build_line_grid(slender.lines[0])
    alpha = auto_rotary_scale(grid)
    rows = _Rows(grid)
    # the smallest factor: the rotation rows meet the translation rows exactly there
    assert np.max(rows.rotation(alpha)) == pytest.approx(np.max(rows.translation()), rel=1e-9)
    assert np.max(rows.rotation(0.99 * alpha)) > np.max(rows.translation())
    assert alpha > 10.0
    plain = cosnet.Simulation(slender).stable_dt()
    scaled = cosnet.Simulation(rod(n=100, rotary_inertia_scale="auto"))
    assert scaled.line_factors[0].rotary == pytest.approx(alpha)
    # the step was the rotation's r/c; now it is the axial wave's l/c (within the bound's factors)
    c = math.sqrt(STEEL.E / STEEL.density)
    assert plain < 1.2e-3 / c and 5.0 * plain < scaled.stable_dt() < 0.01 / c


# ------------------------------------------------------------------ bending modes
@pytest.mark.parametrize("fm", ["rotary", "soften"])
def test_treated_rod_keeps_its_bending_frequencies(fm):
    exact = euler_bernoulli(CLAMPED_FREE, 1.0, 1e-3)
    plain = cosnet.Simulation(rod(n=40))
    sim = cosnet.Simulation(rod(n=40), fast_modes=fm)
    assert sim.dt > 5 * plain.dt
    w0, w = bending_omegas(plain, 3), bending_omegas(sim, 3)
    # the treatment's own share of the error stays within its stated tolerance on omega^2
    assert np.all(np.abs(w ** 2 / w0 ** 2 - 1.0) < MODE_TOLERANCE)
    assert np.all(np.abs(w / exact - 1.0) < 0.01)


@pytest.mark.parametrize("fm", ["rotary", "soften"])
def test_scaled_rotary_inertia_moves_the_fifth_mode_by_its_share_of_the_tolerance(fm):
    """A long slender line, where the rotary scale is capped: the rotary term alpha k^2 I / A of
    the fifth bending mode is exactly ROTARY_SHARE of MODE_TOLERANCE, and the fifth discrete
    frequency moves by about half of that (rotary inertia only, so under "rotary")."""
    L, r = 10.0, 1e-3
    sim = cosnet.Simulation(rod(n=100, r=r, L=L), fast_modes=fm)
    alpha = sim.line_factors[0].rotary
    k2 = (MODES_KEPT * math.pi / L) ** 2
    assert alpha * k2 * r * r / 4.0 == pytest.approx(ROTARY_SHARE * MODE_TOLERANCE, rel=1e-9)
    if fm == "rotary":
        w0 = bending_omegas(cosnet.Simulation(rod(n=100, r=r, L=L)), 5)
        w = bending_omegas(sim, 5)
        assert 1.0 - w[4] / w0[4] == pytest.approx(0.5 * ROTARY_SHARE * MODE_TOLERANCE, rel=0.1)


def test_scaled_line_bending_frequencies_converge_as_n_minus_2():
    """A rotary inertia scaled by alpha = 100: the frequencies converge as n^-2 to
    Euler-Bernoulli's with the rotary-inertia and shear terms of Timoshenko,
    omega^2 = omega_EB^2 / (1 + k^2 I/A (alpha + E/G))."""
    alpha, k = 100.0, np.array(CLAMPED_FREE)
    exact = euler_bernoulli(CLAMPED_FREE, 1.0, 1e-3)
    timoshenko = exact / np.sqrt(1.0 + k ** 2 * 2.5e-7 * (alpha + STEEL.E / STEEL.G))
    w = [bending_omegas(cosnet.Simulation(rod(n=n, rotary_inertia_scale=alpha)), 3) for n in (20, 40, 80)]
    ratio = (w[0] - w[1]) / (w[1] - w[2])
    assert np.all((3.7 < ratio) & (ratio < 4.3)), ratio
    limit = w[2] + (w[2] - w[1]) / 3.0            # Richardson: the n -> infinity value
    assert np.all(np.abs(limit / timoshenko - 1.0) < 5e-4)
    assert np.all(np.abs(w[2] / exact - 1.0) < 0.01)


# ------------------------------------------------------------------ dynamics
def swinging(fm, dt_factor=1.0, until=0.02):
    """A clamped 1 m wire under gravity, released straight: the treated step, run and energy."""
    sim = cosnet.Simulation(rod(n=20), effects=[cosnet.Gravity()], fast_modes=fm)
    if dt_factor != 1.0:
        sim = cosnet.Simulation(rod(n=20), effects=[cosnet.Gravity()], fast_modes=fm, dt=sim.dt * dt_factor)
    e0 = sim.energy()
    err = 0.0
    for k in range(1, 21):
        sim.run(until=until * k / 20)
        err = max(err, abs(sim.energy() - e0))
    return sim, err


def test_softened_energy_error_is_bounded_and_second_order():
    big, e1 = swinging("soften", 1.0)
    small, e2 = swinging("soften", 0.5)
    assert big.line_factors[0].softened
    assert 3.3 < e1 / e2 < 4.7
    assert e1 < 1e-3 * abs(cosnet.Gravity().energy_scale(big))


def test_softened_junctions_exact_and_free_net_keeps_its_momenta():
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), mass=0.01, inertia=(1e-7, 1e-7, 1e-7), name="a")
    b = net.add_node((1, 0, 0), mass=0.02, inertia=(2e-7, 2e-7, 2e-7), name="b")
    c = net.add_node((1, 1, 0), name="c")
    for s, e in ((a, b), (b, c)):
        net.add_line(s, e, material=STEEL, section=cosnet.Circle(1e-3), elements=30,
                     start_offset=(0.0, 0.0, 0.01) if s is b else (0, 0, 0))
    sim = cosnet.Simulation(net, fast_modes="soften")
    assert all(f.rotary > 1 for f in sim.line_factors)
    sim.node_velocity(a)[:] = (0.0, 0.3, 0.1)
    sim.node_angular_velocity(b)[:] = (0.0, 0.0, 2.0)
    sim.line_velocities(net.lines[1])[1:-1] += (0.0, 0.0, -0.2)
    p0, l0 = sim.momentum(), sim.angular_momentum()
    sim.run(steps=3000)
    np.testing.assert_allclose(sim.momentum(), p0, atol=1e-14)
    np.testing.assert_allclose(sim.angular_momentum(), l0, atol=1e-14)
    x = sim.line_positions(net.lines[1])[0]
    np.testing.assert_allclose(x, sim.node_position(b) + sim.node_rotation(b) @ (0, 0, 0.01), atol=1e-14)
    np.testing.assert_allclose(sim.line_positions(net.lines[0])[-1], sim.node_position(b), atol=1e-14)


def test_a_softened_line_that_cannot_hold_stops_with_a_clear_error():
    sim = cosnet.Simulation(rod(n=20), fast_modes="soften")
    assert sim.line_factors[0].axial < 0.1
    v = sim.line_velocities(sim.net.lines[0])
    v[1:, 0] = np.linspace(0.0, 3.0, v.shape[0])[1:]    # a hard axial pull on the tip
    with pytest.raises(FastModesError, match=r"line 'rod': fast_modes 'soften' cannot hold .* exceeds "
                                             + re.escape(f"{STRAIN_GUARD:g}")):
        sim.run(steps=2500)


def test_auto_keeps_stubby_lines_and_treats_slender_ones():
    assert cosnet.Simulation(rod(n=100, r=1e-2), fast_modes="auto").line_factors[0].treatment == "resolve"
    assert cosnet.Simulation(rod(n=100), fast_modes="auto").line_factors[0].treatment == "soften"
    # a line's own setting wins over the simulation's
    own = cosnet.Simulation(rod(n=100, fast_modes="rotary"), fast_modes="soften").line_factors[0]
    assert own.treatment == "rotary" and not own.softened


# ------------------------------------------------------------------ input
@pytest.mark.parametrize("kw, msg", [
    (dict(rotary_inertia_scale=0.5), "rotary_inertia_scale must be >= 1"),
    (dict(rotary_inertia_scale="fast"), "rotary_inertia_scale must be a number >= 1 or \"auto\""),
    (dict(rotary_inertia=(1.0, -1.0, 1.0)), "rotary_inertia must be positive"),
    (dict(rotary_inertia=(1.0, 1.0)), "rotary_inertia must be three numbers"),
    (dict(fast_modes="fast"), "fast_modes must be one of"),
])
def test_bad_line_settings_are_refused_in_one_line(kw, msg):
    with pytest.raises(ValueError, match=re.escape(msg)):
        rod(**kw)
    with pytest.raises(ValueError, match="fast_modes must be one of"):
        cosnet.Simulation(rod(), fast_modes="fastest")


SCENE = """
[materials.steel]
E = 2.1e11
poisson = 0.3
density = 7850.0
[sections.wire]
kind = "circle"
radius = 0.001
{section}
[nodes.a]
position = [0.0, 0.0, 0.0]
fixed = true
[nodes.b]
position = [1.0, 0.0, 0.0]
[lines.rod]
start = "a"
end = "b"
material = "steel"
section = "wire"
elements = 20
{line}
[run]
until = 0.1
{run}
"""


def scene(section="", line="", run=""):
    import tomllib
    return build_scene(tomllib.loads(SCENE.format(section=section, line=line, run=run)), "s.toml")


def test_scene_keys_reach_the_simulation():
    s = scene('rotary_inertia = [1e-6, 1e-6, 2e-6]', 'rotary_inertia_scale = "auto"', 'fast_modes = "soften"')
    sim = s.simulation()
    assert sim.fast_modes == "soften" and sim.net.lines[0].section.rotary_inertia == (1e-6, 1e-6, 2e-6)
    assert s.net.lines[0].rotary_inertia_scale == "auto"
    assert scene(line='fast_modes = "rotary"').simulation().line_factors[0].treatment == "rotary"


@pytest.mark.parametrize("where, text, msg", [
    ("run", 'fast_modes = "fast"', "[run] fast_modes: must be one of"),
    ("line", 'fast_modes = 3', "[lines.rod] fast_modes: must be one of"),
    ("line", 'rotary_inertia_scale = 0.5', "[lines.rod] rotary_inertia_scale:"),
    ("section", 'rotary_inertia = [1e-6, 0.0, 1e-6]', "[sections.wire] rotary_inertia:"),
])
def test_bad_scene_keys_name_file_table_and_key(where, text, msg):
    with pytest.raises(ValueError, match=re.escape(f"s.toml: {msg}")) as e:
        scene(**{where: text})
    assert "\n" not in str(e.value)


def test_info_prints_the_setting_the_step_and_the_gain():
    out = subprocess.run([sys.executable, "-m", "cosnet.cli", "info", "overhead_line"], capture_output=True,
                         text=True, cwd=REPO, timeout=300)
    assert out.returncode == 0, out.stderr
    line = next(l for l in out.stdout.splitlines() if l.startswith("fast_modes"))
    m = re.search(r"stable dt ([0-9.e+-]+) s \(([0-9.]+)x the ([0-9.e+-]+) s of \"resolve\"\); "
                  r"\"auto\" gives ([0-9.e+-]+) s \(([0-9.]+)x\)", line)
    assert line.split()[1] == "auto" and m, line
    # what it prints is what the engine steps with, and each step is stable for the line's own
    # spectrum: Verlet's limit 2 / omega_max, omega_max^2 the largest eigenvalue of K u = w^2 M u
    # of the same model (the case's arrays) linearised about a straight rest state, which the
    # Gershgorin rows behind stable_dt() bound from above
    from cosnet.scene.loader import load_scene
    from cosnet.studies.modes import linearise
    import scipy.linalg
    scene = load_scene(REPO / "cases" / "overhead_line.toml")
    steps, limits = {}, {}
    for setting in ("resolve", "auto"):
        case = scene.simulation(fast_modes=setting)
        steps[setting] = case.stable_dt()
        net = cosnet.Net()
        ends = net.add_node((0, 0, 0), mass="inf"), net.add_node((scene.net.lines[0].length, 0, 0), mass="inf")
        cable = scene.net.lines[0]
        net.add_line(*ends, material=cable.material, section=cable.section, elements=cable.elements)
        straight = cosnet.Simulation(net)
        for name in ("element_stiffness", "element_inertia", "vertex_mass", "voronoi_stiffness"):
            getattr(straight.model, name)[...] = getattr(case.model, name)
        lin = linearise(straight.model, straight.state, net)
        w2 = scipy.linalg.eigh(lin.K.toarray(), np.diag(lin.M.diagonal()), eigvals_only=True)[-1]
        limits[setting] = 2 / math.sqrt(w2)
        assert steps[setting] <= limits[setting]
    assert limits["auto"] / limits["resolve"] >= AUTO_MIN_GAIN       # the rule by which "auto" treats a line
    assert float(m.group(1)) == pytest.approx(steps["auto"], rel=1e-3)
    assert float(m.group(3)) == pytest.approx(steps["resolve"], rel=1e-3)
    assert float(m.group(2)) == pytest.approx(steps["auto"] / steps["resolve"], rel=2e-3)
    assert float(m.group(5)) == pytest.approx(1.0)


def test_docs_blocks_run():
    """Every Python block of docs/fast_modes.md runs as written."""
    text = (REPO / "docs" / "fast_modes.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks
    for code in blocks:
        exec(compile(code, "docs/fast_modes.md", "exec"), {})
    for cmd in re.findall(r"```sh\n(.*?)```", text, re.S):
        for line in cmd.strip().splitlines():
            args = line.split()
            assert args[0] == "cosnet"
            out = subprocess.run([sys.executable, "-m", "cosnet.cli", *args[1:]], capture_output=True,
                                 text=True, cwd=REPO, timeout=300)
            assert out.returncode == 0, out.stderr


@pytest.mark.parametrize("path", sorted((REPO / "cases" / "hard").glob("*.toml")), ids=lambda p: p.stem)
def test_hard_cases_run_under_auto_never_slower(path):
    from cosnet.scene.loader import load_scene
    scene = load_scene(path)
    full = scene.simulation(fast_modes="resolve")
    sim = scene.simulation(fast_modes="auto")
    assert sim.stable_dt() >= full.stable_dt() * (1 - 1e-12)
    sim.run(steps=50)
    for line, f in zip(scene.net.lines, sim.line_factors):
        assert np.all(np.isfinite(sim.line_positions(line)))
        if f.treatment == "resolve":      # untreated lines are exactly today's
            np.testing.assert_array_equal(sim.model.element_inertia[sim.element_range(line)],
                                          full.model.element_inertia[full.element_range(line)])
