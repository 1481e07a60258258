"""cosnet side by side with PyElastica (same physics, same element count, same dt, position
Verlet, one process, one thread each): cost per step and the ratio, plus a trajectory check.
Times are the CPU time of the stepping thread per step, best of N alternating runs (on a shared machine the
wall time also counts the time the process waits for a core); wall-clock ratios are kept too.

Cases
  rod n      a straight steel rod (1 m, r = 1 cm) clamped at one end under gravity, n elements
             (PyElastica: CosseratRod.straight_rod + OneEndFixedBC + GravityForces).
  chain m    m rods of 0.1 m x 10 elements (r = 2 mm) in a line, clamped at the first end,
             under gravity. cosnet joins consecutive lines at exact point junctions (one
             shared node); PyElastica joins consecutive rods with FixedJoint penalty springs
             (k = E A / l_element, kt = E I / l_element, undamped), so both carry the same
             stiffest frequency to within a factor of order one.
The step is the smaller of the two stable steps: cosnet's estimate (Gershgorin bound x 0.9
safety) is used for both after checking that PyElastica stays finite and bounded with it.

Trajectory: the 100-element rod released from straight, positions over 0.05 s compared at
common times; the difference is quoted relative to the largest tip deflection, next to each
code's own discretisation change (n vs 2 n elements).

Cable: the steel cable of bench/fast_modes.py (L = 10 m, r = 1 mm, 100 elements, pinned at both
ends 9 m apart, released in a plane turned 40 degrees sideways, straight at rest), built in
PyElastica from cosnet's own vertices and directors (rest curvature set to zero, ends pinned
by GeneralConstraint on positions only, gravity). PyElastica's stable step is the largest of a
sequence of steps (cosnet's "resolve" step times 2^(k/2)) that stays finite and bounded over a
fixed number of steps; its cost per simulated second is timed over a fixed number of steps at
that step and extrapolated (a 3-period run would take hours). cosnet is timed at "resolve"
and at "auto" (which softens this cable: its midpoint path stays within ~1 % of the full
scheme's over three swing periods, bench/fast_modes.json); the wall-time ratio per simulated
second is what a user feels at matched (1 %) accuracy.

Usage: python bench/pyelastica_compare.py [--quick]       writes bench/pyelastica_compare.json
       python bench/pyelastica_compare.py --cable       the cable only, into the same JSON
                                                        (its other entries kept)
"""

from __future__ import annotations

import json
import os
import sys
import time
import warnings

from pathlib import Path

import numpy as np

import cosnet
from harness import table, write_json

warnings.filterwarnings("ignore")
import elastica as ea  # noqa: E402

E, G, RHO = 2.1e11, 8.1e10, 7850.0
GRAV = np.array([0.0, 0.0, -9.81])
ALPHA_C = 27.0 / 28.0          # PyElastica's shear coefficient (straight_rod), used by both
STEEL = cosnet.Material(E=E, G=G, density=RHO)


# --------------------------------------------------------------------------- cosnet side
def cn_rod(n, length=1.0, r=0.01):
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True)
    b = net.add_node((length, 0, 0))
    line = net.add_line(a, b, material=STEEL, section=cosnet.Circle(r, shear_coefficient=ALPHA_C),
                        elements=n)
    return net, line


def cn_chain(m, per=10, seg=0.1, r=0.002):
    net = cosnet.Net()
    prev = net.add_node((0, 0, 0), fixed=True)
    for k in range(m):
        node = net.add_node((seg * (k + 1), 0, 0))
        net.add_line(prev, node, material=STEEL, section=cosnet.Circle(r, shear_coefficient=ALPHA_C),
                     elements=per)
        prev = node
    return net


def cn_sim(net, dt=None):
    return cosnet.Simulation(net, effects=[cosnet.Gravity(tuple(GRAV))], stepper="verlet", dt=dt,
                             threads=1)


# --------------------------------------------------------------------------- PyElastica side
class PESim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Connections):
    pass


def pe_rod_obj(n, start, length, r):
    return ea.CosseratRod.straight_rod(n, np.asarray(start, float), np.array([1.0, 0, 0]),
                                       np.array([0, 0, 1.0]), length, r, RHO,
                                       youngs_modulus=E, shear_modulus=G)


def pe_rod(n, length=1.0, r=0.01):
    sim = PESim()
    rod = pe_rod_obj(n, (0, 0, 0), length, r)
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,),
                             constrained_director_idx=(0,))
    sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=GRAV)
    sim.finalize()
    return sim, rod


