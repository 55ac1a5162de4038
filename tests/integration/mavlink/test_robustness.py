"""Loss, garbage, signing and restart: the mission on the vehicle is always exactly the old or the new one."""

from __future__ import annotations

import os
import random
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from groundstation.bench_upload import start_vehicle, stop_vehicle
from groundstation.mavclient import MavClient
from groundstation.mission_files import goal_item
from groundstation.relay import LossyRelay
from tests.integration.mavlink.conftest import Vehicle
from tests.waiting import wait_until


def goals_for(k: int, n: int) -> list:
    return [goal_item(float(k), float(i), 1.0 + 0.5 * (i % 3), None) for i in range(n)]


def test_twenty_uploads_through_20_percent_loss_relay(tmp_path: Path) -> None:
    # GIVEN 20 % loss each way with reordering WHEN 20 uploads run in a row
    # THEN after each the vehicle holds exactly the previous or the new mission, never a mix
    v = Vehicle(tmp_path / "s").start()
    successes, held_new = 0, 0
    try:
        with LossyRelay(("127.0.0.1", v.port), loss=0.2, reorder=0.1, seed=7) as relay:
            c = MavClient(f"udpout:127.0.0.1:{relay.port}")
            for _ in range(20):
                c.heartbeat()
                try:
                    c.wait_heartbeat(0.5)
                    break
                except Exception:
                    continue
            previous = [(g.x_m, g.y_m, g.depth_m) for g in v.link.mission().goals]
            for k in range(1, 21):
                items = goals_for(k, 5 + k % 4)
                new = [(it.x / 1e4, it.y / 1e4, it.z) for it in items]
                r = c.upload(items, timeout_s=6.0)
                successes += r.ok
                time.sleep(0.02)
                now = [(g.x_m, g.y_m, g.depth_m) for g in v.link.mission().goals]
                assert now in (previous, new), f"upload {k}: a mix"
                if r.ok:
                    assert now == new, f"upload {k}: GCS saw ACCEPTED but the vehicle did not change"
                held_new += now == new
                previous = now
            c.close()
            print(
                f"\nlossy relay: {successes}/20 GCS successes, vehicle took {held_new}/20; "
                f"dropped {relay.dropped}"
            )
    finally:
        v.stop()
    assert successes >= 15


def test_garbage_flood_no_crash_no_state_change_and_counted(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        assert c.upload(goals_for(3, 4)).ok
        before = vehicle.link.mission()
        valid = bytearray()

        class Sink:
            def write(self, b: bytes) -> None:
                valid.extend(b)

        mav = mavlink.MAVLink(Sink(), 255, 190)
        mav.send(mavlink.MAVLink_mission_count_message(1, 1, 2, 0))
        rng = random.Random(3)
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        # (what a flood costs the vehicle's loop and heartbeat in time is auv-bench's, section links)
        t_end = time.monotonic() + 1.5
        sent = 0
        while time.monotonic() < t_end:
            kind = rng.randrange(3)
            if kind == 0:
                data = rng.randbytes(rng.randrange(1, 300))
            elif kind == 1:
                data = bytes(valid[: rng.randrange(1, len(valid))])  # truncated
            else:
                b = bytearray(valid)
                b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)  # bit flip
                data = bytes(b)
            s.sendto(data, ("127.0.0.1", vehicle.port))
            sent += 1
        s.close()
        stats = wait_until(
            lambda: (st := vehicle.link.stats())["malformed"] + st["shed"] + st["unknown"] > 0 and st,
            what="the garbage counted",
        )
        assert vehicle.link.mission() == before
        print(f"\nflood: {sent} datagrams, stats {stats}")
        assert c.upload(goals_for(4, 2), timeout_s=6.0).ok  # the link still works


