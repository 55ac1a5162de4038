"""The commander: the one judge of every command from every source (see ``onboard/core/DESIGN.md``).

:func:`judge` answers a :class:`~onboard.core.commands.Verdict` with a reason for each command. What depends
on the mission state alone (which event is allowed where and what to do instead, what changes nothing, that
a mission has goals, that a goal index is in range, which states are live) is asked of the state table,
:mod:`onboard.core.mission.state`, as a dry run; the judge adds only what the state cannot know (navigation
valid, the CAN bus, the actuator node's failsafe: :func:`readiness`, the one place it is checked; at START
and RESUME the goal's feasibility against the estimated current,
:func:`onboard.core.executive.monitors.feasibility`) and the commands that are not state events (a
mission, a parameter, a mode, a lost link or bus). :func:`apply` is the
one place a transition is carried out: the state changes, the operator is told, the executive learns it.
"""

from __future__ import annotations

import logging
from dataclasses import replace

from onboard.core import commands as c
from onboard.core.executive.monitors import feasibility
from onboard.core.mission.model import Mission, MissionError
from onboard.core.mission.state import MissionEvent, MissionState, Transition, goal_problem, no_op, transition
from onboard.core.mission.validate import check_limits
from onboard.core.nav.confidence import confidence_radius_m
from onboard.core.vehicle import Core

log = logging.getLogger(__name__)


def readiness(ap: Core) -> tuple[bool, str]:
    """(True, "") when a START would pass the vehicle's own checks, else (False, why): the CAN bus, a valid
    navigation solution whose position's 95 % region is within ``[nav] start_position_95_m`` (the first
    plan starts from the estimate), no latched actuator failsafe."""
    if ap.bus_lost:
        return False, f"CAN bus lost ({ap.bus_lost})"
    if not (ap.last_nav and ap.last_nav.valid):
        return False, "navigation not valid yet"
    region_m = confidence_radius_m(ap.last_nav.position_std_max_m)
    bound_m = ap.config.nav.start_position_95_m
    if not region_m <= bound_m:
        return False, (
            f"navigation not good enough to start: the position's 95 % region is {region_m:.1f} m, wider "
            f"than [nav] start_position_95_m {bound_m:g} m"
        )
    if ap.actuator_failsafe:
        return False, "the actuator node reports its failsafe (the SAFE command sent while ARMED clears it)"
    return True, ""


def judge(ap: Core, command: c.Command) -> c.Verdict:
    """The verdict on ``command``, carried out when accepted."""
    state = ap.status.state
    src = getattr(command, "source", "")
    if isinstance(command, c.Arm):
        if ap.bus_lost and not no_op(ap.status, MissionEvent.ARM) and state is not MissionState.ABORT:
            return c.not_now(f"CAN bus lost ({ap.bus_lost}): the actuators cannot be reached")
        return _event(ap, MissionEvent.ARM, src)
    if isinstance(command, c.Disarm):
        return _event(ap, MissionEvent.DISARM_FORCED if command.forced else MissionEvent.DISARM, src)
    if isinstance(command, c.Start):
        return _start(ap, command.first_goal, src)
    if isinstance(command, c.Hold):
        return _event(ap, MissionEvent.HOLD, src)
    if isinstance(command, c.Resume):
        if no_op(ap.status, MissionEvent.RESUME) or state is not MissionState.HOLD:
            return _event(ap, MissionEvent.RESUME, src)  # the table's no-op or refusal
        return _start(ap, None, src)
    if isinstance(command, c.Abort):
        return _event(ap, MissionEvent.ABORT, f"{command.reason} ({src})" if src else command.reason)
    if isinstance(command, c.SetCurrent):
        return _set_current(ap, command.index)
    if isinstance(command, c.SetMode):
        return _set_mode(ap, command)
    if isinstance(command, c.ReplaceMission):
        return _replace(ap, command.mission, command.goals_changed, src)
    if isinstance(command, c.SetParam):
        return _set_param(ap, command.name, command.value)
    if isinstance(command, c.LinkLost):
        if command.action == "hold" and state is MissionState.RUNNING:
            return _event(ap, MissionEvent.HOLD, "ground-station link lost", severity=c.Severity.WARNING)
        if command.action == "surface" and ap.status.active:
            return _event(ap, MissionEvent.ABORT, "ground-station link lost: surface")
        return c.accepted(f"ground-station link lost: {command.action} ({state.name})")
    if isinstance(command, c.BusLost):
        return _bus_lost(ap, command.reason)
    if isinstance(command, c.BusBack):
        return _bus_back(ap)
    return c.Verdict(c.Outcome.UNSUPPORTED, f"unknown command {type(command).__name__}")


