"""What ``auv-hil campaign`` (:mod:`auv_campaign.cli`) and ``auv-hil tune`` (:mod:`auv_campaign.tune`) share
on their command lines: the exit codes, the executor's options, the one-line usage error and the ``--out``
check. Both import it; neither imports the other's module at load (``cli.main`` loads ``tune`` only for
``tune``), so the two form no import circle (``python -m tests.import_contract`` checks)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

EXIT_OK, EXIT_RUN_ERROR, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


def add_executor_args(p: argparse.ArgumentParser) -> None:
    """``--workers``, ``--ray [ADDRESS]`` and ``--no-progress``: where the runs fly."""
    from auv_campaign.execute import default_workers

    p.add_argument(
        "--workers",
        type=int,
        default=default_workers(),
        help=f"local worker processes, or the CPUs of a local Ray (default: the cores, {default_workers()})",
    )
    p.add_argument(
        "--ray",
        nargs="?",
        const="",
        default=None,
        metavar="ADDRESS",
        help="run the runs as Ray tasks: on a local Ray (no ADDRESS) or on the cluster at ADDRESS",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar (e.g. in a log)")


def fail(prog: str, message: str, code: int = EXIT_USAGE) -> int:
    """``prog: message`` on stderr, one line; returns the exit code (usage by default)."""
    sys.stderr.write(f"{prog}: {message}\n")
    return code


def usable_out_dir(out: Path) -> str:
    """ "" if ``out`` is (or can be made) a directory this process can write in, else why not (one line)."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".write-test"
        probe.write_text("")
        probe.unlink()
    except OSError as exc:
        return f"--out {out}: not a directory that can be written ({exc.strerror or exc})"
    return ""
