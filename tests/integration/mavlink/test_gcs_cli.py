"""auv-gcs against the in-process endpoint (files, --json, params, commands, tlog and plot) and against a
scripted vehicle (no onboard code): the MAV_RESULT / MISSION_ACK result and the vehicle's reason
(STATUSTEXT, reassembled from its chunks) are printed, and the exit code follows the result."""

from __future__ import annotations

import json
import socket
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.__main__ import main
from groundstation.mavclient import MAV_RESULT_NAMES, StatusTextAssembler
from groundstation.mission_files import MissionFileError, load
from tests.integration.mavlink.conftest import Vehicle
from tests.waiting import wait_until

YAML = """goals:
  - {x_m: 20.0, y_m: 5.0, depth_m: 2.0, yaw_deg: 90}
  - {x_m: 30.0, y_m: -5.0, depth_m: 3.0}
obstacles:
  - {x_m: 10.0, y_m: 2.0, radius_m: 3.0}
"""
WPL = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t35.1\t129.04\t0\t1
1\t0\t1\t16\t0\t0\t0\tnan\t12.5\t-4\t1.5\t1
2\t0\t1\t5004\t2.5\t0\t0\t0\t5\t5\t0\t1
"""


def run(capsys: pytest.CaptureFixture[str], vehicle: Vehicle, tmp_path: Path, *args: str) -> tuple[int, dict]:
    url = f"udpout:127.0.0.1:{vehicle.port}"
    code = main(["--connect", url, "--json", "--tlog-dir", str(tmp_path / "tlogs"), "--timeout", "3", *args])
    out = capsys.readouterr().out.strip().splitlines()
    return code, json.loads(out[-1]) if out else {}


def test_cli_session(vehicle: Vehicle, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(YAML)
    code, out = run(capsys, vehicle, tmp_path, "upload", str(f))
    assert code == 0 and out["ok"] and [r["items"] for r in out["results"]] == [2, 1]
    m = vehicle.link.mission()
    assert [g.x_m for g in m.goals] == [20.0, 30.0] and m.obstacles[0].radius_m == 3.0
    code, out = run(capsys, vehicle, tmp_path, "download")
    assert code == 0 and out["mission"]["goals"][0] == {
        "x_m": 20.0,
        "y_m": 5.0,
        "depth_m": 2.0,
        "yaw_deg": 90.0,
    }
    assert out["mission"]["goals"][1]["yaw_deg"] is None
    code, out = run(capsys, vehicle, tmp_path, "download", str(tmp_path / "back.yaml"))
    assert code == 0 and load(tmp_path / "back.yaml")[0] == load(f)[0]
    assert run(capsys, vehicle, tmp_path, "start")[0] == 1  # not armed: refused
    assert run(capsys, vehicle, tmp_path, "arm")[1]["result"] == "MAV_RESULT_ACCEPTED"
    assert run(capsys, vehicle, tmp_path, "start")[0] == 0
    assert run(capsys, vehicle, tmp_path, "abort")[0] == 0
    code, out = run(capsys, vehicle, tmp_path, "params", "set", "LIM_RPS_MAX", "25")
    assert code == 0 and out["value"] == 25.0
    code, out = run(capsys, vehicle, tmp_path, "params", "set", "LIM_RPS_MAX", "999")
    assert code == 1 and out["value"] == 25.0
    code, out = run(capsys, vehicle, tmp_path, "params")
    assert code == 0 and out["params"]["LIM_RPS_MAX"] == 25.0
    code, out = run(capsys, vehicle, tmp_path, "monitor", "--duration", "1.2")
    assert code == 0 and out["state"] in ("ABORT", "COMPLETE")
    code, out = run(capsys, vehicle, tmp_path, "clear")
    assert code == 0 and vehicle.link.mission().goals == ()
    tlogs = sorted((tmp_path / "tlogs").glob("*.tlog"))
    assert len(tlogs) == 1 and tlogs[0].name.startswith("gcs-20")  # one for the day's session
    biggest = tlogs[0]
    code, out = run(capsys, vehicle, tmp_path, "plot", str(biggest), "-o", str(tmp_path / "plot.png"))
    assert code == 0 and (tmp_path / "plot.png").stat().st_size > 1000


def test_cli_upload_refused_exit_code_and_wpl(vehicle: Vehicle, tmp_path: Path, capsys) -> None:
    f = tmp_path / "far.yaml"
    f.write_text("goals:\n  - {x_m: 5000.0, y_m: 0.0, depth_m: 1.0}\n")
    code, out = run(capsys, vehicle, tmp_path, "upload", str(f))
    assert code == 1 and out["results"][0]["result"] == "MAV_MISSION_INVALID_PARAM5_X"
    assert out["result"] == "MAV_MISSION_INVALID_PARAM5_X" and "goal 0" in out["reason"]  # the vehicle's word
    w = tmp_path / "m.waypoints"
    w.write_text(WPL)
    goals, fences = load(w)
    assert len(goals) == 1 and len(fences) == 1 and goals[0].x == 125000
    code, out = run(capsys, vehicle, tmp_path, "upload", str(w))
    assert code == 0
    assert vehicle.link.mission().goals[0].x_m == 12.5 and vehicle.link.mission().obstacles[0].radius_m == 2.5


def test_cli_bad_file_and_no_vehicle(tmp_path: Path, capsys) -> None:
    f = tmp_path / "bad.yaml"
    f.write_text("goals:\n  - {x_m: 1}\n")
    with pytest.raises(MissionFileError):
        load(f)
    assert main(["--json", "upload", str(f)]) == 2
    code = main(
        ["--connect", "udpout:127.0.0.1:9", "--json", "--timeout", "0.5", "--tlog-dir", str(tmp_path), "arm"]
    )
    assert code == 2 and "heartbeat" in capsys.readouterr().out


# ---- the vehicle's word: results, reasons and exit codes against a scripted vehicle ------------------
class ScriptedVehicle:
    """A scripted MAVLink 2 vehicle on a free UDP port of 127.0.0.1 (no onboard code): it answers each
    command with the result and reason it is given (the reason as STATUSTEXT right after the ACK, chunked
    when longer than 50 characters, as the vehicle does), each upload likewise, and sends a HEARTBEAT with
    ``system_status`` every 0.1 s to whoever spoke to it."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.02)
        self.port = int(self.sock.getsockname()[1])
        self.mav = mavlink.MAVLink(self, 1, 1)
        self.peer: tuple[str, int] | None = None
        self.answers: dict[int, tuple[int, str]] = {}
        self.commands: list[tuple[int, list[float]]] = []
        self.upload_answers: dict[int, tuple[int, str]] = {}  # mission_type -> (MAV_MISSION result, reason)
        self.plans: dict[int, list[Any]] = {
            mavlink.MAV_MISSION_TYPE_MISSION: [],
            mavlink.MAV_MISSION_TYPE_FENCE: [],
        }
        self.uploads: list[int] = []  # mission types of the uploads started, in order
        self.system_status = mavlink.MAV_STATE_STANDBY
        self.ready_at: float | None = None  # BOOT until this monotonic time, then STANDBY
        self.chatter = ""  # a STATUSTEXT repeated with every heartbeat
        self._rx: dict[str, Any] = {}
        self._chunk_id = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def write(self, buf: bytes) -> None:
        if self.peer is not None:
            self.sock.sendto(bytes(buf), self.peer)

    def __enter__(self) -> ScriptedVehicle:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.sock.close()

    def statustext(self, severity: int, text: str) -> None:
        raw = text.encode("ascii")
        if len(raw) <= 50:
            self.mav.send(mavlink.MAVLink_statustext_message(severity, raw, 0, 0))
            return
        self._chunk_id += 1
        chunks = [raw[i : i + 50] for i in range(0, len(raw), 50)]
        if len(chunks[-1]) == 50:
            chunks.append(b"")
        for k, c in enumerate(chunks):
            self.mav.send(mavlink.MAVLink_statustext_message(severity, c, self._chunk_id, k))

    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if self.peer is not None and now >= next_hb:
                next_hb = now + 0.1
                status = self.system_status
                if self.ready_at is not None:
                    status = mavlink.MAV_STATE_BOOT if now < self.ready_at else mavlink.MAV_STATE_STANDBY
                self.mav.send(
                    mavlink.MAVLink_heartbeat_message(
                        mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_GENERIC, 0, 0, status, 3
                    )
                )
                if self.chatter:
                    self.statustext(mavlink.MAV_SEVERITY_INFO, self.chatter)
            try:
                data, addr = self.sock.recvfrom(65535)
            except (TimeoutError, OSError):
                continue
            self.peer = addr
            parser = mavlink.MAVLink(None)
            for m in parser.parse_buffer(data) or []:
                self._handle(m)

    def _handle(self, m: Any) -> None:
        kind = m.get_type()
        src = (m.get_srcSystem(), m.get_srcComponent())
        if kind == "COMMAND_LONG" and m.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            self.mav.send(
                mavlink.MAVLink_command_ack_message(m.command, mavlink.MAV_RESULT_ACCEPTED, 0, 0, *src)
            )
        elif kind == "COMMAND_LONG":
            p = [m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7]
            self.commands.append((m.command, p))
            result, reason = self.answers.get(m.command, (mavlink.MAV_RESULT_ACCEPTED, ""))
            self.mav.send(mavlink.MAVLink_command_ack_message(m.command, result, 0, 0, *src))
            if reason:
                self.statustext(mavlink.MAV_SEVERITY_WARNING, reason)
        elif kind == "MISSION_COUNT":
            self.uploads.append(m.mission_type)
            self._rx = {"type": m.mission_type, "count": m.count, "items": []}
            if m.count == 0:
                self._finish_upload(src)
            else:
                self.mav.send(mavlink.MAVLink_mission_request_int_message(*src, 0, m.mission_type))
        elif kind == "MISSION_ITEM_INT" and self._rx and m.seq == len(self._rx["items"]):
            self._rx["items"].append(m)
            if len(self._rx["items"]) == self._rx["count"]:
                self._finish_upload(src)
            else:
                self.mav.send(mavlink.MAVLink_mission_request_int_message(*src, m.seq + 1, m.mission_type))
        elif kind == "MISSION_REQUEST_LIST":
            n = len(self.plans[m.mission_type])
            self.mav.send(mavlink.MAVLink_mission_count_message(*src, n, m.mission_type))
        elif kind == "MISSION_REQUEST_INT":
            it = self.plans[m.mission_type][m.seq]
            self.mav.send(
                mavlink.MAVLink_mission_item_int_message(
                    *src, m.seq, it.frame, it.command, 0, it.autocontinue, it.param1, it.param2, it.param3,
                    it.param4, it.x, it.y, it.z, m.mission_type,
                )
            )  # fmt: skip

    def _finish_upload(self, src: tuple[int, int]) -> None:
        mt = self._rx["type"]
        result, reason = self.upload_answers.get(mt, (mavlink.MAV_MISSION_ACCEPTED, ""))
        if result == mavlink.MAV_MISSION_ACCEPTED and mt == mavlink.MAV_MISSION_TYPE_ALL:  # goals and fence
            fence = mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
            for t, want in (
                (mavlink.MAV_MISSION_TYPE_MISSION, False),
                (mavlink.MAV_MISSION_TYPE_FENCE, True),
            ):
                self.plans[t] = [it for it in self._rx["items"] if (it.command == fence) == want]
        elif result == mavlink.MAV_MISSION_ACCEPTED:
            self.plans[mt] = list(self._rx["items"])
        self.mav.send(mavlink.MAVLink_mission_ack_message(*src, result, mt))
        if reason:
            self.statustext(mavlink.MAV_SEVERITY_WARNING, reason)
        self._rx = {}


