"""What ``auv-gcs`` says and how it ends: the console or JSON lines (:class:`Out`) and the exit codes, one
owner for the sub-commands in ``__main__`` and ``fly``."""

from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20 import common as mavlink
from rich.text import Text

from groundstation.text import plain

if TYPE_CHECKING:
    from rich.progress import Progress

EXIT_OK, EXIT_REFUSED, EXIT_ERROR, EXIT_NOT_NOW, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
EXIT_STATUS = """exit status:
  0    accepted / done (fly: COMPLETE)
  1    refused by the vehicle: MAV_RESULT_DENIED, _FAILED, _UNSUPPORTED, or a MAV_MISSION_* error;
       fly: also the vehicle stopped short of COMPLETE (ABORT, HOLD, disarmed)
       (the vehicle's reason is printed, and is the "reason" of --json)
  2    usage, file or link error (no heartbeat, no answer; logs: no such log on the vehicle)
  3    temporarily rejected: MAV_RESULT_TEMPORARILY_REJECTED (valid, but not now, e.g. the navigation
       is not valid yet: try again later), or wait-ready / fly not ready in time
  130  interrupted (fly: HOLD sent if the mission had been started)"""


def exit_code_of_command(result: int) -> int:
    """The exit code of a command's MAV_RESULT (see :data:`EXIT_STATUS`)."""
    if result == mavlink.MAV_RESULT_ACCEPTED:
        return EXIT_OK
    if result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED:
        return EXIT_NOT_NOW
    return EXIT_REFUSED


class Out:
    """The operator's console (rich), or with ``--json`` one JSON line per result on stdout (the console
    then writes to stderr)."""

    def __init__(self, as_json: bool) -> None:
        self.as_json = as_json
        from rich.console import Console

        self.console = Console(stderr=as_json, soft_wrap=True)  # a line is one line, however long

    def done(self, data: dict[str, Any], text: str | Text) -> None:
        """``data`` as a JSON line (``--json``), else ``text`` (:meth:`show`)."""
        if self.as_json:
            sys.stdout.write(json.dumps(data, default=str) + "\n")
        else:
            self.show(text)

    def show(self, text: str | Text) -> None:
        """``text`` on the console, never as markup: a ``str`` is one line, shown as it is but for the
        control characters of the wire's words in it (:func:`groundstation.text.plain`); several lines and
        styled parts come as rich Text (:mod:`groundstation.text`'s ``lines`` and ``labelled``)."""
        self.console.print(text if isinstance(text, Text) else plain(text))

    def progress(self) -> Progress:
        """rich's progress bar, its description (a file name may be the vehicle's) never markup."""
        from rich.progress import Progress, TextColumn

        return Progress(
            TextColumn("{task.description}", markup=False),
            *Progress.get_default_columns()[1:],
            console=self.console,
            transient=True,
        )
