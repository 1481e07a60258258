"""A catenary mooring line under a surging fairlead, in cosnet and in MoorDyn, side by side in
one process: the fairlead's pull (mean, first-harmonic amplitude and phase over the last two
periods) and the wall time per simulated second, each at its own step, at two resolutions.

The line: 47 m of steel wire (r = 20 mm, EA = 1.26e8 N, EI = 1.26e4 N m^2) from an anchor on a
frictionless seabed 20 m down (MoorDyn's soil in both, KBOT and CBOT) to a fairlead at the
surface 40 m away, in still water (rho = 1025, C_dn = 1.2, C_dt = 0.008, C_an = 1, C_at = 0).
The fairlead surges 1 m at an 8 s period, ramped in over the first period. cosnet runs with
fast_modes "auto" (its default for slender lines) and "resolve" (every mode of the line as it
is).

Each code starts from its own static equilibrium: cosnet from MoorPy's catenary relaxed under
mass-proportional damping (SETTLE s at DAMPING /s, the pull then steady to 1e-4), MoorDyn by
its dynamic relaxation. MoorDyn's segments carry the internal damping it needs (BA = -1,
critical); cosnet's line carries none in its main rows and InternalDamping(ratio=1) in a row
beside each, so without it cosnet's line keeps the fast axial vibration the start and the
surge excite: its pull is sampled every SAMPLE s (sampled every 0.1 s, that vibration
aliases into the fitted harmonic by tens of per cent). MoorDyn moves its coupled fairlead by
a constant velocity over each coupling step and returns the pull at its end; the swing
converges as that step shrinks (about 10 % high at 0.01 s), so MoorDyn runs at COUPLINGS.
Each row's swing is also given against the refined reference, MoorDyn at the finest coupling
and the most elements.
cosnet's wall time is that of a second run of the same span in one call (the samples' calls
left out); MoorDyn's includes a Python call per coupling step.
Run: python bench/moordyn_compare.py; writes bench/moordyn_compare.json (needs the extras
peers and bench: moorpy, moordyn).
"""

import math
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import cosnet
from harness import table, write_json

SEA, DEPTH, SPAN, R, RHO_S, E = 1025.0, 20.0, 40.0, 0.02, 7850.0, 1e11
AMPLITUDE, PERIOD, T_END = 1.0, 8.0, 48.0
OMEGA = 2 * math.pi / PERIOD
AREA = math.pi * R * R
DRAG, ADDED = (1.2, 0.008), (1.0, 0.0)
SETTLE, DAMPING, SAMPLE = 20.0, 1.0, 1e-3
INTERNAL = 1.0   # a row with the lines' internal damping at MoorDyn's ratio (BA = -1: critical)
COUPLINGS = (1e-2, 2e-4)
KBOT, CBOT = 3.0e6, 3.0e5   # the seabed's stiffness (N/m^3) and damping (N s/m^3) per contact area

MOORDYN_INPUT = """--------------------- MoorDyn Input File ------------------------------------
catenary wire under a surging fairlead
----------------------- LINE TYPES ------------------------------------------
TypeName   Diam    Mass/m     EA         BA/-zeta   EI        Cd     Ca    CdAx    CaAx
(name)     (m)     (kg/m)     (N)        (N-s/-)    (N-m^2)   (-)    (-)   (-)     (-)
wire       {d}    {mass}     {ea}   -1.0       {ei}  {cd}    {ca}   {cdax}   {caax}
---------------------- POINTS --------------------------------
ID    Attachment  X       Y     Z      Mass   Volume  CdA    Ca
(#)   (-)         (m)     (m)   (m)    (kg)   (m^3)   (m^2)  (-)
1     Fixed       0       0     -{depth}    0      0       0      0
2     Coupled     {span}      0     0      0      0       0      0
---------------------- LINES --------------------------------------
ID   LineType   AttachA  AttachB  UnstrLen  NumSegs  Outputs
(#)  (name)     (#)      (#)      (m)       (-)      (-)
1    wire       1        2        {length}      {segs}       -
---------------------- OPTIONS -----------------------------------------
{dt}     dtM
{kbot}    kbot
{cbot}    cbot
{depth}     WtrDpth
{rho}     WtrDnsty
9.81     g
5.0      dtIC
60.0     TmaxIC
4.0      CdScaleIC
0.001    threshIC
------------------------- need this line --------------------------------------
"""


