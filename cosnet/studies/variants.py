"""The variants of a sweep: a base scene document and variations of its keys.

A variation is written ``KEY=VALUES``: KEY a dotted path into the scene's TOML
(``materials.steel.E``, ``lines."λ1".elements``, ``effects[1].translational``), VALUES a comma
separated list of TOML values (``1e11, 2e11``, ``"pefrl"``, ``[0, 0, -9.81]``; a bare word is a
string) or a range ``linspace(a, b, n)``, ``logspace(a, b, n)`` (10**a .. 10**b, as numpy) or
``geomspace(a, b, n)``. Variations combine as a full product (or, zipped, element by element);
an ensemble of N adds the seeds of ``[initial.perturbation]``. Every variant's document goes
through ``build_scene`` -- the loader of the file -- so a misspelt key or a wrong type gets the
file's one-line error before anything runs.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import re
import tomllib
from dataclasses import dataclass

import numpy as np

from .runner import schedule
from ..scene.loader import build_scene

SEED_KEY = "initial.perturbation.seed"
_PART = re.compile(r'(?:"(?P<q>[^"]*)"|(?P<b>[A-Za-z0-9_\-]+))(?P<idx>(?:\[\d+\])*)')
_RANGE = re.compile(r"^\s*(linspace|logspace|geomspace)\s*\((.*)\)\s*$", re.S)
_WORD = re.compile(r"^[A-Za-z_][A-Za-z0-9_.@\-]*$")


@dataclass
class Variant:
    """One run of a sweep: its ``index``, the varied ``values`` (dotted key -> value), its
    scene document ``doc``, the validated ``scene`` and ``key``, a hash of doc and end time."""

    index: int
    values: dict
    doc: dict
    scene: object
    key: str


def split_path(key: str, where: str) -> list:
    """The parts of a dotted path: names (str) and list indices (int)."""
    parts, pos = [], 0
    while True:
        m = _PART.match(key, pos)
        if m is None or not m.group(0):
            raise ValueError(f"{where}: --vary {key!r}: cannot read the key at {key[pos:]!r} "
                             f"(use a dotted path such as materials.steel.E)")
        parts.append(m["q"] if m["q"] is not None else m["b"])
        parts += [int(i) for i in re.findall(r"\[(\d+)\]", m["idx"])]
        pos = m.end()
        if pos == len(key):
            return parts
        if key[pos] != ".":
            raise ValueError(f"{where}: --vary {key!r}: cannot read the key at {key[pos:]!r}")
        pos += 1


def set_path(doc: dict, key: str, value, where: str):
    """Set ``key`` (a dotted path) in the document ``doc``, creating missing tables; whether
    the key means anything is for the scene loader to say."""
    parts = split_path(key, where)
    node = doc
    for j, part in enumerate(parts):
        last = j == len(parts) - 1
        here = ".".join(map(str, parts[:j])) or "the scene"
        if isinstance(node, list):
            i = int(part) if isinstance(part, int) or str(part).isdigit() else None
            if i is None or not 0 <= i < len(node):
                raise ValueError(f"{where}: --vary {key}: {here} is a list of {len(node)} "
                                 f"tables; {part!r} is not an index of it")
            part = i
        elif not isinstance(node, dict):
            raise ValueError(f"{where}: --vary {key}: {here} is a value, not a table")
        elif isinstance(part, int):
            raise ValueError(f"{where}: --vary {key}: {here} is a table, not a list")
        if last:
            node[part] = value
        else:
            if isinstance(node, dict) and part not in node:
                node[part] = {}
            node = node[part]


def parse_values(text: str, key: str, where: str) -> list:
    """The values of one variation: a TOML list's items or a linspace/logspace/geomspace range."""
    bad = f"{where}: --vary {key}"
    m = _RANGE.match(text)
    if m:
        return _range(m[1], m[2], bad)
    if re.match(r"^\s*\w+\s*\(", text):
        raise ValueError(f"{bad}: cannot parse {text.strip()!r}: ranges are linspace(a, b, n), "
                         f"logspace(a, b, n) or geomspace(a, b, n)")
    if not text.strip():
        raise ValueError(f"{bad}: no values (write KEY=V1,V2,... or KEY=linspace(a, b, n))")
    try:
        values = tomllib.loads(f"v = [{text}]")["v"]
    except tomllib.TOMLDecodeError:
        values = []
        for item in _split_items(text):
            try:
                values.append(tomllib.loads(f"v = {item}")["v"])
            except tomllib.TOMLDecodeError:
                if not _WORD.match(item):
                    raise ValueError(f"{bad}: cannot parse the value {item!r} (numbers, "
                                     f"true/false, \"strings\" or [arrays])") from None
                values.append(item)
    if not values:
        raise ValueError(f"{bad}: no values (write KEY=V1,V2,... or KEY=linspace(a, b, n))")
    return values


