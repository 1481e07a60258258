"""PyElastica's continuum snake (its examples/ContinuumSnakeCase) and cosnet's
cases/snake.toml side by side in one process: forward speed of each and their ratio, and the
wall time per simulated second of each.

Both snakes are built from the case file's numbers (rod, material, muscle wave, friction,
damping). PyElastica: CosseratRod.straight_rod along +z with d1 = +y (the ground's normal),
GravityForces, MuscleTorques (with_spline, b_coeff, wave number 2 pi per body length,
ramp_up_time = one period), a Plane with RodPlaneContactWithAnisotropicFriction (k = 1,
nu = 1e-6, slip_velocity_tol = 1e-8, kinetic [mu, 1.5 mu, 2 mu], no static part),
AnalyticalLinearDamper(damping_constant = 2e-3), position Verlet at dt = 1e-4 s, as the
example. cosnet: the case as it is (its own stable step).

Forward speed: the centre of mass's displacement from the end of period 2 to the end of the
run, over that time (the first two periods are the ramp and the start). The two codes run one
period in turn, each period timed; the wall time per simulated second is the sum over the
periods after the first (PyElastica compiles its kernels in the first) over their length.

Usage: python bench/snake.py [--quick]        writes bench/snake.json
"""

from __future__ import annotations

import os
import sys
import time
import tomllib
import warnings
from pathlib import Path

import numpy as np

from cosnet.scene.loader import load_scene
from harness import table, write_json

warnings.filterwarnings("ignore")
import elastica as ea  # noqa: E402

CASE = Path(__file__).resolve().parents[1] / "cases" / "snake.toml"
B_COEFF = np.array([3.4e-3, 3.3e-3, 4.2e-3, 2.6e-3, 3.6e-3, 3.5e-3])   # PyElastica's example
PE_DT = 1e-4


class SnakeSim(ea.BaseSystemCollection, ea.Forcing, ea.Damping, ea.Contact):
    pass


def case_numbers():
    d = tomllib.loads(CASE.read_text())
    line = d["lines"]["snake"]
    effects = {e["kind"]: e for e in d["effects"]}
    return {"n": line["elements"], "L": d["nodes"]["head"]["position"][2],
            "r": d["sections"]["snake"]["radius"], "E": d["materials"]["snake"]["E"],
            "G": d["materials"]["snake"]["G"], "rho": d["materials"]["snake"]["density"],
            "g": -effects["gravity"]["g"][1], "T": effects["muscle_torque"]["period"],
            "mu": effects["obstacle"]["mu_k"], "damping": effects["damping"]["translational"]}


def pe_snake(c, n=None, sim=None, x0=0.0):
    """PyElastica's snake (n elements, default the case's) added to sim (a new one if None)."""
    sim = SnakeSim() if sim is None else sim
    normal = np.array([0.0, 1.0, 0.0])
    rod = ea.CosseratRod.straight_rod(n or c["n"], np.array([x0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), normal,
                                      c["L"], c["r"], c["rho"], youngs_modulus=c["E"], shear_modulus=c["G"])
    sim.append(rod)
    sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, -c["g"], 0.0]))
    sim.add_forcing_to(rod).using(ea.MuscleTorques, base_length=c["L"], b_coeff=B_COEFF, period=c["T"],
                                  wave_number=2.0 * np.pi, phase_shift=0.0, rest_lengths=rod.rest_lengths,
                                  ramp_up_time=c["T"], direction=normal, with_spline=True)
    plane = ea.Plane(plane_origin=np.array([0.0, -c["r"], 0.0]), plane_normal=normal)
    sim.append(plane)
    mu_head_first, mu_tail_first, mu_across = c["mu"][1], c["mu"][0], c["mu"][2]
    sim.detect_contact_between(rod, plane).using(
        ea.RodPlaneContactWithAnisotropicFriction, k=1.0, nu=1e-6, slip_velocity_tol=1e-8,
        static_mu_array=np.zeros(3), kinetic_mu_array=np.array([mu_head_first, mu_tail_first, mu_across]))
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, damping_constant=c["damping"], time_step=PE_DT)
    return sim, rod


def main():
    quick = "--quick" in sys.argv
    periods = 4 if quick else 8
    c = case_numbers()
    load0 = os.getloadavg()[0]
    scene = load_scene(CASE)
    cn = scene.simulation()
    w = cn.model.vertex_mass / cn.model.vertex_mass.sum()
    pe, rod = pe_snake(c)
    pe.finalize()
    stepper, t_pe = ea.PositionVerlet(), np.float64(0.0)
    cn.run(steps=1)    # compile (or load) cosnet's step outside the timing
    com = {"cosnet": [w @ cn.state.x], "pyelastica": [rod.compute_position_center_of_mass().copy()]}
    wall = {"cosnet": [], "pyelastica": []}
    per = int(round(c["T"] / PE_DT))
    for p in range(1, periods + 1):
        t0 = time.perf_counter()
        cn.run(until=p * c["T"])
        t1 = time.perf_counter()
        for _ in range(per):
            t_pe = stepper.step(pe, t_pe, np.float64(PE_DT))
        t2 = time.perf_counter()
        wall["cosnet"].append(t1 - t0)
        wall["pyelastica"].append(t2 - t1)
        com["cosnet"].append(w @ cn.state.x)
        com["pyelastica"].append(rod.compute_position_center_of_mass().copy())
        print(f"period {p}: cosnet {t1 - t0:.1f} s, PyElastica {t2 - t1:.1f} s", flush=True)
    out = {}
    for code in ("cosnet", "pyelastica"):
        x = np.array(com[code])
        d = x[-1] - x[2]
        span = (periods - 2) * c["T"]
        out[code] = {"displacement_m": d.tolist(), "speed_m_per_s": float(np.linalg.norm(d) / span),
                     "forward_speed_m_per_s": float(d[2] / span), "lateral_speed_m_per_s": float(d[0] / span),
                     "wall_s_per_sim_s": float(sum(wall[code][1:]) / ((periods - 1) * c["T"])),
                     "com_per_period": x.tolist()}
    out["cosnet"]["dt"], out["pyelastica"]["dt"] = cn.dt, PE_DT
    ratio_speed = out["pyelastica"]["forward_speed_m_per_s"] / out["cosnet"]["forward_speed_m_per_s"]
    ratio_wall = out["pyelastica"]["wall_s_per_sim_s"] / out["cosnet"]["wall_s_per_sim_s"]
    load1 = os.getloadavg()[0]
    table(f"continuum snake, {c['n']} elements, T = {c['T']} s, speeds over periods 3-{periods}",
          ["code", "dt (s)", "forward speed (m/s)", "lateral (m/s)", "wall s / sim s"],
          [[code, out[code]["dt"], out[code]["forward_speed_m_per_s"], out[code]["lateral_speed_m_per_s"],
            out[code]["wall_s_per_sim_s"]] for code in ("pyelastica", "cosnet")])
    print(f"forward speed PyElastica / cosnet {ratio_speed:.3g}; wall time per simulated second "
          f"PyElastica / cosnet {ratio_wall:.3g}; 1-minute load average {load0:.1f} -> {load1:.1f} "
          f"on {os.cpu_count()} cores")
    write_json(__file__, {"periods": periods, "period_s": c["T"], "quick": quick, **out,
                          "speed_ratio_pyelastica_over_cosnet": ratio_speed,
                          "wall_ratio_pyelastica_over_cosnet": ratio_wall,
                          "load_average_1min": [load0, load1]})


if __name__ == "__main__":
    main()
