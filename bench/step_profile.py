"""Where a step's time goes, kernel by kernel: each scene stepped under `perf record` (the CPU
clock sampled 5,000 times a second) with the compiled kernels named for perf by a map file
(/tmp/perf-PID.map: each function's address, size and name, an effect's slot by the kernel
it calls), the samples summed by kernel. The step's own kernels (the internal loads with the
load effects' slots before them, the node balances, the kick, the drift) and each effect's
slot are rows of their own; what is left (Python between chunks of steps, the watch) is "the
rest". A share is of the samples while the scene steps, so it carries the sampling's spread
(about a percent at 20,000 samples) beside the machine's.

Scenes, one thread each: bench/fluid.py's wire of 1000 elements dry, in water (drag, added
mass, buoyancy; Lagrange's law and Morison's), and the same 1000 elements as 200 lines of 5;
bench/joints.py's hanging chain of 100 links of 5 elements welded, on free hinges and on ball
joints with a spring.

Run: python bench/step_profile.py [--quick]; needs perf (Debian's linux-perf) and a kernel
that lets this user sample its own processes; writes bench/step_profile.json
(docs/performance.md shows its table).
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter

import cosnet
from cosnet.kernels import compose
from fluid import FLUIDS, SEA, wire
from harness import table, write_json
from joints import JOINTS
from joints import chain as link_chain
from numba.core.registry import cpu_target

CORE = {"start_loads_at": "internal loads", "gather_loads_at": "node balances", "kick_velocities_at": "kick",
        "drift_positions_at": "drift"}
REST = "the rest"
RATE = 5000   # samples a second
MINOR = 0.01  # a row of less than this share goes to the rest


def wet(kind):
    return cosnet.Fluid(SEA, surface=0.0, **FLUIDS[kind])


def scenes():
    """{name: a function building the scene's Simulation}."""
    def on_wire(n, lines, medium):
        dt = cosnet.Simulation(wire(n, lines), [cosnet.Gravity()], threads=1, fast_modes="rotary").dt
        return cosnet.Simulation(wire(n, lines), [cosnet.Gravity(), *medium], dt=dt, force_dt=True, threads=1,
                                 fast_modes="rotary")

    def on_chain(kind):
        welded = cosnet.Simulation(link_chain(100, JOINTS["welded"]), [cosnet.Gravity()], threads=1)
        return cosnet.Simulation(link_chain(100, JOINTS[kind]), [cosnet.Gravity()], dt=welded.dt, force_dt=True,
                                 threads=1)
    lagrange, morison = "drag + added mass + buoyancy", "the same, Morison's added mass"
    return {
        "wire of 1000, dry": lambda: on_wire(1000, 1, []),
        "wire of 1000, water (Lagrange)": lambda: on_wire(1000, 1, [wet(lagrange)]),
        "wire of 1000, water (Morison)": lambda: on_wire(1000, 1, [wet(morison)]),
        "200 lines of 5, dry": lambda: on_wire(1000, 200, []),
        "200 lines of 5, water (Lagrange)": lambda: on_wire(1000, 200, [wet(lagrange)]),
        "100 links, welded": lambda: on_chain("welded"),
        "100 links, free hinges": lambda: on_chain("free hinges"),
        "100 links, ball joints with spring": lambda: on_chain("ball joints with spring"),
    }


def labels() -> dict:
    """{mangled name: row} of the step's kernels and the effect slots compiled so far."""
    out = {}
    for kernel in compose.CORE:
        for cres in kernel.overloads.values():
            out[cres.fndesc.mangled_name] = CORE.get(kernel.py_func.__name__, kernel.py_func.__name__)
    for held in compose._WRAPPERS.values():
        hook, name = held.slot_name.split(":", 1)
        for cres in held.overloads.values():
            out[cres.fndesc.mangled_name] = f"{name.rsplit('.', 1)[-1]} ({hook})"
    return out


def function_name(mangled: str) -> str:
    """The module and function of a numba symbol ("joint_lanes.settle_sockets"), REST for
    another or an entry wrapper (the Python calling convention's)."""
    m = re.match(r"_ZN((?:\d+\w+?)+?)B\d*v\d+", mangled)
    if not m:
        return REST
    parts, rest = [], m.group(1)
    while rest:
        size = re.match(r"\d+", rest).group(0)
        rest = rest[len(size):]
        parts.append(rest[:int(size)])
        rest = rest[int(size):]
    return REST if parts[0] == "cpython" or "_3clocals_3e" in parts else ".".join(parts[-2:])


def write_map(path) -> set:
    """Write perf's map of the JIT code: every symbol numba's engine defines, its size the gap
    to the next one (1 MB at most), named by labels() where it is a kernel of the step, else
    by its function (a helper the kernels call rather than inline); return the names written."""
    engine = cpu_target.target_context.codegen()._engine
    named = labels()
    found = []
    for name in engine._defined_symbols:
        try:
            address = engine._ee.get_function_address(name)
        except Exception:   # (a symbol the engine cannot resolve is no code of ours to name)
            continue
        if address:
            found.append((address, name))
    found.sort()
    written = set()
    with open(path, "w") as f:
        for (a, name), (b, _) in zip(found, found[1:] + [(found[-1][0] + 4096, "")]):
            row = named.get(name) or function_name(name)
            f.write(f"{a:x} {min(b - a, 1 << 20):x} {row}\n")
            written.add(row)
    return written


def profile(sim, seconds, steps=2000) -> dict:
    """Step sim for about ``seconds`` under perf; return its µs per step and the share of each row."""
    sim.run(steps=steps)   # (compiled, and its caches warm)
    map_path = f"/tmp/perf-{os.getpid()}.map"
    ours = write_map(map_path)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            data = os.path.join(tmp, "perf.data")
            rec = subprocess.Popen(["perf", "record", "-q", "-e", "cpu-clock", "-F", str(RATE), "-p",
                                    str(os.getpid()), "-o", data], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            try:
                time.sleep(0.3)   # (perf attached)
                t0, done = time.perf_counter(), 0
                while time.perf_counter() - t0 < seconds:
                    sim.run(steps=steps)
                    done += steps
                wall = time.perf_counter() - t0
            finally:
                rec.send_signal(2)
                rec.wait(timeout=60)
            out = subprocess.run(["perf", "script", "-i", data, "-F", "ip,sym"], capture_output=True, text=True,
                                 timeout=300).stdout
    finally:
        os.remove(map_path)
    counts = Counter((line.split(None, 1)[1:] or [REST])[0].strip() for line in out.splitlines() if line.strip())
    total = sum(counts.values())
    shares = Counter()
    for sym, n in counts.items():   # (a symbol of Python or the C library: the rest)
        shares[sym if sym in ours and n >= MINOR * total else REST] += n / total
    return {"us_per_step": 1e6 * wall / done, "samples": total, "shares": dict(shares.most_common())}


def main():
    if shutil.which("perf") is None:
        sys.exit("step_profile: perf is not installed (Debian's linux-perf)")
    quick = "--quick" in sys.argv
    results, rows = [], []
    for name, build in scenes().items():
        r = {"scene": name, **profile(build(), 1.0 if quick else 4.0)}
        if r["samples"] < 100:
            sys.exit(f"step_profile: perf took {r['samples']} samples of {name!r}: may this user sample its "
                     f"processes? (/proc/sys/kernel/perf_event_paranoid)")
        results.append(r)
        for row, share in r["shares"].items():
            rows.append([name, row, share * r["us_per_step"], 100.0 * share])
    table("step profile: where a step's time goes (one thread)", ["scene", "kernel", "us/step", "%"], rows)
    write_json(__file__, {"command": " ".join(["python", "bench/step_profile.py", *sys.argv[1:]]),
                          "rate_per_s": RATE, "scenes": results})


if __name__ == "__main__":
    main()
