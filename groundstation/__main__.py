"""``auv-gcs``: the operator's MAVLink tool for the ISiMI100.

    auv-gcs [--connect URL] [--json] fly FILE [--ready-timeout S] | upload FILE |
            download [FILE] [--format plan|wpl|yaml] | clear | fence FILE | arm | disarm [--force] |
            start [--from SEQ] | hold | resume | abort | wait-ready [--timeout S] |
            params [get NAME | set NAME VALUE] | monitor | map [--port P] [--tlog FILE] | plot FILE

URL: udpin:HOST:PORT (default udpin:0.0.0.0:14550, where the vehicle sends), udpout:HOST:PORT, tcp:HOST:PORT.
Every call is recorded in the day's .tlog, gcs-YYYY-MM-DD.tlog in --tlog-dir (default
~/.local/share/isimi100/tlogs).

The ground station tells the truth it is told: every command prints the vehicle's MAV_RESULT and, for a
refusal, the vehicle's reason (the STATUSTEXT it sends right after the ACK); an upload prints the MISSION_ACK
result and the reason likewise. ``--json`` lines carry ``result`` and ``reason``. Exit status
(:data:`EXIT_STATUS`): 0 accepted / done, 1 refused (DENIED, FAILED, UNSUPPORTED, a MAV_MISSION_* error),
2 usage / file / link error, 3 temporarily rejected (not now, e.g. the navigation is not valid yet; also
``wait-ready`` timing out), 130 interrupted.
"""

from __future__ import annotations

import argparse
import os
import random
import sys
import time
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from groundstation import fly, mission_files
from groundstation import map as gcs_map
from groundstation.command_client import CommandAck
from groundstation.ftp_client import FtpClient
from groundstation.link import Link, LinkError
from groundstation.mavclient import MavClient
from groundstation.messages import MAV_STATE_NAMES, state_from_heartbeat
from groundstation.mission_client import Item, MissionClient
from groundstation.output import (
    EXIT_ERROR,
    EXIT_INTERRUPTED,
    EXIT_NOT_NOW,
    EXIT_OK,
    EXIT_REFUSED,
    EXIT_STATUS,
    Out,
    exit_code_of_command,
)
from groundstation.param_client import ParamClient, UnknownParameter
from groundstation.text import labelled, lines, plain

_Out = Out  # the name the download handler's tests (tests/unit/app) construct
FORCE_DISARM_MAGIC = 21196.0  # MAV_CMD_COMPONENT_ARM_DISARM param2: disarm even while running

COMMANDS: dict[str, tuple[int, str]] = {
    "arm": (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, "arm the vehicle"),
    "disarm": (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, "disarm (refused while running unless --force)"),
    "start": (mavlink.MAV_CMD_MISSION_START, "start the mission (default: from its current goal)"),
    "hold": (mavlink.MAV_CMD_DO_PAUSE_CONTINUE, "hold a running mission"),
    "resume": (mavlink.MAV_CMD_DO_PAUSE_CONTINUE, "resume a held mission"),
    "abort": (mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, "abort: propeller off, surface"),
}


def command_params(args: argparse.Namespace) -> tuple[int, tuple[float, ...]]:
    """MAV_CMD and params of a command sub-command."""
    cmd = COMMANDS[args.cmd][0]
    if args.cmd == "arm":
        return cmd, (1.0,)
    if args.cmd == "disarm":
        return cmd, (0.0, FORCE_DISARM_MAGIC if args.force else 0.0)
    if args.cmd == "start":  # first_item 0: the vehicle continues from the mission's current goal
        return cmd, (float(args.from_seq), 0.0)
    if args.cmd in ("hold", "resume"):
        return cmd, (0.0 if args.cmd == "hold" else 1.0,)
    return cmd, ()


