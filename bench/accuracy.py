"""Work-precision: error against wall time on cases with known answers, sweeping element
count, time step and stepper ("verlet", order 2; "pefrl", order 4).

Cases (reference in brackets):
  freq      first bending frequency of a clamped-free steel rod (L/r = 50)
            [cosnet.studies.lincos.analytic_modes: the exact Timoshenko frequency of the same rod];
            started in the exact mode shape, frequency from a least-squares sinusoid fit
            to the tip's transverse motion over three periods
  static    tip deflection of an end-loaded cantilever in the linear regime, damped to rest
            [P L^3 / 3EI + P L / kGA]
  elastica  tip deflections of a cantilever under a large dead end load, P L^2 / EI = 3,
            damped to rest [the extensible, shearable elastica (Bisshopp-Drucker with the
            rod's stretch and shear), solved with scipy.integrate.solve_bvp]
  pendulum  period of a heavy rigid body on a stiff light line swinging from 1 rad
            [the compound pendulum, T = 4 sqrt(I_p / (m g l)) K(sin^2(theta0 / 2))]
  transient tip position of a suddenly loaded undamped cantilever after 1.5 periods
            [the same mesh with PEFRL at a 16 times smaller step: pure time error]
  energy    energy error of a free net (three lines and a rigid body, smooth start) over
            30 periods of its slowest mode (10 with --quick) [conservation: E(t) = E(0)]

With --fast-modes, instead: the work-precision panel of the ``fast_modes`` settings (resolve,
rotary, soften, auto; docs/fast_modes.md), Verlet at each setting's stable step:
  bending   lowest five bending frequencies of a clamped-free steel rod, L = 1 m, r = 1 mm,
            25/50/100 elements (l/r = 40/20/10) [Euler-Bernoulli; the discrete modes of the
            treated mass and stiffness with Verlet's frequency error at that step]; wall time
            per simulated second timed over a fixed number of steps
  elastica  the large-deflection cantilever above (P L^2 / EI = 3) made slender: r = 5 mm,
            10/20 elements (l/r = 20/10), damped to rest [the same elastica reference]
  cable     the swinging 10 m cable of bench/fast_modes.py: midpoint path over three swing
            periods against "resolve" at the same mesh, and wall-time ratios, read from
            bench/fast_modes.json (its reference run takes half an hour)
Writes bench/accuracy_fast_modes.json and bench/figures/accuracy_fast_modes.png.

With --joints, instead: junctions that turn and lines that slide (the paper's section 8)
against their rigid-body limits:
  hinge     a double compound pendulum of two 1 m steel arms released from the horizontal,
            its middle junction an exact hinge or a penalty HingeJoint of spring k (after the
            Elastica page), each at its own stable step: the largest distance of the free end
            from the rigid arms' over 0.5 s, relative to the arms' length [Lagrange's equations
            of the two arms as rigid bodies with the discrete arms' masses and inertias,
            scipy.integrate.solve_ivp, rtol 1e-12] (bench/joints.py builds both)
  atwood    an Atwood machine, 0.3 and 0.2 kg on a rope over a sheave of 5 cm, 5, 10 and 20
            elements per radius, over 0.3 s: the heavier mass's drop [the rigid rope's motion,
            x(t) = (alpha / beta)(cosh(sqrt(beta) t) - 1)] and the energy the rope's landings
            on the rim took against the kinetic energy (bench/sheaves.py builds it)
Writes bench/accuracy_joints.json.

Observed orders are least-squares slopes of log(error) against log(elements) (space) or
log(dt) (time). Prints a table, writes bench/accuracy.json and bench/figures/accuracy.png
(one work-precision panel per case) and bench/figures/accuracy_orders.png.

    python bench/accuracy.py [--quick] [--fast-modes | --joints]
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_bvp
from scipy.optimize import minimize_scalar
from scipy.special import ellipk

import cosnet
from cosnet.core.fast_modes import FAST_MODES
from cosnet.core.rotations import matrix_from_quat
from cosnet.core.samples import free_net, smooth_motion
from cosnet.studies.lincos import analytic_modes
from harness import table, write_json

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")
STEPPERS = ("verlet", "pefrl")
FIGURES = Path(__file__).resolve().parent / "figures"
BETA1 = 1.8751040687


def cantilever(n, length=1.0, radius=0.02, tip_mass=0.0):
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True, name="root")
    tip = net.add_node((length, 0.0, 0.0), mass=tip_mass, name="tip")
    line = net.add_line(root, tip, material=STEEL, section=cosnet.Circle(radius), elements=n,
                        name="rod")
    return net, line, tip


def timed(sim, **kw) -> float:
    t0 = time.perf_counter()
    sim.run(**kw)
    return time.perf_counter() - t0


def warm(make):
    """Compile (or load from the cache) a configuration before timing it."""
    make().run(steps=2)


def slope(x, y) -> float:
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(y)
    if ok.sum() < 2:
        return math.nan
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def point(case, stepper, elements, dt, error, wall, simulated, **extra):
    return {"case": case, "stepper": stepper, "elements": elements, "dt": dt, "error": error,
            "wall": wall, "wall_per_sim_s": wall / simulated, **extra}


# ---------------------------------------------------------------------- frequency
def fit_omega(t, y, guess) -> float:
    """Angular frequency of the sinusoid a cos + b sin + c best fitting y(t)."""
    def resid(w):
        B = np.column_stack([np.cos(w * t), np.sin(w * t), np.ones_like(t)])
        c, *_ = np.linalg.lstsq(B, y, rcond=None)
        r = y - B @ c
        return float(r @ r)
    grid = guess * np.linspace(0.95, 1.05, 201)
    k = int(np.argmin([resid(w) for w in grid]))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    return float(minimize_scalar(resid, bounds=(lo, hi), method="bounded",
                                 options={"xatol": 1e-12 * guess}).x)


def freq_case(ns, dt_divs):
    out = []
    exact = None
    for n in ns:
        net, line, tip = cantilever(n)
        modes = analytic_modes(net, count=2).shapes
        if exact is None:
            exact = float(modes[0].omega)
        # the pair of (degenerate) first bending modes, combined to move the tip along z
        u0, _ = modes[0].line_shape(line, 1.0)
        u1, _ = modes[1].line_shape(line, 1.0)
        c = np.array([u1[0, 1], -u0[0, 1]])
        c /= np.linalg.norm(c)
        s_v = np.linspace(0.0, 1.0, n + 1)
        s_e = 0.5 * (s_v[1:] + s_v[:-1])
        uv = c[0] * modes[0].line_shape(line, s_v)[0] + c[1] * modes[1].line_shape(line, s_v)[0]
        th = c[0] * modes[0].line_shape(line, s_e)[1] + c[1] * modes[1].line_shape(line, s_e)[1]
        scale = 1e-4 * exact / np.abs(uv[:, 2]).max()      # tip speed 1e-4 * omega m/s
        for stepper in STEPPERS:
            for div in dt_divs:
                def make():
                    sim = cosnet.Simulation(net, stepper=stepper)
                    sim = cosnet.Simulation(net, stepper=stepper, dt=sim.dt / div)
                    sim.line_velocities(line)[:] = scale * uv
                    D = matrix_from_quat(sim.state.q)
                    sim.line_angular_velocities(line)[:] = np.einsum("eji,ej->ei", D, scale * th)
                    return sim
                warm(make)
                sim = make()
                period = 2 * math.pi / exact
                sub = max(1, int(period / 60 / sim.dt))
                t, y, wall = [0.0], [sim.node_position(tip)[2]], 0.0
                while sim.time < 3.0 * period:
                    wall += timed(sim, steps=sub)
                    t.append(sim.time)
                    y.append(sim.node_position(tip)[2])
                w = fit_omega(np.array(t), np.array(y), exact)
                out.append(point("freq", stepper, n, sim.dt, abs(w / exact - 1), wall, sim.time,
                                 omega=w, exact=exact))
    return out


# ---------------------------------------------------------------------- statics
def settle(sim, omega1, periods=24.0) -> float:
    return timed(sim, until=periods / omega1)


def loaded_cantilevers(ns, L, r, P, omega1, periods=24.0, steppers=STEPPERS, fast_modes="resolve"):
    """(n, stepper, sim, tip, wall) for each element count and stepper: the cantilever under a
    dead tip load P along -z, damped to rest over ``periods`` / omega1."""
    for n in ns:
        net, line, tip = cantilever(n, L, r)
        for stepper in steppers:
            make = lambda: cosnet.Simulation(net, stepper=stepper, fast_modes=fast_modes, effects=[
                cosnet.NodeLoad(tip, force=(0, 0, -P)), cosnet.Damping(2.0 * omega1)])
            warm(make)
            sim = make()
            wall = settle(sim, omega1, periods)
            yield n, stepper, sim, tip, wall


def static_case(ns):
    L, r = 1.0, 0.02
    sec = cosnet.Circle(r)
    EI = STEEL.E * sec.I11
    P = 1e-4 * 3 * EI / L**3
    exact = P * L**3 / (3 * EI) + P * L / (sec.shear_coefficient * STEEL.G * sec.A)
    omega1 = BETA1**2 * math.sqrt(EI / (STEEL.density * sec.A)) / L**2
    out = []
    for n, stepper, sim, tip, wall in loaded_cantilevers(ns, L, r, P, omega1):
        w = -sim.node_position(tip)[2]
        out.append(point("static", stepper, n, sim.dt, abs(w / exact - 1), wall, sim.time,
                         deflection=w, exact=exact))
    return out


def elastica_reference(alpha, EI, EA, kGA, L=1.0):
    """Tip (horizontal shortening, vertical deflection) / L of a cantilever clamped along x
    under a dead tip load P = alpha EI / L^2 along -z: theta' = m / EI, m' = P x',
    x' = (1 + n_t / EA) cos - (n_d / kGA) sin, z' = (1 + n_t / EA) sin + (n_d / kGA) cos,
    with the constant internal force n = (0, -P): n_t = -P sin(theta), n_d = -P cos(theta)."""
    ea, es = EI / (EA * L**2), EI / (kGA * L**2)     # in units of L and EI / L

    def f(s, y):
        th, m, x, z = y
        nt, nd = -alpha * np.sin(th), -alpha * np.cos(th)
        xp = (1 + ea * nt) * np.cos(th) - es * nd * np.sin(th)
        zp = (1 + ea * nt) * np.sin(th) + es * nd * np.cos(th)
        return np.vstack([m, alpha * xp, xp, zp])

    def bc(ya, yb):
        return np.array([ya[0], yb[1], ya[2], ya[3]])

    s = np.linspace(0, 1, 201)
    guess = np.vstack([-0.5 * alpha * s * (2 - s), -alpha * (1 - s), s, -0.3 * alpha * s**2])
    sol = solve_bvp(f, bc, s, guess, tol=1e-10, max_nodes=100000)
    if not sol.success:
        raise RuntimeError(f"elastica reference: {sol.message}")
    x, z = sol.sol(1.0)[2], sol.sol(1.0)[3]
    return 1.0 - x, -z


def elastica_case(ns, alpha=3.0, r=0.02, fast_modes=None):
    """Points of the large-deflection cantilever for both steppers, or with fast_modes given,
    Verlet with that setting (the point's stepper names it)."""
    L = 1.0
    sec = cosnet.Circle(r)
    EI, EA, kGA = STEEL.E * sec.I11, STEEL.E * sec.A, sec.shear_coefficient * STEEL.G * sec.A
    # the inextensible, unshearable limit reproduces Bisshopp & Drucker's table
    bd = elastica_reference(1.0, EI, 1e9 * EA, 1e9 * kGA)
    ref = elastica_reference(alpha, EI, EA, kGA, L)
    P = alpha * EI / L**2
    omega1 = BETA1**2 * math.sqrt(EI / (STEEL.density * sec.A)) / L**2
    out = []
    steppers = STEPPERS if fast_modes is None else ("verlet",)
    for n, stepper, sim, tip, wall in loaded_cantilevers(ns, L, r, P, omega1, 40.0, steppers,
                                                         fast_modes or "resolve"):
        p = sim.node_position(tip)
        dh, dv = (L - p[0]) / L, -p[2] / L
        err = math.hypot(dh - ref[0], dv - ref[1]) / math.hypot(*ref)
        out.append(point("elastica", fast_modes or stepper, n, sim.dt, err, wall, sim.time,
                         tip=[dh, dv], exact=list(ref)))
    return out, {"alpha": alpha, "reference_tip": list(ref), "bisshopp_drucker_alpha1": list(bd)}


# ---------------------------------------------------------------------- pendulum
def pendulum_case(ns, dt_divs, theta0=1.0):
    L, g, M, Ib, r = 1.0, 9.81, 1.0, 0.01, 0.1
    m_line = 0.05
    A = math.pi * r * r
    # EA = 1e6 N: the static stretch M g / EA ~ 1e-5 lengthens the period by ~5e-6
    mat = cosnet.Material(E=1e6 / A, poisson=0.3, density=m_line / (A * L))
    Ip = M * L**2 + Ib + m_line * L**2 / 3
    mgl = (M * L + m_line * L / 2) * g
    exact = 4 * math.sqrt(Ip / mgl) * ellipk(math.sin(theta0 / 2) ** 2)
    out = []
    for n in ns:
        net = cosnet.Net()
        pivot = net.add_node((0, 0, 0), mass=math.inf, name="pivot")
        bob = net.add_node((L * math.sin(theta0), 0, -L * math.cos(theta0)), mass=M,
                           inertia=(Ib, Ib, Ib), name="bob")
        net.add_line(pivot, bob, material=mat, section=cosnet.Circle(r), elements=n)
        for stepper in STEPPERS:
            for div in dt_divs:
                def make():
                    sim = cosnet.Simulation(net, stepper=stepper, effects=[cosnet.Gravity((0, 0, -g))])
                    return cosnet.Simulation(net, stepper=stepper, dt=sim.dt / div,
                                             effects=[cosnet.Gravity((0, 0, -g))])
                warm(make)
                sim = make()
                sub = max(1, int(exact / 200 / sim.dt))
                t, x, wall = [0.0], [sim.node_position(bob)[0]], 0.0
                while sim.time < 1.3 * exact:       # three zero crossings
                    wall += timed(sim, steps=sub)
                    t.append(sim.time)
                    x.append(sim.node_position(bob)[0])
                t, x = np.array(t), np.array(x)
                k = np.flatnonzero(np.sign(x[1:]) != np.sign(x[:-1]))
                # zero crossings by cubic interpolation through four samples
                cross = []
                for j in k:
                    lo = max(j - 1, 0)
                    tt, xx = t[lo:lo + 4], x[lo:lo + 4]
                    roots = np.roots(np.polyfit(tt - t[j], xx, len(tt) - 1)).real + t[j]
                    cross.append(roots[np.argmin(np.abs(roots - t[j]))])
                T = 2 * (cross[-1] - cross[0]) / (len(cross) - 1)
                out.append(point("pendulum", stepper, n, sim.dt, abs(T / exact - 1), wall, sim.time,
                                 period=T, exact=exact))
    return out


# ---------------------------------------------------------------------- time error
def transient_case(dt_divs, n=8):
    L, r = 1.0, 0.02
    net, line, tip = cantilever(n, L, r)
    sec = cosnet.Circle(r)
    EI = STEEL.E * sec.I11
    P = 1e-2 * 3 * EI / L**3          # static tip deflection L / 100: errors well above round-off
    omega1 = BETA1**2 * math.sqrt(EI / (STEEL.density * sec.A)) / L**2
    T = 1.5 * 2 * math.pi / omega1
    eff = [cosnet.NodeLoad(tip, force=(0, 0, -P))]
    base = {s: cosnet.Simulation(net, stepper=s, effects=eff).dt for s in STEPPERS}
    h0 = min(base.values())
    steps0 = int(math.ceil(T / h0))
    ref_sim = cosnet.Simulation(net, stepper="pefrl", effects=eff, dt=T / (16 * steps0))
    ref_sim.run(steps=16 * steps0)
    ref = ref_sim.node_position(tip).copy()
    out = []
    for stepper in STEPPERS:
        warm(lambda: cosnet.Simulation(net, stepper=stepper, effects=eff))
        for div in dt_divs:
            sim = cosnet.Simulation(net, stepper=stepper, effects=eff, dt=T / (steps0 * div),
                                    force_dt=True)
            wall = timed(sim, steps=steps0 * div)
            err = float(np.linalg.norm(sim.node_position(tip) - ref)) / (P * L**3 / (3 * EI))
            out.append(point("transient", stepper, n, sim.dt, err, wall, sim.time))
    return out


def energy_case(dt_divs, periods=100.0):
    net = free_net()
    omega_slow = float(analytic_modes(net, count=1, shapes=False).omega[0])
    T = periods * 2 * math.pi / omega_slow
    out = []
    for stepper in STEPPERS:
        h0 = cosnet.Simulation(net, stepper=stepper).dt
        warm(lambda: cosnet.Simulation(net, stepper=stepper))
        for div in dt_divs:
            sim = cosnet.Simulation(net, stepper=stepper, dt=h0 / div)
            smooth_motion(sim, amplitude=0.05, spin=0.5)
            e0 = sim.energy()
            samples = 400
            sub = max(1, int(T / samples / sim.dt))
            errs, wall = [], 0.0
            while sim.time < T:
                wall += timed(sim, steps=sub)
                errs.append(sim.energy() - e0)
            errs = np.array(errs)
            tt = np.arange(1, len(errs) + 1) * sub * sim.dt
            drift = float(np.polyfit(tt, errs, 1)[0]) * T / e0
            out.append(point("energy", stepper, net.element_count, sim.dt,
                             float(np.abs(errs).max() / e0), wall, sim.time, drift=drift))
    return out


# ---------------------------------------------------------------------- fast modes
def bending_panel(ns, steps):
    from fast_modes import CLAMPED_FREE, bending_errors, eb, straight
    exact = eb(CLAMPED_FREE, 1.0, 1e-3)
    out = []
    for n in ns:
        for fm in FAST_MODES:
            sim = cosnet.Simulation(straight(1.0, 1e-3, n, clamped=True), fast_modes=fm)
            err, each = bending_errors(straight(1.0, 1e-3, n, clamped=True), fm, exact, sim.dt)
            sim.run(steps=10)
            wall = timed(sim, steps=steps)
            out.append(point("bending", fm, n, sim.dt, err, wall, steps * sim.dt, errors=each))
    return out


def cable_panel():
    """The cable's points from bench/fast_modes.json: wall time per simulated second timed in
    alternation with "resolve", path error against "resolve"."""
    path = Path(__file__).resolve().with_name("fast_modes.json")
    cab = json.loads(path.read_text())["cable"]
    out = []
    for fm in FAST_MODES:
        c = cab[fm]
        out.append(point("cable", fm, 100, c["dt"], c["path_error_over_amplitude"],
                         c["wall_per_sim_s"], 1.0, wall_ratio=c["wall_ratio"], source=path.name))
    return out


def fast_modes_plot(points):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    FIGURES.mkdir(exist_ok=True)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.5))
    titles = {"bending": "5 bending frequencies, rod L/r = 1000 (rel.)",
              "elastica": "large-deflection cantilever, r = 5 mm (rel.)",
              "cable": "cable midpoint path / amplitude, 3 periods"}
    for ax, case in zip(axes, titles):
        for fm, colour in zip(FAST_MODES, ("tab:blue", "tab:green", "tab:red", "tab:purple")):
            ps = sorted((p for p in points if p["case"] == case and p["stepper"] == fm),
                        key=lambda p: p["elements"])
            if case == "cable" and fm == "resolve":      # the reference: error 0 by definition
                ax.axvline(ps[0]["wall_per_sim_s"], color=colour, ls="--", label="resolve (reference)")
                continue
            ax.loglog([p["wall_per_sim_s"] for p in ps], [p["error"] for p in ps],
                      "o-", color=colour, label=fm, alpha=0.8)
        ax.set_title(titles[case], fontsize=9)
        ax.set_xlabel("wall time per simulated second [s] (under load)")
        ax.set_ylabel("error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(FIGURES / "accuracy_fast_modes.png", dpi=110)
    plt.close(fig)


def fast_modes_main(quick):
    points = bending_panel((25, 50) if quick else (25, 50, 100), 2000 if quick else 20000)
    for fm in FAST_MODES:
        points += elastica_case((10,) if quick else (10, 20), r=5e-3, fast_modes=fm)[0]
    points += cable_panel()
    table("fast_modes work-precision (Verlet at each setting's stable step; bending: worst of 5 "
          "frequencies; elastica: tip; cable: path / amplitude; measured under load)",
          ["case", "fast_modes", "elements", "dt [s]", "error", "wall s / sim s"],
          [[p["case"], p["stepper"], p["elements"], f"{p['dt']:.3g}", f"{p['error']:.3g}",
            f"{p['wall_per_sim_s']:.3g}"] for p in points])
    fast_modes_plot(points)
    write_json(str(Path(__file__).with_name("accuracy_fast_modes.py")),
               {"quick": quick, "under_load": True, "points": points})


def joints_main(quick):
    import joints
    import sheaves
    until, samples = (0.1, 10) if quick else (0.5, 50)
    hinge = joints.accuracy(until, samples, (1e6, 1e8) if quick else (1e5, 1e6, 1e7, 1e8))
    table(f"a double compound pendulum against its rigid limit over {until} s",
          ["middle junction", "dt (s)", "steps", "largest end distance / length", "wall (s)"],
          [[r["middle"], r["dt"], r["steps"], r["error_over_length"], r["wall_s"]] for r in hinge])
    atwood_until = 0.1 if quick else 0.3
    atwood = [sheaves.accuracy(n, atwood_until) for n in ((5, 10) if quick else (5, 10, 20))]
    table(f"the Atwood machine against the rigid rope over {atwood_until} s",
          ["elements per radius", "elements", "dt (s)", "steps", "drop error", "landings / kinetic", "wall (s)"],
          [[r["per_radius"], r["elements"], r["dt"], r["steps"], r["drop_error"], r["landings_over_kinetic"],
            r["wall_s"]] for r in atwood])
    write_json(str(Path(__file__).with_name("accuracy_joints.py")),
               {"command": " ".join(["python", "bench/accuracy.py", *sys.argv[1:]]), "quick": quick,
                "until": until, "hinge": hinge, "atwood_until": atwood_until, "atwood": atwood})


# ---------------------------------------------------------------------- report
def orders(points):
    """Observed orders per case and stepper: in space (slope against elements, at the base dt)
    and in time (slope against dt, at a fixed element count)."""
    res = {}
    for case in sorted({p["case"] for p in points}):
        for st in STEPPERS:
            ps = [p for p in points if p["case"] == case and p["stepper"] == st]
            if not ps:
                continue
            base_dt = {}
            for p in ps:
                base_dt.setdefault(p["elements"], max(q["dt"] for q in ps if q["elements"] == p["elements"]))
            sp = [p for p in ps if p["dt"] == base_dt[p["elements"]]]
            space = -slope([p["elements"] for p in sp], [p["error"] for p in sp]) \
                if len({p["elements"] for p in sp}) > 1 else math.nan
            n_fix = max({p["elements"] for p in ps}, key=lambda n: sum(q["elements"] == n for q in ps))
            tp = [p for p in ps if p["elements"] == n_fix]
            tim = slope([p["dt"] for p in tp], [p["error"] for p in tp]) if len(tp) > 1 else math.nan
            res[f"{case}/{st}"] = {"space": space, "time": tim}
    return res


def fmt_order(x) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.2f}"


