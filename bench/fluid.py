"""Cost of the fluid medium per step: the same submerged line stepped dry (gravity alone) and
in water with each set of the fluid's terms, side by side in one process (interleaved rounds,
the median of three copies of each: harness.median_of_copies), per step and per element-step.

Scene: a steel wire (r = 20 mm) of N elements, 1 m each, pinned at both ends 2 m under the
surface, under gravity; and the same 1000 elements as a chain of 200 lines of 5, joined at
point junctions of 10 kg (a net's twine between knots: the nodes' share of the medium's
work); every step is taken at the dry net's stable step; and the wire of 50,000 elements as lines of
5, dry and in water, on 1 and on 2 threads (on_threads). Run: python bench/fluid.py
[--quick]; writes bench/fluid.json (docs/fluid.md shows its table).
"""

import sys

import numpy as np

import cosnet
from cosnet.kernels.stepping import CHUNK_STEPS
from harness import best_interleaved, median_of_copies, table, write_json

SEA = 1025.0
WIRE = cosnet.Material(E=1e11, poisson=0.3, density=7850.0)

KNOT = dict(mass=10.0, inertia=(0.1, 0.1, 0.1))   # the junctions of a chain of lines
THREADED, STEPS_THREADED = 50_000, 100   # on_threads: the net's elements, and steps a timing


def wire(n, lines=1):
    """A straight wire of n elements between two pins, 2 m under the surface; as ``lines``
    lines of n / lines elements joined at point junctions of 10 kg."""
    net = cosnet.Net()
    pin = dict(mass=np.inf, inertia=(1.0, 1.0, 1.0))
    nodes = [net.add_node((float(n) * k / lines, 0.0, -2.0), **(pin if k in (0, lines) else KNOT))
             for k in range(lines + 1)]
    for a, b in zip(nodes, nodes[1:]):
        net.add_line(a, b, material=WIRE, section=cosnet.Circle(0.02), elements=n // lines)
    return net



FLUIDS = {
    "drag": dict(drag=(1.2, 0.008)),
    "drag + added mass + buoyancy": dict(drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True),
    "the same, Morison's added mass": dict(drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True,
                                           added_mass_law="morison"),
    "the same in a current": dict(drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True,
                                  velocity=(0.0, 0.5, 0.0)),
    "the same in two wave components": dict(drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True,
                                            depth=50.0, wave_amplitudes=[1.0, 0.3], wave_periods=[8.0, 5.0],
                                            wave_headings=[0.0, 30.0]),
    "the same in a JONSWAP sea of 20 components": dict(drag=(1.2, 0.008), added_mass=(1.0, 0.0), buoyancy=True,
                                                       depth=50.0, wave_spectrum="jonswap", significant_height=2.0,
                                                       peak_period=8.0, wave_components=20),
    "Stokes resistance": dict(resistance=(2.0, 1.0)),
}


def main():
    quick = "--quick" in sys.argv
    sizes, copies, rounds = (((100, 1),), 1, 3) if quick else (((100, 1), (1000, 1), (1000, 200)), 3, 5)
    rows, results = [], []
    for n, lines in sizes:
        steps = max(CHUNK_STEPS, 2_000_000 // n)   # whole chunks: the watch's tests at their usual rate
        dt = cosnet.Simulation(wire(n, lines), [cosnet.Gravity()], threads=1, fast_modes="rotary").dt
        cases = {"dry (gravity)": None, **FLUIDS}

        def build(kw):   # each copy a simulation of its own (harness.median_of_copies)
            medium = [] if kw is None else [cosnet.Fluid(SEA, surface=0.0, **kw)]
            sim = cosnet.Simulation(wire(n, lines), [cosnet.Gravity(), *medium], dt=dt, force_dt=True, threads=1,
                                    fast_modes="rotary")
            return lambda: sim.run(steps=steps)
        times = median_of_copies([lambda kw=kw: build(kw) for kw in cases.values()], copies, rounds)
        base = times[0] / steps
        for name, t in zip(cases, times):
            per = t / steps
            results.append({"elements": n, "lines": lines, "case": name, "us_per_step": 1e6 * per,
                            "ns_per_element_step": 1e9 * per / n, "over_dry_percent": 100.0 * (per / base - 1)})
            rows.append([n, lines, name, 1e6 * per, 1e9 * per / n, 100.0 * (per / base - 1)])
    table("fluid: cost per step of a submerged wire (one thread, the dry line's step)",
          ["elements", "lines", "case", "us/step", "ns/element-step", "over dry %"], rows)
    threads = on_threads(quick)
    table("fluid: the wire as a net of short lines on 1 and 2 threads",
          ["elements", "lines", "case", "threads", "us/step"],
          [[r["elements"], r["lines"], r["case"], r["threads"], r["us_per_step"]] for r in threads])
    write_json(__file__, {"command": " ".join(["python", "bench/fluid.py", *sys.argv[1:]]), "runs": results,
                          "threads": threads})


def on_threads(quick):
    """The wire of THREADED elements as lines of 5 (a net's twine between knots, at the size
    where a net runs on two threads by default: simulation.PARALLEL_MIN_ELEMENTS), dry and
    with drag + added mass + buoyancy, each on 1 and on 2 threads, timed in alternation:
    the elastic step's loops and the fluid's sample and kick run on the threads."""
    n, lines = THREADED, THREADED // 5
    dt = cosnet.Simulation(wire(n, lines), [cosnet.Gravity()], threads=1, fast_modes="rotary").dt
    runs, fns = [], []
    for name, kw in (("dry (gravity)", None), ("drag + added mass + buoyancy", FLUIDS["drag + added mass + buoyancy"])):
        for k in (1, 2):
            medium = [] if kw is None else [cosnet.Fluid(SEA, surface=0.0, **kw)]
            sim = cosnet.Simulation(wire(n, lines), [cosnet.Gravity(), *medium], dt=dt, force_dt=True, threads=k,
                                    fast_modes="rotary")
            runs.append({"elements": n, "lines": lines, "case": name, "threads": k})
            fns.append(lambda sim=sim: sim.run(steps=STEPS_THREADED))
    times = best_interleaved(fns, 3 if quick else 7)
    for r, t in zip(runs, times):
        r["us_per_step"] = 1e6 * t / STEPS_THREADED
    return runs


if __name__ == "__main__":
    main()