def default_tlog_dir() -> Path:
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "isimi100" / "tlogs"


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="auv-gcs",
        description="ISiMI100 ground station (MAVLink 2). Prints the vehicle's answer to every command and "
        "upload: the MAV_RESULT / MISSION_ACK result and, for a refusal, the vehicle's reason (STATUSTEXT).",
        epilog=EXIT_STATUS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--connect", default="udpin:0.0.0.0:14550", help="udpin:H:P | udpout:H:P | tcp:H:P")
    ap.add_argument("--json", action="store_true", help="machine-readable output")
    ap.add_argument("--tlog-dir", type=Path, default=None, help="where the day's .tlog goes")
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the vehicle")
    ap.add_argument("--signing-key", type=Path, help="sign with this key (32 bytes or 64 hex characters)")
    ap.add_argument(
        "--system-id",
        type=_system_id,
        default=None,
        help="our MAVLink system id (default: one of our own, drawn from 200-254 per session, so two "
        "ground stations do not share the ids every stock one has, 255)",
    )
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser(
        "upload",
        help="upload goals (and obstacles, if the file has any: goals and fence in one transfer, judged as "
        "one: both in force, or, refused, neither, so a refused upload changes nothing)",
    )
    p.add_argument("file", type=Path)
    p = sub.add_parser("download", help="download the mission and fence")
    p.add_argument("file", type=Path, nargs="?")
    p.add_argument(
        "--format",
        choices=mission_files.FORMATS,
        help="plan (QGroundControl), wpl (QGC WPL 110) or yaml (default: from FILE's suffix: .plan; "
        ".waypoints, .txt; .yaml, .yml; otherwise and on stdout yaml)",
    )
    sub.add_parser("clear", help="clear mission and fence")
    p = sub.add_parser("fence", help="upload the obstacles of a file as the fence")
    p.add_argument("file", type=Path)
    for name, (_cmd, text) in COMMANDS.items():
        p = sub.add_parser(
            name, help=text, epilog=EXIT_STATUS, formatter_class=argparse.RawDescriptionHelpFormatter
        )
        if name == "disarm":
            p.add_argument("--force", action="store_true", help="disarm even while running (param2 21196)")
        elif name == "start":
            p.add_argument(
                "--from",
                dest="from_seq",
                type=int,
                default=0,
                metavar="SEQ",
                help="start at mission item SEQ (MISSION_START first_item; default 0: the vehicle continues "
                "from the mission's current goal, i.e. its progress)",
            )
    p = sub.add_parser(
        "wait-ready",
        help="wait until the vehicle's HEARTBEAT no longer says BOOT (it is ready: navigation valid)",
        epilog=EXIT_STATUS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--timeout",
        dest="ready_timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="give up after S s (exit 3)",
    )
    p = sub.add_parser(
        "fly",
        help="fly a mission file: upload it (fence and goals), wait until ready, arm, start, and show the "
        "progress to the end (0 COMPLETE; 1 with the vehicle's reason when it stops short; Ctrl-C: HOLD)",
        epilog=EXIT_STATUS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", type=Path, help="our YAML, a QGroundControl .plan or a QGC WPL 110 file")
    p.add_argument(
        "--ready-timeout", type=float, default=30.0, metavar="S", help="wait S s for the vehicle to be ready"
    )
    p = sub.add_parser(
        "logs", help="list the vehicle's flight logs (MCAP), or download one (MAVLink FTP): logs [get NAME]"
    )
    p.add_argument("action", nargs="?", choices=["get"])
    p.add_argument("name", nargs="?", help="a log's name as listed (default for get: the newest)")
    p.add_argument("-o", "--output", type=Path, help="file or folder to write it to (default: the name)")
    p = sub.add_parser("params", help="list, get or set parameters")
    p.add_argument("action", nargs="?", choices=["get", "set"])
    p.add_argument("name", nargs="?")
    p.add_argument("value", nargs="?", type=float)
    p = sub.add_parser("monitor", help="live telemetry table")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0 = never)")
    p = sub.add_parser("plot", help="plot a flight log (.mcap) or a tlog: track, paths, goals, states")
    p.add_argument("tlog", type=Path, metavar="FILE")
    p.add_argument("-o", "--output", type=Path, help="image file (default: FILE with .png)")
    gcs_map.add_parser(sub)
    return ap


def _load_key(path: Path | None) -> bytes | None:
    if path is None:
        return None
    raw = path.read_bytes()
    txt = raw.strip()
    if len(txt) == 64:
        return bytes.fromhex(txt.decode("ascii"))
    if len(raw) == 32:
        return raw
    raise ValueError(f"{path}: a signing key is 32 raw bytes or 64 hex characters")


