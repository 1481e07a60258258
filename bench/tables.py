"""The tables and figures of README.md and docs/, made from the benchmarks' JSON.

A page holds each table between two markers:

    <!-- bench table NAME -->
    | ... generated rows ... |
    <!-- end bench table -->

and each figure quoted in its prose between two markers naming where it comes from:

    one thread: <!-- fig: sci(many_snakes.rows.where(snakes=100).rate) -->4.0 × 10^5<!-- /fig --> rod-steps/s

The expression reads the JSON files beside this script by their names (bench/many_snakes.json
is ``many_snakes``; a key is an attribute, ``rows.where(key=value)`` picks the one row of a list
that matches) and formats with the helpers of FORMATS. The source of a figure is thus in the
page's own text, next to the figure.

`python bench/tables.py [PAGE ...]` rewrites every table and figure (of the pages named, else
of all) from the JSON files (after a benchmark has been rerun); `python bench/tables.py --check`
exits 1, naming the pages, when one differs from its JSON (tests/test_docs.py runs the check),
so a figure cannot drift from the run that produced it.
"""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parent
DOCS = BENCH.parent / "docs"
BLOCK = re.compile(r"(<!-- bench table (\w+) -->\n)(.*?)(<!-- end bench table -->)", re.S)
# a figure: its expression, then its text (one line at most)
FIGURE = re.compile(r"(<!-- fig: (.+?) -->)([^\n]*?)(<!-- /fig -->)")


def _json(name: str) -> dict:
    return json.loads((BENCH / name).read_text(encoding="utf-8"))


def _g(x: float, digits: int = 2) -> str:
    """x to `digits` significant digits, in the e-notation of the pages below 0.01."""
    if x == 0 or not math.isfinite(x):
        return str(x)
    if abs(x) < 0.01:
        return f"{x:.{digits - 1}e}".replace("e-0", "e-")
    return f"{x:.{max(digits - 1 - math.floor(math.log10(abs(x))), 0)}f}"


def _count(x: float) -> str:
    """A rate in millions (element-steps/s)."""
    return f"{x / 1e6:.3g} M"


