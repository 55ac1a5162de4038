"""Two ground stations with the same MAVLink ids (every stock one is 255/190) upload at once, over UDP and
over TCP: a transfer belongs to one peer (its link and ids), its requests and ACK go to it alone, and a
second uploader meanwhile is refused (MAV_MISSION_DENIED with a STATUSTEXT), never merged (issue 12)."""

from __future__ import annotations

import threading
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import Item, MavClient
from groundstation.mission_files import goal_item
from tests.integration.mavlink.conftest import Vehicle

N_GOALS = 100


def _mission(east_m: float) -> list[Item]:
    """100 goals on a line north, at ``east_m`` east: two ground stations' missions differ in every item."""
    return [goal_item(2.0 * k, east_m, 1.0, None) for k in range(N_GOALS)]


def _race(clients: list[MavClient], missions: list[list[Item]]) -> list[object]:
    start = threading.Barrier(len(clients))
    results: list[object] = [None] * len(clients)

    def upload(k: int) -> None:
        start.wait()
        results[k] = clients[k].upload(missions[k], timeout_s=6.0)

    threads = [threading.Thread(target=upload, args=(k,)) for k in range(len(clients))]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=30.0)
    return results


@pytest.mark.parametrize("transport", ["udp", "tcp"])
def test_two_ground_stations_with_the_same_ids_never_mix_their_missions(
    tmp_path: Path, transport: str
) -> None:
    endpoint = "udpin:127.0.0.1:0" if transport == "udp" else "tcpin:127.0.0.1:0"
    vehicle = Vehicle(tmp_path / "state", endpoints=(endpoint,)).start()
    try:
        url = f"{'udpout' if transport == 'udp' else 'tcp'}:127.0.0.1:{vehicle.port}"
        for round_ in range(3):
            clients = [MavClient(url), MavClient(url)]  # both 255/190, each its own socket
            try:
                for c in clients:
                    c.heartbeat()
                    c.wait_heartbeat(3.0)
                missions = [_mission(10.0 * round_ + 1.0), _mission(10.0 * round_ + 2.0)]
                results = _race(clients, missions)
                told = [getattr(r, "result_name", None) for r in results]
                stored = vehicle.link.mission().goals
                east = {round(g.y_m, 3) for g in stored}
                # THEN the stored mission is exactly one of the two, whole
                assert len(stored) == N_GOALS and len(east) == 1, (round_, told, east)
                winner = 0 if east == {10.0 * round_ + 1.0} else 1
                assert told[winner] == "MAV_MISSION_ACCEPTED", told
                # and the other was either refused with a reason, or uploaded wholly before (then overwritten)
                loser = clients[1 - winner]
                if told[1 - winner] != "MAV_MISSION_ACCEPTED":
                    assert told[1 - winner] == "MAV_MISSION_DENIED", told
                    assert any("mission transfer refused" in t.text for t in loser.texts), list(loser.texts)
                # a download by either gives the stored one
                got = clients[1 - winner].download()
                assert [i.y for i in got] == [it.y for it in missions[winner]]
            finally:
                for c in clients:
                    c.close()
    finally:
        vehicle.stop()


def test_a_command_ack_goes_to_the_station_that_sent_the_command(tmp_path: Path) -> None:
    # GIVEN two ground stations with the same ids (255/190) on their own sockets
    vehicle = Vehicle(tmp_path / "state").start()
    try:
        a, b = (MavClient(f"udpout:127.0.0.1:{vehicle.port}") for _ in range(2))
        try:
            for c in (a, b):
                c.heartbeat()
                c.wait_heartbeat(3.0)
            acks_b: list[object] = []
            b.on_message = lambda m: acks_b.append(m) if m.get_type() == "COMMAND_ACK" else None
            # WHEN A sends a command (a request for the vehicle's HOME_POSITION)
            ack = a.command_ack(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION)
            deadline = time.monotonic() + 1.0
            while time.monotonic() < deadline:
                b.recv(0.1)
            # THEN A is answered and B, whose ids are the same, hears no ACK it could take for its own
            assert ack.result == mavlink.MAV_RESULT_ACCEPTED, ack
            assert acks_b == []
        finally:
            a.close()
            b.close()
    finally:
        vehicle.stop()
