"""Discrete modes of a clamped-free steel rod (L = 1 m, r = 2 mm) against Euler-Bernoulli and
the quarter-wave axial/torsional frequencies, over refinement, with the solve time.

    python bench/modes_convergence.py [n1 n2 ...]
"""

import math
import sys
import time

import numpy as np

import cosnet
from cosnet.studies.modes import modes

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0)
EB = np.array([1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910])
R = 0.002


def rod(n):
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True)
    b = net.add_node((1, 0, 0))
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(R), elements=n)
    return net


def pick(res, kind):
    """The frequency of the mode whose kinetic energy is mostly axial (kind 0) or twist (1)."""
    m = res.lin.model
    share = []
    for j in range(len(res)):
        dx, alpha, dc, phi = res.raw(j)
        share.append(np.sum(m.vertex_mass[1:-1] * dx[1:-1, 0] ** 2) + m.node_mass[1] * dc[1, 0] ** 2 if kind == 0
                     else np.sum(m.element_inertia[:, 2] * alpha[:, 2] ** 2) + m.node_inertia[1, 2] * phi[1, 2] ** 2)
    return res.omega[int(np.argmax(share))]


def table(ns):
    sec = cosnet.Circle(R)
    bend = EB**2 * math.sqrt(STEEL.E * sec.I11 / (STEEL.density * sec.A))
    axial = 0.5 * math.pi * math.sqrt(STEEL.E / STEEL.density)
    torsion = 0.5 * math.pi * math.sqrt(STEEL.G / STEEL.density)
    print(f"{'n':>6} {'dofs':>7} {'time[s]':>8} " + " ".join(f"bend{k + 1:<5d}" for k in range(5))
          + "  axial      torsion")
    try:   # the analytic modes of the same continuum model (Timoshenko + axial + torsion)
        from cosnet.studies.lincos import analytic_modes
        exact = analytic_modes(rod(4), count=10).omega[::2]
    except ImportError:
        exact = None
    prev, rows = None, []
    for n in ns:
        net = rod(n)
        t = time.perf_counter()
        res = modes(net, count=10)
        el = time.perf_counter() - t
        near = [pick(modes(net, count=6, sigma=w), kind) for w, kind in ((axial, 0), (torsion, 1))]
        err = np.abs(np.concatenate([res.omega[::2] / bend, np.array(near) / (axial, torsion)]) - 1)
        print(f"{n:6d} {res.lin.K.shape[0]:7d} {el:8.3f} " + " ".join(f"{e:9.2e}" for e in err))
        if prev is not None:
            print(f"{'order':>23} " + " ".join(f"{o:9.2f}" for o in np.log(prev[1] / err) / np.log(n / prev[0])))
        prev = (n, err)
        if exact is not None:
            rows.append((n, np.abs(res.omega[::2] / exact - 1)))
    if rows:
        print("\nbending against the analytic modes of the same continuum (no Euler-Bernoulli floor)")
        for k, (n, e) in enumerate(rows):
            tail = "" if k == 0 else "   order " + " ".join(
                f"{o:5.2f}" for o in np.log(rows[k - 1][1] / e) / np.log(n / rows[k - 1][0]))
            print(f"{n:6d} " + " ".join(f"{x:9.2e}" for x in e) + tail)


if __name__ == "__main__":
    table([int(a) for a in sys.argv[1:]] or [20, 40, 80, 160, 320, 640, 2560])