def gcs(
    capsys: pytest.CaptureFixture[str], v: ScriptedVehicle, tmp_path: Path, *args: str
) -> tuple[int, dict]:
    code = main(
        [
            "--connect",
            f"udpout:127.0.0.1:{v.port}",
            "--json",
            "--tlog-dir",
            str(tmp_path),
            "--timeout",
            "3",
            *args,
        ]
    )
    out = capsys.readouterr().out.strip().splitlines()
    return code, json.loads(out[-1]) if out else {}


LONG_REASON = "RUNNING: hold (or force the disarm) first; the vehicle is flying goal 3 of 4 at 2.0 m depth"


def test_refusal_prints_the_result_and_the_vehicles_reassembled_reason(tmp_path: Path, capsys) -> None:
    # GIVEN a vehicle that denies DISARM with a reason longer than one STATUSTEXT (two chunks)
    with ScriptedVehicle() as v:
        v.answers[mavlink.MAV_CMD_COMPONENT_ARM_DISARM] = (mavlink.MAV_RESULT_DENIED, LONG_REASON)
        v.chatter = "an unrelated info line"
        # WHEN the operator disarms THEN exit 1 with the result and the whole reason
        code, out = gcs(capsys, v, tmp_path, "disarm")
        assert code == 1 and out["ok"] is False
        assert out["result"] == "MAV_RESULT_DENIED" and out["reason"] == LONG_REASON
        # AND the text output says the same
        url = f"udpout:127.0.0.1:{v.port}"
        assert main(["--connect", url, "--tlog-dir", str(tmp_path), "disarm"]) == 1
        text = " ".join(capsys.readouterr().out.split())
        assert "MAV_RESULT_DENIED" in text and LONG_REASON in text


