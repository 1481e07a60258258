"""A clamped steel cantilever rolled up by a dead (constant-direction) end torque M = 2 pi EI / L
on its massless free end (docs/rolled_cantilever.md).

Two flutters of this non-conservative load: at n = 60 elements a pair of grid-scale modes
of the discretised rod, caught by the watch; and near the full roll-up a slow one that
converges at order 2 in the element length, a property of the rod itself. The linear
analysis differentiates the kernels' own loads, so it tests the semi-discrete equations the
steppers integrate, with no time step at all; the grid flutter's growth in a run is held to
it through Verlet's own map of a mode."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.engine import measure
from cosnet.kernels.motion import place_line_ends
from cosnet.core.rotations import matrix_from_quat, matrix_from_rotvec, quat_from_matrix

E, G, RHO, R, L = 2.1e11, 8.1e10, 7850.0, 0.01, 1.0
EI = E * math.pi * R ** 4 / 4
M_ROLL = 2 * math.pi * EI / L          # bends the rod into one full circle


def cantilever(n, ramp=0.05, tip_inertia=None, dt_factor=1.0):
    net = cosnet.Net()
    root = net.add_node([0, 0, 0], fixed=True, name="root")
    tip = net.add_node([L, 0, 0], name="tip", **({} if tip_inertia is None else {"inertia": [tip_inertia] * 3}))
    net.add_line(root, tip, material=cosnet.Material(E=E, G=G, density=RHO), section=cosnet.Circle(R),
                 elements=n, name="rod")
    load = cosnet.NodeLoad(tip, torque=(0, M_ROLL, 0), times=[0, ramp, 1e9], values=[0, 1, 1])
    sim = cosnet.Simulation(net, [load])
    sim.dt *= dt_factor
    return sim, tip


def run_to(sim, until):
    while sim.time < until:
        sim.run(steps=500)


def test_grid_flutter_at_60_elements_is_caught_and_named():
    sim, _ = cantilever(60)
    with pytest.raises(cosnet.InstabilityError, match=r"flutter of the discretised net .* at node 'tip'.*"
                                                      r"a smaller dt does not remove it"):
        run_to(sim, 0.04)


def test_grid_flutter_does_not_depend_on_the_time_step():
    times = []
    for f in (1.0, 0.5):
        sim, _ = cantilever(60, dt_factor=f)
        with pytest.raises(cosnet.InstabilityError, match="flutter"):
            run_to(sim, 0.04)
        times.append(sim.time)
    assert abs(times[1] - times[0]) < 0.004   # within a check interval: the same growth


@pytest.mark.parametrize("n, inertia", [(16, None), (60, 1e-5)])
def test_no_grid_flutter_at_16_elements_or_with_an_end_inertia(n, inertia):
    sim, tip = cantilever(n, tip_inertia=inertia)
    run_to(sim, 0.04)
    assert np.abs(sim.state.x[:, 1]).max() < 1e-12        # still planar: nothing grew
    assert measure.node_wobble(sim.model, sim.state)[0] < 1e-3


def _rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def bend_to_arc(sim, n, alpha, ramp=1.0):
    """Set sim's rod on its equilibrium under alpha * M_ROLL, the circular arc of curvature
    alpha M / EI (exact for the discrete rod), and its clock where a load ramped over `ramp`
    reaches alpha."""
    s = sim.state
    kappa, le = alpha * M_ROLL / EI, L / n
    for e in range(n):
        turn = _rot_y((e + 0.5) * kappa * le)
        s.q[e] = quat_from_matrix(turn @ matrix_from_quat(s.q[e]))
        s.x[e + 1] = s.x[e] + le * turn[:, 0]
    s.node_q[1] = quat_from_matrix(_rot_y(kappa * L) @ matrix_from_quat(s.node_q[1]))
    s.node_x[1] = s.x[n]
    s.clock[0] = alpha * ramp


def flutter(n, alpha, tip_inertia=None, below=math.inf):
    """(growth rate 1/s, angular frequency rad/s) of the fastest-growing mode (of those turning
    slower than `below` rad/s) of the discrete rod linearised about its equilibrium under
    alpha * M_ROLL (bend_to_arc). The stiffness is the central difference of the kernels'
    generalised forces in the stepper's coordinates (interior vertices, element and node body
    rotations, node centre of mass), the mass matrix the stepper's diagonal one."""
    sim, _ = cantilever(n, ramp=1.0, tip_inertia=tip_inertia)
    m, s = sim.model, sim.state
    le = L / n
    bend_to_arc(sim, n, alpha)
    coords = ([("x", i, k) for i in range(1, n) for k in range(3)] + [("q", e, k) for e in range(n) for k in range(3)]
              + [("nx", 1, k) for k in range(3)] + [("nq", 1, k) for k in range(3)])
    mass = np.array([{"x": m.vertex_mass, "nx": m.node_mass}[c][i] if c in ("x", "nx")
                     else {"q": m.element_inertia, "nq": m.node_inertia}[c][i, k] for c, i, k in coords])
    base = {k: v.copy() for k, v in s._asdict().items()}

    def forces(c, i, k, h):
        for name, arr in base.items():
            getattr(s, name)[...] = arr
        d = np.zeros(3)
        d[k] = h
        if c == "x":
            s.x[i, k] += h
        elif c == "nx":
            s.node_x[i, k] += h
        else:
            qs = s.q if c == "q" else s.node_q
            qs[i] = quat_from_matrix(matrix_from_quat(qs[i]) @ matrix_from_rotvec(d))
        place_line_ends(m, s)
        sim.evaluate_loads()
        ld = sim.loads
        tau_node = matrix_from_quat(s.node_q[1]).T @ ld.node_tau[1]
        table = {"x": ld.f, "q": ld.tau, "nx": ld.node_f}
        return np.array([table[c][i, k] if c in table else tau_node[k] for c, i, k in coords])

    assert np.abs(forces("x", 1, 0, 0.0)).max() < 1e-5 * M_ROLL    # in equilibrium
    K = np.zeros((len(coords), len(coords)))
    for j, (c, i, k) in enumerate(coords):
        h = 1e-5 * (le if c in ("x", "nx") else 1.0)
        K[:, j] = -(forces(c, i, k, h) - forces(c, i, k, -h)) / (2 * h)
    s_modes = np.sqrt(-np.linalg.eigvals(K / mass[:, None]).astype(complex))   # q ~ exp(s t)
    s_modes = s_modes[np.abs(s_modes.imag) < below]
    j = int(np.argmax(s_modes.real))
    return float(s_modes.real[j]), float(abs(s_modes.imag[j]))