def _split_items(text: str) -> list[str]:
    """Comma separated items, commas inside brackets or quotes kept."""
    items, depth, quote, cur = [], 0, None, ""
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            items.append(cur.strip())
            cur = ""
            continue
        cur += ch
    items.append(cur.strip())
    return [i for i in items if i]


def _range(kind: str, args: str, bad: str) -> list:
    parts = [a.strip() for a in args.split(",")]
    form = f"{kind}(a, b, n)"
    if len(parts) != 3:
        raise ValueError(f"{bad}: cannot parse {kind}({args}): expected {form}")
    try:
        a, b = float(parts[0]), float(parts[1])
        n = int(parts[2])
    except ValueError:
        raise ValueError(f"{bad}: cannot parse {kind}({args}): expected {form} with numbers "
                         f"a, b and an integer n") from None
    if n < 1 or not (np.isfinite(a) and np.isfinite(b)):
        raise ValueError(f"{bad}: {kind}({args}): n must be at least 1 and a, b finite")
    if kind == "geomspace" and (a <= 0 or b <= 0):
        raise ValueError(f"{bad}: {kind}({args}): a and b must be positive")
    vals = getattr(np, kind)(a, b, n)
    ints = kind == "linspace" and all(re.fullmatch(r"[+-]?\d+", p) for p in parts[:2])
    if ints and np.all(vals == np.round(vals)):
        return [int(v) for v in vals]
    return [float(v) for v in vals]


def parse_vary(spec: str, where: str) -> tuple[str, list]:
    """``KEY=VALUES`` -> (KEY, values)."""
    key, eq, text = spec.partition("=")
    key = key.strip()
    if not eq or not key:
        raise ValueError(f"{where}: --vary {spec!r}: write KEY=VALUES, e.g. materials.steel.E=1e11,2e11")
    split_path(key, where)
    return key, parse_values(text, key, where)


def plan(doc: dict, path, axes: list[tuple[str, list]], zipped: bool = False,
         ensemble: int = 0, until: float | None = None) -> list[Variant]:
    """The validated variants of a base document and its variation axes (key, values)."""
    where = str(path)
    axes = list(axes)
    keys = [k for k, _ in axes]
    if len(set(keys)) != len(keys):
        dup = next(k for k in keys if keys.count(k) > 1)
        raise ValueError(f"{where}: --vary {dup}: varied twice")
    if zipped and len({len(v) for _, v in axes}) > 1:
        lens = ", ".join(f"{k}: {len(v)}" for k, v in axes)
        raise ValueError(f"{where}: --zip needs lists of one length, got {lens}")
    combos = (list(zip(*(v for _, v in axes))) if zipped and axes
              else list(itertools.product(*(v for _, v in axes))))
    if ensemble:
        if isinstance(ensemble, bool) or not isinstance(ensemble, int) or ensemble < 1:
            raise ValueError(f"--ensemble must be a positive integer, got {ensemble!r}")
        if SEED_KEY in keys:
            raise ValueError(f"{where}: --ensemble sets {SEED_KEY}; do not vary it as well")
        base = doc.get("initial", {}).get("perturbation", {}).get("seed", 0)
        base = base if isinstance(base, int) else 0
        keys = keys + [SEED_KEY]
        combos = [c + (base + i,) for c in combos for i in range(ensemble)]
    out = []
    for i, combo in enumerate(combos):
        d = copy.deepcopy(doc)
        for k, v in zip(keys, combo):
            set_path(d, k, v, where)
        scene = build_scene(d, path)
        schedule(scene, until)
        blob = json.dumps([d, until], sort_keys=True, default=repr).encode()
        out.append(Variant(i, dict(zip(keys, combo)), d, scene, hashlib.sha256(blob).hexdigest()[:16]))
    return out