@pytest.mark.parametrize(
    ("result", "code"),
    [
        (mavlink.MAV_RESULT_ACCEPTED, 0),
        (mavlink.MAV_RESULT_TEMPORARILY_REJECTED, 3),
        (mavlink.MAV_RESULT_DENIED, 1),
        (mavlink.MAV_RESULT_FAILED, 1),
        (mavlink.MAV_RESULT_UNSUPPORTED, 1),
    ],
)
def test_exit_code_follows_the_result(result: int, code: int, tmp_path: Path, capsys) -> None:
    with ScriptedVehicle() as v:
        reason = "" if result == mavlink.MAV_RESULT_ACCEPTED else "navigation not valid yet"
        v.answers[mavlink.MAV_CMD_MISSION_START] = (result, reason)
        got, out = gcs(capsys, v, tmp_path, "start")
    assert got == code and out["result"] == MAV_RESULT_NAMES[result] and out["reason"] == reason


def test_command_parameters(tmp_path: Path, capsys) -> None:
    with ScriptedVehicle() as v:
        for args in (["start"], ["start", "--from", "2"], ["disarm"], ["disarm", "--force"], ["arm"]):
            assert gcs(capsys, v, tmp_path, *args)[0] == 0
        sent = [(c, p[:2]) for c, p in v.commands]
    start, arm = mavlink.MAV_CMD_MISSION_START, mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    assert sent == [
        (start, [0.0, 0.0]),  # first_item 0: the vehicle continues from the mission's current goal
        (start, [2.0, 0.0]),
        (arm, [0.0, 0.0]),
        (arm, [0.0, 21196.0]),
        (arm, [1.0, 0.0]),
    ]