def test_the_grid_flutter_grows_in_a_run_as_the_linear_analysis_says():
    """Set half rolled (its equilibrium, the load held there), the 60-element rod's grid
    flutter grows from round-off. Verlet maps a mode q ~ exp(s t) of the semi-discrete
    equations to one growing per step by exp(h s_h) with 2 (cosh(h s_h) - 1) = (h s)^2, so
    s_h = (2/h) asinh(h s / 2): at this mode's h omega of 0.85 that is 10 % faster than Re s,
    at half the step 2.4 %. The run's growth (the envelope of the tip node's turning against
    its end element, its largest sample over each five periods, fitted over four decades) is
    held to Re s_h at both steps. A sample taken every step falls within h omega / 2 of a
    crest, so the envelope's log is short by at most 1 - cos(h omega / 2), at either end of
    the fit: the slope's bound is that over ln 1e4. Re s itself would be 10 % off at the larger
    step. 16 elements do not flutter half rolled (a rate of round-off)."""
    rate, omega = flutter(60, 0.5)
    s = complex(rate, omega)
    assert rate > 0 and omega > math.sqrt(E / RHO) * 60 / L     # the grid's scale: a wave over one element ~ 2c/l
    for f in (1.0, 0.5):
        sim, _ = cantilever(60, ramp=1e4, dt_factor=f)
        bend_to_arc(sim, 60, 0.5, ramp=1e4)
        h, start = sim.dt, sim.time
        window = int(round(5e-5 / h))                 # about five periods of the mode
        t, env = [], []
        while not env or env[-1] < 1.0:
            top = 0.0
            for _ in range(window):
                sim.run(steps=1)
                top = max(top, measure.node_wobble(sim.model, sim.state)[1])
            t.append(sim.time - start)
            env.append(top)
            assert sim.time - start < 0.05
        t, env = np.array(t), np.array(env)
        grown = (env > 1e-4) & (env < 1.0)
        assert grown.sum() > 10, f"no growth from round-off to fit: {env}"
        fitted = np.polyfit(t[grown], np.log(env[grown]), 1)[0]
        mapped = (2 / h * np.arcsinh(h * s / 2)).real
        assert fitted == pytest.approx(mapped, rel=(1 - math.cos(h * omega / 2)) / math.log(1e4))
    assert flutter(16, 0.5)[0] < 1e-3


def test_the_full_roll_up_flutters_slowly_converging_at_order_two():
    """Fully rolled, the rod's slowest unstable pair (below 1e4 rad/s; 64 elements also have a
    grid flutter) at 16, 32 and 64 elements: its growth rate and frequency converge at order 2
    in the element length (the discretisation's own order), to a rod's flutter, not a grid's."""
    modes = np.array([flutter(n, 1.0, below=1e4) for n in (16, 32, 64)])
    assert np.all(modes[:, 0] > 0.1 * modes[:, 1])          # growing within ten turns
    order = np.log2((modes[0] - modes[1]) / (modes[1] - modes[2]))
    np.testing.assert_allclose(order, 2.0, atol=0.1)
