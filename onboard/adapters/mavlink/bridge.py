"""The per-tick bridge between the autopilot and the MAVLink endpoint (no pymavlink here).

- :func:`param_specs`: the MAVLink parameter table built from the running configuration, so a parameter's
  default is the value the vehicle flies with (the 16 gains of paper eqs. 8-10 named as in the paper, the
  actuator limits and the planner weights).
- :func:`apply_event`: a ground-station event (already acknowledged by the endpoint) applied to the autopilot.
- :func:`snapshot`: what the endpoint publishes as telemetry, from one tick's output.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Any

from auv_common.config import ConfigError
from onboard.adapters.mavlink import api
from onboard.adapters.mavlink.params import ParamSpec
from onboard.core.autopilot import Autopilot, StepOutput
from onboard.core.control.actuators import ActuatorFlag
from onboard.core.mission.state import MissionEvent, MissionState

log = logging.getLogger(__name__)

GAIN_NAMES = tuple(f"K{kind}{i}" for i in range(1, 9) for kind in ("p", "D"))
_LIMIT_PARAMS = {
    "LIM_RUDDER_DEG": ("rudder_limit_deg", 1.0, 45.0),
    "LIM_STERN_DEG": ("stern_limit_deg", 1.0, 45.0),
    "LIM_RPS_MAX": ("propeller_max_rps", 0.0, 40.0),
}
_PLANNER_PARAMS = {
    "PLN_W_D": ("weight_distance", 0.0, 1000.0),
    "PLN_W_PSI": ("weight_yaw", 0.0, 1000.0),
    "PLN_W_DR": ("weight_rudder", 0.0, 1000.0),
    "PLN_MARGIN_M": ("obstacle_margin_m", 0.0, 50.0),
}


def _param_name(gain: str) -> str:
    return f"PD_{gain.upper()}" if gain.startswith("Kp") else f"PD_{gain}"


def param_specs(ap: Autopilot) -> tuple[ParamSpec, ...]:
    """The parameter table with the running configuration as defaults."""
    gains = ap.config.control.gains
    specs = [
        ParamSpec(
            _param_name(g), float(getattr(gains, g)), -100.0, 100.0, "", f"revised PD gain {g} (eqs. 8-10)"
        )
        for g in GAIN_NAMES
    ]
    limits = ap.config.control.limits
    for name, (attr, lo, hi) in _LIMIT_PARAMS.items():
        specs.append(ParamSpec(name, float(getattr(limits, attr)), lo, hi, "", f"actuator limit {attr}"))
    for name, (attr, lo, hi) in _PLANNER_PARAMS.items():
        specs.append(ParamSpec(name, float(getattr(ap.config.planner, attr)), lo, hi, "", f"planner {attr}"))
    return tuple(specs)


def apply_param(ap: Autopilot, name: str, value: float) -> bool:
    """Put one parameter value into the running configuration.

    False if the name is not ours or the value breaks a rule of the configuration that spans several
    values (e.g. propeller max above min): the running configuration is then left unchanged.
    """
    try:
        return _apply_param(ap, name, value)
    except (ConfigError, ValueError) as exc:
        log.error("parameter %s = %g not applied: %s", name, value, exc)
        return False


def _apply_param(ap: Autopilot, name: str, value: float) -> bool:
    cfg = ap.config
    for gain in GAIN_NAMES:
        if _param_name(gain) == name:
            profile = cfg.control.profile
            changes: dict[str, Any] = {gain: value}
            gains = dataclasses.replace(cfg.control.gains, **changes)
            control = dataclasses.replace(cfg.control, **{profile: gains})  # type: ignore[arg-type]
            ap.config = dataclasses.replace(cfg, control=control)
            return True
    if name in _LIMIT_PARAMS:
        limit_changes: dict[str, Any] = {_LIMIT_PARAMS[name][0]: value}
        limits = dataclasses.replace(cfg.control.limits, **limit_changes)
        ap.config = dataclasses.replace(cfg, control=dataclasses.replace(cfg.control, limits=limits))
        return True
    if name in _PLANNER_PARAMS:
        planner_changes: dict[str, Any] = {_PLANNER_PARAMS[name][0]: value}
        ap.config = dataclasses.replace(cfg, planner=dataclasses.replace(cfg.planner, **planner_changes))
        return True
    return False


def apply_event(ap: Autopilot, event: api.VehicleEvent) -> None:
    """Apply one ground-station event to the autopilot (logged on acceptance/rejection by the autopilot)."""
    if isinstance(event, api.MissionReplaced):
        if event.mission != ap.mission:  # the endpoint announces the start-up mission the loop already has
            ap.replace_mission(event.mission)
    elif isinstance(event, api.Arm):
        ap.apply(MissionEvent.ARM, "MAVLink arm")
    elif isinstance(event, api.Disarm):
        ap.apply(MissionEvent.DISARM, "MAVLink disarm")
    elif isinstance(event, api.StartMission):
        state = ap.status.state
        if state is MissionState.HOLD:
            ap.apply(MissionEvent.RESUME, "MAVLink mission start (resume)")
        else:
            if state is MissionState.COMPLETE:  # fly the mission again: back to ARMED with the same goals
                ap.replace_mission(ap.mission)
            ap.apply(MissionEvent.START, "MAVLink mission start")
        if event.first_index is not None and ap.status.state is MissionState.RUNNING:
            ap.set_current(event.first_index)
    elif isinstance(event, api.Abort):
        ap.apply(MissionEvent.ABORT, f"MAVLink abort: {event.reason}")
    elif isinstance(event, api.Hold):
        ap.apply(MissionEvent.HOLD, "MAVLink hold")
    elif isinstance(event, api.Resume):
        ap.apply(MissionEvent.RESUME, "MAVLink resume")
    elif isinstance(event, api.SetCurrent):
        ap.set_current(event.index)
    elif isinstance(event, api.ParamChanged):
        if not apply_param(ap, event.name, event.value):
            log.warning("parameter %s is not used by this vehicle", event.name)
    elif isinstance(event, api.GcsLinkLost):
        log.warning("ground-station link lost: action %s", event.action)
        if event.action == "hold":
            ap.apply(MissionEvent.HOLD, "GCS link lost")
        elif event.action == "surface":
            ap.apply(MissionEvent.ABORT, "GCS link lost: surface")
    elif isinstance(event, api.GcsLinkRegained):
        log.info("ground-station link regained")


def snapshot(ap: Autopilot, out: StepOutput, now_s: float, overruns: int = 0) -> api.VehicleSnapshot:
    """The telemetry snapshot of one tick."""
    n, r, c = out.nav, out.reference, out.command
    nan = math.nan
    goal_distance = nan
    if ap.mission.goals and out.status.goal_index < len(ap.mission.goals):
        g = ap.mission.goals[out.status.goal_index]
        goal_distance = math.hypot(g.x_m - n.x_m, g.y_m - n.y_m)
    return api.VehicleSnapshot(
        t_s=now_s,
        state=out.status.state.name,  # type: ignore[arg-type]
        current_goal=out.status.goal_index,
        goals_reached=ap.goals_reached,
        x_m=n.x_m,
        y_m=n.y_m,
        depth_m=n.depth_m,
        roll_rad=n.roll_rad,
        pitch_rad=n.pitch_rad,
        yaw_rad=n.yaw_rad,
        u_mps=n.u_mps,
        v_mps=n.v_mps,
        w_mps=n.w_mps,
        p_radps=n.p_radps,
        q_radps=n.q_radps,
        r_radps=n.r_radps,
        cross_track_m=r.cross_track_m if r else nan,
        along_track_m=r.along_track_m if r else nan,
        yaw_error_rad=r.e_yaw_rad if r else nan,
        depth_error_m=r.e_depth_m if r else nan,
        goal_distance_m=goal_distance,
        rudder_rad=c.rudder_rad,
        stern_port_rad=c.stern_port_rad,
        stern_starboard_rad=c.stern_starboard_rad,
        propeller_rps=c.propeller_rps,
        rudder_saturated=bool(c.flags & ActuatorFlag.RUDDER_LIMIT),
        stern_saturated=bool(c.flags & ActuatorFlag.STERN_LIMIT),
        propeller_saturated=bool(c.flags & ActuatorFlag.PROPELLER_LIMIT),
        failsafe=out.status.reason if out.status.state.name == "ABORT" else None,
        overruns=overruns,
    )