def test_wait_ready(tmp_path: Path, capsys) -> None:
    with ScriptedVehicle() as v:
        # GIVEN a vehicle that says BOOT for 0.5 s, then STANDBY WHEN waiting THEN exit 0 with the state
        v.ready_at = time.monotonic() + 0.5
        code, out = gcs(capsys, v, tmp_path, "wait-ready", "--timeout", "5")
        assert code == 0 and out["ready"] is True and out["result"] == "MAV_STATE_STANDBY"
        assert out["waited_s"] >= 0.4
        # GIVEN a vehicle that stays in BOOT and says why WHEN waiting 0.6 s THEN exit 3 with its reason
        v.ready_at = time.monotonic() + 60.0
        v.chatter = "navigation not valid yet"
        code, out = gcs(capsys, v, tmp_path, "wait-ready", "--timeout", "0.6")
        assert code == 3 and out["ready"] is False and out["result"] == "MAV_STATE_BOOT"
        assert out["reason"] == "navigation not valid yet"


def test_upload_refusal_prints_the_mission_ack_and_the_reason(tmp_path: Path, capsys) -> None:
    f = tmp_path / "deep.yaml"
    f.write_text("goals:\n  - {x_m: 10.0, y_m: 0.0, depth_m: 25.0}\n")
    reason = "goal 0: depth 25 m is below the failsafe depth limit 20 m"
    with ScriptedVehicle() as v:
        v.upload_answers[mavlink.MAV_MISSION_TYPE_MISSION] = (mavlink.MAV_MISSION_INVALID_PARAM7, reason)
        code, out = gcs(capsys, v, tmp_path, "upload", str(f))
        assert code == 1 and out["result"] == "MAV_MISSION_INVALID_PARAM7" and out["reason"] == reason
        assert out["results"][0]["reason"] == reason
        url = f"udpout:127.0.0.1:{v.port}"
        assert main(["--connect", url, "--tlog-dir", str(tmp_path), "upload", str(f)]) == 1
    text = " ".join(capsys.readouterr().out.split())
    assert f"MAV_MISSION_INVALID_PARAM7: {reason}" in text


