"""The ground station's MAVLink client as one object: a :class:`~groundstation.link.Link` with its four
clients, each its own module, mirroring the vehicle's services:

- :attr:`MavClient.mission`: :class:`~groundstation.mission_client.MissionClient` (upload, download, clear);
- :attr:`MavClient.commands`: :class:`~groundstation.command_client.CommandClient` (COMMAND_LONG and ACK);
- :attr:`MavClient.params`: :class:`~groundstation.param_client.ParamClient` (list, get, set);
- :attr:`MavClient.ftp`: :class:`~groundstation.ftp_client.FtpClient` (read a file, its CRC, a directory).

The link is the object itself (sockets, signing, tlog, heartbeat, ``recv``, ``texts``, ``target``). The
methods below hand each call to its client unchanged: the names the tests, the benches and the map use
(``client.upload(...)``, ``client.param_get(...)``, ...). The names of the split modules are re-exported
here for the same reason.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from groundstation.command_client import CommandAck, CommandClient
from groundstation.ftp_client import FtpClient
from groundstation.link import REASON_WINDOW_S, Link, LinkError, SigningStats
from groundstation.messages import (
    ARDUSUB_AUTO,
    ARDUSUB_CIRCLE,
    ARDUSUB_MANUAL,
    ARDUSUB_POSHOLD,
    ARDUSUB_SURFACE,
    MAV_RESULT_NAMES,
    MAV_STATE_NAMES,
    MISSION_RESULT_NAMES,
    NOT_READY_STATES,
    STATUSTEXT_LEN,
    Msg,
    StatusText,
    StatusTextAssembler,
    state_from_heartbeat,
)
from groundstation.mission_client import MISSION_REPLIES, Item, MissionClient, TransferResult
from groundstation.param_client import ParamClient, UnknownParameter

__all__ = [
    "ARDUSUB_AUTO",
    "ARDUSUB_CIRCLE",
    "ARDUSUB_MANUAL",
    "ARDUSUB_POSHOLD",
    "ARDUSUB_SURFACE",
    "MAV_RESULT_NAMES",
    "MAV_STATE_NAMES",
    "MISSION_REPLIES",
    "MISSION_RESULT_NAMES",
    "NOT_READY_STATES",
    "REASON_WINDOW_S",
    "STATUSTEXT_LEN",
    "CommandAck",
    "Item",
    "LinkError",
    "MavClient",
    "Msg",
    "SigningStats",
    "StatusText",
    "StatusTextAssembler",
    "TransferResult",
    "UnknownParameter",
    "state_from_heartbeat",
]


class MavClient(Link):
    """A link to the vehicle and the clients that speak over it (see the module docstring)."""

    def __init__(
        self,
        url: str = "udpin:0.0.0.0:14550",
        *,
        system_id: int = 255,
        component_id: int = 190,
        tlog: Path | None = None,
        signing_key: bytes | None = None,
        heartbeat_period_s: float = 1.0,
        gcs_session: bool = True,
    ) -> None:
        super().__init__(
            url,
            system_id=system_id,
            component_id=component_id,
            tlog=tlog,
            signing_key=signing_key,
            heartbeat_period_s=heartbeat_period_s,
            gcs_session=gcs_session,
        )
        self.mission = MissionClient(self)
        self.commands = CommandClient(self)
        self.params = ParamClient(self)
        self.ftp = FtpClient(self)

    # ---- the mission protocol ------------------------------------------------------------------
    def upload(
        self,
        items: list[Item],
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
        *,
        progress: Callable[[int, int], None] | None = None,
        resend_s: float = 0.4,
        timeout_s: float = 8.0,
    ) -> TransferResult:
        """:meth:`MissionClient.upload`."""
        return self.mission.upload(
            items, mission_type, progress=progress, resend_s=resend_s, timeout_s=timeout_s
        )

    def download(
        self,
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
        *,
        resend_s: float = 0.5,
        retries: int = 10,
    ) -> list[Item]:
        """:meth:`MissionClient.download`."""
        return self.mission.download(mission_type, resend_s=resend_s, retries=retries)

    def clear(
        self, mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION, *, resend_s: float = 0.5
    ) -> TransferResult:
        """:meth:`MissionClient.clear`."""
        return self.mission.clear(mission_type, resend_s=resend_s)

    # ---- commands ------------------------------------------------------------------------------
    def command(self, command: int, *params: float, resend_s: float = 1.0, retries: int = 3) -> int:
        """:meth:`CommandClient.command`."""
        return self.commands.command(command, *params, resend_s=resend_s, retries=retries)

    def command_ack(
        self,
        command: int,
        *params: float,
        resend_s: float = 1.0,
        retries: int = 3,
        reason: bool = True,
        window_s: float = REASON_WINDOW_S,
    ) -> CommandAck:
        """:meth:`CommandClient.command_ack`."""
        return self.commands.command_ack(
            command, *params, resend_s=resend_s, retries=retries, reason=reason, window_s=window_s
        )

    # ---- parameters ----------------------------------------------------------------------------
    def param_list(self, *, quiet_s: float = 1.0, timeout_s: float = 10.0) -> dict[str, float]:
        """:meth:`ParamClient.get_all`."""
        return self.params.get_all(quiet_s=quiet_s, timeout_s=timeout_s)

    def param_get(self, name: str, *, resend_s: float = 0.5, retries: int = 5) -> float:
        """:meth:`ParamClient.get`."""
        return self.params.get(name, resend_s=resend_s, retries=retries)

    def param_set(
        self, name: str, value: float, *, resend_s: float = 0.5, retries: int = 5
    ) -> tuple[bool, float]:
        """:meth:`ParamClient.set`."""
        return self.params.set(name, value, resend_s=resend_s, retries=retries)

    # ---- MAVLink FTP ---------------------------------------------------------------------------
    def read_file(
        self,
        path: str,
        on_other: Callable[[Msg], None] | None = None,
        *,
        progress: Callable[[int, int], None] | None = None,
    ) -> bytes:
        """:meth:`FtpClient.read_file`."""
        return self.ftp.read_file(path, on_other, progress=progress)

    def file_crc32(self, path: str, on_other: Callable[[Msg], None] | None = None) -> int | None:
        """:meth:`FtpClient.file_crc32`."""
        return self.ftp.file_crc32(path, on_other)

    def list_dir(
        self, path: str, on_other: Callable[[Msg], None] | None = None
    ) -> list[tuple[str, str, int]]:
        """:meth:`FtpClient.list_dir`."""
        return self.ftp.list_dir(path, on_other)
