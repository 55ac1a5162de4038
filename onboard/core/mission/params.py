"""The ``[mission]`` table: arrival, misses, the end, capacities, planning deadline, the leg monitors."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from auv_common.config import check_declared, param, require

EndAction = Literal["surface", "loiter"]
#: What a monitor that ends a leg does (``monitor_action``): HOLD (the operator decides) or ABORT (surface).
MonitorAction = Literal["hold", "abort"]

#: The smallest arrival radius that means one, m: the navigation estimate is good to decimetres (a fix's
#: sigma is 0.3 m), so a radius below 0.1 m turns every arrival into a miss.
ARRIVAL_RADIUS_MIN_M = 0.1
#: The arrival radius's default, m: MIS_ARRIVE_R_M declares it with this value; guidance built without a
#: configuration (tests) uses it too.
ARRIVAL_RADIUS_DEFAULT_M = 0.5


@dataclass(frozen=True)
class MissionParams:
    """How a mission is flown and judged. Every key is optional; each is declared once below (unit, range,
    description, MAVLink name: ``docs/parameters.md``).

    ``arrival_radius_m`` is the one arrival distance: the path to a goal is done when the vehicle's estimate
    comes within it of the goal with the heading within ``[guidance] arrival_yaw_tol_deg``, or crosses the
    goal line (guidance gets it from :class:`~onboard.core.config.CoreConfig`); the goal is then reached
    if the estimate is within it of the goal, else it is a miss, re-planned until ``max_tries``, then HOLD.
    After the last goal, ``end_action``: ``surface`` (the vehicle stops, then propeller 0 and fins neutral,
    the positively buoyant vehicle floats up; disarmed once stopped) or ``loiter`` (circle the last goal at
    its depth; armed). The run-in to the last goal slows to ``arrival_speed_mps`` (the speed reference
    falls at ``run_in_decel_mps2``); after COMPLETE (surface) and in HOLD the vehicle brakes (propeller in
    reverse up to ``brake_rps``, stern planes level or nose up) until its speed over ground is about 0, so it
    stops within ``stop_distance_m``, the zone the validator keeps clear past every goal.

    The leg monitors (:mod:`onboard.core.executive.monitors`): less progress (along the path, or back
    onto it; all the tries at a goal together) than ``progress_min_mps`` over ``monitor_window_s``; off the
    path by more than ``cross_track_max_m`` (+ ``cross_track_sigmas`` x the position's 1-sigma) for
    ``cross_track_time_s``; a goal that takes ``eta_factor`` x its expected time; a goal the vehicle makes
    good slower than ``min_made_good_mps`` against the estimated current for ``feasibility_time_s``. Each
    ends the leg with ``monitor_action``: ``hold`` (HOLD, the operator decides) or ``abort`` (ABORT). At
    START and RESUME such a goal is refused (not now) with the figures.
    """

    arrival_radius_m: float = param(
        ARRIVAL_RADIUS_DEFAULT_M,
        unit="m",
        min=ARRIVAL_RADIUS_MIN_M,
        max=50.0,
        mavlink="MIS_ARRIVE_R_M",
        desc="goal arrival radius",
    )
    max_tries: int = param(3, min=1, max=20, mavlink="MIS_MAX_TRIES", desc="attempts at one goal before HOLD")
    end_action: EndAction = "surface"
    loiter_radius_m: float = param(
        0.0, unit="m", min=0.0, max=100.0, mavlink="MIS_LOITER_R_M",
        desc="loiter radius (0 = twice the turning radius)",
    )  # fmt: skip
    max_goals: int = param(1000, min=1, max=10000, desc="goals in one mission, at most")
    max_obstacles: int = param(64, min=0, max=1000, desc="fence circles in one mission, at most")
    plan_deadline_s: float = param(
        2.0, unit="s", min=0.05, max=60.0,
        desc="a plan (in the planning worker) that takes longer is a refusal with a reason",
    )  # fmt: skip
    # The end that stops (onboard/core/executive/surface.py; issue 23 item 3): the run-in to the last goal
    # slows to arrival_speed_mps, then COMPLETE (surface), HOLD brake with the propeller in reverse and the
    # stern planes nose up until the speed over ground is about 0; the validator keeps stop_distance_m past
    # every goal clear of obstacles and the depth limit.
    arrival_speed_mps: float = param(
        0.25, unit="m/s", min=0.0, max=5.0, mavlink="MIS_ARRIVE_SPD",
        desc="speed at the last goal: the run-in slows to it (0 = no slow-down)",
    )  # fmt: skip
    run_in_decel_mps2: float = param(
        0.025, unit="m/s^2", min=0.001, max=5.0, mavlink="MIS_RUNIN_DEC",
        desc="the run-in's speed reference falls at this rate towards the last goal",
    )  # fmt: skip
    brake_rps: float = param(
        10.0, unit="rps", min=0.0, max=40.0, mavlink="MIS_BRAKE_RPS",
        desc="reverse propeller speed, at most, while stopping after COMPLETE or in HOLD (0 = glide)",
    )  # fmt: skip
    stop_distance_m: float = param(
        3.0, unit="m", min=0.0, max=100.0, mavlink="MIS_STOP_M",
        desc="the stopping zone past every goal (along its heading) the validator keeps clear (0 = off)",
    )  # fmt: skip
    # The leg monitors and the feasibility check (onboard/core/executive/monitors.py; DUNE's PathController).
    # Defaults generous enough that no mission of the repo's campaign specs that completes is stopped: they
    # catch the missions that cannot be flown (campaign hil_sim/campaigns/strong_current_monitors.yaml).
    # Measured (issue 23): the progress window cannot be shorter (head_current 0.09 m/s over its first 30 s;
    # strong_current 1.5 m/s towards 0 completes after -0.06 m/s over 45 s); cross-track and feasibility never
    # fired in a completing run, so they get 20 s of their own; the ETA factor 4 (head_current: 3.4 x).
    monitor_action: MonitorAction = "hold"
    monitor_window_s: float = param(
        60.0, unit="s", min=5.0, max=600.0, mavlink="MIS_MON_WIN_S",
        desc="leg monitors' window: progress (along the path, over all the tries at a goal) measured over it",
    )  # fmt: skip
    progress_min_mps: float = param(
        0.1, unit="m/s", min=0.0, max=2.0, mavlink="MIS_PROG_MPS",
        desc="least progress (along the path flown, or back onto it) over the monitors' window, as a speed "
        "(0 = off)",
    )  # fmt: skip
    cross_track_max_m: float = param(
        15.0, unit="m", min=0.0, max=1000.0, mavlink="MIS_XTRACK_M",
        desc="off the path flown farther than this (plus cross_track_sigmas x the position's 1 sigma) "
        "for cross_track_time_s ends the leg (0 = off)",
    )  # fmt: skip
    cross_track_time_s: float = param(
        20.0, unit="s", min=1.0, max=600.0, mavlink="MIS_XTRACK_S",
        desc="off the path beyond the cross-track bound this long ends the leg",
    )  # fmt: skip
    cross_track_sigmas: float = param(
        3.0, min=0.0, max=10.0,
        desc="the cross-track bound widens by this many 1-sigma of the position estimate",
    )  # fmt: skip
    eta_factor: float = param(
        4.0, min=0.0, max=100.0, mavlink="MIS_ETA_FACTOR",
        desc="a goal that takes longer than this x its expected time (all its tries) ends the leg "
        "(0 = off; else >= 1)",
    )  # fmt: skip
    min_made_good_mps: float = param(
        0.25, unit="m/s", min=0.0, max=2.0, mavlink="MIS_MG_MIN_MPS",
        desc="a goal the vehicle makes good slower than this against the estimated current is refused "
        "at START and ends the leg while RUNNING (0 = off)",
    )  # fmt: skip
    feasibility_time_s: float = param(
        20.0, unit="s", min=1.0, max=600.0, mavlink="MIS_MG_S",
        desc="a goal judged unable to be made good this long while RUNNING ends the leg",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_declared(self)
        require(
            self.end_action in ("surface", "loiter"),
            f"end_action must be surface or loiter, got {self.end_action!r}",
        )
        require(
            self.monitor_action in ("hold", "abort"),
            f"monitor_action must be hold or abort, got {self.monitor_action!r}",
        )
        require(self.eta_factor == 0.0 or self.eta_factor >= 1.0, "eta_factor must be 0 (off) or >= 1")