def test_upload_of_goals_and_fence_is_one_transfer_and_a_refusal_changes_nothing(
    tmp_path: Path, capsys
) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(YAML)
    with ScriptedVehicle() as v:
        # GIVEN a stored mission and fence, and a vehicle that refuses the next whole-plan upload
        old = tmp_path / "old.yaml"
        old.write_text(
            "goals:\n  - {x_m: 1.0, y_m: 2.0, depth_m: 1.0}\n"
            "obstacles:\n  - {x_m: -40.0, y_m: 7.0, radius_m: 2.0}\n"
        )
        code, out = gcs(capsys, v, tmp_path, "upload", str(old))
        assert code == 0 and [(r["type"], r["items"], r["ok"]) for r in out["results"]] == [
            ("mission", 1, True),
            ("fence", 1, True),
        ]
        assert v.uploads == [mavlink.MAV_MISSION_TYPE_ALL]  # goals and fence: one transfer, one verdict
        why = "goal 1 refused: no path"
        v.upload_answers[mavlink.MAV_MISSION_TYPE_ALL] = (mavlink.MAV_MISSION_ERROR, why)
        # WHEN goals and fence are uploaded
        code, out = gcs(capsys, v, tmp_path, "upload", str(f))
        # THEN exit 1 with the vehicle's reason for both parts, one transfer, and what is in force said
        assert code == 1 and out["reason"] == why and [r["ok"] for r in out["results"]] == [False, False]
        assert v.uploads == [mavlink.MAV_MISSION_TYPE_ALL] * 2
        assert out["in_force"] == "in force on the vehicle: 1 mission items, 1 fence circles"
        fence = v.plans[mavlink.MAV_MISSION_TYPE_FENCE]
        assert [(it.x, it.y, it.param1) for it in fence] == [(-400000, 70000, 2.0)]
        # and a fence alone is a FENCE transfer
        assert gcs(capsys, v, tmp_path, "fence", str(f))[0] == 0
        assert v.uploads[-1] == mavlink.MAV_MISSION_TYPE_FENCE