def surge(t):
    """The fairlead's surge (m), ramped in smoothly over the first period."""
    ramp = np.clip(t / PERIOD, 0.0, 1.0)
    return AMPLITUDE * np.sin(OMEGA * t) * ramp * ramp * (3 - 2 * ramp)


def harmonic(t, y) -> dict:
    """Mean, first-harmonic amplitude and phase (rad) of y(t) over the last two periods."""
    keep = t > T_END - 2 * PERIOD
    fit = np.column_stack([np.ones(keep.sum()), np.cos(OMEGA * t[keep]), np.sin(OMEGA * t[keep])])
    c = np.linalg.lstsq(fit, y[keep], rcond=None)[0]
    return {"mean": float(c[0]), "amplitude": float(math.hypot(c[1], c[2])), "phase": float(math.atan2(c[2], c[1]))}


def run_cosnet(n: int, fast_modes: str = "auto", timed: bool = True, internal: float = 0.0) -> dict:
    from moorpy.Catenary import catenary
    w = (RHO_S - SEA) * 9.81 * AREA
    guess = catenary(SPAN, DEPTH, 47.0, E * AREA, w, CB=0.0, nNodes=n + 1, plots=1)[4]
    net = cosnet.Net()
    net.add_node((0.0, 0.0, -DEPTH), fixed=True)
    fair = net.add_node((SPAN, 0.0, 0.0), mass=1.0, inertia=(0.1, 0.1, 0.1))
    points = np.column_stack([guess["X"], np.zeros(n + 1), guess["Z"] - DEPTH])
    net.add_line(net.nodes[0], fair, material=cosnet.Material(E=E, G=E / 2.6, density=RHO_S),
                 section=cosnet.Circle(R), elements=n, points=points, rest_curvature=(0.0, 0.0, 0.0))

    def seabed():   # MoorDyn's soil: its kbot and cbot per contact area, the plane r below its seabed
        return cosnet.Obstacle("plane", point=(0.0, 0.0, -DEPTH - R), normal=(0.0, 0.0, 1.0), k_soil=KBOT,
                               gamma_soil=CBOT)
    still = cosnet.Simulation(net, [cosnet.Gravity(), cosnet.Fluid(SEA, buoyancy=True, surface=0.0), seabed(),
                                    cosnet.Drive(fair, position={"rate": [0.0, 0.0, 0.0]}), cosnet.Damping(DAMPING)],
                              fast_modes=fast_modes)
    still.run(until=SETTLE - 1.0)
    before = still.reaction(fair)[0].copy()
    still.run(until=SETTLE)
    settled = float(np.abs(still.reaction(fair)[0] - before).max() / np.abs(before).max())
    ts = np.arange(0.0, T_END + 1e-9, 0.05)
    path = {"times": ts.tolist(), "values": [[float(surge(t)), 0.0, 0.0] for t in ts]}

    def surging():
        damped = [cosnet.InternalDamping(ratio=internal)] if internal else []
        sim = cosnet.Simulation(net, [cosnet.Gravity(), cosnet.Fluid(SEA, drag=DRAG, added_mass=ADDED, buoyancy=True,
                                                                     surface=0.0),
                                      seabed(), cosnet.Drive(fair, position=path), *damped], fast_modes=fast_modes)
        for mine, still_state in zip(sim.state, still.state):
            mine[...] = still_state
        sim.state.clock[0] = 0.0
        return sim
    sim = surging()
    out = []
    while sim.time < T_END - 1e-9:
        sim.run(until=min(T_END, sim.time + SAMPLE))
        out.append([sim.time, *sim.reaction(fair)[0]])   # what holds the fairlead: the line's pull on it, reversed
    o = np.array(out)
    wall = math.nan
    if timed:
        again = surging()
        t0 = time.perf_counter()
        again.run(until=T_END)
        wall = (time.perf_counter() - t0) / again.time
    return {"code": "cosnet" + (f", internal damping {internal:g}" if internal else ""), "fast_modes": fast_modes,
            "elements": n, "dt": sim.dt, "sampled_every": SAMPLE,
            "settled_to": settled, "wall_per_simulated_s": wall,
            "H": harmonic(o[:, 0], o[:, 1]), "V": harmonic(o[:, 0], o[:, 3])}


