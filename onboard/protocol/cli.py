"""Small command-line helpers shared by the programs (argparse edges only)."""

from __future__ import annotations

import re
from collections.abc import Iterable

_NEGATIVE = re.compile(r"^-[0-9.]")


def join_negative_values(argv: list[str], value_options: Iterable[str]) -> list[str]:
    """Turn ``--start -15,5,0`` into ``--start=-15,5,0``: argparse takes '-15,5,0' for an option.

    Only the options in ``value_options`` (which take numbers) are joined; ``--start=-15,5,0`` passes as is.
    """
    options = frozenset(value_options)
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        if tok in options and i + 1 < len(argv) and _NEGATIVE.match(argv[i + 1]):
            out.append(f"{tok}={argv[i + 1]}")
            i += 2
            continue
        out.append(tok)
        i += 1
    return out
