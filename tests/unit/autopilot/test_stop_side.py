"""A fast stop turns hard to the side clear of the obstacles (issue 23 item 4: 0 penetrations after the end).

The stop after COMPLETE puts the rudder hard over while faster than HARD_OVER_MPS, the way it was already
turning. Arriving at 1.05 m/s (clutter_current r7: the run-in did not fit among the obstacles) it turned
that way into an obstacle 5 m past the last goal, 1.4 m deep.
"""

from __future__ import annotations

import math

from onboard.core.control.actuators import ActuatorCommand
from onboard.core.executive.surface import Stop, clear_side
from onboard.core.nav.types import nav_state_at
from tests.unit.autopilot.test_autopilot import load_core

#: An obstacle ahead to starboard of a vehicle at the origin heading north (NED: east is starboard).
STARBOARD = ((3.0, 4.5, 1.5),)
STARBOARD_RUDDER = -0.3  # negative rudder: a turn to starboard (the bus contract's sign)


def test_the_side_clear_of_an_obstacle_is_chosen_over_the_way_it_was_turning() -> None:
    # GIVEN a vehicle turning to starboard with an obstacle ahead to starboard
    # THEN the stop turns to port (positive rudder)
    assert clear_side(0.0, 0.0, 0.0, STARBOARD, STARBOARD_RUDDER) == 1.0
    # AND with the obstacle to port it keeps turning to starboard
    assert clear_side(0.0, 0.0, 0.0, ((3.0, -4.5, 1.5),), STARBOARD_RUDDER) == -1.0
    # AND with none near, the way it was turning
    assert clear_side(0.0, 0.0, 0.0, ((50.0, 50.0, 1.0),), STARBOARD_RUDDER) == -1.0
    assert clear_side(0.0, 0.0, 0.0, (), 0.2) == 1.0


def test_a_fast_stop_puts_the_rudder_over_to_the_clear_side() -> None:
    # GIVEN the stop begun at 1.0 m/s among the mission's obstacles, the rudder turning to starboard
    cfg = load_core()
    stop = Stop()
    stop.begin(1.0, STARBOARD)
    nav = nav_state_at(0.0, 0.0, 1.0, 0.0, u_mps=1.0)
    previous = ActuatorCommand(STARBOARD_RUDDER, 0.0, 0.0, 20.0)
    rudders = []
    for _ in range(40):
        cmd = stop.command(nav, cfg, previous, 0.05)
        assert cmd is not None
        rudders.append(cmd.rudder_rad)
        previous = cmd
    # THEN the rudder goes over to port, hard (its limit), not on to starboard
    assert rudders[-1] == math.radians(cfg.control.limits.rudder_limit_deg)
    # AND without obstacles it goes hard over the way it was turning, as before
    stop.begin(1.0)
    cmd = stop.command(nav, cfg, ActuatorCommand(STARBOARD_RUDDER, 0.0, 0.0, 20.0), 0.05)
    assert cmd is not None and cmd.rudder_rad < STARBOARD_RUDDER
