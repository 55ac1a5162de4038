"""``auv-gcs``: the operator's MAVLink tool for the ISiMI100.

    auv-gcs [--connect URL] [--json] upload FILE | download [FILE] | clear | fence FILE | arm | disarm |
            start | hold | resume | abort | params [get NAME | set NAME VALUE] | monitor | plot TLOG

URL: udpin:HOST:PORT (default udpin:0.0.0.0:14550, where the vehicle sends), udpout:HOST:PORT, tcp:HOST:PORT.
Every session is recorded as a .tlog in --tlog-dir (default ~/.local/share/isimi100/tlogs).
Exit status: 0 done, 1 refused by the vehicle, 2 usage / file / link error.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from groundstation import mission_files
from groundstation.mavclient import MAV_RESULT_NAMES, Item, LinkError, MavClient

COMMANDS: dict[str, tuple[int, tuple[float, ...]]] = {
    "arm": (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,)),
    "disarm": (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (0.0,)),
    "start": (mavlink.MAV_CMD_MISSION_START, (0.0, 0.0)),
    "hold": (mavlink.MAV_CMD_DO_PAUSE_CONTINUE, (0.0,)),
    "resume": (mavlink.MAV_CMD_DO_PAUSE_CONTINUE, (1.0,)),
    "abort": (mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, ()),
}


def default_tlog_dir() -> Path:
    base = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(base) / "isimi100" / "tlogs"


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="auv-gcs", description="ISiMI100 ground station (MAVLink 2)")
    ap.add_argument("--connect", default="udpin:0.0.0.0:14550", help="udpin:H:P | udpout:H:P | tcp:H:P")
    ap.add_argument("--json", action="store_true", help="machine-readable output")
    ap.add_argument("--tlog-dir", type=Path, default=None, help="where the session .tlog goes")
    ap.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the vehicle")
    ap.add_argument("--signing-key", type=Path, help="sign with this key (32 bytes or 64 hex characters)")
    ap.add_argument("--system-id", type=int, default=255, help="our MAVLink system id")
    sub = ap.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("upload", help="upload goals (and obstacles, if the file has any)")
    p.add_argument("file", type=Path)
    p = sub.add_parser("download", help="download the mission and fence")
    p.add_argument("file", type=Path, nargs="?")
    sub.add_parser("clear", help="clear mission and fence")
    p = sub.add_parser("fence", help="upload the obstacles of a file as the fence")
    p.add_argument("file", type=Path)
    for name in COMMANDS:
        sub.add_parser(name, help=f"send the {name} command")
    p = sub.add_parser("params", help="list, get or set parameters")
    p.add_argument("action", nargs="?", choices=["get", "set"])
    p.add_argument("name", nargs="?")
    p.add_argument("value", nargs="?", type=float)
    p = sub.add_parser("monitor", help="live telemetry table")
    p.add_argument("--duration", type=float, default=0.0, help="stop after this many seconds (0 = never)")
    p = sub.add_parser("plot", help="plot track and errors from a tlog")
    p.add_argument("tlog", type=Path)
    p.add_argument("-o", "--output", type=Path, help="image file (default: TLOG with .png)")
    return ap


class _Out:
    def __init__(self, as_json: bool) -> None:
        self.as_json = as_json
        from rich.console import Console

        self.console = Console(stderr=as_json)

    def done(self, data: dict[str, Any], text: str) -> None:
        if self.as_json:
            sys.stdout.write(json.dumps(data, default=str) + "\n")
        else:
            self.console.print(text)


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


def _upload(client: MavClient, out: _Out, items: list[Item], mission_type: int, label: str) -> dict[str, Any]:
    if out.as_json or not items:
        r = client.upload(items, mission_type)
    else:
        from rich.progress import Progress

        with Progress(console=out.console, transient=True) as prog:
            task = prog.add_task(f"upload {label}", total=len(items))
            r = client.upload(items, mission_type, progress=lambda done, n: prog.update(task, completed=done))
    return {"type": label, "items": len(items), "ok": r.ok, "result": r.result_name, "elapsed_s": r.elapsed_s}


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    out = _Out(args.json)
    if args.cmd == "plot":
        from groundstation.plot import plot_tlog

        target = args.output or args.tlog.with_suffix(".png")
        try:
            counts = plot_tlog(args.tlog, target)
        except OSError as exc:
            out.done({"ok": False, "error": str(exc)}, f"[red]error:[/] {exc}")
            return 2
        out.done({"ok": True, "output": str(target), **counts}, f"wrote {target} ({counts})")
        return 0
    try:
        key = _load_key(args.signing_key)
        goals: list[Item] = []
        fences: list[Item] = []
        if args.cmd in ("upload", "fence"):
            goals, fences = mission_files.load(args.file)
    except (ValueError, OSError) as exc:
        out.done({"ok": False, "error": str(exc)}, f"[red]error:[/] {exc}")
        return 2
    tlog_dir = args.tlog_dir or default_tlog_dir()
    tlog_dir.mkdir(parents=True, exist_ok=True)
    tlog = tlog_dir / f"gcs-{time.strftime('%Y%m%d-%H%M%S')}-{os.getpid()}.tlog"
    try:
        with MavClient(args.connect, tlog=tlog, signing_key=key, system_id=args.system_id) as client:
            client.heartbeat()
            client.wait_heartbeat(args.timeout)
            return _run(args, client, out, goals, fences, tlog)
    except LinkError as exc:
        out.done({"ok": False, "error": str(exc), "tlog": str(tlog)}, f"[red]error:[/] {exc}")
        return 2
    except KeyboardInterrupt:
        return 130


def _run(
    args: argparse.Namespace, client: MavClient, out: _Out, goals: list[Item], fences: list[Item], tlog: Path
) -> int:
    if args.cmd in ("upload", "fence"):
        results = []
        if args.cmd == "upload":
            results.append(_upload(client, out, goals, mavlink.MAV_MISSION_TYPE_MISSION, "mission"))
        if fences or args.cmd == "fence":
            results.append(_upload(client, out, fences, mavlink.MAV_MISSION_TYPE_FENCE, "fence"))
        ok = all(r["ok"] for r in results)
        text = "\n".join(
            f"{r['type']}: {r['items']} items {'accepted' if r['ok'] else 'REFUSED'} ({r['result']}, "
            f"{r['elapsed_s']:.3f} s)"
            for r in results
        )
        out.done({"ok": ok, "results": results, "tlog": str(tlog)}, text)
        return 0 if ok else 1
    if args.cmd == "download":
        g = client.download(mavlink.MAV_MISSION_TYPE_MISSION)
        f = client.download(mavlink.MAV_MISSION_TYPE_FENCE)
        text = (
            mission_files.to_wpl(g, f) if args.file and args.file.suffix in (".txt", ".waypoints") else None
        )
        text = text or mission_files.to_yaml(g, f)
        if args.file:
            args.file.write_text(text, encoding="utf-8")
        data = {
            "ok": True,
            "goals": len(g),
            "obstacles": len(f),
            "file": str(args.file) if args.file else None,
        }
        if args.json and not args.file:
            import yaml

            data["mission"] = yaml.safe_load(mission_files.to_yaml(g, f))
        out.done(data, f"wrote {args.file}" if args.file else text)
        return 0
    if args.cmd == "clear":
        r = client.clear(mavlink.MAV_MISSION_TYPE_ALL)
        out.done({"ok": r.ok, "result": r.result_name}, f"clear: {r.result_name}")
        return 0 if r.ok else 1
    if args.cmd in COMMANDS:
        cmd, params = COMMANDS[args.cmd]
        result = client.command(cmd, *params)
        name = MAV_RESULT_NAMES.get(result, str(result))
        ok = result == mavlink.MAV_RESULT_ACCEPTED
        out.done({"ok": ok, "command": args.cmd, "result": name}, f"{args.cmd}: {name}")
        return 0 if ok else 1
    if args.cmd == "params":
        return _params(args, client, out)
    if args.cmd == "monitor":
        from groundstation.monitor import monitor

        monitor(client, out.console, args.duration, as_json=args.json)
        return 0
    return 2


def _params(args: argparse.Namespace, client: MavClient, out: _Out) -> int:
    if args.action is None:
        values = client.param_list()
        if args.json:
            out.done({"ok": True, "params": values}, "")
        else:
            from rich.table import Table

            table = Table("name", "value")
            for k, v in values.items():
                table.add_row(k, f"{v:g}")
            out.console.print(table)
        return 0
    if not args.name:
        out.done({"ok": False, "error": "parameter name missing"}, "[red]error:[/] parameter name missing")
        return 2
    if args.action == "get":
        v = client.param_get(args.name)
        out.done({"ok": True, "name": args.name, "value": v}, f"{args.name} = {v:g}")
        return 0
    if args.value is None:
        out.done({"ok": False, "error": "value missing"}, "[red]error:[/] value missing")
        return 2
    ok, v = client.param_set(args.name, args.value)
    out.done(
        {"ok": ok, "name": args.name, "value": v},
        f"{args.name} = {v:g}" + ("" if ok else f" (refused {args.value:g})"),
    )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
