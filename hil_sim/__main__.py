"""auv-hil: the ISiMI100 hardware-in-the-loop bench."""

from __future__ import annotations

import argparse
import logging
import sys

DESCRIPTION = """\
The ISiMI100 hardware-in-the-loop bench.

  demo       the paper's straight line and turn in closed loop (bench + firmware as real processes in
             lock-step), errors next to the paper's, figures in out/demo/.
  bus-demo   two real processes exchange E2E-protected frames through the bench hub; prints a table.
  scenario   one of the paper's scenarios end to end with metrics (--json, --plot DIR).
  campaign   fly a campaign spec (missions x seeds x currents x profiles x onboard overrides x vehicle
             variants) in parallel (local processes or Ray); runs.csv, summary.json, report.html.
  tune       tune onboard gains with optuna over a campaign spec (train and held-out runs).
  replay     play a recorded .blf/.asc frame log onto the bench bus (hosts the hub).
  run        host the bench CAN hub and fly the 6-DOF model: reads FIN_CMD / PROP_CMD (and SYNC_ACK in
             lock-step) from the bus; publishes AHRS, depth, DVL and position-fix frames at their sensor
             rates, FIN_STATUS / PROP_STATUS every control period, and a heartbeat per node at 1 Hz.
             Time modes: realtime (paced by the clock, the default) or lockstep (one SYNC per control
             period; integrates only after the onboard's SYNC_ACK; no wall clock is read).
"""


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="auv-hil", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("demo", help="the main demonstration")
    bd = sub.add_parser("bus-demo", help="two processes exchange protected frames through the hub")
    bd.add_argument("--count", type=int, default=200, help="SYNC frames to send (default 200)")
    bd.add_argument("--rate", type=float, default=100.0, help="SYNC rate in Hz (default 100)")
    for name, text in (
        ("campaign", "fly a campaign spec (python -m auv_campaign campaign --help)"),
        ("tune", "tune onboard gains over a campaign spec (python -m auv_campaign tune --help)"),
        ("scenario", "one of the paper's scenarios end to end"),
        ("replay", "play a recorded frame log onto the bench bus"),
        ("run", "host the bench hub and fly the 6-DOF model"),
    ):
        sub.add_parser(name, help=text, add_help=False)
    if argv and argv[0] in ("campaign", "tune"):
        # The campaigns fly the onboard core in this very process, which hil_sim may not import: they live
        # in auv_campaign, the one package that imports both. Hand the process over to it.
        import os

        os.execv(sys.executable, [sys.executable, "-m", "auv_campaign", *argv])
    if argv and argv[0] == "replay":
        from hil_sim.replay import main as replay_main

        return replay_main(argv[1:])
    if argv and argv[0] in ("run", "scenario"):
        from hil_sim.bench_program import main as bench_main

        return bench_main(argv)
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    if args.command == "demo":
        from hil_sim.demo import main as demo_main

        return demo_main()
    if args.command == "bus-demo":
        from hil_sim.busdemo import print_bus_demo, run_bus_demo

        result = run_bus_demo(count=args.count, rate_hz=args.rate)
        print_bus_demo(result)
        return 0 if result.ok else 1
    return 2


if __name__ == "__main__":
    sys.exit(main())