def _session_tlog(tlog_dir: Path) -> Path:
    """The day's .tlog, ``gcs-YYYY-MM-DD.tlog`` (local date): every call of the day appends to it (one
    session's log, not one file per command; each record is one append, so two stations at once do not
    tear each other's records)."""
    return tlog_dir / f"gcs-{time.strftime('%Y-%m-%d')}.tlog"


#: The sub-commands that are an operator's session: they send GCS heartbeats, which the vehicle watches (a
#: one-shot command sends none, so its exit is no "link lost" on the vehicle).
SESSIONS = frozenset({"monitor", "fly", "map"})

#: The system ids a ground station draws its own from (255, the stock default, and below 200 are left to
#: vehicles and other tools).
OWN_SYSTEM_IDS = range(200, 255)


def _system_id(text: str) -> int:
    """argparse type: a MAVLink system id, 1-255 (a bad one is a one-line usage error, exit 2)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if not 1 <= value <= 255:
        raise argparse.ArgumentTypeError(f"a MAVLink system id is 1-255, got {value}")
    return value


def own_system_id() -> int:
    """A system id of this session's own, drawn from :data:`OWN_SYSTEM_IDS`."""
    return random.SystemRandom().choice(OWN_SYSTEM_IDS)


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    out = Out(args.json)
    if args.cmd == "plot":
        from groundstation.plot import plot_tlog

        target = args.output or args.tlog.with_suffix(".png")
        try:
            counts = plot_tlog(args.tlog, target)
        except (OSError, ValueError) as exc:
            out.done({"ok": False, "error": str(exc)}, labelled("error:", "red", exc))
            return 2
        out.done({"ok": True, "output": str(target), **counts}, f"wrote {target} ({counts})")
        return 0
    try:
        key = _load_key(args.signing_key)
        goals: list[Item] = []
        fences: list[Item] = []
        if args.cmd in ("upload", "fence", "fly"):
            goals, fences = mission_files.load(args.file)
    except (ValueError, OSError) as exc:
        out.done({"ok": False, "error": str(exc)}, labelled("error:", "red", exc))
        return 2
    tlog_dir = args.tlog_dir or default_tlog_dir()
    tlog_dir.mkdir(parents=True, exist_ok=True)
    tlog = _session_tlog(tlog_dir)
    try:
        system_id = args.system_id if args.system_id is not None else own_system_id()
        if args.cmd == "map":  # serves until stopped; it opens the link itself (a --tlog replay opens none)

            def connect() -> MavClient:
                return MavClient(args.connect, tlog=tlog, signing_key=key, system_id=system_id)

            return gcs_map.run(args, connect, out.done)
        session = args.cmd in SESSIONS  # GCS heartbeats (watched by the vehicle) only from a session
        with MavClient(
            args.connect, tlog=tlog, signing_key=key, system_id=system_id, gcs_session=session
        ) as client:
            client.heartbeat()
            t0 = time.monotonic()
            first_s = args.ready_timeout if args.cmd == "wait-ready" else args.timeout
            client.wait_heartbeat(first_s)
            if args.cmd == "wait-ready":
                return _wait_ready(client, out, max(0.0, args.ready_timeout - (time.monotonic() - t0)), t0)
            return _run(args, client, out, goals, fences, tlog)
    except UnknownParameter as exc:
        out.done({"ok": False, "error": str(exc), "tlog": str(tlog)}, labelled("refused:", "red", exc))
        return EXIT_REFUSED
    except LinkError as exc:
        out.done({"ok": False, "error": str(exc), "tlog": str(tlog)}, labelled("error:", "red", exc))
        return EXIT_ERROR
    except OSError as exc:  # the link could not be opened: e.g. the port is taken by another station
        why = exc.strerror or str(exc)
        text = f"cannot open {args.connect}: {why}"
        out.done({"ok": False, "error": text, "tlog": str(tlog)}, labelled("error:", "red", text))
        return EXIT_ERROR
    except KeyboardInterrupt:
        return EXIT_INTERRUPTED


