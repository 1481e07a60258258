"""A clamped steel cantilever rolled up by a dead (constant-direction) end torque M = 2 pi EI / L
on its massless free end (docs/rolled_cantilever.md).

Two flutters of this non-conservative load: at n = 60 elements a pair of grid-scale modes
(about 6.4e5 rad/s) of the discretised rod, caught by the watch; and near the full roll-up a
slow one (about 250 rad/s) that is the same at n = 16 and 32, a property of the rod itself.
The linear analysis differentiates the kernels' own loads, so it tests the semi-discrete
equations the steppers integrate, with no time step at all."""

import math

import numpy as np
import pytest

import cosnet
from cosnet.engine import measure
from cosnet.kernels.motion import place_line_ends
from cosnet.kernels.stepping import evaluate_loads
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
    assert 0.025 < sim.time < 0.032     # round-off grown by about 1e11 at 700-1900 /s


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


def flutter(n, alpha, tip_inertia=None):
    """(growth rate 1/s, angular frequency rad/s) of the fastest-growing mode of the discrete
    rod linearised about its equilibrium under alpha * M_ROLL: the circular arc of curvature
    alpha M / EI (exact for the discrete rod). The stiffness is the central difference of the
    kernels' generalised forces in the stepper's coordinates (interior vertices, element and
    node body rotations, node centre of mass), the mass matrix the stepper's diagonal one."""
    sim, _ = cantilever(n, ramp=1.0, tip_inertia=tip_inertia)
    m, s = sim.model, sim.state
    kappa, le = alpha * M_ROLL / EI, L / n
    for e in range(n):
        turn = _rot_y((e + 0.5) * kappa * le)
        s.q[e] = quat_from_matrix(turn @ matrix_from_quat(s.q[e]))
        s.x[e + 1] = s.x[e] + le * turn[:, 0]
    s.node_q[1] = quat_from_matrix(_rot_y(kappa * L) @ matrix_from_quat(s.node_q[1]))
    s.node_x[1] = s.x[n]
    s.clock[0] = alpha                 # the ramp's amplitude
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
        evaluate_loads(m, s, sim.loads, sim.load_records, sim.backend)
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
    j = int(np.argmax(s_modes.real))
    return float(s_modes.real[j]), float(abs(s_modes.imag[j]))


def test_linear_analysis_finds_the_grid_flutter():
    rate, omega = flutter(60, 0.5)
    assert 1.5e3 < rate < 2.2e3 and omega > 5e5           # a grid-scale pair (max about 7e5 rad/s)
    assert flutter(16, 0.5)[0] < 1e-3                     # 16 elements: no flutter half rolled


def test_the_full_roll_up_flutters_slowly_at_any_resolution():
    (r16, w16), (r32, w32) = flutter(16, 1.0), flutter(32, 1.0)
    assert 200 < r16 < 320 and 200 < w16 < 320             # 1/s and rad/s: the rod's own scale
    assert abs(r32 - r16) < 0.02 * r16 and abs(w32 - w16) < 0.02 * w16