def pe_chain(m, per=10, seg=0.1, r=0.002):
    sim = PESim()
    rods = [pe_rod_obj(per, (seg * k, 0, 0), seg, r) for k in range(m)]
    for rod in rods:
        sim.append(rod)
        sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=GRAV)
    sim.constrain(rods[0]).using(ea.OneEndFixedBC, constrained_position_idx=(0,),
                                 constrained_director_idx=(0,))
    le = seg / per
    area, inertia = np.pi * r * r, np.pi * r ** 4 / 4
    for a, b in zip(rods[:-1], rods[1:]):
        sim.connect(a, b, first_connect_idx=-1, second_connect_idx=0).using(
            ea.FixedJoint, k=E * area / le, nu=0.0, kt=E * inertia / le)
    sim.finalize()
    return sim, rods


class PERunner:
    def __init__(self, sim, dt):
        self.sim, self.dt, self.t = sim, np.float64(dt), np.float64(0.0)
        self.stepper = ea.PositionVerlet()

    def run(self, steps):
        st, sim, dt, t = self.stepper, self.sim, self.dt, self.t
        for _ in range(steps):
            t = st.step(sim, t, dt)
        self.t = t


def pe_ok(rods, bound):
    x = np.concatenate([r.position_collection for r in rods], axis=1)
    return bool(np.isfinite(x).all() and np.abs(x).max() < bound)


# --------------------------------------------------------------------------- timing
def time_pair(name, elements, cn, pe, pe_rods, steps_cn, steps_pe, repeat, bound):
    """Best-of-repeat wall time per step of both codes, their runs alternating (so that a
    change of the shared machine's load hits both alike)."""
    cn.run(steps=10)                                   # JIT (or cache load)
    pe_run = PERunner(pe, cn.dt)
    pe_run.run(5)                                      # PyElastica's own JIT warm-up
    t_cn = t_pe = w_cn = w_pe = np.inf
    for _ in range(repeat):
        c0, t0 = time.thread_time(), time.perf_counter()
        cn.run(steps=steps_cn)
        c1, t1 = time.thread_time(), time.perf_counter()
        pe_run.run(steps_pe)
        c2, t2 = time.thread_time(), time.perf_counter()
        t_cn, t_pe = min(t_cn, (c1 - c0) / steps_cn), min(t_pe, (c2 - c1) / steps_pe)
        w_cn, w_pe = min(w_cn, (t1 - t0) / steps_cn), min(w_pe, (t2 - t1) / steps_pe)
    stable = pe_ok(pe_rods, bound) and bool(np.isfinite(cn.state.x).all())
    return {"case": name, "elements": elements, "dt": cn.dt, "steps_cosnet": steps_cn,
            "steps_pyelastica": steps_pe, "repeats": repeat, "us_per_step_cosnet": 1e6 * t_cn,
            "us_per_step_pyelastica": 1e6 * t_pe, "ratio": t_pe / t_cn,
            "wall_us_per_step_cosnet": 1e6 * w_cn, "wall_us_per_step_pyelastica": 1e6 * w_pe,
            "wall_ratio": w_pe / w_cn,
            "pyelastica_stable": bool(stable)}


def speed(quick):
    rep = 5 if quick else 10
    out = []
    for n, s_cn, s_pe in ((100, 5_000, 500), (1000, 500, 100)):
        net, _ = cn_rod(n)
        cn = cn_sim(net)
        pe, rod = pe_rod(n)
        out.append(time_pair(f"rod {n}", n, cn, pe, [rod], s_cn, s_pe, rep, 10.0))
    for m, s_cn, s_pe, r in ((100, 500, 30, rep), (1000, 50, 5 if quick else 10, 3)):
        net = cn_chain(m)
        cn = cn_sim(net)
        pe, rods = pe_chain(m)
        out.append(time_pair(f"chain {m} x 10", 10 * m, cn, pe, rods, s_cn, s_pe, r, 1e3))
    return out


