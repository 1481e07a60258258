"""Start-up: where the time goes between starting cosnet and its first frame, per shipped case.

    python bench/startup.py [CASE ...]          (default: every case in cases/)

Each case runs three times in processes of its own, one at a time, with a numba cache
directory of its own: cold (the cache empty), warm (the cache the cold run left), then warm
with one effect kind the case does not declare added (a small line load, else a node load,
else gravity): what an edit that adds an effect costs. Python runs as a user's does, with
the modules' bytecode written once, before the first case, and read from then on. Each
process does what `cosnet run CASE` does up to its first frame after t = 0, and times the
phases: starting Python and importing cosnet, loading the scene, building the simulation
(flattening), frame 0 (the watch's energy and checksum kernels), the step to frame 1, with a
second process compiling the step's kernels meanwhile, from the first compilation on (the
build's included; cosnet.compiling.compiling_alongside, as `cosnet run` does). Compilation
in the first process is split by the compile log (cosnet/compiling.py) into numba's part
(type inference, lowering) and LLVM's (optimisation, linking, machine code); the waits for
the second process are counted apart; what a phase spends beyond those is loading kernels
from the cache and running them. The figures go to startup.json and the table of
docs/performance.md (bench/tables.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROOT = Path(__file__).resolve().parents[1]
CASES = ROOT / "cases"

# What one process does (argv: case, output folder, the wall-clock time its parent started it);
# each phase: [seconds, of which compiling, of which LLVM].
PHASES = r"""
import json, sys, time
born = float(sys.argv[3])
marks = {"python": [time.time() - born, 0.0, 0.0]}
t = time.perf_counter()
done = [0.0, 0.0]
def mark(name, log=None):
    global t
    now = time.perf_counter()
    c, l = (log.seconds, log.llvm) if log is not None else (0.0, 0.0)
    marks[name] = [now - t, c - done[0], l - done[1]]
    t, done[:] = now, [c, l]
import cosnet
from cosnet.compiling import CompileLog, compiling_alongside
from cosnet.output.record import Recorder
mark("import")
with CompileLog() as log:
    scene = cosnet.load_scene(sys.argv[1])
    mark("load", log)
    with compiling_alongside(sys.argv[1]):   # as `cosnet run` does: from the build on
        sim = scene.simulation()
        mark("build", log)
        rec = Recorder(sys.argv[2], sim, scene.run.interval, scene.run.interval, scene.run.probes)
        mark("frame_0", log)
        rec.run()
        mark("frame_1", log)
print(json.dumps({"phases": marks, "steps": sim.steps, "kernels": len(log.kernels),
                  "compile": log.seconds, "llvm": log.llvm, "waited": log.waited,
                  "first_frame": time.time() - born,
                  "by_root": {k.rsplit(".", 1)[-1]: v for k, v in log.by_root().items()}}))
"""

def one(case: Path, cache: str) -> dict:
    from harness import python_env
    with tempfile.TemporaryDirectory() as out:
        env = python_env(NUMBA_CACHE_DIR=cache)
        born = time.time()
        done = subprocess.run([sys.executable, "-c", PHASES, str(case), out, repr(born)], env=env,
                              capture_output=True, text=True, timeout=1800)
    if done.returncode:
        raise SystemExit(f"{case.name}: {done.stderr.strip().splitlines()[-1]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


# effect kinds to add, the first the case lacks: kind, keys (given a line's and a node's name)
EXTRA = (("line_load", 'line = "{line}"\nforce_per_length = [0.0, 0.0, -1e-3]'),
         ("node_load", 'node = "{node}"\nforce = [0.0, 0.0, -1e-3]'),
         ("gravity", "g = [0.0, 0.0, -1e-3]"))


def with_new_kind(case: Path, folder: Path) -> tuple[str, Path]:
    """The case with one effect kind it lacks added, written into folder: (kind, path)."""
    import tomllib
    doc = tomllib.loads(case.read_text())
    kinds = {e.get("kind") for e in doc.get("effects", [])}
    kind, keys = next((k, v) for k, v in EXTRA if k not in kinds)
    text = keys.format(line=next(iter(doc["lines"])), node=next(iter(doc["nodes"])))
    path = folder / case.name
    path.write_text(case.read_text().replace("\n[run]", f"\n[[effects]]\nkind = \"{kind}\"\n{text}\n\n[run]", 1))
    return kind, path


def main(argv: list[str]) -> int:
    from harness import python_env, write_json
    names = argv or sorted(p.stem for p in CASES.glob("*.toml"))
    runs = []
    load_before = os.getloadavg()[0]
    started = time.perf_counter()
    # the bytecode written before the first case, as an installed package has it
    subprocess.run([sys.executable, "-c", "import cosnet.compiling, cosnet.output.record"], env=python_env(),
                   check=True, timeout=600)
    for name in names:
        case = CASES / f"{name}.toml"
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as scenes:
            cold, warm = one(case, cache), one(case, cache)
            kind, edited = with_new_kind(case, Path(scenes))
            added = one(edited, cache)
        runs.append({"case": name, "cold": cold, "warm": warm, "added_kind": kind, "added": added})
        print(f"{name:16s} cold {cold['first_frame']:6.1f} s ({cold['kernels']} kernels, compile "
              f"{cold['compile']:.1f} s of which LLVM {cold['llvm']:.1f})  warm {warm['first_frame']:5.2f} s  "
              f"+{kind} {added['first_frame']:5.1f} s", flush=True)
    write_json(__file__, {"command": "python bench/startup.py " + " ".join(argv), "load_before": load_before,
                          "wall_s": time.perf_counter() - started, "runs": runs})
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
