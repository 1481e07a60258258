"""The scene reference of the effects, generated from their declarations (cosnet.engine.registry):

    python -m cosnet.scene.reference > docs/scene_reference.md

One section per effect kind: its keys with type, unit, whether required, default, and the
first paragraph of the class docstring. tests/test_registry.py fails when the committed page
differs from this output.
"""

from __future__ import annotations

import inspect

import numpy as np

from ..core import units as V
from ..engine.registry import Effect, builtin_effects, default_of

REGENERATE = "python -m cosnet.scene.reference > docs/scene_reference.md"

_TYPES = {V.number: "number", V.positive: "number > 0", V.nonnegative: "number >= 0",
          V.vec3: "3 numbers", V.floats: "list of numbers", V.boolean: "true or false",
          V.string: "string", V.string_list: "list of strings", V.integer: "integer >= 1",
          "node": "node name", "line": "line name", "lines": "list of line names",
          "nodes": "list of node names"}


def _type(conv) -> str:
    if conv in _TYPES:
        return _TYPES[conv]
    options = getattr(conv, "options", None)
    if options is not None:
        return " or ".join(f'"{o}"' for o in options)
    doc = inspect.getdoc(conv)
    return doc.splitlines()[0] if doc else getattr(conv, "__name__", "value")


def _default(cls, key) -> str:
    if key.required:
        return ""
    d = default_of(cls, key)
    if d is inspect.Parameter.empty or d is None:
        return "-"
    if isinstance(d, (tuple, list, np.ndarray)):
        return "[" + ", ".join(f"{float(x):g}" for x in d) + "]"
    if isinstance(d, bool):
        return str(d).lower()
    return f"{d:g}" if isinstance(d, float) else str(d)


def _summary(cls) -> str:
    doc = inspect.getdoc(cls) or ""
    return " ".join(doc.split("\n\n")[0].split())


def effect_section(cls: type[Effect]) -> str:
    """The Markdown section of one effect declaration."""
    rows = [f"## `{cls.kind}`", "", f"{_summary(cls)} (`{cls.__module__}.{cls.__name__}`, "
            f"stage {cls.stage})", "",
            "| key | type | unit | required | default | meaning |",
            "|---|---|---|---|---|---|"]
    for k in cls.keys:
        if isinstance(k.unit, dict):   # an inline table: a unit per key of it
            unit = ", ".join(f"{name}: {u.symbol}" for name, u in k.unit.items())
        else:
            unit = k.unit.symbol if k.unit is not None else ""
        rows.append(f"| `{k.name}` | {_type(k.convert)} | {unit} | {'yes' if k.required else ''} | "
                    f"{_default(cls, k)} | {k.doc} |")
    return "\n".join(rows) + "\n"


def scene_reference(effects: dict | None = None) -> str:
    """Markdown reference of the [[effects]] tables of a scene (cosnet's own effects unless
    ``effects``, kind -> class, is given)."""
    effects = builtin_effects() if effects is None else effects
    head = ["# Scene reference: effects", "",
            f"<!-- generated from the effect declarations by `{REGENERATE}`; do not edit -->", "",
            "An `[[effects]]` table (or `[effects.NAME]`) names its `kind` and gives that kind's "
            "keys. Numbers are SI, or in the scaled units of a `[scale]` table, converted with "
            "the unit shown. A key without a default and not required is left to the effect.",
            "", "Kinds: " + ", ".join(f"`{k}`" for k in effects), ""]
    return "\n".join(head) + "\n" + "\n".join(effect_section(c) for c in effects.values())


if __name__ == "__main__":
    print(scene_reference(), end="")
