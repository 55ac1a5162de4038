"""One tick's record: what every stage of the pipeline computed, the one shape every reader takes.

:func:`onboard.core.pipeline.tick` returns one :class:`TickRecord` per control tick, carrying the output and
the debug of each stage (navigation, failsafes, the executive, guidance, PD, saturation). Every reader of a
tick reads this record and its names, and only these (``tick record`` in ``onboard/core/DESIGN.md``):

- the loop's telemetry row and CSV (:meth:`TickRecord.row`, ``[loop] telemetry_csv``, the scenario and
  campaign readers);
- the MAVLink snapshot (:func:`onboard.adapters.mavlink.bridge.snapshot` copies the row's values whose
  names :class:`~onboard.adapters.mavlink.api.VehicleSnapshot` has: the same name means the same number),
  and through it the MCAP flight log's ``/telemetry`` (which logs every snapshot field).

Names: SI units and radians, the unit in the name; errors are e = desired - actual (``e_yaw_rad``,
``e_depth_m``, as :class:`~onboard.core.guidance.guidance.GuidanceReference` names them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from onboard.core.control.actuators import ActuatorCommand
from onboard.core.control.pd import ControlDebug
from onboard.core.guidance.guidance import GuidanceDebug, GuidanceReference
from onboard.core.mission.state import MissionState, MissionStatus
from onboard.core.nav.estimator import NavDebug
from onboard.core.nav.types import NavState
from onboard.core.safety.diagnosis import FaultFlag, Measured
from onboard.core.safety.failsafe import FailsafeFlag
from onboard.protocol import messages as m


@dataclass(frozen=True)
class TickRecord:
    """One tick: the command the loop sends and what each stage computed to get there.

    ``command`` (after saturation), ``mode`` (the ACTUATOR_MODE the actuators get), ``mission_state`` and
    ``status`` (after the tick's events), ``nav`` (the navigation solution) with ``nav_debug`` (the fix's
    gate, None before the first step), ``failsafe_flags`` (the checks failing this tick), ``reference``
    (guidance's desired state and errors, None when no path is flown) with ``guidance_debug``, and
    ``control_debug`` (the PD's terms, None when the PD did not run), ``planner_error`` (the last plan's
    failure, "" when it succeeded), ``fault_flags`` (the faults the vehicle names,
    :mod:`onboard.core.safety.diagnosis`) with ``fault_measured`` (the detectors' figures).
    """

    command: ActuatorCommand
    mode: m.ActuatorMode
    mission_state: MissionState
    status: MissionStatus
    nav: NavState
    reference: GuidanceReference | None
    failsafe_flags: FailsafeFlag
    planner_error: str
    nav_debug: NavDebug | None = None
    guidance_debug: GuidanceDebug | None = None
    control_debug: ControlDebug | None = None
    fault_flags: FaultFlag = FaultFlag(0)  # noqa: RUF009 (an immutable IntFlag value)
    fault_measured: Measured | None = None

    @property
    def rudder_rad(self) -> float:
        return self.command.rudder_rad

    @property
    def stern_port_rad(self) -> float:
        return self.command.stern_port_rad

    @property
    def stern_starboard_rad(self) -> float:
        return self.command.stern_starboard_rad

    @property
    def propeller_rps(self) -> float:
        return self.command.propeller_rps

    def row(self) -> dict[str, float | int | str]:
        """The tick as one flat row, the names every reader uses (built on demand: the loop keeps the
        record). Unknown numbers are NaN; the columns and their order are the same every tick."""
        n, r, c = self.nav, self.reference, self.command
        row: dict[str, float | int | str] = {
            "state": self.status.state.name,
            "goal_index": self.status.goal_index,
            "x_m": n.x_m,
            "y_m": n.y_m,
            "depth_m": n.depth_m,
            "roll_rad": n.roll_rad,
            "pitch_rad": n.pitch_rad,
            "yaw_rad": n.yaw_rad,
            "u_mps": n.u_mps,
            "nav_conditions": int(n.conditions),
            "rudder_rad": c.rudder_rad,
            "stern_port_rad": c.stern_port_rad,
            "stern_starboard_rad": c.stern_starboard_rad,
            "propeller_rps": c.propeller_rps,
            "actuator_flags": int(c.flags),
            "failsafe_flags": int(self.failsafe_flags),
        }
        if r is None:
            row.update(_NO_REFERENCE_ROW)
        else:
            row["ref_x_m"] = r.x_m
            row["ref_y_m"] = r.y_m
            row["ref_depth_m"] = r.depth_m
            row["ref_yaw_rad"] = r.yaw_rad
            row["along_track_m"] = r.along_track_m
            row["cross_track_m"] = r.cross_track_m
            row["e_along_m"] = r.e_along_m
            row["e_cross_m"] = r.e_cross_m
            row["e_depth_m"] = r.e_depth_m
            row["e_yaw_rad"] = r.e_yaw_rad
        # the stages' debug, after the columns the readers had before (a CSV reader by name sees no change)
        row["v_mps"] = n.v_mps
        row["w_mps"] = n.w_mps
        row["p_radps"] = n.p_radps
        row["q_radps"] = n.q_radps
        row["r_radps"] = n.r_radps
        row["position_std_m"] = n.position_std_m
        row["position_std_max_m"] = n.position_std_max_m
        row["fixes_rejected"] = n.fixes_rejected
        row["current_north_mps"] = n.current_north_mps
        row["current_east_mps"] = n.current_east_mps
        d2 = self.nav_debug.fix_d2 if self.nav_debug is not None else None
        row["fix_d2"] = math.nan if d2 is None else d2
        g = self.guidance_debug
        row["los_correction_rad"] = g.los_correction_rad if g is not None else math.nan
        row["ilos_int_m"] = g.ilos_int_m if g is not None else math.nan
        row["crab_rad"] = g.crab_rad if g is not None else math.nan
        p = self.control_debug
        row["rps_ff"] = p.rps_ff if p is not None else math.nan
        row["rudder_ff_rad"] = p.rudder_ff_rad if p is not None else math.nan
        row["fault_flags"] = int(self.fault_flags)
        f = self.fault_measured if self.fault_measured is not None else _NO_MEASURED
        row["fin_error_deg"] = f.fin_error_deg
        row["heading_error_deg"] = f.heading_error_deg
        row["depth_innovation_m"] = f.depth_innovation_m
        row["thrust_ratio"] = f.thrust_ratio
        return row

    def telemetry_row(self) -> dict[str, float | int | str]:
        """:meth:`row` (the loop's :class:`~onboard.app.loop.StepResult` protocol asks for this name)."""
        return self.row()


_NO_MEASURED = Measured()

#: The reference columns of a tick without a guidance reference (same keys and order as with one).
_NO_REFERENCE_ROW: dict[str, float | int | str] = dict.fromkeys(
    (
        "ref_x_m",
        "ref_y_m",
        "ref_depth_m",
        "ref_yaw_rad",
        "along_track_m",
        "cross_track_m",
        "e_along_m",
        "e_cross_m",
        "e_depth_m",
        "e_yaw_rad",
    ),
    math.nan,
)

__all__ = ["TickRecord"]