def _run(
    args: argparse.Namespace, client: MavClient, out: Out, goals: list[Item], fences: list[Item], tlog: Path
) -> int:
    """The sub-command ``args.cmd`` over a link that heard the vehicle: each to its client's handler."""
    if args.cmd in ("upload", "fence"):
        return _upload(args, client.mission, out, goals, fences, tlog)
    if args.cmd == "download":
        return _download(args, client.mission, out)
    if args.cmd == "clear":
        r = client.mission.clear(mavlink.MAV_MISSION_TYPE_ALL)
        why = f": {r.reason}" if r.reason else ""
        out.done({"ok": r.ok, "result": r.result_name, "reason": r.reason}, f"clear: {r.result_name}{why}")
        return EXIT_OK if r.ok else EXIT_REFUSED
    if args.cmd in COMMANDS:
        cmd, params = command_params(args)
        ack: CommandAck = client.commands.command_ack(cmd, *params)
        data = {
            "ok": ack.ok,
            "command": args.cmd,
            "result": ack.result_name,
            "reason": ack.reason,
            "texts": list(ack.texts),
        }
        out.done(data, f"{args.cmd}: {ack.result_name}" + (f": {ack.reason}" if ack.reason else ""))
        return exit_code_of_command(ack.result)
    if args.cmd == "params":
        return _params(args, client.params, client, out)
    if args.cmd == "fly":
        return fly.run(client, out, goals, fences, ready_timeout_s=args.ready_timeout, tlog=tlog)
    if args.cmd == "logs":
        return _logs(args, client.ftp, out)
    if args.cmd == "monitor":
        from groundstation.monitor import monitor

        monitor(client, out.console, args.duration, as_json=args.json)
        return 0
    return 2


def _upload(
    args: argparse.Namespace,
    missions: MissionClient,
    out: Out,
    goals: list[Item],
    fences: list[Item],
    tlog: Path,
) -> int:
    """``upload`` and ``fence``: :func:`groundstation.fly.upload_plans`, its verdict and exit code."""
    with_fence = bool(fences) or args.cmd == "fence"
    results, note = fly.upload_plans(missions, out, goals, fences, args.cmd == "upload", with_fence)
    ok = all(r["ok"] for r in results)
    refused = next((r for r in results if not r["ok"]), None)
    text = lines([*map(fly.upload_text, results), *([note] if note else [])])
    data = {
        "ok": ok,
        "result": refused["result"] if refused else "MAV_MISSION_ACCEPTED",
        "reason": refused["reason"] if refused else "",
        "results": results,
        "in_force": note,
        "tlog": str(tlog),
    }
    out.done(data, text)
    if ok:
        return EXIT_OK
    return EXIT_ERROR if refused and refused["timeout"] else EXIT_REFUSED


def _download(args: argparse.Namespace, missions: MissionClient, out: Out) -> int:
    """``download``: the mission and fence, to a file in its format or to stdout."""
    g = missions.download(mavlink.MAV_MISSION_TYPE_MISSION)
    f = missions.download(mavlink.MAV_MISSION_TYPE_FENCE)
    fmt = args.format or mission_files.format_for(args.file)
    text = mission_files.dump(fmt, g, f)  # home: the vehicle's placeholder if it holds one (to_plan)
    if args.file:
        try:
            args.file.write_text(text, encoding="utf-8")
        except OSError as exc:
            why = f"cannot write {args.file}: {exc.strerror or exc}"
            out.done({"ok": False, "error": why}, labelled("error:", "red", why))
            return EXIT_ERROR
    data = {
        "ok": True,
        "goals": len(g),
        "obstacles": len(f),
        "file": str(args.file) if args.file else None,
        "format": fmt,
    }
    if args.json and not args.file:
        import yaml

        data["mission"] = yaml.safe_load(mission_files.to_yaml(g, f))
        if fmt != "yaml":
            data["text"] = text
    if args.file or args.json:
        out.done(data, f"wrote {args.file} ({fmt})")
    else:
        sys.stdout.write(text)  # the file's text as it is: no rich markup or wrapping, for a redirect
    return 0


