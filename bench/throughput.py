"""Throughput: element-steps per second of cosnet's compiled stepper.

Cases: a clamped rod of 100 and 1,000 elements under gravity, and nets of 100 and 1,000
lines x 10 elements (a chain joined at point junctions); on 1 and on 2 threads, each pair
timed in alternation, chains of 2 * 10^4, 5 * 10^4 and 10^5 elements and rods of 2 * 10^4
and 5 * 10^4 (where two threads start to pay: the default thread count,
simulation.PARALLEL_MIN_ELEMENTS, docs/threads.md). Run: python bench/throughput.py
"""

import sys

import cosnet
from harness import best_interleaved, best_of, chain, cpu_times, rod, stolen_since, table, write_json


def figures(name, sim, steps, t):
    ne = sim.net.element_count
    return {"case": name, "elements": ne, "threads": sim.threads, "steps_per_s": steps / t,
            "element_steps_per_s": steps * ne / t, "us_per_step": 1e6 * t / steps}


def measure(name, net, steps, threads=None):
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()], threads=threads)
    sim.run(steps=10)                       # compile (or load the cache)
    return figures(name, sim, steps, best_of(lambda: sim.run(steps=steps)))


def measure_threads(name, net, steps, rounds):
    """The net on 1 and on 2 threads, timed in alternation (see harness.best_interleaved)."""
    sims = [cosnet.Simulation(net, effects=[cosnet.Gravity()], threads=k) for k in (1, 2)]
    times = best_interleaved([lambda s=s: s.run(steps=steps) for s in sims], rounds)
    return [figures(name, s, steps, t) for s, t in zip(sims, times)]


def call_cost(sim, step_s, calls=20):
    """Seconds a run() call costs beyond its steps (the call's checks: a hash of the state at
    its start, a scan for non-finite values at its end), from run(steps=1) in a loop."""
    t = best_of(lambda: [sim.run(steps=1) for _ in range(calls)])
    return t / calls - step_s


def main():
    quick = "--quick" in sys.argv
    cases = [("rod 100", rod(100), 20_000), ("rod 1000", rod(1000), 2_000),
             ("chain 100 x 10", chain(100), 2_000), ("chain 1000 x 10", chain(1000), 200)]
    div = 10 if quick else 1
    results = [measure(n, net, s // div) for n, net, s in cases]
    small = cosnet.Simulation(cases[0][1], effects=[cosnet.Gravity()])
    big = chain(10_000)
    start = cpu_times()
    threads = measure_threads("chain 10000 x 10", big, 100 // div, 5 if quick else 9)
    stolen = stolen_since(start)
    speedups = {"chain 10000 x 10": threads[0]["us_per_step"] / threads[1]["us_per_step"]}
    for name, net in (("chain 2000 x 10", chain(2_000)), ("chain 5000 x 10", chain(5_000)),
                      ("rod 20000", rod(20_000)), ("rod 50000", rod(50_000))):
        pair = measure_threads(name, net, max(10, 4_000_000 // net.element_count // div), 5 if quick else 9)
        speedups[name] = pair[0]["us_per_step"] / pair[1]["us_per_step"]
        threads += pair
    results += threads
    table("cosnet throughput (Verlet, gravity)",
          ["case", "elements", "threads", "steps/s", "element-steps/s", "us/step"],
          [[r["case"], r["elements"], r["threads"], r["steps_per_s"], r["element_steps_per_s"], r["us_per_step"]]
           for r in results])
    speedup = speedups["chain 10000 x 10"]
    print(f"\n2 threads vs 1 on {big.element_count:,} elements: {speedup:.2f}x "
          f"({100 * stolen:.0f}% of the CPU time stolen by the hypervisor meanwhile); " +
          ", ".join(f"{k} {v:.2f}x" for k, v in speedups.items() if k != "chain 10000 x 10"))
    big1 = cosnet.Simulation(big, effects=[cosnet.Gravity()], threads=1)
    calls = {"rod 100": call_cost(small, 1e-6 * results[0]["us_per_step"]),
             "chain 10000 x 10": call_cost(big1, 1e-6 * threads[0]["us_per_step"], 5)}
    print("cost of a run() call beyond its steps: " +
          ", ".join(f"{k} {1e6 * v:.0f} us" for k, v in calls.items()))
    write_json(__file__, {"throughput": results, "thread_speedup": speedup, "thread_speedups": speedups,
                          "cpu_stolen": stolen,
                          "run_call_cost_s": calls})


if __name__ == "__main__":
    main()