def test_statustext_chunks_are_reassembled() -> None:
    asm = StatusTextAssembler(max_age_s=1.0)
    mav = mavlink.MAVLink(None, 1, 1)

    def msg(text: bytes, chunk_id: int, seq: int) -> Any:
        buf = mavlink.MAVLink_statustext_message(4, text, chunk_id, seq).pack(mav)
        return mavlink.MAVLink(None).parse_buffer(buf)[0]

    assert asm.feed(msg(b"short", 0, 0), 0.0).text == "short"
    assert asm.feed(msg(b"a" * 50, 9, 0), 0.0) is None
    done = asm.feed(msg(b"b" * 50, 9, 1), 0.1) or asm.feed(msg(b"", 9, 2), 0.2)
    assert done is not None and done.text == "a" * 50 + "b" * 50 and done.complete
    # a text whose last chunk never comes is given up after max_age_s, marked incomplete
    assert asm.feed(msg(b"c" * 50, 10, 0), 1.0) is None
    assert asm.flush(1.5) == []
    (lost,) = asm.flush(2.5)
    assert lost.text == "c" * 50 and not lost.complete


def test_scenario_runner_raises_with_the_vehicles_reason(tmp_path: Path) -> None:
    # GIVEN a ready vehicle that takes the mission and the ARM but refuses the START, saying why
    from hil_sim.scenario import upload_and_start

    mission = tmp_path / "m.yaml"
    mission.write_text("goals:\n  - {x_m: 10.0, y_m: 0.0, depth_m: 1.0}\n")
    with ScriptedVehicle() as v:
        v.answers[mavlink.MAV_CMD_MISSION_START] = (mavlink.MAV_RESULT_DENIED, "the mission is complete")
        # WHEN the scenario runner uploads, arms and starts THEN one try each, and the vehicle's word
        with pytest.raises(RuntimeError, match="MAV_RESULT_DENIED: the mission is complete"):
            upload_and_start(f"udpout:127.0.0.1:{v.port}", mission, tmp_path, timeout_s=20.0)
        assert [c for c, _p in v.commands] == [
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
            mavlink.MAV_CMD_MISSION_START,
        ]
        assert v.uploads == [mavlink.MAV_MISSION_TYPE_MISSION]


def test_a_signing_ground_station_ignores_an_unsigned_spoofer_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # GIVEN no vehicle, only an unsigned spoofer that answers every command ACCEPTED (issue 12: before,
    # `auv-gcs --signing-key K arm` printed MAV_RESULT_ACCEPTED)
    spoof = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    spoof.bind(("127.0.0.1", 0))
    spoof.settimeout(0.1)
    stop = threading.Event()
    mav = mavlink.MAVLink(None, 1, 1)

    def answer() -> None:
        while not stop.is_set():
            try:
                _data, addr = spoof.recvfrom(65535)
            except (TimeoutError, OSError):
                continue
            hb = mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_GENERIC, 0, 0, mavlink.MAV_STATE_STANDBY, 3
            )
            ack = mavlink.MAVLink_command_ack_message(400, mavlink.MAV_RESULT_ACCEPTED, 0, 0, 0, 0)
            for msg in (hb, ack):
                spoof.sendto(msg.pack(mav), addr)

    t = threading.Thread(target=answer, daemon=True)
    t.start()
    key = tmp_path / "key"
    key.write_text(bytes(range(1, 33)).hex())
    try:
        code = main(
            ["--connect", f"udpout:127.0.0.1:{spoof.getsockname()[1]}", "--json", "--tlog-dir",
             str(tmp_path / "tlogs"), "--timeout", "2", "--signing-key", str(key), "arm"]
        )  # fmt: skip
    finally:
        stop.set()
        t.join(timeout=2.0)
        spoof.close()
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    # THEN it is no vehicle to it: an error, no ACCEPTED, and the reason names the unsigned packets
    assert code == 2 and not out["ok"] and "ACCEPTED" not in json.dumps(out)
    assert "not signed with our key" in out["error"] and "unsigned" in out["error"], out