def apply(
    ap: Core,
    event: MissionEvent,
    detail: str = "",
    *,
    goal_count: int | None = None,
    goal_index: int | None = None,
    severity: c.Severity | None = None,
) -> Transition:
    """Carry out a mission event: the state table's transition; each accepted one is noted once for the
    operator (``severity``: of the note; default CRITICAL for ABORT, else INFO) and told to the executive."""
    if event is MissionEvent.MISSION_REPLACED and goal_count is None:
        goal_count = len(ap.mission.goals)
    result = transition(
        ap.status,
        event,
        goal_count=goal_count,
        goal_index=goal_index,
        detail=detail,
        complete_armed=ap.config.mission.end_action == "loiter",
    )
    if not result.accepted:
        log.debug("mission event %s rejected: %s", event.value, result.reason)
        return result
    result = _with_faults(ap, result)
    before = ap.status.state
    ap.status = result.status
    after = result.status.state
    if after is not before or event is not MissionEvent.GOAL_REACHED:
        log.info("mission %s -> %s (%s)", before.name, after.name, result.reason)
    if severity is None:
        severity = c.Severity.CRITICAL if after is MissionState.ABORT else c.Severity.INFO
    ap.note(severity, result.reason)
    ap.executive.on_transition(ap, event, after)
    if after is not MissionState.ARMED:
        ap.autostart_pending = False
    return result


#: The ends of a mission, whose reason names the faults the vehicle named on it.
_ENDS = (MissionState.COMPLETE, MissionState.HOLD, MissionState.ABORT)


def _with_faults(ap: Core, result: Transition) -> Transition:
    """An end of a mission (COMPLETE, HOLD, ABORT) with the faults named on it appended to its reason (a
    campaign's ``final_reason``, the operator's last word): those its own detail does not name already."""
    named = ap.faults_named
    if not named or result.status.state not in _ENDS or result.status.state is ap.status.state:
        return result
    missing = [part for part in named.split("; ") if part.split(" ", 1)[0] not in result.reason]
    if not missing:
        return result
    reason = f"{result.reason}; faults named: {'; '.join(missing)}"
    return replace(result, status=replace(result.status, reason=reason), reason=reason)


def _event(
    ap: Core,
    event: MissionEvent,
    detail: str = "",
    goal_index: int | None = None,
    severity: c.Severity | None = None,
) -> c.Verdict:
    """The table's no-op, refusal or transition for ``event``, as a verdict."""
    same = no_op(ap.status, event)
    if same:
        return c.accepted(same)
    result = apply(ap, event, detail, goal_index=goal_index, severity=severity)
    return c.accepted(result.reason) if result.accepted else c.denied(result.reason)


def _start(ap: Core, first_goal: int | None, src: str) -> c.Verdict:
    """START (or RESUME, or mode "mission"): the table's dry run, then the vehicle's readiness."""
    status = ap.status
    if status.state is MissionState.RUNNING and first_goal is not None and first_goal != status.goal_index:
        return _set_current(ap, first_goal)
    event = (
        MissionEvent.RESUME
        if status.state is MissionState.HOLD and first_goal is None
        else MissionEvent.START
    )
    same = no_op(status, event)
    if same:
        return c.accepted(same)
    dry = transition(status, event, goal_index=first_goal, detail=src)
    if not dry.accepted:
        return c.denied(dry.reason)
    ok, why = readiness(ap)
    if not ok:
        return c.not_now(why)
    index = dry.status.goal_index  # a goal the vehicle cannot make good against the current: not now
    if ap.last_nav is not None and 0 <= index < len(ap.mission.goals):
        why = feasibility(ap.config, ap.last_nav, ap.mission.goals[index], index)
        if why:
            return c.not_now(why)
    return _event(ap, event, src, goal_index=first_goal)


def _set_current(ap: Core, index: int) -> c.Verdict:
    why = goal_problem(ap.status, index)
    if why:
        return c.denied(why)
    ap.status = replace(ap.status, goal_index=index)
    ap.executive.goto.goal_set(ap.executive)
    return c.accepted(f"current goal {index}")


