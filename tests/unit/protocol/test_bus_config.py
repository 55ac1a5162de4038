"""Buses by configuration: explicit arguments, clear errors, nothing onto the LAN."""

from __future__ import annotations

import time

import pytest

import onboard.protocol.bus as bus_module
from auv_common.config import ConfigError, from_table
from onboard.protocol.bus import BusConfig, BusUnavailable, check_multicast_route_via_lo, open_bus
from onboard.protocol.messages import FinCmd
from onboard.protocol.port import BusPort


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"interface": "kvaser"}, "must be one of"),
        ({"interface": "remote", "channel": "127.0.0.1:54701"}, "malformed remote channel"),
        ({"interface": "remote", "channel": "ws://10.1.2.3:54701/"}, "not loopback"),
        ({"interface": "remote", "channel": "ws://127.0.0.1:notaport/"}, "malformed remote channel"),
        ({"interface": "socketcan", "channel": "can 0; rm"}, "malformed socketcan channel"),
        ({"interface": "udp_multicast", "channel": "239.74.163.2", "hop_limit": 1}, "hop_limit = 0"),
        ({"interface": "udp_multicast", "channel": "10.0.0.1"}, "not a multicast group"),
        ({"interface": "udp_multicast", "channel": "not-an-ip"}, "not an IP address"),
        ({"bitrate": 500000}, "unknown key bitrate"),
        ({"record": "frames.txt"}, "must end in .blf, .asc or .log"),
    ],
)
def test_bad_bus_configuration_is_one_clear_error(table: dict, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        from_table(BusConfig, table, "test.toml [bus]")
    assert "\n" not in str(info.value)


def test_multicast_group_not_routed_via_lo_is_refused() -> None:
    # On this machine no route sends 239.74.163.2 via lo (the default route would take it to the LAN).
    with pytest.raises(ConfigError, match="does not route via lo"):
        check_multicast_route_via_lo("239.74.163.2")


def test_virtual_bus_by_configuration_round_trips_a_frame() -> None:
    cfg = from_table(BusConfig, {"interface": "virtual", "channel": f"t-{time.monotonic_ns()}"}, "t")
    a, b = BusPort(open_bus(cfg), time.monotonic), BusPort(open_bus(cfg), time.monotonic)
    try:
        a.send(FinCmd(0.1, 0.0, 0.0))
        msg = b.recv(1.0)
        assert isinstance(msg, FinCmd) and abs(msg.rudder_rad - 0.1) < 1e-4
    finally:
        a.close()
        b.close()


def test_waiting_for_a_missing_hub_gives_up_at_the_timeout(monkeypatch: pytest.MonkeyPatch) -> None:
    # GIVEN no hub, and open_bus's clock simulated (its retry waits advance it), so load cannot matter
    class Clock:
        now_s = 0.0

        def monotonic(self) -> float:
            return self.now_s

        def sleep(self, s: float) -> None:
            self.now_s += s

    clock = Clock()
    monkeypatch.setattr(bus_module, "time", clock)
    cfg = from_table(BusConfig, {"interface": "remote", "channel": "ws://127.0.0.1:9/"}, "t")
    # WHEN it waits for the bus with a 0.5 s timeout THEN it gives up with the reason at the first retry past
    # 0.5 s (it retries every 0.2 s)
    with pytest.raises(BusUnavailable, match="not available"):
        open_bus(cfg, timeout_s=0.5)
    assert clock.now_s == pytest.approx(0.6)


def test_recording_writes_an_asc_log_that_replays(tmp_path) -> None:
    import can

    path = tmp_path / "frames.asc"
    cfg = from_table(BusConfig, {"interface": "virtual", "channel": f"r-{time.monotonic_ns()}"}, "t")
    a = BusPort(open_bus(cfg), time.monotonic, record=path)
    b = BusPort(open_bus(cfg), time.monotonic)
    for i in range(5):
        a.send(FinCmd(0.01 * i, 0.0, 0.0))
    a.close()
    b.close()
    frames = list(can.LogReader(str(path)))
    assert [f.arbitration_id for f in frames] == [0x10] * 5
