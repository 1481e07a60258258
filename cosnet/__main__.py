"""`python -m cosnet ...`: the `cosnet` command, from an install or a source checkout."""

from .cli import command

raise SystemExit(command())
