"""auv-onboard: the ISiMI100 vehicle firmware."""

from __future__ import annotations

import argparse
import sys

DESCRIPTION = """\
The ISiMI100 onboard firmware.

  run    the fixed-rate control loop (default 20 Hz, 1-200 Hz by config). Reads sensor frames from the CAN
         bus (AHRS attitude and rates, depth, DVL velocity, position fix, actuator status, SYNC in
         lock-step); runs the mission, the virtual-goal homing planner, guidance and the revised PD
         controller; sends FIN_CMD and PROP_CMD every tick (and SYNC_ACK per SYNC in lock-step) and an
         ONBOARD_HEARTBEAT at 1 Hz. Bus from the [bus] table of --config (default: the bench hub on
         ws://127.0.0.1:54701/).
  plan   plan a homing path (pure, no bus): prints the path, its virtual goals and cost; --json for programs.
"""


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "plan":
        from onboard.app.plan_cli import main as plan_main

        return plan_main(argv[1:])
    if argv and argv[0] == "run":
        from onboard.app.runtime import main as run_main

        return run_main(argv[1:])
    parser = argparse.ArgumentParser(
        prog="auv-onboard", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("command", choices=["run", "plan"], help="run: the control loop; plan: a path")
    parser.parse_args(argv[:1] or ["--help"])
    return 2


if __name__ == "__main__":
    sys.exit(main())
