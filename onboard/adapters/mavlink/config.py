"""The ``[mavlink]`` table of ``onboard.toml`` as a frozen dataclass (strict: unknown keys stop start-up).

Example::

    [mavlink]
    endpoints = ["udpout:127.0.0.1:14550", "tcpin:127.0.0.1:5760"]  # udpout, udpin (port 0 = any), tcpin
    gcs_loss_action = "continue"
    signing_key_file = ""                      # empty = signing off
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from auv_common.config import ConfigError, from_table, require

ENDPOINT_KINDS = ("udpout", "udpin", "tcpin")


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


def default_state_dir() -> Path:
    """Per-user state path: ``$XDG_STATE_HOME/isimi100`` or ``~/.local/state/isimi100``."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "isimi100"


@dataclass(frozen=True)
class MavlinkConfig:
    """MAVLink endpoint settings. Rates in Hz (0 = off), times in s, angles in deg.

    The mission limits (operating area, depth, counts) are not here: the mission validator owns them.
    """

    enabled: bool = True
    endpoints: tuple[str, ...] = ("udpout:127.0.0.1:14550",)
    system_id: int = 1
    component_id: int = 1  # MAVSDK ignores autopilots with another component id
    heartbeat_rate_hz: float = 1.0
    position_rate_hz: float = 5.0  # LOCAL_POSITION_NED
    attitude_rate_hz: float = 10.0  # ATTITUDE
    nav_rate_hz: float = 5.0  # NAV_CONTROLLER_OUTPUT
    actuator_rate_hz: float = 5.0  # ACTUATOR_OUTPUT_STATUS
    sys_status_rate_hz: float = 1.0  # SYS_STATUS
    mission_current_rate_hz: float = 1.0  # MISSION_CURRENT
    home_rate_hz: float = 0.2  # HOME_POSITION and GPS_GLOBAL_ORIGIN
    gcs_timeout_s: float = 5.0
    gcs_loss_action: Literal["continue", "hold", "surface"] = "continue"
    origin_lat_deg: float = 35.1
    origin_lon_deg: float = 129.04
    origin_alt_m: float = 0.0  # AMSL altitude of the local origin (the sea surface)
    item_timeout_s: float = 0.25  # re-request a missing mission item after this
    upload_timeout_s: float = 5.0  # give up an upload after this long without progress
    validate_timeout_s: float = 3.0  # a mission check (worker thread) that takes longer refuses the upload
    command_timeout_s: float = 1.0  # a command the loop has not taken by then: TEMPORARILY_REJECTED
    state_dir: str = ""  # empty = default_state_dir()
    signing_key_file: str = ""  # empty = signing off; 32 raw bytes or 64 hex characters
    #: endpoints (of ``endpoints``) over which SETUP_SIGNING is taken without a signature (a secure link:
    #: a USB serial, a loopback only the vehicle's computer reaches); elsewhere it must be signed
    secure_endpoints: tuple[str, ...] = ()
    signing_link_id: int = 0
    rx_peer_per_s: int = 500  # datagrams (TCP: messages) parsed per second per known peer; the rest shed
    rx_strangers_per_s: int = 200  # the same, shared by every address not (yet) a known peer
    #: per link: a SET_MESSAGE_INTERVAL asks for at most this rate (faster requests are clamped to it)
    max_stream_rate_hz: float = 50.0
    #: per link: messages sent per second to one peer (its output budget; strangers share one); the rest
    #: is dropped (counted as ``tx_shed``), so what one peer asks for never costs another its telemetry
    tx_peer_per_s: int = 2000
    #: a TCP connection that sends no MAVLink message for this long is closed
    tcp_idle_timeout_s: float = 20.0
    #: when the connection table is full, the longest-silent connection gives way to a new one if it has
    #: been silent this long (a live ground station sends its HEARTBEAT every second, so it is kept)
    tcp_evict_idle_s: float = 3.0

    def __post_init__(self) -> None:
        require(len(self.endpoints) >= 1 or not self.enabled, "endpoints: at least one when enabled")
        for spec in self.endpoints:
            parse_endpoint(spec)
        for spec in self.secure_endpoints:
            require(spec in self.endpoints, f"secure_endpoints: {spec!r} is not one of endpoints")
        require(1 <= self.system_id <= 255, f"system_id must be 1..255, got {self.system_id}")
        require(1 <= self.component_id <= 255, f"component_id must be 1..255, got {self.component_id}")
        for name in (
            "heartbeat_rate_hz",
            "position_rate_hz",
            "attitude_rate_hz",
            "nav_rate_hz",
            "actuator_rate_hz",
            "sys_status_rate_hz",
            "mission_current_rate_hz",
            "home_rate_hz",
        ):
            v = getattr(self, name)
            require(0.0 <= v <= 100.0, f"{name} must be within 0..100 Hz, got {v}")
            require(
                v <= self.max_stream_rate_hz,
                f"{name} ({v} Hz) must not exceed max_stream_rate_hz ({self.max_stream_rate_hz} Hz)",
            )
        require(
            1.0 <= self.max_stream_rate_hz <= 100.0,
            f"max_stream_rate_hz must be within 1..100 Hz, got {self.max_stream_rate_hz}",
        )
        require(10 <= self.tx_peer_per_s <= 1_000_000, f"tx_peer_per_s out of range: {self.tx_peer_per_s}")
        require(
            1.0 <= self.tcp_idle_timeout_s <= 3600.0,
            f"tcp_idle_timeout_s must be 1..3600, got {self.tcp_idle_timeout_s}",
        )
        require(
            0.5 <= self.tcp_evict_idle_s <= self.tcp_idle_timeout_s,
            f"tcp_evict_idle_s must be within 0.5..tcp_idle_timeout_s, got {self.tcp_evict_idle_s}",
        )
        require(
            0.5 <= self.gcs_timeout_s <= 3600.0, f"gcs_timeout_s must be 0.5..3600, got {self.gcs_timeout_s}"
        )
        require(-90.0 <= self.origin_lat_deg <= 90.0, f"origin_lat_deg out of range: {self.origin_lat_deg}")
        require(-180.0 <= self.origin_lon_deg <= 180.0, f"origin_lon_deg out of range: {self.origin_lon_deg}")
        require(math.isfinite(self.origin_alt_m), "origin_alt_m must be finite")
        require(
            0.01 <= self.item_timeout_s <= 10.0, f"item_timeout_s must be 0.01..10, got {self.item_timeout_s}"
        )
        require(
            self.item_timeout_s < self.upload_timeout_s <= 600.0,
            f"upload_timeout_s must exceed item_timeout_s and be <= 600, got {self.upload_timeout_s}",
        )
        require(
            0.1 <= self.validate_timeout_s <= 60.0,
            f"validate_timeout_s must be 0.1..60, got {self.validate_timeout_s}",
        )
        require(
            0.05 <= self.command_timeout_s <= 30.0,
            f"command_timeout_s must be 0.05..30, got {self.command_timeout_s}",
        )
        require(
            0 <= self.signing_link_id <= 255, f"signing_link_id must be 0..255, got {self.signing_link_id}"
        )
        require(10 <= self.rx_peer_per_s <= 1_000_000, f"rx_peer_per_s out of range: {self.rx_peer_per_s}")
        require(
            10 <= self.rx_strangers_per_s <= 1_000_000,
            f"rx_strangers_per_s out of range: {self.rx_strangers_per_s}",
        )

    @classmethod
    def from_table(cls, table: dict[str, Any] | None, where: str = "onboard.toml [mavlink]") -> MavlinkConfig:
        """Build from the ``[mavlink]`` TOML table (unknown keys and bad values raise ConfigError)."""
        return from_table(cls, table, where)

    def resolved_state_dir(self) -> Path:
        """The state directory to use (config value or the per-user default)."""
        return Path(self.state_dir) if self.state_dir else default_state_dir()


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
