"""What the core reads of the bus: the edge between the bus contract and the core's own types.

The bus messages (:mod:`onboard.protocol.messages`) and the navigation types (:mod:`onboard.core.nav.types`)
share their units and conventions (SI, radians, NED / FRD, the sample time ``t_sample_s``); this is the one
place that copies the one into the other (and reads the actuator node's failsafe bit and its feedback for
the fault detectors), so the decision code
(the commander, the executive, the pipeline's stages) never sees a bus message.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from onboard.core.nav.types import Ahrs, Depth, DvlVelocity, NavInputs, PositionFix
from onboard.core.safety.diagnosis import ActuatorFeedback
from onboard.protocol import messages as m


def nav_inputs(cache: Mapping[type, Any]) -> NavInputs:
    """The latest bus messages (a latest-value cache keyed by message type) as navigation inputs; an
    attitude needs both AHRS messages (its sample time is the older of the two); an invalid DVL is none."""
    att: m.AhrsAttitude | None = cache.get(m.AhrsAttitude)
    rates: m.AhrsRates | None = cache.get(m.AhrsRates)
    depth: m.DepthMeas | None = cache.get(m.DepthMeas)
    dvl: m.DvlVelocity | None = cache.get(m.DvlVelocity)
    fix: m.PositionFix | None = cache.get(m.PositionFix)
    ahrs = None
    if att is not None and rates is not None:
        ahrs = Ahrs(
            att.roll_rad,
            att.pitch_rad,
            att.yaw_rad,
            rates.p_radps,
            rates.q_radps,
            rates.r_radps,
            min(att.t_sample_s, rates.t_sample_s),
        )
    return NavInputs(
        position=PositionFix(fix.x_m, fix.y_m, fix.t_sample_s, fix.std_m) if fix is not None else None,
        dvl=DvlVelocity(dvl.u_mps, dvl.v_mps, dvl.w_mps, dvl.t_sample_s)
        if dvl is not None and dvl.valid
        else None,
        ahrs=ahrs,
        depth=Depth(depth.depth_m, depth.t_sample_s) if depth is not None else None,
    )


def actuator_failsafe(cache: Mapping[type, Any]) -> bool:
    """True when the latest PROP_STATUS or FIN_STATUS reports the actuator node's failsafe."""
    prop: m.PropStatus | None = cache.get(m.PropStatus)
    fin: m.FinStatus | None = cache.get(m.FinStatus)
    return bool((prop is not None and prop.failsafe) or (fin is not None and fin.failsafe))


def actuator_feedback(cache: Mapping[type, Any]) -> ActuatorFeedback:
    """What the actuator node reports of its fins (FIN_STATUS) and propeller (PROP_STATUS), for the fault
    detectors (:mod:`onboard.core.safety.diagnosis`)."""
    prop: m.PropStatus | None = cache.get(m.PropStatus)
    fin: m.FinStatus | None = cache.get(m.FinStatus)
    return ActuatorFeedback(
        fins_rad=(fin.rudder_rad, fin.stern_port_rad, fin.stern_starboard_rad) if fin is not None else None,
        fins_t_s=fin.t_sample_s if fin is not None else float("-inf"),
        propeller_rps=prop.propeller_rps if prop is not None else None,
        propeller_t_s=prop.t_sample_s if prop is not None else float("-inf"),
    )
