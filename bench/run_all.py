"""Run every benchmark script in bench/, each in its own subprocess, and print a summary.

Scripts that are absent are reported as missing. By default the quick settings are used
(the whole set stays under 15 minutes on a 2-core machine) and each script's JSON and any
figure it writes in bench/ go to --out DIR (default: a temporary folder, printed), leaving the
full-size figures in bench/ alone. --full runs every bench whose JSON the README and docs quote,
at the size they quote, on one commit: each script waits for the machine to be idle first
(its cores busy less than IDLE of the time, for at most WAIT seconds; how busy they were and
the load average when it started are recorded), writes bench/NAME.json, and the pages are
then rendered anew from the JSON (bench/tables.py); bench/run_all.json records the machine,
the commit, each script's start and seconds, and the whole run's wall time. Each script's
output goes to stdout as it runs (and to LOGDIR/NAME.txt with --logs LOGDIR).

With --full and --only, the rows of the scripts named replace theirs in bench/run_all.json,
which lists the rerun (command, machine, commit, seconds) beside the full run it amends.

Usage: python bench/run_all.py [--full] [--out DIR] [--logs DIR] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from harness import cpu_times, machine  # noqa: E402  (beside this script)

# name, quick arguments (None: full runs only), full arguments, time limit (s) in quick mode;
# a name SCRIPT@PANEL runs SCRIPT.py with --PANEL added to both argument lists
SCRIPTS = [
    ("throughput", ["--quick"], [], 120),
    ("scaling", ["--quick"], [], 300),
    ("pyelastica_compare", ["--quick"], [], 120),
    ("effects", ["--quick"], [], 120),
    ("contact_scaling", ["--quick"], [], 120),
    ("accuracy", ["--quick"], [], 120),
    ("accuracy@fast-modes", ["--quick"], [], 300),     # reads bench/fast_modes.json for the cable
    ("accuracy@joints", ["--quick"], [], 180),
    ("fast_modes", None, [], None),                     # about 40 minutes: full runs only
    ("long_run", ["200000"], [], 60),
    ("modes_convergence", ["20", "40", "80", "160", "320"], [], 120),
    ("cosseratbench_run", None, [], None),        # about 6 minutes: full runs only
    ("fluid", ["--quick"], [], 180),
    ("moordyn_compare", None, [], None),          # needs moordyn (the bench extra)
    ("joints", ["--quick"], [], 180),
    ("step_profile", ["--quick"], [], 300),       # needs perf (Debian's linux-perf)
    ("sheaves", ["--quick"], [], 120),
    ("sweep", None, [], None),                    # Dask clusters of 1 and 2 workers
    ("contact_scaling@friction", ["--quick"], [], 180),
    ("snake", ["--quick"], [], 300),                # PyElastica side by side
    ("many_snakes", ["--quick"], ["--profile", "1", "10", "100", "1000"], 900),
    # before the vectorised ground contact; once more with its contact compiled as a script did
    ("snakes_against", None, ["05c0a97", "--no-fastmath", "obstacles.add_obstacle"], None),
    ("startup", None, [], None),                  # about 8 minutes: every case cold and warm
    ("soak", None, [], None),                     # about 13 minutes: 10^7 steps of two cases
]
IDLE, WAIT = 0.1, 300.0   # the machine counts as idle below this busy share; the longest wait


def snapshot() -> dict:
    """Contents of the non-source files in bench/ (figures, JSON), by path."""
    return {p: p.read_bytes() for p in HERE.rglob("*")
            if p.is_file() and p.suffix != ".py" and "__pycache__" not in p.parts}


def set_aside(before: dict, out: Path):
    """Move files a quick run wrote into bench/ to out/ (same relative path) and put back what
    was there, so quick runs leave the full-size figures alone."""
    for p, data in snapshot().items():
        if before.get(p) != data:
            dest = out / p.relative_to(HERE)
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_bytes(data)
            if p in before:
                p.write_bytes(before[p])
            else:
                p.unlink()
            print(f"(quick run: {p.relative_to(HERE)} moved to {dest})")


def accepts_quick(path: Path) -> bool:
    return "--quick" in path.read_text(errors="replace")


def busy(seconds: float = 2.0) -> float:
    """The share of all cores' time spent running anything over the next `seconds`
    (/proc/stat; 0 where it is unavailable). Unlike the load average, which lags a minute
    behind, it tells at once whether the bench just finished left the machine idle."""
    _, t0, b0 = cpu_times()
    time.sleep(seconds)
    _, t1, b1 = cpu_times()
    return (b1 - b0) / max(t1 - t0, 1)


def wait_idle() -> float:
    """Wait until the cores are idle (busy below IDLE), at most WAIT seconds; return how busy
    they were when the script starts (recorded beside its result: a busy start shows)."""
    t0 = time.monotonic()
    share = busy()
    while share > IDLE and time.monotonic() - t0 < WAIT:
        share = busy()
    return share


def run(name, args, limit, logs, env):
    script, _, panel = name.partition("@")
    path = HERE / f"{script}.py"
    if not path.exists():
        return {"script": name, "status": "missing", "seconds": 0.0}
    if args is None:
        return {"script": name, "status": "skipped (--full only)", "seconds": 0.0}
    if "--quick" in args and not accepts_quick(path):
        args = [a for a in args if a != "--quick"]
    if panel:
        args = [*args, f"--{panel}"]
    print(f"\n===== {name} {' '.join(args)} =====", flush=True)
    t0 = time.perf_counter()
    lines = []
    proc = subprocess.Popen([sys.executable, "-u", str(path), *args], cwd=str(HERE),
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env, start_new_session=True)
    killed = threading.Event()

    def stop():             # the script and any subprocess it started
        killed.set()
        os.killpg(proc.pid, signal.SIGKILL)

    timer = threading.Timer(limit, stop) if limit else None
    if timer:
        timer.start()
    for line in proc.stdout:
        sys.stdout.write(line)
        sys.stdout.flush()
        lines.append(line)
    rc = proc.wait()
    if timer:
        timer.cancel()
    status = f"killed after {limit} s" if killed.is_set() else ("ok" if rc == 0 else f"failed (exit {rc})")
    wall = time.perf_counter() - t0
    if logs:
        Path(logs).mkdir(parents=True, exist_ok=True)
        (Path(logs) / f"{name.replace('@', '_')}.txt").write_text("".join(lines))
    tail = [l.rstrip() for l in lines if l.strip()][-1:] if lines else []
    return {"script": name, "args": args, "status": status, "seconds": wall,
            "last_line": tail[0] if tail else ""}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="each script at its default (larger) size")
    ap.add_argument("--logs", help="also write each script's output to DIR/NAME.txt")
    ap.add_argument("--out", help="folder for the quick runs' JSON files (default: a temporary one)")
    ap.add_argument("--only", nargs="*", help="run only these scripts (names without .py)")
    opts = ap.parse_args(argv)
    t_all = time.perf_counter()
    results = []
    env = dict(os.environ)
    out = HERE
    if not opts.full:
        out = Path(opts.out or tempfile.mkdtemp(prefix="cosnet_bench_quick_"))
        env["COSNET_BENCH_OUT"] = str(out)
        print(f"quick run: JSON files go to {out}")
    known = {s[0].partition("@")[0] for s in SCRIPTS}
    for name, quick, full, limit in SCRIPTS:
        if opts.only and name not in opts.only:
            continue
        before = None if opts.full else snapshot()
        share = wait_idle() if opts.full else busy(0.5)
        results.append(run(name, full if opts.full else quick, None if opts.full else limit,
                           opts.logs, env) | {"busy_before": share, "load_before": os.getloadavg()[0]})
        if before is not None:
            set_aside(before, out)
    total = time.perf_counter() - t_all
    if opts.full:   # the pages quote the JSON just written
        subprocess.run([sys.executable, str(HERE / "tables.py")], check=False)
        print("README.md and docs/: tables and figures remade from the new JSON")
    others = sorted(p.stem for p in HERE.glob("*.py")
                    if p.stem not in known | {"harness", "run_all", "tables"}
                    and "__main__" in p.read_text(errors="replace"))
    print("\n===== summary =====")
    width = max(len(r["script"]) for r in results) if results else 10
    for r in results:
        print(f"{r['script']:<{width}}  {r['status']:<22} {r['seconds']:8.1f} s"
              + (f"   {r['last_line'][:70]}" if r["status"] != "ok" and r.get("last_line") else ""))
    print(f"{'total':<{width}}  {'':<22} {total:8.1f} s")
    if others:
        print(f"not in the benchmark list (run by hand): {', '.join(others)}")
    print(f"JSON files in {out}")
    command = "python bench/run_all.py " + " ".join(argv or sys.argv[1:])
    record = {"machine": machine(), "mode": "full" if opts.full else "quick", "command": command,
              "total_s": total, "scripts": results}
    last = out / "run_all.json"
    if opts.full and opts.only and last.exists():
        # a partial rerun updates the record of the last full run: its scripts' rows replaced,
        # the rerun itself (machine, commit, seconds) listed beside it
        full = json.loads(last.read_text())
        if full.get("mode") == "full":
            rerun = {r["script"] for r in results}
            full["scripts"] = [next((r for r in results if r["script"] == old["script"]), old)
                               for old in full["scripts"]]
            kept = {o["script"] for o in full["scripts"]}
            full["scripts"] += [r for r in results if r["script"] not in kept]
            full.setdefault("reruns", []).append({"command": command, "machine": record["machine"],
                                                  "seconds": total, "scripts": sorted(rerun)})
            record = full
    last.write_text(json.dumps(record, indent=2))
    return 0 if all(r["status"] == "ok" or r["status"] == "missing" or r["status"].startswith("skipped")
                    for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