def test_signing_rejects_unsigned_and_wrong_key_and_survives_forged_future(tmp_path: Path) -> None:
    key = bytes(range(1, 33))
    (tmp_path / "key").write_text(key.hex())
    v = Vehicle(tmp_path / "s", signing_key_file=str(tmp_path / "key")).start()
    try:
        unsigned = MavClient(f"udpout:127.0.0.1:{v.port}")
        unsigned.heartbeat()
        r = unsigned.upload(goals_for(1, 2), timeout_s=1.0)
        assert not r.ok and r.result_name == "TIMEOUT"
        unsigned.close()
        wrong = MavClient(f"udpout:127.0.0.1:{v.port}", signing_key=bytes(32))
        assert not wrong.upload(goals_for(1, 2), timeout_s=1.0).ok
        wrong.close()
        # a forger with the GCS's ids and a timestamp far in the future, wrong key
        forger = MavClient(f"udpout:127.0.0.1:{v.port}", signing_key=bytes([9]) * 32)
        forger.mav.signing.timestamp += 10**12
        forger.heartbeat()
        forger.close()
        good = MavClient(f"udpout:127.0.0.1:{v.port}", signing_key=key)
        good.heartbeat()
        good.wait_heartbeat(3.0)
        assert good.upload(goals_for(2, 2)).ok
        good.close()
        st = v.link.stats()
        assert st["unsigned_rejected"] > 0 and st["bad_signature"] > 0
        assert [g.x_m for g in v.link.mission().goals] == [2.0, 2.0]
    finally:
        v.stop()


def test_kill_9_after_ack_loses_nothing(tmp_path: Path) -> None:
    state = tmp_path / "state"
    proc, port = start_vehicle(state)
    try:
        with MavClient(f"udpout:127.0.0.1:{port}") as c:
            c.heartbeat()
            c.wait_heartbeat(5.0)
            assert c.upload(goals_for(5, 3)).ok
            assert c.param_set("LIM_RPS_MAX", 12.5)[0]
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=5.0)
    finally:
        if proc.poll() is None:
            stop_vehicle(proc)
    proc, port = start_vehicle(state)
    try:
        with MavClient(f"udpout:127.0.0.1:{port}") as c:
            c.heartbeat()
            c.wait_heartbeat(5.0)
            got = c.download()
            assert [(i.x / 1e4, i.y / 1e4) for i in got] == [(5.0, 0.0), (5.0, 1.0), (5.0, 2.0)]
            assert c.param_get("LIM_RPS_MAX") == 12.5
    finally:
        stop_vehicle(proc)


def test_standalone_rejects_bad_config(tmp_path: Path) -> None:
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[mavlink]\nno_such_key = 1\n")
    r = subprocess.run(
        [sys.executable, "-m", "onboard.app.standalone", "--config", str(cfg)],
        capture_output=True, text=True, timeout=30,
    )  # fmt: skip
    assert r.returncode == 2 and "no_such_key" in r.stderr


def test_a_signed_packet_replayed_after_a_restart_is_refused(tmp_path: Path) -> None:
    # GIVEN a signing vehicle and its ground station, whose signed PARAM_SET LIM_RPS_MAX = 20 is captured
    key = bytes(range(1, 33))
    (tmp_path / "key").write_text(key.hex())
    state = tmp_path / "s"
    v = Vehicle(state, signing_key_file=str(tmp_path / "key")).start()
    captured: list[bytes] = []
    try:
        gcs = MavClient(f"udpout:127.0.0.1:{v.port}", signing_key=key)
        gcs.heartbeat()
        gcs.wait_heartbeat(3.0)
        inner = gcs.write
        gcs.write = lambda buf: (captured.append(bytes(buf)), inner(buf))[1]  # type: ignore[method-assign]
        assert gcs.param_set("LIM_RPS_MAX", 20.0)[0]
        gcs.write = inner  # type: ignore[method-assign]
        assert gcs.param_set("LIM_RPS_MAX", 25.0)[0]  # the operator changes it again
        gcs.close()
    finally:
        v.stop()
    replay = next(b for b in captured if b[7] | b[8] << 8 | b[9] << 16 == 23)  # PARAM_SET's message id
    # WHEN the firmware restarts (same state directory) and an attacker without the key replays the packet
    v = Vehicle(state, signing_key_file=str(tmp_path / "key")).start()
    try:
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        for _ in range(3):
            raw.sendto(replay, ("127.0.0.1", v.port))
        raw.close()
        # THEN it is refused as an old timestamp, and the parameter is the operator's last value
        wait_until(lambda: v.link.stats()["old_timestamp"] >= 3, what="3 replays refused as old")
        good = MavClient(f"udpout:127.0.0.1:{v.port}", signing_key=key)
        good.heartbeat()
        good.wait_heartbeat(3.0)
        assert good.param_get("LIM_RPS_MAX") == 25.0  # and the real ground station is not locked out
        good.close()
    finally:
        v.stop()
