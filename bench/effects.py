"""Cost of the effect mechanism: the step assembled through Simulation against the bare
elastic step kernels, the marginal cost per step of each effect, and the stable step against
the stiffness of a penalty joint.

Scene: two steel rods of 500 elements each, end to end along x (the first clamped at its
start), the second on a node of its own at the first one's end, so that every joint kind can
join them. Run: python bench/effects.py [--quick]; writes bench/effects.json.
"""

import sys

import cosnet
from harness import best_of, table, write_json

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0)
RUBBER = cosnet.Material(E=1e6, poisson=0.45, density=1000.0)


def two_rods(per_rod=500, material=STEEL, radius=0.01, length=1.0):
    """Returns (net, rod a, rod b)."""
    net = cosnet.Net()
    root = net.add_node((0.0, 0.0, 0.0), fixed=True)
    mid_a = net.add_node((length, 0.0, 0.0))
    mid_b = net.add_node((length, 0.0, 0.0))
    tip = net.add_node((2 * length, 0.0, 0.0), name="tip")
    sec = cosnet.Circle(radius)
    a = net.add_line(root, mid_a, material=material, section=sec, elements=per_rod, name="a")
    b = net.add_line(mid_b, tip, material=material, section=sec, elements=per_rod, name="b")
    return net, a, b


def effect_cases(net, a, b):
    """name -> list of effects (each on top of the elastic step)."""
    cases = {
        "gravity": [cosnet.Gravity()],
        "damping": [cosnet.Damping(1.0)],
        "internal damping": [cosnet.InternalDamping(ratio=1.0)],
        "node load": [cosnet.NodeLoad(net.node("tip"), force=(0.0, 0.0, -1.0))],
        "line load": [cosnet.LineLoad(a, force_per_length=(0.0, 0.0, -1.0))],
        "spherical joint": [cosnet.SphericalJoint(a, "end", b, "start", k=1e5)],
        "hinge joint": [cosnet.HingeJoint(a, "end", b, "start", k=1e5, kt=10.0, normal=(0, 1, 0))],
        "fixed joint": [cosnet.FixedJoint(a, "end", b, "start", k=1e5, kt=10.0)],
    }
    if hasattr(cosnet, "Contact"):
        cases["contact"] = [cosnet.Contact(k=1e5)]
    # every vertex 1 mm into a plane under the rods: the per-vertex law and the soft soil's
    # (its constants per contact area, each contact's results scaled by its area)
    ground = dict(point=(0.0, 0.0, -0.009), normal=(0.0, 0.0, 1.0), mu_s=0.5, mu_k=0.4)
    cases["plane, k per vertex"] = [cosnet.Obstacle("plane", k=1e5, gamma=10.0, **ground)]
    cases["plane, soft soil"] = [cosnet.Obstacle("plane", k_soil=2.5e9, gamma_soil=2.5e5, **ground)]
    return cases


def interleaved(runs: dict, rounds: int) -> dict:
    """name -> smallest seconds per step of fn() for runs[name] = (fn, steps), timed in turns
    (round after round through all of them), so that load from other processes hits every
    case alike."""
    for fn, _ in runs.values():
        fn()                                            # compile or load the cache
    best = dict.fromkeys(runs, float("inf"))
    for _ in range(rounds):
        for name, (fn, steps) in runs.items():
            best[name] = min(best[name], best_of(fn, repeat=1) / steps)
    return best


def bare_run(net, dt, steps):
    """A closure running ``steps`` steps of the compiled stepper directly, with no effects (the
    entry point a Simulation calls, without its Python around it)."""
    sim = cosnet.Simulation(net, dt=dt, threads=1)
    step = sim._stepper()
    args = (sim.model, sim.state, sim.loads, sim.step_table, dt, steps, sim.backend)
    return lambda: step(*args)


def stable_steps(ks):
    """Rows (k, dt elastic only, dt spherical, dt fixed with kt = 1e-4 k m^2) for a soft pair
    of 10-element rods (rubber, 1 cm radius, 0.5 m each)."""
    net, a, b = two_rods(10, RUBBER, 0.01, 0.5)
    base = cosnet.Simulation(net).stable_dt()
    rows = []
    for k in ks:
        sph = cosnet.Simulation(net, [cosnet.SphericalJoint(a, "end", b, "start", k=k)]).stable_dt()
        fix = cosnet.Simulation(net, [cosnet.FixedJoint(a, "end", b, "start", k=k, kt=1e-4 * k)]).stable_dt()
        rows.append([k, base, sph, fix])
    return rows


def main():
    quick = "--quick" in sys.argv
    steps, rounds = (200, 3) if quick else (500, 15)
    net, a, b = two_rods()
    plain = cosnet.Simulation(net, threads=1)
    runs = {"elastic (Simulation)": (lambda: plain.run(steps=steps), steps),
            "elastic (bare kernel)": (bare_run(net, plain.dt, steps), steps)}
    for name, effects in effect_cases(net, a, b).items():
        sim = cosnet.Simulation(net, effects, dt=plain.dt, force_dt=True, threads=1)
        n = steps // 50 if name == "contact" else steps  # contact: ~100 x the elastic step
        runs[name] = (lambda sim=sim, n=n: sim.run(steps=n), n)
    cost = interleaved(runs, rounds)
    t_sim, t_bare = cost.pop("elastic (Simulation)"), cost.pop("elastic (bare kernel)")
    ratio = t_sim / t_bare
    print(f"\nelastic step, {net.element_count} elements: Simulation {1e6 * t_sim:.2f} us, bare "
          f"advance_verlet {1e6 * t_bare:.2f} us, ratio {ratio:.3f}")
    marginal = [{"effect": name, "us_per_step": 1e6 * t, "marginal_us": 1e6 * (t - t_sim),
                 "marginal_percent": 100.0 * (t - t_sim) / t_sim} for name, t in cost.items()]
    table(f"marginal cost per step ({net.element_count} elements, elastic step {1e6 * t_sim:.2f} us)",
          ["effect", "us/step", "marginal us", "marginal %"],
          [[m["effect"], m["us_per_step"], m["marginal_us"], m["marginal_percent"]] for m in marginal])

    ks = [10.0 ** e for e in range(2, 9)]
    rows = stable_steps(ks)
    table("stable dt vs joint stiffness (soft pair, 2 x 10 elements)",
          ["k (N/m)", "dt elastic (s)", "dt spherical (s)", "dt fixed (s)"], rows)
    write_json(__file__, {
        "elastic": {"elements": net.element_count, "simulation_us": 1e6 * t_sim, "bare_us": 1e6 * t_bare,
                    "ratio": ratio},
        "marginal": marginal,
        "stable_dt": [dict(zip(("k", "dt_elastic", "dt_spherical", "dt_fixed"), r)) for r in rows],
    })


if __name__ == "__main__":
    main()
