"""Frame, unit and sign conventions, stated once for the whole system.

- World frame NED: x north, y east, z down (metres). Depth = z.
- Body frame FRD (forward, starboard, down); SNAME names u v w (m/s), p q r (rad/s).
- Yaw in radians, 0 = north, positive clockwise seen from above, wrapped to (-pi, pi]. Pitch positive nose
  up, roll positive starboard down.
- Fin signs as in Prestero's REMUS model: a positive rudder deflection gives a turn to port (negative yaw
  moment); a positive stern-plane deflection gives nose down (negative pitch moment). The split stern has
  a port and a starboard plane; their mean is the stern-plane command and half their difference
  (starboard minus port) is the roll (differential) command.
- Degrees only at the edges (config, CLI, MAVLink fields that are degrees by spec), converted once into a
  field with a different name (``yaw_deg`` -> ``yaw_rad``).
"""

from __future__ import annotations

import math

RUDDER_POSITIVE_TURNS_TO_PORT = True
STERN_POSITIVE_PITCHES_NOSE_DOWN = True


def wrap_pi(angle_rad: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    a = math.fmod(angle_rad + math.pi, 2.0 * math.pi)
    if a <= 0.0:
        a += 2.0 * math.pi
    return a - math.pi


def body_to_ned_matrix(roll_rad: float, pitch_rad: float, yaw_rad: float) -> tuple[float, ...]:
    """The rotation body (FRD) -> world (NED), R = Rz(yaw) Ry(pitch) Rx(roll) (ZYX Euler angles, Fossen
    eq. 2.18), row by row: (r11, r12, r13, r21, r22, r23, r31, r32, r33). Its transpose is NED -> body."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    return (
        cy * cp,
        cy * sp * sr - sy * cr,
        cy * sp * cr + sy * sr,
        sy * cp,
        sy * sp * sr + cy * cr,
        sy * sp * cr - cy * sr,
        -sp,
        cp * sr,
        cp * cr,
    )


def body_to_ned(
    roll_rad: float, pitch_rad: float, yaw_rad: float, u: float, v: float, w: float
) -> tuple[float, float, float]:
    """A body-frame (FRD) vector u, v, w rotated to the world frame (NED) (:func:`body_to_ned_matrix`).
    NaN in, NaN out."""
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = body_to_ned_matrix(roll_rad, pitch_rad, yaw_rad)
    return r11 * u + r12 * v + r13 * w, r21 * u + r22 * v + r23 * w, r31 * u + r32 * v + r33 * w


def stern_split(stern_rad: float, roll_diff_rad: float) -> tuple[float, float]:
    """Port and starboard stern-plane angles (rad) from a common stern and a differential roll command."""
    return stern_rad - roll_diff_rad, stern_rad + roll_diff_rad


def stern_combine(port_rad: float, starboard_rad: float) -> tuple[float, float]:
    """Common stern and differential roll command (rad) from the port and starboard plane angles."""
    return 0.5 * (port_rad + starboard_rad), 0.5 * (starboard_rad - port_rad)
