"""The ready cases: where they are, and a scene named on the command line."""

from __future__ import annotations

from pathlib import Path


def cases_dir() -> Path:
    """The ready cases: cases/ of a source checkout, or the copy installed as cosnet.cases."""
    package = Path(__file__).resolve().parent.parent
    for cand in (package.parent / "cases", package / "cases"):
        if (cand / "bridge.toml").exists():
            return cand
    raise ValueError("the ready cases (cases/*.toml) were not found next to the package")


def default_scene() -> Path:
    """cases/bridge.toml, the suspension bridge of Figure 1.1."""
    return cases_dir() / "bridge.toml"


def scene_path(arg: str | None) -> Path:
    """A scene file given on the command line, or the name of a ready case (``cantilever``,
    ``hard/column``), or the default case when none is given."""
    if arg is None:
        return default_scene()
    p = Path(arg)
    if p.is_file() or p.suffix == ".toml":
        return p
    case = cases_dir() / f"{arg}.toml"
    if case.exists():
        return case
    names = sorted(str(c.relative_to(cases_dir()).with_suffix("")) for c in cases_dir().rglob("*.toml"))
    raise ValueError(f"{arg}: no such scene file, nor a ready case; cases are {', '.join(names)}")