def _set_mode(ap: Core, command: c.SetMode) -> c.Verdict:
    """DO_SET_MODE: ``mission`` starts or resumes, ``loiter`` holds, ``surface`` aborts; ``ready`` only when
    nothing moves and nothing is to be acknowledged."""
    src, state = command.source, ap.status.state
    if command.mode == "mission":
        return _start(ap, None, src)
    if command.mode == "loiter":
        return judge(ap, c.Hold(src))
    if command.mode == "surface":
        return judge(ap, c.Abort("mode surface", src))
    if state in (MissionState.RUNNING, MissionState.HOLD):
        return c.denied(f"{state.name}: hold or abort to leave the mission")
    if state is MissionState.ABORT:
        return c.denied("ABORT: disarm to acknowledge it")
    if ap.actuators_live:  # COMPLETE, loitering or still braking: the propeller turns, "ready" would be a lie
        doing = "braking to a stop" if ap.executive.stop.braking else "loitering"
        return c.denied(f"{state.name} ({doing}): disarm to stop")
    return c.accepted(f"ready ({state.name}): nothing to change")


def _bus_lost(ap: Core, reason: str) -> c.Verdict:
    ap.bus_lost = reason or "no reason given"
    what = f"CAN bus lost ({ap.bus_lost})"
    state = ap.status.state
    if state is MissionState.ABORT or not (ap.actuators_live or ap.status.active):
        ap.note(c.Severity.CRITICAL, f"{what}: {state.name}, reconnecting")
        return c.accepted(f"{what} ({state.name})")
    verdict = _event(ap, MissionEvent.FAILSAFE, f"{what}, reconnecting")
    if verdict.accepted:
        ap.bus_abort = ap.status
    return verdict


def _bus_back(ap: Core) -> c.Verdict:
    if not ap.bus_lost:
        return c.accepted("CAN bus up")
    was, ap.bus_lost = ap.bus_lost, ""
    aborted, ap.bus_abort = ap.bus_abort, None
    if aborted is not None and ap.status is aborted:  # nothing happened since the loss's ABORT
        return _event(
            ap,
            MissionEvent.DISARM,
            "CAN bus back: disarmed, the mission kept (arm and start to fly it again)",
            severity=c.Severity.NOTICE,
        )
    ap.note(c.Severity.NOTICE, f"CAN bus back (it was lost: {was})")
    return c.accepted(f"CAN bus back ({ap.status.state.name})")


def _replace(ap: Core, mission: Mission, goals_changed: bool, src: str) -> c.Verdict:
    try:
        mission.validate()
    except MissionError as exc:
        return c.denied(f"mission refused: {exc}")
    broken = check_limits(mission, ap.config).first  # the configuration may have changed since
    if broken is not None:
        return c.denied(f"mission refused: {broken}")
    if not goals_changed:
        ap.mission = mission
        ap.executive.fence_replaced(ap)
        return c.accepted(f"fence replaced ({len(mission.obstacles)} obstacles)")
    old = ap.mission
    ap.mission = mission
    result = apply(ap, MissionEvent.MISSION_REPLACED, src, goal_count=len(mission.goals))
    if not result.accepted:
        ap.mission = old
        return c.denied(result.reason)
    ap.executive.mission_replaced()
    return c.accepted(result.reason)


def _set_param(ap: Core, name: str, value: float) -> c.Verdict:
    from onboard.core import params

    try:
        in_force = params.param_value(ap.config, name)
    except params.ParamError as exc:
        return c.denied(exc.reason)
    if ap.bus_limits is None:
        return c.denied(f"{name}: parameters cannot be set (the bus limits are unknown)", value=in_force)
    try:
        config = params.apply_param(ap.config, name, value, ap.bus_limits)
    except params.ParamError as exc:
        return c.denied(exc.reason, value=in_force)
    broken = check_limits(ap.mission, config).first
    if broken is not None:  # e.g. a failsafe depth above a goal of the mission in force
        return c.denied(f"{name} = {value:g} refused: the mission would break it ({broken})", value=in_force)
    ap.config = config
    return c.accepted(f"{name} = {value:g}", value=params.param_value(ap.config, name))


__all__ = ["apply", "judge", "readiness"]
