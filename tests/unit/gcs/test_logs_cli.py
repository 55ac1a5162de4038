"""``auv-gcs logs get``: a name from the vehicle's listing is never a path; a file it cannot write is one
line with the reason."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import pytest

from groundstation.__main__ import EXIT_ERROR, _logs
from groundstation.link import LinkError
from groundstation.output import Out


class Lister:
    def __init__(self, names: list[str]) -> None:
        self.names = names

    def list_dir(self, path: str) -> list[tuple[str, str, int]]:
        return [("F", n, 3) for n in self.names]

    def read_file(self, path: str, progress: Any = None) -> bytes:
        return b"abc"


def args(tmp_path: Path, output: Path | None = None) -> argparse.Namespace:
    return argparse.Namespace(action="get", name=None, output=output)


@pytest.mark.parametrize("name", ["../../.bashrc", "/etc/passwd", "sub/flight.mcap", ".."])
def test_a_listed_name_that_is_a_path_is_refused(tmp_path: Path, name: str) -> None:
    with pytest.raises(LinkError, match="a log name that is a path"):
        _logs(args(tmp_path, tmp_path), Lister([name]), Out(True))  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_a_file_that_cannot_be_written_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "no-such-folder" / "x.mcap"
    code = _logs(args(tmp_path, target), Lister(["flight-20261202-010000.mcap"]), Out(True))  # type: ignore[arg-type]
    out = capsys.readouterr().out.strip().splitlines()
    assert code == EXIT_ERROR and len(out) == 1 and "cannot write" in out[0] and "No such file" in out[0]