# --------------------------------------------------------------------------- trajectory
def trajectories(n, until, samples, base_dt=None):
    """Vertex positions (samples+1, n+1, 3) of both codes at common times, and dt. With
    base_dt, the step is base_dt / m (the smallest whole m that is stable), so that the
    sampling times coincide exactly with those of a run at base_dt."""
    net, line = cn_rod(n)
    est = cn_sim(net).dt
    m = 1 if base_dt is None else int(np.ceil(base_dt / est - 1e-12))
    dt = est if base_dt is None else base_dt / m
    cn = cn_sim(net, dt)
    per = (int(round(until / (dt * m))) // samples) * m
    pe, rod = pe_rod(n)
    runner = PERunner(pe, dt)
    xs_cn, xs_pe, ts = [cn.line_positions(line).copy()], [rod.position_collection.T.copy()], [0.0]
    for _ in range(samples):
        cn.run(steps=per)
        runner.run(per)
        xs_cn.append(cn.line_positions(line).copy())
        xs_pe.append(rod.position_collection.T.copy())
        ts.append(cn.time)
    return np.array(ts), np.array(xs_cn), np.array(xs_pe), dt


def trajectory(quick):
    n, until, samples = 100, 0.05, 50
    ts, a, b, dt = trajectories(n, until, samples)
    x0 = a[0]
    tip = float(np.abs(a[:, -1, 2] - x0[-1, 2]).max())
    diff = float(np.abs(a - b).max())
    tip_pe = float(np.abs(b[:, -1, 2] - b[0, -1, 2]).max())
    res = {"elements": n, "until_s": until, "dt": dt, "samples": samples,
           "max_tip_deflection_cosnet_m": tip, "max_tip_deflection_pyelastica_m": tip_pe,
           "max_position_difference_m": diff, "relative_difference": diff / tip,
           "tip_history_z": {"t": ts.tolist(), "cosnet": (a[:, -1, 2]).tolist(),
                             "pyelastica": (b[:, -1, 2]).tolist()}}
    if not quick:
        # each code's own discretisation change, n -> 2n (common vertices: every other one)
        ts2, a2, b2, _ = trajectories(2 * n, until, samples, base_dt=dt)
        res["cosnet_n_vs_2n"] = float(np.abs(a2[:, ::2] - a).max()) / tip
        res["pyelastica_n_vs_2n"] = float(np.abs(b2[:, ::2] - b).max()) / tip
        tip2 = float(np.abs(a2[:, -1, 2] - a2[0, -1, 2]).max())
        res["relative_difference_2n"] = float(np.abs(a2 - b2).max()) / tip2
        res["time_sample_mismatch_s"] = float(np.abs(ts2 - ts).max())
    return res


# --------------------------------------------------------------------------- the cable
def pe_cable(positions, directors):
    sim = PESim()
    n = positions.shape[0] - 1
    normal = directors[0, 0].copy()
    rod = ea.CosseratRod.straight_rod(n, positions[0].copy(), np.array([1.0, 0, 0]), normal, 10.0,
                                      1e-3, RHO, youngs_modulus=E, shear_modulus=G,
                                      position=positions.T.copy(),
                                      directors=np.ascontiguousarray(directors.transpose(1, 2, 0)))
    rod.rest_kappa[:] = 0.0          # straight at rest, as cosnet's cable
    sim.append(rod)
    sim.constrain(rod).using(ea.GeneralConstraint, constrained_position_idx=(0, -1),
                             translational_constraint_selector=np.array([True, True, True]))
    sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=GRAV)
    sim.finalize()
    return sim, rod


def pe_stable_dt(positions, directors, dt0, steps):
    """The largest dt0 * 2^(k/2) (k from 4 down) with which PyElastica stays finite and within
    1 m of its start over ``steps`` steps."""
    tried = []
    for k in range(4, -9, -1):
        dt = dt0 * 2.0 ** (k / 2)
        sim, rod = pe_cable(positions, directors)
        PERunner(sim, dt).run(steps)
        ok = bool(np.isfinite(rod.position_collection).all()
                  and np.abs(rod.position_collection.T - positions).max() < 1.0)
        tried.append({"dt": dt, "stable": ok})
        if ok:
            return dt, tried
    raise RuntimeError(f"PyElastica cable: no stable step found ({tried})")


