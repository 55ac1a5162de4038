"""Water-current estimate: a three-state Kalman filter on the DVL's velocity over ground.

The DVL tracks the bottom, so it measures the velocity over ground. A torpedo's velocity through the water is
along its heading (the sideslip through the water is small, and larger in turns), so::

    state   [c_n, c_e, u_w]     c = water current (NED, m/s), u_w = speed through the water (m/s)
    measure v_ned = c + u_w * (cos psi, sin psi) + noise          (the DVL velocity rotated to NED)

With the heading constant only the current across the heading and (current along it + u_w) are observable;
the filter keeps the correlation, so what a change of heading, or the vehicle at rest (u_w = 0: it drifts
with the water, so the DVL then measures the current itself), taught it stays. The current walks slowly
(``current_walk_mps_per_sqrt_s``), the water speed quickly (``water_speed_walk_mps_per_sqrt_s``: the
propeller changes it within seconds). The measurement noise is the DVL's along the heading and, across it,
the DVL's plus the sideslip through the water, ``water_sway_sigma_mps`` + ``sway_per_yaw_rate_mps_per_radps``
* |r| (a turning vehicle slips sideways).

Pure and small (3 x 3, written out: no matrix library in the tick).
"""

from __future__ import annotations

import math
from typing import NamedTuple

#: What counts as a current, for every decision that uses the estimate (the planner's current-aware plans,
#: the feasibility monitor, the run-in): its 1-sigma must be below this (m/s), else it is not believed ...
CURRENT_BELIEVED_STD_MPS = 0.2
#: ... and a current slower than this (m/s) is still water (the estimate's noise is not a current).
CURRENT_NOISE_MPS = 0.05


class CurrentFilter(NamedTuple):
    """The estimate (c_n, c_e in m/s NED, u_w in m/s) and its symmetric covariance, upper triangle
    (p_nn, p_ne, p_nu, p_ee, p_eu, p_uu); ``t_s`` is the time of the last DVL sample used."""

    c_n: float
    c_e: float
    u_w: float
    p_nn: float
    p_ne: float
    p_nu: float
    p_ee: float
    p_eu: float
    p_uu: float
    t_s: float

    @classmethod
    def at_rest(cls, t_s: float, current_sigma_mps: float, water_speed_sigma_mps: float) -> CurrentFilter:
        """The prior at boot: no current known (sigma ``current_sigma_mps``), the vehicle at rest in the
        water (a reboot under way learns the split of its speed at the next change of heading)."""
        pc, pu = current_sigma_mps**2, water_speed_sigma_mps**2
        return cls(0.0, 0.0, 0.0, pc, 0.0, 0.0, pc, 0.0, pu, t_s)

    @property
    def current_std_mps(self) -> float:
        """The current's 1-sigma uncertainty (m/s, the root of the trace of its 2 x 2 block)."""
        return math.sqrt(max(self.p_nn + self.p_ee, 0.0))

    def update(
        self,
        t_s: float,
        v_n_mps: float,
        v_e_mps: float,
        yaw_rad: float,
        q_current: float,
        q_water_speed: float,
        along_var: float,
        across_var: float,
        max_current_mps: float,
    ) -> CurrentFilter:
        """Predict to ``t_s`` (random walks of squared densities ``q_*``) and take the velocity over ground
        (``v_n_mps``, ``v_e_mps``) seen at heading ``yaw_rad`` with noise variances along and across it."""
        dt = max(0.0, t_s - self.t_s)
        p_nn, p_ne, p_nu = self.p_nn + q_current * dt, self.p_ne, self.p_nu
        p_ee, p_eu, p_uu = self.p_ee + q_current * dt, self.p_eu, self.p_uu + q_water_speed * dt
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        # H = [[1, 0, c], [0, 1, s]]; P H^T (3 x 2) columns:
        a_n, a_e, a_u = p_nn + c * p_nu, p_ne + c * p_eu, p_nu + c * p_uu  # first column
        b_n, b_e, b_u = p_ne + s * p_nu, p_ee + s * p_eu, p_eu + s * p_uu  # second column
        # R = along_var h h^T + across_var h_perp h_perp^T, h = (c, s), h_perp = (-s, c)
        r11 = along_var * c * c + across_var * s * s
        r12 = (along_var - across_var) * c * s
        r22 = along_var * s * s + across_var * c * c
        s11, s12, s22 = a_n + c * a_u + r11, b_n + c * b_u + r12, b_e + s * b_u + r22
        det = s11 * s22 - s12 * s12
        if not (det > 0.0 and math.isfinite(det)):
            return self._replace(t_s=t_s)
        i11, i12, i22 = s22 / det, -s12 / det, s11 / det
        # K = P H^T S^-1
        k_n1, k_n2 = a_n * i11 + b_n * i12, a_n * i12 + b_n * i22
        k_e1, k_e2 = a_e * i11 + b_e * i12, a_e * i12 + b_e * i22
        k_u1, k_u2 = a_u * i11 + b_u * i12, a_u * i12 + b_u * i22
        i_n = v_n_mps - (self.c_n + c * self.u_w)
        i_e = v_e_mps - (self.c_e + s * self.u_w)
        c_n = self.c_n + k_n1 * i_n + k_n2 * i_e
        c_e = self.c_e + k_e1 * i_n + k_e2 * i_e
        u_w = self.u_w + k_u1 * i_n + k_u2 * i_e
        speed = math.hypot(c_n, c_e)
        if speed > max_current_mps:
            c_n, c_e = c_n * max_current_mps / speed, c_e * max_current_mps / speed
        # P - K H P, with H P = (P H^T)^T: rows (a_n, a_e, a_u) and (b_n, b_e, b_u)
        return CurrentFilter(
            c_n,
            c_e,
            u_w,
            p_nn - (k_n1 * a_n + k_n2 * b_n),
            p_ne - (k_n1 * a_e + k_n2 * b_e),
            p_nu - (k_n1 * a_u + k_n2 * b_u),
            p_ee - (k_e1 * a_e + k_e2 * b_e),
            p_eu - (k_e1 * a_u + k_e2 * b_u),
            p_uu - (k_u1 * a_u + k_u2 * b_u),
            t_s,
        )