@pytest.mark.parametrize("bad", ["300", "0", "x"])
def test_a_bad_system_id_is_one_usage_line(bad: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exited:
        main(["--connect", "udpout:127.0.0.1:9", "--system-id", bad, "arm"])
    err = capsys.readouterr().err.strip().splitlines()
    assert exited.value.code == 2 and "--system-id" in err[-1] and "Traceback" not in "\n".join(err)


def test_the_ground_station_draws_its_own_system_id() -> None:
    from groundstation.__main__ import OWN_SYSTEM_IDS, own_system_id

    ids = {own_system_id() for _ in range(200)}
    assert ids <= set(OWN_SYSTEM_IDS) and len(ids) > 20 and 255 not in ids


def test_cli_edges_are_one_line_with_a_reason(vehicle: Vehicle, tmp_path: Path, capsys) -> None:
    # an unknown parameter: "no such parameter", exit 1 (the vehicle refused), for a set and for a get
    code, out = run(capsys, vehicle, tmp_path, "params", "set", "NOPE", "1")
    assert code == 1 and "no such parameter NOPE" in out["error"], out
    code, out = run(capsys, vehicle, tmp_path, "params", "get", "NOPE")
    assert code == 1 and "no such parameter NOPE" in out["error"], out
    # a file that is no tlog: refused with the reason, exit 2, no picture
    bogus = tmp_path / "notes.txt"
    bogus.write_text("not a telemetry log\n")
    code, out = run(capsys, vehicle, tmp_path, "plot", str(bogus), "-o", str(tmp_path / "p.png"))
    assert code == 2 and "not a tlog" in out["error"] and not (tmp_path / "p.png").exists(), out
    # a listening port another station holds: one line, exit 2 (was a traceback)
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", 0))
    try:
        port = taken.getsockname()[1]
        code = main(["--connect", f"udpin:127.0.0.1:{port}", "--json", "--tlog-dir", str(tmp_path / "t"),
                     "--timeout", "1", "arm"])  # fmt: skip
        out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        assert code == 2 and "cannot open" in out["error"] and "in use" in out["error"], out
    finally:
        taken.close()
    # a long error without --json is still one line (rich wrapped it at the terminal's width)
    missing = tmp_path / ("a-long-folder-name-" * 6) / "mission.plan"
    code = main(["--connect", f"udpout:127.0.0.1:{vehicle.port}", "--tlog-dir", str(tmp_path / "t"), "fly",
                 str(missing)])  # fmt: skip
    lines = capsys.readouterr().out.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error: ") and "No such file" in lines[0]


def test_one_shot_commands_are_no_session_the_vehicle_watches(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    """``arm``, ``params``... send no GCS heartbeat, so their exit is no "link lost" on the vehicle; a
    session (``monitor``) does, and its end is one."""
    v = Vehicle(tmp_path / "state", gcs_timeout_s=1.0).start()
    try:
        with caplog.at_level("WARNING", logger="onboard.adapters.mavlink.endpoint"):
            # WHEN the operator runs one-shot commands
            for args in (("params", "get", "MIS_ARRIVE_R_M"), ("wait-ready", "--timeout", "2"), ("disarm",)):
                code, _ = run(capsys, v, tmp_path, *args)
                assert code in (0, 1, 3), args
            # THEN the vehicle never counted them as a ground-station link (its watch has heard no station's
            # heartbeat, so it has none to lose), and none was lost
            assert v.link._gcs_last_s is None
            assert not [r for r in caplog.records if "link lost" in r.getMessage()]
            # WHEN a session watches for 1 s and ends
            code, _ = run(capsys, v, tmp_path, "monitor", "--duration", "1")
            assert code == 0
            # THEN its end is reported (gcs_timeout_s after its last heartbeat), once
            wait_until(
                lambda: [r for r in caplog.records if "ground-station link lost" in r.getMessage()],
                what="the session's end reported",
            )
        lost = [r for r in caplog.records if "ground-station link lost" in r.getMessage()]
        assert len(lost) == 1
    finally:
        v.stop()