def plot(points, ords):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    FIGURES.mkdir(exist_ok=True)
    cases = ["freq", "static", "elastica", "pendulum", "transient", "energy"]
    titles = {"freq": "1st bending frequency (rel. error)", "static": "Timoshenko cantilever (rel.)",
              "elastica": "large-deflection cantilever (rel.)", "pendulum": "pendulum period (rel.)",
              "transient": "transient tip position (time error)", "energy": "free net |E - E0| / E0"}
    fig, axes = plt.subplots(2, 3, figsize=(14, 8.5))
    for ax, case in zip(axes.flat, cases):
        for st, colour in zip(STEPPERS, ("tab:blue", "tab:red")):
            ps = [p for p in points if p["case"] == case and p["stepper"] == st]
            if not ps:
                continue
            groups = {}
            key = "elements" if case not in ("transient", "energy") else "stepper"
            for p in ps:
                groups.setdefault(p[key], []).append(p)
            for i, (k, g) in enumerate(sorted(groups.items())):
                g = sorted(g, key=lambda p: p["wall_per_sim_s"])
                ax.loglog([p["wall_per_sim_s"] for p in g], [max(p["error"], 1e-16) for p in g],
                          "o-" if len(g) > 1 else "o", color=colour, alpha=0.35 + 0.65 * (i + 1) / len(groups),
                          label=f"{st}" + (f", n={k}" if key == "elements" else ""))
            if key == "elements" and len(groups) > 1:
                # the element sweep at the base dt
                best = sorted((max(g, key=lambda p: p["dt"]) for g in groups.values()),
                              key=lambda p: p["elements"])
                ax.loglog([p["wall_per_sim_s"] for p in best], [max(p["error"], 1e-16) for p in best],
                          "-", color=colour, lw=2)
        o = {st: ords.get(f"{case}/{st}", {}) for st in STEPPERS}
        txt = "  ".join(f"{st}: p_x={fmt_order(o[st].get('space'))} p_t={fmt_order(o[st].get('time'))}"
                        for st in STEPPERS)
        ax.set_title(f"{titles[case]}\n{txt}", fontsize=9)
        ax.set_xlabel("wall time per simulated second [s]")
        ax.set_ylabel("error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
    fig.suptitle("cosnet work-precision (lines: element sweep at the stable dt; "
                 "points of one n: dt, dt/2, dt/4)", fontsize=11)
    fig.tight_layout()
    fig.savefig(FIGURES / "accuracy.png", dpi=110)
    plt.close(fig)
    # error against elements and against dt
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    for case, mk in zip(["freq", "static", "elastica", "pendulum"], "osd^"):
        for st, colour in zip(STEPPERS, ("tab:blue", "tab:red")):
            ps = [p for p in points if p["case"] == case and p["stepper"] == st]
            byn = {}
            for p in ps:
                if p["dt"] >= max(q["dt"] for q in ps if q["elements"] == p["elements"]):
                    byn[p["elements"]] = p["error"]
            if len(byn) > 1:
                ns = sorted(byn)
                a1.loglog(ns, [byn[n] for n in ns], mk + "-", color=colour, label=f"{case} {st}")
    a1.set_xlabel("elements")
    a1.set_ylabel("relative error")
    a1.set_title("space convergence (stable dt)")
    a1.grid(True, which="both", alpha=0.3)
    a1.legend(fontsize=7)
    for case, mk in zip(["transient", "energy"], "os"):
        for st, colour in zip(STEPPERS, ("tab:blue", "tab:red")):
            ps = sorted((p for p in points if p["case"] == case and p["stepper"] == st),
                        key=lambda p: p["dt"])
            if ps:
                a2.loglog([p["dt"] for p in ps], [max(p["error"], 1e-16) for p in ps], mk + "-",
                          color=colour, label=f"{case} {st}")
    a2.set_xlabel("dt [s]")
    a2.set_ylabel("error")
    a2.set_title("time convergence")
    a2.grid(True, which="both", alpha=0.3)
    a2.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(FIGURES / "accuracy_orders.png", dpi=110)
    plt.close(fig)


def main():
    quick = "--quick" in sys.argv
    if "--fast-modes" in sys.argv:
        return fast_modes_main(quick)
    if "--joints" in sys.argv:
        return joints_main(quick)
    ns_freq = (4, 8, 16) if quick else (4, 8, 16, 32)
    ns_pend = (1, 2) if quick else (1, 2, 4)
    ns_static = (4, 8, 16) if quick else (4, 8, 16, 32)
    divs = (1, 2) if quick else (1, 2, 4)
    t0 = time.perf_counter()
    points = []
    print("frequency ...", file=sys.stderr, flush=True)
    points += freq_case(ns_freq, divs)
    print("static ...", file=sys.stderr, flush=True)
    points += static_case(ns_static)
    print("elastica ...", file=sys.stderr, flush=True)
    pts, elastica_ref = elastica_case(ns_static)
    points += pts
    print("pendulum ...", file=sys.stderr, flush=True)
    points += pendulum_case(ns_pend, divs)
    print("transient ...", file=sys.stderr, flush=True)
    points += transient_case((1, 2, 4) if quick else (1, 2, 4, 8))
    print("energy ...", file=sys.stderr, flush=True)
    points += energy_case((1, 2, 4), periods=10.0 if quick else 30.0)
    ords = orders(points)
    rows = [[p["case"], p["stepper"], p["elements"], f"{p['dt']:.3g}", f"{p['error']:.3g}",
             f"{p['wall_per_sim_s']:.3g}"] for p in points]
    table("work-precision (error is relative; energy: max |E - E0| / E0)",
          ["case", "stepper", "elements", "dt [s]", "error", "wall s / sim s"], rows)
    table("observed orders (slopes of log error; space: against elements at the stable dt, "
          "time: against dt)", ["case/stepper", "space", "time"],
          [[k, fmt_order(v["space"]), fmt_order(v["time"])] for k, v in ords.items()])
    print(f"\nelastica reference (P L^2/EI = {elastica_ref['alpha']:g}): tip shortening "
          f"{elastica_ref['reference_tip'][0]:.6f} L, deflection {elastica_ref['reference_tip'][1]:.6f} L; "
          f"inextensible check at P L^2/EI = 1: {elastica_ref['bisshopp_drucker_alpha1'][1]:.5f} L "
          f"(Bisshopp-Drucker 0.30172)")
    plot(points, ords)
    print(f"figures in {FIGURES}; total {time.perf_counter() - t0:.1f} s")
    write_json(__file__, {"quick": quick, "points": points, "orders": ords, "elastica": elastica_ref})


if __name__ == "__main__":
    main()