def _table(head: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def throughput() -> str:
    d = _json("throughput.json")
    rows = [[r["case"], f"{r['elements']:,}", str(r["threads"]), _g(r["us_per_step"], 3),
             _count(r["element_steps_per_s"])] for r in d["throughput"]]
    return _table(["case", "elements", "threads", "µs/step", "element-steps/s"], rows)


def pyelastica() -> str:
    d = _json("pyelastica_compare.json")
    rows = [[r["case"], f"{r['elements']:,}", _g(r["us_per_step_pyelastica"], 3),
             _g(r["us_per_step_cosnet"], 3), f"{r['ratio']:.1f}×"] for r in d["speed"]]
    return _table(["case", "elements", "PyElastica µs/step", "cosnet µs/step", "ratio"], rows)


SPACE_CASES = {   # case in accuracy.json -> what it is, against what
    "freq": ("first bending frequency, clamped–free steel rod, L/r = 50",
             "exact Timoshenko frequency (`cosnet.studies.lincos.analytic_modes`)"),
    "static": ("end-loaded cantilever, static tip deflection (damped to rest)", "P L³/3EI + P L/kGA"),
    "elastica": ("large-deflection cantilever, P L²/EI = 3, tip displacement",
                 "elastica with stretch and shear (`scipy.integrate.solve_bvp`; gives Bisshopp–Drucker's "
                 "0.30172 L at P L²/EI = 1 when inextensible)"),
    "pendulum": ("rigid body (1 kg, I = 0.01 kg m²) on a light stiff line (5 % of its mass), "
                 "released from 1 rad: period",
                 "compound pendulum 4 √(I_p/mgl) K(sin²(θ₀/2))"),
}
TIME_CASES = {
    "transient": "undamped cantilever (n = 8) under a sudden tip load, tip position after 1.5 periods, "
                 "relative to the static deflection; reference: PEFRL at dt/16",
    "energy": "free net (three lines, a rigid body), max \\|E − E₀\\|/E₀ over 30 periods of its slowest mode",
}


def _points(d: dict, case: str, stepper: str) -> list[dict]:
    return [p for p in d["points"] if p["case"] == case and p["stepper"] == stepper]


def accuracy_space() -> str:
    """Error at the stable step (the largest dt of each element count), Verlet."""
    d = _json("accuracy.json")
    rows = []
    for case, (what, ref) in SPACE_CASES.items():
        best: dict[int, dict] = {}
        for p in _points(d, case, "verlet"):
            if p["elements"] not in best or p["dt"] > best[p["elements"]]["dt"]:
                best[p["elements"]] = p
        errs = [f"n = {n}: {_g(best[n]['error'])}" for n in sorted(best)]
        order = d["orders"][f"{case}/verlet"]["space"]
        rows.append([what, ref, ", ".join(errs), f"{order:.2f}"])
    return _table(["case", "reference", "relative error at the stable step", "order in space"], rows)


def accuracy_time() -> str:
    d = _json("accuracy.json")
    rows = []
    for case, what in TIME_CASES.items():
        row = [what]
        for stepper in ("verlet", "pefrl"):
            pts = sorted(_points(d, case, stepper), key=lambda p: -p["dt"])
            row += [", ".join(_g(p["error"]) for p in pts), f"{d['orders'][f'{case}/{stepper}']['time']:.2f}"]
        rows.append(row)
    return _table(["case", "Verlet dt, dt/2, …", "order", "PEFRL dt, dt/2, …", "order"], rows)


EXPERIMENTS = {"catenary": "catenary (pinned cable, elastic catenary)",
               "cantilever": "cantilever (small tip load, Euler–Bernoulli)",
               "pendulum": "pendulum (hanging cable swinging in its first mode)",
               "twist": "twist (Greenhill buckling under driven clamps)",
               "crossing": "crossing (two pinned ropes, one resting on the other; frictionless rod–rod contact)",
               "capstan": "capstan (rope over a fixed cylinder; overhang as a fraction of the longest that holds)",
               "pile": "pile (rope lowered onto a floor; friction on the floor and between rods)"}
METRICS = {"catenary": ("shape_error", "sag_error"), "cantilever": ("tip_deflection_error",),
           "pendulum": ("period_error", "amplitude_change"), "twist": ("critical_twist_error",),
           "crossing": ("shape_error", "lift_error", "settling_residual"),
           "capstan": ("slide", "max_penetration"),
           "pile": ("pile_height", "footprint", "contacts", "settling_residual", "max_penetration",
                    "max_rod_overlap")}


# experiments run at several values of one parameter: a row per value
VARIANT = {"capstan": "overhang"}


def cosseratbench() -> str:
    d = _json("cosseratbench.json")

    def row_key(r):
        key = VARIANT.get(r["experiment"])
        return r["experiment"], (r["values"][key] if key else None)
    by = {(row_key(r), r["solver"]): r for r in d["results"]}
    rows = []
    for exp, value in dict.fromkeys(row_key(r) for r in d["results"]):
        runs = [r for r in d["results"] if row_key(r) == (exp, value)]
        names = METRICS.get(exp) or sorted({k for r in runs for k in r["metrics"]})
        cells, walls = [], []
        for solver in ("cosnet", "pyelastica"):
            r = by.get(((exp, value), solver))
            if r is None or r["outcome"] != "completed":
                cells.append(r["outcome"] if r else "not run")
                walls.append("–")
            else:
                scores = {**r["metrics"], **r.get("observations", {})}
                cells.append(" / ".join(_g(scores[k]) for k in names if k in scores))
                # a run on a loaded machine (cosseratbench_run.py records the load) says so
                load = r.get("load_average", 0.0)
                busy = f" (load {load:.1f})" if load > d["machine"]["cores"] else ""
                walls.append(_g(r["wall_time"]) + busy)
        n = runs[0]["n_elements"]
        metric = " / ".join(k.replace("_", " ") for k in names)
        label = EXPERIMENTS.get(exp, exp) + (f", {VARIANT[exp]} {value:g}" if value is not None else "")
        rows.append([label, str(n), metric, *cells, " / ".join(walls)])
    return _table(["experiment", "elements", "metric", "cosnet", "PyElastica", "wall s cosnet / PyElastica"],
                  rows) + measured_on(d["machine"],
                                      f", cosseratbench {d['cosseratbench']}, `python bench/cosseratbench_run.py`")


def contact_friction() -> str:
    d = _json("contact_scaling.json")["friction"]
    rows = [[f"{r['segments']:,}", f"{r['rod_pairs']:,}", f"{r['ground_contacts']:,}",
             _g(1e3 * r["contact_frictionless_s"]), _g(1e3 * r["contact_friction_s"]),
             _g(r["contact_friction_ns_per_segment"] / 1e3), _g(r["friction_extra_ns_per_pair"] / 1e3),
             _g(r["ground_ns_per_contact"] / 1e3), _g(1e3 * r["step_s"])] for r in d["rows"]]
    e = d["exponents"]
    rows.append(["growth exponent", "", "", "", f"{e['contact_friction_s']:.2f}", "", "", "",
                 f"{e['step_s']:.2f}"])
    return _table(["segments", "rod pairs", "ground contacts", "contact, frictionless (ms)",
                   "contact with friction (ms)", "µs/segment", "friction's extra µs/pair",
                   "ground µs/contact", "step (ms)"], rows)


SNAKE_RUNS = {"cosnet 1 thread": "cosnet, 1 thread", "cosnet 2 threads": "cosnet, 2 threads",
              "cosnet 2 processes": "cosnet, 2 processes", "PyElastica": "PyElastica 1.0.0"}
SNAKE_LONG = {"cosnet 1 thread": "cosnet, 1 thread", "cosnet 1 thread x16 rotary": "cosnet x16 rotary, 1 thread",
              "cosnet 2 processes x16 rotary": "cosnet x16 rotary, 2 processes", "PyElastica": "PyElastica 1.0.0"}


def _snake_rows(unit: str, runs: dict, cell) -> list[list[str]]:
    return [[str(r["snakes"])] + [cell(r[f"{unit}[{k}]"]) if f"{unit}[{k}]" in r else "not run" for k in runs]
            for r in _json("many_snakes.json")["rows"]]


def snakes_rate() -> str:
    """rod-steps/s of the many-snakes runs, at PyElastica's step."""
    return _table(["snakes", *SNAKE_RUNS.values()], _snake_rows("rod_steps_per_s", SNAKE_RUNS, lambda x: f"{x:,.0f}"))


def snakes_simulated() -> str:
    """rod-seconds simulated per wall second, the longer step beside PyElastica's."""
    return _table(["snakes", *SNAKE_LONG.values()], _snake_rows("rod_s_per_s", SNAKE_LONG, lambda x: _g(x, 2)))


def snakes_against() -> str:
    """The many snakes on two cores, this code against an earlier commit's, in alternation."""
    d = _json("snakes_against.json")
    rev = d["against"]
    rows = [[f"{r['size']:,} {'snakes, 2 processes' if r['workload'] == 'snakes' else 'elements, 1 rod'}",
             f"{r['median']['this']:,.0f}", f"{r['median'][rev]:,.0f}",
             _g(r["ratio_of_medians"], 3), f"{100 * r['spread']['this']:.0f} %", f"{100 * r['spread'][rev]:.0f} %",
             _g(r["largest_position_difference_m"], 2),
             _g(r.get("largest_position_difference_no_fastmath_m", float("nan")), 2)] for r in d["rows"]]
    return _table(["workload (rod-steps/s of snakes, element-steps/s of the rod)",
                   f"this code ({d['machine']['commit']})", rev, "ratio", "spread, this", f"spread, {rev}",
                   "largest position difference (m)", f"the same, {rev}'s contact without fast-math (m)"], rows)


def snakes_accuracy() -> str:
    acc = _json("many_snakes.json")["accuracy"]
    rows = [[name, _g(r["dt"], 3), _g(r["velocity"][2], 4), _g(r["velocity"][0], 4),
             f"{100 * r['error_of_forward_speed']:.3f} %" if r["error_of_forward_speed"] else "–"]
            for name, r in acc.items()]
    return _table(["run", "dt (s)", "forward (m/s)", "sideways (m/s)", "difference from the reference / forward speed"],
                  rows)


def measured_on(m: dict, extra: str = "") -> str:
    """The line under a table saying where its figures were measured."""
    where = f"{m.get('cpu_model', m.get('cpu', '?'))}, {m.get('cores', '?')} cores"
    load = f", load average {m['load_average_1min']:.1f} at the end" if "load_average_1min" in m else ""
    return f"\nMeasured on {where}{load}{extra}, commit {m.get('commit', 'unknown')}.\n"


SEEN = {"iso": "", "xy": ", seen along z", "xz": ", seen along y", "yz": ", seen along x"}


def gallery() -> str:
    """docs/cases.md's gallery: each case's picture and GIF, with what they show."""
    d = _json("gallery.json")
    out = []
    for r in d["rows"]:
        seen = SEEN.get(r["view"], f", seen from {r['view']}")
        every = "every frame" if r["gif_every"] == 1 else f"every {r['gif_every']} frames"
        out.append(f"**{r['case']}** — {r['title']}\n\n"
                   f"![{r['title']}: cosnet run {r['case']} at {_g(r['time'], 3)} s of {_g(r['until'], 3)} s, "
                   f"coloured by {r['field']}{seen}](cases/{r['case']}.png)\n"
                   f"![{r['title']}: the whole run, {every}](cases/{r['case']}.gif)\n")
    return "\n".join(out) + f"\nDrawn by `{d['command']}` on commit {d['machine'].get('commit', 'unknown')}.\n"


def soak() -> str:
    d = _json("soak.json")
    rows = [[r["case"], f"{r['steps']:,}", str(r["frames"]), f"{r['wall_s']:.0f}",
             f"{r['rss_mb_at_frame_10']:.0f} → {r['rss_mb_last']:.0f} (max {r['rss_mb_max']:.0f})",
             f"{r['open_files_min']}–{r['open_files_max']}",
             f"{r['energy_first']:.4g} / {r['energy_max']:.4g} / {r['energy_max_second_half']:.4g} / "
             f"{r['energy_last']:.4g}"] for r in d["runs"]]
    return _table(["case", "steps", "frames and checkpoints", "wall s", "resident MB, frame 10 → last",
                   "open files", "energy J: first / max / max of 2nd half / last"], rows) + measured_on(
        d["machine"], f" (load {d['load_before']:.1f} before), `{d['command']}`")


def startup() -> str:
    d = _json("startup.json")
    rows = []
    for r in d["runs"]:
        c, w = r["cold"], r["warm"]
        ph = c["phases"]
        rows.append([r["case"], f"{c['first_frame']:.1f}", f"{ph['import'][0]:.1f}", f"{ph['build'][0]:.1f}",
                     str(c["kernels"]), f"{c['compile'] - c['llvm']:.1f} + {c['llvm']:.1f}",
                     f"{c['waited']:.1f}", f"{c['first_frame'] - c['compile'] - c['waited']:.1f}",
                     f"{w['first_frame']:.2f}", f"{w['phases']['import'][0]:.2f}",
                     f"{r['added']['first_frame']:.1f} ({r['added_kind']})"])
    return _table(["case", "cold: first frame s", "import s", "build s", "kernels compiled here",
                   "compiling s: numba + LLVM", "waiting for the other process s", "rest s", "warm: first frame s",
                   "import s", "warm + a new effect kind: first frame s"], rows) + measured_on(
        d["machine"], f" (load {d['load_before']:.1f} before), `{d['command'].strip()}`, {d['wall_s'] / 60:.0f} min")


def fluid_cost() -> str:
    d = _json("fluid.json")
    rows = [[str(r["elements"]), str(r.get("lines", 1)), r["case"], f"{r['us_per_step']:.3g}",
             f"{r['ns_per_element_step']:.3g}",
             "–" if r["case"].startswith("dry") else f"{r['over_dry_percent']:+.0f} %"] for r in d["runs"]]
    return _table(["elements", "lines", "the wire", "µs per step", "ns per element-step", "over the dry step"],
                  rows) + measured_on(d["machine"], f", one thread, `{d['command']}`")


def moordyn() -> str:
    d = _json("moordyn_compare.json")

    def against(r, k):
        a = r["against_reference"][k]
        return f"{100 * a['amplitude']:+.1f} % / {100 * a['phase_over_period']:+.2f} %"
    rows = [[r["code"], r.get("fast_modes", "-"), str(r["elements"]), _g(r["dt"]),
             _g(r["coupling_step"]) if "coupling_step" in r else "-", f"{r['wall_per_simulated_s']:.3g}",
             f"{r['H']['mean']:.0f}", f"{r['H']['amplitude']:.0f}", f"{r['H']['phase']:.3f}", against(r, "H"),
             f"{r['V']['mean']:.0f}", f"{r['V']['amplitude']:.0f}", f"{r['V']['phase']:.3f}", against(r, "V")]
            for r in d["runs"]]
    return _table(["code", "fast modes", "elements", "dt (s)", "coupling step (s)", "wall s per simulated s",
                   "H mean (N)", "H amplitude (N)", "H phase (rad)", "H: amplitude / phase (of a period) against the "
                   "reference", "V mean (N)", "V amplitude (N)", "V phase (rad)", "V: against the reference"],
                  rows) + measured_on(d["machine"], f", one thread each, `{d['command']}`")


def joints_cost() -> str:
    d = _json("joints.json")
    rows = [[str(r["links"]), str(r.get("elements_per_link", 5)), r["junctions"], f"{r['us_per_step']:.3g}",
             "–" if r["junctions"] == "welded" else f"{r['over_weld_percent']:+.0f} %",
             "–" if r["junctions"] == "welded" else f"{r['us_per_joint']:.2g}", f"{r['stable_dt_over_weld']:.3g}"]
            for r in d["cost"]]
    head = ["links", "elements per link", "junctions", "µs per step", "over the welded chain", "µs per joint",
            "stable step / the welded one's"]
    return _table(head, rows) + measured_on(d["machine"], f", one thread, `{d['command']}`")


def step_profile() -> str:
    d = _json("step_profile.json")
    rows = [[r["scene"], f"{r['us_per_step']:.3g}",
             ", ".join(f"{k} {100 * v:.0f} %" for k, v in r["shares"].items())] for r in d["scenes"]]
    return _table(["scene", "µs per step", "where it goes (share of the samples)"], rows) + measured_on(
        d["machine"], f", one thread, {d['rate_per_s']:,} samples a second, `{d['command']}`")


def rings_cost() -> str:
    d = _json("joints.json")
    rows = [[r["medium"], str(r["rings"]), f"{r['us_per_step']:.3g}",
             "–" if r["rings"] == 0 else f"{r['us_per_ring']:.2g}"] for r in d["rings"]]
    return _table(["medium", "rings", "µs per step", "µs per ring"], rows) + measured_on(
        d["machine"], f", one thread, `{d['command']}`")


def sheaves_cost() -> str:
    d = _json("sheaves.json")
    rows = [[str(r["per_radius"]), str(r["elements"]), str(r["engaged"]), f"{r['us_bare']:.3g}",
             f"{r['us_sheave']:.3g}", f"{r['over_percent']:+.0f} %", f"{r['us_per_engaged']:.2g}"] for r in d["cost"]]
    head = ["elements per radius", "elements", "vertices on the rim", "µs per step, bare rope",
            "µs per step, over the sheave", "over the bare rope", "µs per vertex on the rim"]
    return _table(head, rows) + measured_on(d["machine"], f", one thread, `{d['command']}`")


def sheaves_accuracy() -> str:
    d = _json("accuracy_joints.json")
    rows = [[str(r["per_radius"]), str(r["elements"]), _g(r["dt"], 3), f"{r['steps']:,}", _g(r["drop_error"]),
             _g(r["landings_over_kinetic"]), f"{r['wall_s']:.2g}"] for r in d["atwood"]]
    return _table(["elements per radius", "elements", "stable dt (s)", "steps", "drop against the rigid rope",
                   "landings' energy / kinetic energy", "wall (s)"], rows) + measured_on(
        d["machine"], f", one thread, over {d['atwood_until']} s, `{d['command']}`")


def joints_accuracy() -> str:
    d = _json("accuracy_joints.json")
    rows = [[r["middle"], _g(r["dt"], 3), f"{r['steps']:,}", _g(r["error_over_length"]), f"{r['wall_s']:.2g}"]
            for r in d["hinge"]]
    return _table(["middle junction", "stable dt (s)", "steps", "largest end distance / length", "wall (s)"],
                  rows) + measured_on(d["machine"], f", one thread, over {d['until']} s, `{d['command']}`")


class Data(dict):
    """A JSON object whose keys read as attributes (``many_snakes.machine.cores``)."""

    def __getattr__(self, key):
        try:
            return self[key]
        except KeyError:
            raise AttributeError(f"no key {key!r}; keys: {sorted(self)}") from None


class Rows(list):
    """A JSON list; ``where(key=value, ...)`` is its one element with those values."""

    def where(self, **match):
        return self.one(lambda r: all(r.get(k) == v for k, v in match.items()), match)

    def one(self, test, said=None):
        """Its one element for which test(element) holds (``said``: how an error names the
        test). (A page's ``[...][0]`` would read to the site's builder as a link to a label.)"""
        found = [r for r in self if test(r)]
        if len(found) != 1:
            raise LookupError(f"{len(found)} rows match {said if said is not None else 'the test'}")
        return found[0]

    def each(self, key):
        """The values of ``key`` in every row."""
        return [r[key] for r in self]


def _wrap(value):
    if isinstance(value, dict):
        return Data({k: _wrap(v) for k, v in value.items()})
    if isinstance(value, list):
        return Rows(_wrap(v) for v in value)
    return value


def sci(x: float, digits: int = 2) -> str:
    """x as a × 10^n, `digits` significant digits (4.0 × 10^5)."""
    mantissa, exponent = f"{x:.{digits - 1}e}".split("e")
    return f"{mantissa} × 10^{int(exponent)}"


def pct(x: float, digits: int = 2) -> str:
    """A fraction as a percentage (0.022 -> 2.2 %)."""
    return f"{_g(100 * x, digits)} %"


def span(values, digits: int = 2, fmt=None) -> str:
    """The range of values, low–high (one value when they round alike)."""
    fmt = fmt or (lambda v: _g(v, digits))
    low, high = fmt(min(values)), fmt(max(values))
    return low if low == high else f"{low}–{high}"


def fixed(x: float, decimals: int = 1) -> str:
    """x with a fixed number of decimals."""
    return f"{x:.{decimals}f}"


def on(d: dict) -> str:
    """Where a bench ran: CPU, cores, load average at its end, commit (what a JSON written
    before the harness recorded them all lacks is said to be missing)."""
    m = d["machine"]
    cpu = m.get("cpu_model") or m.get("cpu", "an unrecorded CPU")
    known = [f"{cpu}, {m.get('cores', '?')} cores"]
    if "load_average_1min" in m:
        known.append(f"load {m['load_average_1min']:.1f}")
    if "commit" in m:
        known.append(f"commit {m['commit']}")
    missing = [w for w, k in (("load", "load_average_1min"), ("commit", "commit")) if k not in m]
    return ", ".join(known) + (f" ({' and '.join(missing)} not recorded)" if missing else "")


FORMATS = {"g": _g, "sci": sci, "pct": pct, "span": span, "fixed": fixed, "on": on, "count": _count,
           "min": min, "max": max, "round": round, "len": len, "sum": sum, "abs": abs}


def figures() -> dict:
    """The namespace of the figures' expressions: every bench JSON by name, and FORMATS."""
    names = {p.stem: _wrap(json.loads(p.read_text(encoding="utf-8"))) for p in sorted(BENCH.glob("*.json"))}
    return {**names, **FORMATS}


def figure(expression: str, namespace: dict, where: str) -> str:
    """The text of one figure: its expression evaluated over the bench JSON."""
    try:
        # the pages' own expressions; the namespace as globals, so that comprehensions see it
        return str(eval(expression, {**namespace, "__builtins__": {}}))
    except Exception as e:
        raise ValueError(f"{where}: figure {expression!r}: {type(e).__name__}: {e}") from None


TABLES = {"fluid_cost": fluid_cost, "joints_cost": joints_cost, "joints_accuracy": joints_accuracy,
          "rings_cost": rings_cost, "sheaves_cost": sheaves_cost, "sheaves_accuracy": sheaves_accuracy,
          "moordyn": moordyn, "step_profile": step_profile,
          "soak": soak, "startup": startup, "snakes_rate": snakes_rate, "snakes_simulated": snakes_simulated,
          "snakes_accuracy": snakes_accuracy,
          "snakes_against": snakes_against, "throughput": throughput, "contact_friction": contact_friction,
          "pyelastica": pyelastica, "accuracy_space": accuracy_space, "accuracy_time": accuracy_time,
          "cosseratbench": cosseratbench, "gallery": gallery}


def render(page: Path, namespace: dict | None = None) -> str:
    """The page's text with every marked table and figure made anew from its JSON."""
    def fill(m: re.Match) -> str:
        name = m.group(2)
        if name not in TABLES:
            raise KeyError(f"{page.name}: unknown bench table {name!r}; known: {sorted(TABLES)}")
        return m.group(1) + TABLES[name]() + m.group(4)

    text = page.read_text(encoding="utf-8")
    if "<!-- bench table" in text:
        text = BLOCK.sub(fill, text)
    if "<!-- fig:" in text:
        ns = figures() if namespace is None else namespace
        text = FIGURE.sub(lambda m: m.group(1) + figure(m.group(2), ns, page.name) + m.group(4), text)
    return text


def pages() -> list[Path]:
    """Every page that may quote a bench: README.md and docs/*.md."""
    return [DOCS.parent / "README.md", *sorted(DOCS.glob("*.md"))]


def stale() -> list[str]:
    """Pages whose tables or figures differ from the JSON."""
    ns = figures()
    return [p.name for p in pages() if render(p, ns) != p.read_text(encoding="utf-8")]


def main(argv: list[str]) -> int:
    if "--check" in argv:
        bad = stale()
        for page in bad:
            print(f"{page}: tables or figures differ from bench/*.json; run python bench/tables.py", file=sys.stderr)
        return 1 if bad else 0
    ns = figures()
    chosen = [Path(a).resolve() for a in argv if not a.startswith("--")]   # pages named, else all
    for p in chosen or pages():
        text = render(p, ns)
        if text != p.read_text(encoding="utf-8"):
            p.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (ValueError, KeyError) as e:   # a page's figure or table that its JSON cannot give
        sys.exit(f"bench/tables.py: {e}")
