"""The ``[mavlink]`` table of ``onboard.toml`` as a frozen dataclass (strict: unknown keys stop start-up).

Example::

    [mavlink]
    endpoints = ["udpout:127.0.0.1:14550", "tcpin:127.0.0.1:5760"]  # udpout, udpin (port 0 = any), tcpin
    gcs_loss_action = "continue"
    signing_key_file = ""                      # empty = signing off
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal

from auv_common.config import Bound, ConfigError, check_declared, from_table, param, require

ENDPOINT_KINDS = ("udpout", "udpin", "tcpin")
#: A telemetry rate's maximum: 100 Hz, and no more than the link's ``max_stream_rate_hz``.
_RATE_MAX = Bound(lambda c: min(100.0, c.max_stream_rate_hz), "the smaller of 100 and max_stream_rate_hz")


def _rate(default_hz: float, what: str) -> Any:
    return param(default_hz, unit="Hz", min=0.0, max=_RATE_MAX, desc=f"{what} rate (0 = off)")


def parse_endpoint(spec: str) -> tuple[str, str, int]:
    """Split ``kind:host:port`` into its parts; raise :class:`ConfigError` when malformed."""
    parts = spec.split(":")
    if len(parts) != 3 or parts[0] not in ENDPOINT_KINDS:
        raise ConfigError(f"endpoint {spec!r}: expected one of {'/'.join(ENDPOINT_KINDS)}:HOST:PORT")
    try:
        port = int(parts[2])
    except ValueError:
        raise ConfigError(f"endpoint {spec!r}: port is not an integer") from None
    if not 0 <= port <= 65535 or (parts[0] == "udpout" and port == 0):
        raise ConfigError(f"endpoint {spec!r}: port out of range")
    return parts[0], parts[1], port


@dataclass(frozen=True)
class MavlinkConfig:
    """MAVLink endpoint settings. Rates in Hz (0 = off), times in s, angles in deg.

    The mission limits (operating area, depth, counts) are not here: the mission validator owns them; nor is
    the state directory: the vehicle's store has its own table, ``[store] dir`` (:mod:`onboard.app.store`).
    """

    #: Keys that moved: refused with the reason (auv_common.config.from_table).
    REMOVED_KEYS: ClassVar[dict[str, str]] = {
        "state_dir": "the vehicle's state store has its own table: set [store] dir (store.dir) instead",
    }

    enabled: bool = True
    endpoints: tuple[str, ...] = ("udpout:127.0.0.1:14550",)
    system_id: int = param(1, min=1, max=255, desc="MAVLink system id of the vehicle")
    component_id: int = param(1, min=1, max=255, desc="MAVLink component id (MAVSDK wants 1)")
    heartbeat_rate_hz: float = _rate(1.0, "HEARTBEAT")
    position_rate_hz: float = _rate(5.0, "LOCAL_POSITION_NED")
    attitude_rate_hz: float = _rate(10.0, "ATTITUDE")
    nav_rate_hz: float = _rate(5.0, "NAV_CONTROLLER_OUTPUT")
    actuator_rate_hz: float = _rate(5.0, "ACTUATOR_OUTPUT_STATUS")
    sys_status_rate_hz: float = _rate(1.0, "SYS_STATUS")
    mission_current_rate_hz: float = _rate(1.0, "MISSION_CURRENT")
    home_rate_hz: float = _rate(0.2, "HOME_POSITION and GPS_GLOBAL_ORIGIN")
    gcs_timeout_s: float = param(
        5.0, unit="s", min=0.5, max=3600.0, desc="no ground-station HEARTBEAT for this long: gcs_loss_action"
    )
    gcs_loss_action: Literal["continue", "hold", "surface"] = "continue"
    origin_lat_deg: float = param(35.1, unit="deg", min=-90.0, max=90.0, desc="latitude of the local origin")
    origin_lon_deg: float = param(
        129.04, unit="deg", min=-180.0, max=180.0, desc="longitude of the local origin"
    )
    origin_alt_m: float = param(0.0, unit="m", desc="AMSL altitude of the local origin (the sea surface)")
    item_timeout_s: float = param(
        0.25, unit="s", min=0.01, max=10.0, desc="re-request a missing mission item after this"
    )
    upload_timeout_s: float = 5.0  # give up an upload after this long without progress
    validate_timeout_s: float = param(
        3.0, unit="s", min=0.1, max=60.0,
        desc="a mission check (worker thread) that takes longer refuses the upload",
    )  # fmt: skip
    command_timeout_s: float = param(
        1.0, unit="s", min=0.05, max=30.0,
        desc="a command the loop has not taken by then: TEMPORARILY_REJECTED",
    )  # fmt: skip
    signing_key_file: str = ""  # empty = signing off; 32 raw bytes or 64 hex characters
    #: endpoints (of ``endpoints``) over which SETUP_SIGNING is taken without a signature (a secure link:
    #: a USB serial, a loopback only the vehicle's computer reaches); elsewhere it must be signed
    secure_endpoints: tuple[str, ...] = ()
    signing_link_id: int = param(0, min=0, max=255, desc="link id of the signatures the vehicle sends")
    rx_peer_per_s: int = param(
        500, unit="1/s", min=10, max=1_000_000,
        desc="datagrams (TCP: messages) parsed per second per known peer; the rest shed",
    )  # fmt: skip
    rx_strangers_per_s: int = param(
        200, unit="1/s", min=10, max=1_000_000,
        desc="the same, shared by every address not (yet) a known peer",
    )  # fmt: skip
    #: per link: a SET_MESSAGE_INTERVAL asks for at most this rate (faster requests are clamped to it)
    max_stream_rate_hz: float = param(
        50.0, unit="Hz", min=1.0, max=100.0, desc="a SET_MESSAGE_INTERVAL asks for at most this rate"
    )
    #: per link: messages sent per second to one peer (its output budget; strangers share one); the rest
    #: is dropped (counted as ``tx_shed``), so what one peer asks for never costs another its telemetry
    tx_peer_per_s: int = param(
        2000, unit="1/s", min=10, max=1_000_000,
        desc="messages sent per second to one peer (its output budget)",
    )  # fmt: skip
    #: a TCP connection that sends no MAVLink message for this long is closed
    tcp_idle_timeout_s: float = param(
        20.0, unit="s", min=1.0, max=3600.0, desc="a TCP connection silent for this long is closed"
    )
    #: when the connection table is full, the longest-silent connection gives way to a new one if it has
    #: been silent this long (a live ground station sends its HEARTBEAT every second, so it is kept)
    tcp_evict_idle_s: float = param(
        3.0, unit="s", min=0.5, max=Bound(lambda c: c.tcp_idle_timeout_s, "tcp_idle_timeout_s"),
        desc="connection table full: a connection silent this long gives way to a new one",
    )  # fmt: skip

    def __post_init__(self) -> None:
        require(len(self.endpoints) >= 1 or not self.enabled, "endpoints: at least one when enabled")
        for spec in self.endpoints:
            parse_endpoint(spec)
        for spec in self.secure_endpoints:
            require(spec in self.endpoints, f"secure_endpoints: {spec!r} is not one of endpoints")
        check_declared(self)
        require(
            self.item_timeout_s < self.upload_timeout_s <= 600.0,
            f"upload_timeout_s must exceed item_timeout_s and be <= 600, got {self.upload_timeout_s}",
        )

    @classmethod
    def from_table(cls, table: dict[str, Any] | None, where: str = "onboard.toml [mavlink]") -> MavlinkConfig:
        """Build from the ``[mavlink]`` TOML table (unknown keys and bad values raise ConfigError)."""
        return from_table(cls, table, where)


def load_signing_key(path: str | Path) -> bytes:
    """Read a 32-byte signing key: the file holds 32 raw bytes or 64 hex characters."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise ConfigError(f"{p}: cannot read signing key: {exc}") from None
    text = data.strip()
    if len(text) == 64:
        try:
            return bytes.fromhex(text.decode("ascii"))
        except (UnicodeDecodeError, ValueError):
            pass
    if len(data) == 32:
        return data
    raise ConfigError(f"{p}: a signing key is 32 raw bytes or 64 hex characters")