def _logs(args: argparse.Namespace, files: FtpClient, out: Out) -> int:
    """``logs``: the flight logs in the vehicle's ``logs/`` over MAVLink FTP; ``get`` writes one whole."""
    entries = [(name, size) for kind, name, size in files.list_dir("logs") if kind == "F"]
    if args.action is None:
        text = lines(f"{name}  {size / 1e6:.2f} MB" for name, size in entries) or "no flight logs"
        out.done({"ok": True, "logs": [{"name": n, "size": s} for n, s in entries]}, text)
        return EXIT_OK
    if not entries:
        text = labelled("error:", "red", "no flight logs")
        out.done({"ok": False, "error": "no flight logs on the vehicle"}, text)
        return EXIT_ERROR  # as for a name not on the vehicle: nothing to download
    name = args.name or entries[-1][0]
    if Path(name).name != name or name in ("", ".", ".."):  # a log's name, never a path
        if args.name:
            why = f"not a log name: {name!r}"
            out.done({"ok": False, "error": why}, labelled("error:", "red", why))
            return EXIT_ERROR
        raise LinkError(f"the vehicle listed a log name that is a path: {name!r}")
    target = args.output or Path(name)
    if target.is_dir():
        target = target / name
    if out.as_json:
        data = files.read_file(f"logs/{name}")
    else:
        with out.progress() as prog:
            task = prog.add_task(name, total=None)
            data = files.read_file(
                f"logs/{name}", progress=lambda done, n: prog.update(task, completed=done, total=n)
            )
    try:
        target.write_bytes(data)
    except OSError as exc:
        text = f"cannot write {target}: {exc.strerror or exc}"
        out.done({"ok": False, "error": text}, labelled("error:", "red", text))
        return EXIT_ERROR
    out.done(
        {"ok": True, "name": name, "file": str(target), "bytes": len(data)},
        f"wrote {target} ({len(data)} bytes)",
    )
    return EXIT_OK


def _wait_ready(link: Link, out: Out, timeout_s: float, t0: float) -> int:
    """``wait-ready``: exit 0 once HEARTBEAT system_status is not UNINIT / BOOT, else 3 at the timeout."""
    ready, hb, why = link.wait_ready(timeout_s)
    status = MAV_STATE_NAMES.get(int(hb.system_status), str(hb.system_status)) if hb is not None else "-"
    state = state_from_heartbeat(hb) if hb is not None else "-"
    armed = bool(hb is not None and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    data = {
        "ok": ready,
        "ready": ready,
        "result": status,
        "reason": why,
        "state": state,
        "armed": armed,
        "waited_s": round(time.monotonic() - t0, 3),
    }
    if ready:
        out.done(data, f"ready: {status} ({state}{', armed' if armed else ''})")
        return EXIT_OK
    text = f"not ready after {data['waited_s']:g} s: {status} ({state})" + (f": {why}" if why else "")
    out.done(data, text)
    return EXIT_NOT_NOW


def _params(args: argparse.Namespace, params: ParamClient, link: Link, out: Out) -> int:
    if args.action is None:
        values = params.get_all()
        if args.json:
            out.done({"ok": True, "params": values}, "")
        else:
            from rich.table import Table

            table = Table("name", "value")
            for k, v in values.items():
                table.add_row(plain(k), f"{v:g}")
            out.console.print(table)
        return 0
    if not args.name:
        out.done(
            {"ok": False, "error": "parameter name missing"},
            labelled("error:", "red", "parameter name missing"),
        )
        return 2
    if args.action == "get":
        v = params.get(args.name)
        out.done({"ok": True, "name": args.name, "value": v}, f"{args.name} = {v:g}")
        return 0
    if args.value is None:
        out.done({"ok": False, "error": "value missing"}, labelled("error:", "red", "value missing"))
        return 2
    t_sent = time.monotonic()
    ok, v = params.set(args.name, args.value)
    why = "" if ok else link.reason_after(t_sent, time.monotonic())  # PARAM_SET has no ACK: its STATUSTEXT
    out.done(
        {"ok": ok, "name": args.name, "value": v, "reason": why},
        f"{args.name} = {v:g}" + ("" if ok else f" (refused {args.value:g}{': ' + why if why else ''})"),
    )
    return EXIT_OK if ok else EXIT_REFUSED


if __name__ == "__main__":
    raise SystemExit(main())