def cable_compare(quick):
    from fast_modes import cable
    sims = {fm: cosnet.Simulation(cable(), effects=[cosnet.Gravity(tuple(GRAV))], fast_modes=fm,
                                  threads=1) for fm in ("resolve", "auto")}
    ref = sims["resolve"]
    line = ref.net.lines[0]
    positions = ref.line_positions(line).copy()
    q = ref.state.q[ref.model.line_element_offsets[0]:ref.model.line_element_offsets[1]]
    from cosnet.core.rotations import matrix_from_quat
    directors = np.array([matrix_from_quat(qq).T for qq in q])   # rows d1, d2, d3
    check = 2000 if quick else 20000
    dt_pe, tried = pe_stable_dt(positions, directors, ref.dt, check)
    steps_pe = 500 if quick else 2000
    sim, rod = pe_cable(positions, directors)
    runner = PERunner(sim, dt_pe)
    runner.run(5)
    steps_cn = {"resolve": 2000 if quick else 20000, "auto": 2000 if quick else 20000}
    for s in sims.values():
        s.run(steps=10)
    best = {"pyelastica": np.inf, "resolve": np.inf, "auto": np.inf}
    for _ in range(3 if quick else 5):
        t0 = time.perf_counter()
        runner.run(steps_pe)
        best["pyelastica"] = min(best["pyelastica"], (time.perf_counter() - t0) / (steps_pe * dt_pe))
        for fm, s in sims.items():
            t0 = time.perf_counter()
            s.run(steps=steps_cn[fm])
            best[fm] = min(best[fm], (time.perf_counter() - t0) / (steps_cn[fm] * s.dt))
    return {"dt_pyelastica": dt_pe, "stability_check_steps": check, "tried": tried,
            "dt_resolve": ref.dt, "dt_auto": sims["auto"].dt,
            "timed_steps": {"pyelastica": steps_pe, **steps_cn},
            "wall_per_sim_s": best, "extrapolated": True,
            "ratio_pyelastica_over_auto": best["pyelastica"] / best["auto"],
            "ratio_pyelastica_over_resolve": best["pyelastica"] / best["resolve"],
            "ratio_resolve_over_auto": best["resolve"] / best["auto"]}


def main():
    quick = "--quick" in sys.argv
    load0 = os.getloadavg()[0]
    cab = cable_compare(quick)
    cab["load_average_1min"] = [load0, os.getloadavg()[0]]
    table("cable L = 10 m, r = 1 mm, 100 elements, pinned, swinging: wall time per simulated second "
          "(best of rounds, each timed over a fixed number of steps and extrapolated)",
          ["code", "dt (s)", "wall s / sim s", "PyElastica / this"],
          [["PyElastica 1.0", cab["dt_pyelastica"], cab["wall_per_sim_s"]["pyelastica"], 1.0],
           ["cosnet resolve", cab["dt_resolve"], cab["wall_per_sim_s"]["resolve"],
            cab["ratio_pyelastica_over_resolve"]],
           ["cosnet auto", cab["dt_auto"], cab["wall_per_sim_s"]["auto"], cab["ratio_pyelastica_over_auto"]]])
    if "--cable" in sys.argv:
        path = Path(__file__).with_suffix(".json")
        if os.environ.get("COSNET_BENCH_OUT"):
            path = Path(os.environ["COSNET_BENCH_OUT"]) / path.name
        old = json.loads(path.read_text()) if path.exists() else {}
        old.pop("machine", None)
        write_json(__file__, {**old, "cable": cab})
        return
    rows = speed(quick)
    table("cosnet vs PyElastica 1.0 (position Verlet, gravity, same dt, 1 thread, best of N, "
          "CPU time per step; wall ratio alongside)",
          ["case", "elements", "dt (s)", "PyElastica us/step", "cosnet us/step", "ratio", "wall ratio",
           "PE stable"],
          [[r["case"], r["elements"], r["dt"], r["us_per_step_pyelastica"], r["us_per_step_cosnet"],
            r["ratio"], r["wall_ratio"], r["pyelastica_stable"]] for r in rows])
    tr = trajectory(quick)
    lines = [["max tip deflection cosnet (m)", tr["max_tip_deflection_cosnet_m"]],
             ["max tip deflection PyElastica (m)", tr["max_tip_deflection_pyelastica_m"]],
             ["max |x_cosnet - x_PyElastica| / tip deflection", tr["relative_difference"]]]
    if "cosnet_n_vs_2n" in tr:
        lines += [["cosnet n=100 vs 200, / tip deflection", tr["cosnet_n_vs_2n"]],
                  ["PyElastica n=100 vs 200, / tip deflection", tr["pyelastica_n_vs_2n"]],
                  ["at 200 elements: max |x_cosnet - x_PyElastica| / tip", tr["relative_difference_2n"]]]
    table(f"Trajectory, clamped rod {tr['elements']} elements, 0-{tr['until_s']} s, dt = {tr['dt']:.4g} s",
          ["quantity", "value"], lines)
    write_json(__file__, {"speed": rows, "trajectory": tr, "cable": cab, "quick": quick,
                          "load_average_1min": [load0, os.getloadavg()[0]]})
    print(f"1-minute load average at start and end: {load0:.2f}, {os.getloadavg()[0]:.2f} "
          f"(cores: {os.cpu_count()})")


if __name__ == "__main__":
    main()
