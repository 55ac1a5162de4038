"""Small command-line helpers shared by the programs (argparse edges only)."""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable

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


def run_bench_sections(prog: str, sections: dict[str, str], argv: list[str] | None = None) -> int:
    """The command line of a package's benchmark module (``python -m PKG.bench --json PATH``).

    ``sections`` maps a section name to a module with ``run(quick: bool) -> dict[str, float]``; a section
    that fails is written as ``{"error": ...}`` and the others still run. ``auv-bench`` merges the files.
    """
    import argparse
    import importlib
    import json
    import traceback

    parser = argparse.ArgumentParser(prog=prog)
    parser.add_argument("--json", required=True, help="write the sections here")
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--only", action="append", help="run only these sections")
    args = parser.parse_args(argv)
    result: dict[str, dict[str, float] | dict[str, str]] = {}
    for name, module in sections.items():
        if args.only and name not in args.only:
            continue
        try:
            result[name] = importlib.import_module(module).run(quick=args.quick)
        except ModuleNotFoundError as exc:
            result[name] = {"error": f"not available: {exc}"}
        except Exception as exc:  # a failing section is reported, the others still run
            traceback.print_exc()
            result[name] = {"error": repr(exc)}
    with open(args.json, "w") as f:
        json.dump(result, f, indent=2)
    return 0


def run_one_section(prog: str, run: Callable[[bool], dict[str, float]], argv: list[str] | None) -> int:
    """The command line of one section module run by hand (``python -m MODULE [--quick] [--json]``):
    its figures as a table, or one JSON line."""
    import argparse
    import json
    import sys

    ap = argparse.ArgumentParser(prog=prog)
    ap.add_argument("--quick", action="store_true", help="fewer repetitions")
    ap.add_argument("--json", action="store_true", help="one JSON line instead of the table")
    args = ap.parse_args(argv)
    res = run(args.quick)
    if args.json:
        sys.stdout.write(json.dumps(res) + "\n")
    else:
        width = max((len(k) for k in res), default=0) + 2
        for k, v in res.items():
            sys.stdout.write(f"{k:{width}s} {v:.4f}\n")
    return 0


def yaml_error_line(exc: Exception) -> str:
    """A YAML parse error in one line: ``line L, column C: problem`` where PyYAML marks it (the parsers'
    multi-line messages with a caret drawing are for terminals, not for one-line refusals)."""
    mark = getattr(exc, "problem_mark", None)
    problem = getattr(exc, "problem", None)
    if mark is not None and problem:
        return f"line {mark.line + 1}, column {mark.column + 1}: {problem}"
    return " ".join(str(exc).split())