def run_moordyn(n: int, dt: float, coupling: float) -> dict:
    import moordyn
    text = MOORDYN_INPUT.format(d=2 * R, mass=RHO_S * AREA, ea=E * AREA, ei=E * math.pi * R ** 4 / 4,
                                cd=DRAG[0], ca=ADDED[0], cdax=DRAG[1], caax=ADDED[1], depth=DEPTH, span=SPAN,
                                length=47.0, segs=n, dt=dt, rho=SEA, kbot=KBOT, cbot=CBOT)
    folder = Path(tempfile.mkdtemp())
    (folder / "line.txt").write_text(text)
    saved = os.dup(1)
    os.dup2(os.open(os.devnull, os.O_WRONLY), 1)   # MoorDyn prints every step
    try:
        system = moordyn.Create(str(folder / "line.txt"))
        moordyn.Init(system, np.array([SPAN, 0.0, 0.0]), np.zeros(3))
        out, t, h = [], 0.0, coupling
        t0 = time.perf_counter()
        while t < T_END - 1e-9:
            x = np.array([SPAN + surge(t + h), 0.0, 0.0])
            v = np.array([(surge(t + h + 1e-6) - surge(t + h - 1e-6)) / 2e-6, 0.0, 0.0])
            f = moordyn.Step(system, x, v, t, h)
            t += h
            out.append([t, *(-np.asarray(f))])
        wall = time.perf_counter() - t0
        moordyn.Close(system)
    finally:
        os.dup2(saved, 1)
    o = np.array(out)
    return {"code": "MoorDyn", "elements": n, "dt": dt, "coupling_step": coupling, "wall_per_simulated_s": wall / t,
            "H": harmonic(o[:, 0], o[:, 1]), "V": harmonic(o[:, 0], o[:, 3])}


def main():
    runs = []
    for n in (24, 48):
        runs.append(run_cosnet(n))
        runs.append(run_cosnet(n, internal=INTERNAL))
        runs.append(run_cosnet(n, "resolve"))
        runs += [run_moordyn(n, 1e-4 * 24 / n, c) for c in COUPLINGS]
    ref = runs[-1]                     # MoorDyn, 48 segments, the finest coupling
    for r in runs:
        r["against_reference"] = {k: {"amplitude": r[k]["amplitude"] / ref[k]["amplitude"] - 1,
                                      "phase_over_period": (r[k]["phase"] - ref[k]["phase"]) / (2 * math.pi)}
                                  for k in ("H", "V")}
    rows = [[r["code"], r.get("fast_modes", "-"), r["elements"], r["dt"], r.get("coupling_step", "-"),
             r["wall_per_simulated_s"], r["H"]["mean"], r["H"]["amplitude"], r["H"]["phase"], r["V"]["mean"],
             r["V"]["amplitude"], r["V"]["phase"]] for r in runs]
    table("fairlead pull under a 1 m, 8 s surge", ["code", "fast modes", "elements", "dt (s)", "coupling (s)",
                                                   "wall s per simulated s", "H mean (N)", "H amplitude (N)",
                                                   "H phase", "V mean (N)", "V amplitude (N)", "V phase"], rows)
    write_json(__file__, {"command": " ".join(["python", "bench/moordyn_compare.py", *sys.argv[1:]]),
                          "reference": f"MoorDyn, 48 segments, coupling step {COUPLINGS[-1]:g} s", "runs": runs})


if __name__ == "__main__":
    main()
