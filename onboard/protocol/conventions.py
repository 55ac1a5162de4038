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


def body_to_ned(
    roll_rad: float, pitch_rad: float, yaw_rad: float, u: float, v: float, w: float
) -> tuple[float, float, float]:
    """A body-frame (FRD) vector u, v, w rotated to the world frame (NED): R = Rz(yaw) Ry(pitch) Rx(roll)
    (ZYX Euler angles, Fossen eq. 2.18). NaN in, NaN out."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    north = cy * cp * u + (cy * sp * sr - sy * cr) * v + (cy * sp * cr + sy * sr) * w
    east = sy * cp * u + (sy * sp * sr + cy * cr) * v + (sy * sp * cr - cy * sr) * w
    down = -sp * u + cp * sr * v + cp * cr * w
    return north, east, down


def stern_split(stern_rad: float, roll_diff_rad: float) -> tuple[float, float]:
    """Port and starboard stern-plane angles (rad) from a common stern and a differential roll command."""
    return stern_rad - roll_diff_rad, stern_rad + roll_diff_rad


def stern_combine(port_rad: float, starboard_rad: float) -> tuple[float, float]:
    """Common stern and differential roll command (rad) from the port and starboard plane angles."""
    return 0.5 * (port_rad + starboard_rad), 0.5 * (starboard_rad - port_rad)
