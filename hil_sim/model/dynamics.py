"""ISiMI100 6-DOF nonlinear dynamics in the paper's eq. 1 form, as a pure derivative function.

    M nu_dot_r = F_CC + F_DL + F_rest + F_thrust + F_fin            (paper eq. 1, Prestero 2001 ch. 3)
    eta_dot    = J(eta) nu                                           (Fossen 2011 eq. 2.40)

Symbols (SNAME / Fossen), all SI, body frame FRD, world frame NED, origin at the centre of buoyancy (CB):

- eta = (x, y, z, phi, theta, psi): NED position (m; z = depth, down) and Euler angles roll, pitch, yaw (rad,
  ZYX convention; pitch positive nose up, yaw 0 = north, clockwise positive seen from above).
- nu = (u, v, w, p, q, r): body velocity over ground (m/s) surge, sway, heave and body rates (rad/s).
- nu_c: the ocean current (constant in NED) in body axes; nu_r = nu - nu_c the velocity through the water.
  Every hydrodynamic term and the rigid-body Coriolis term use nu_r (Fossen 2011 sec. 10.3, property 10.1:
  for an irrotational current constant in NED, M_RB nu_dot + C_RB(nu) nu = M_RB nu_dot_r + C_RB(nu_r) nu_r),
  and nu_dot = nu_dot_r - omega x nu_c since nu_c rotates with the body. A neutral vehicle with the propeller
  off therefore comes to rest in the water and drifts with the current.
- M: constant mass matrix (rigid body + added mass), inverse precomputed in :mod:`hil_sim.model.params`.
- F_CC: rigid-body and added-mass Coriolis/centripetal terms (m(vr - wq), Xwq wq, Yur ur, Muw uw (Munk)...).
- F_DL: cross-flow drag (Yvv v|v| ...), body lift (Yuv uv ...), axial drag Xuu u|u|, roll drag Kpp p|p|.
- F_rest: weight W at the CG (z_g below the CB) and buoyancy B at the CB; B is reduced near the free
  surface by the immersed fraction of the hull section (:func:`hil_sim.model.hull.immersed_fraction`).
- F_thrust: paper eq. 7 polynomial in propeller rev/s n: X = T0 + T1 n + T2 n|n| + T3 n^3 (N), roll torque
  K = Q2 n|n| (N m).
- F_fin: rudder pair dr (rad) and split stern planes ds_p, ds_s (rad): Y = Yuudr u^2 dr, N = Nuudr u^2 dr,
  Z = Zuuds u^2 (ds_p + ds_s)/2, M = Muuds u^2 (ds_p + ds_s)/2, roll K = Kdiff u^2 (ds_p - ds_s).
  Signs (onboard.protocol.conventions): +dr turns to port, +ds pitches nose down.

Written with plain Python floats: for a 12-state model, numpy's per-call overhead (~1 us per small-array op)
costs more than the arithmetic (measured in :mod:`hil_sim.bench_sim`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from hil_sim.model.hull import immersed_fraction
from hil_sim.model.params import Coefficients
from onboard.protocol.conventions import body_to_ned_matrix


class BodyState(NamedTuple):
    """Truth state eta + nu (immutable). NED position (m), Euler angles (rad), body velocities and rates."""

    x_m: float = 0.0
    y_m: float = 0.0
    z_m: float = 0.0
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0
    u_mps: float = 0.0
    v_mps: float = 0.0
    w_mps: float = 0.0
    p_radps: float = 0.0
    q_radps: float = 0.0
    r_radps: float = 0.0


class DynInputs(NamedTuple):
    """Inputs of :func:`derivatives`: actual actuator positions and the current.

    rudder_rad, stern_port_rad, stern_starboard_rad: fin angles (rad); propeller_rps: propeller speed (rev/s);
    current_*_mps: ocean current in NED (m/s).
    """

    rudder_rad: float = 0.0
    stern_port_rad: float = 0.0
    stern_starboard_rad: float = 0.0
    propeller_rps: float = 0.0
    current_north_mps: float = 0.0
    current_east_mps: float = 0.0
    current_down_mps: float = 0.0


def derivatives(state: tuple[float, ...], inputs: tuple[float, ...], c: Coefficients) -> tuple[float, ...]:
    """Time derivative of the 12-element state (eta, nu): (eta_dot, nu_dot). Pure.

    Args:
        state: :class:`BodyState` or any 12-tuple in its order.
        inputs: :class:`DynInputs` or any 7-tuple in its order.
        c: the dimensional model constants.

    Returns:
        A new 12-tuple (x_dot, y_dot, z_dot, phi_dot, theta_dot, psi_dot, u_dot, v_dot, w_dot, p_dot, q_dot,
        r_dot) in m/s, rad/s, m/s^2, rad/s^2.
    """
    _x, _y, z, phi, theta, psi, u, v, w, p, q, r = state
    dr, dsp, dss, n, cn, ce, cd = inputs

    sphi = math.sin(phi)
    cphi = math.cos(phi)
    sth = math.sin(theta)
    cth = math.cos(theta)

    # Rotation body -> NED, R = Rz(psi) Ry(theta) Rx(phi) (Fossen eq. 2.18): the one in the bus contract.
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = body_to_ned_matrix(phi, theta, psi)

    # Current in body axes and the relative (through-the-water) velocity nu_r.
    if cn or ce or cd:
        uc = r11 * cn + r21 * ce + r31 * cd
        vc = r12 * cn + r22 * ce + r32 * cd
        wc = r13 * cn + r23 * ce + r33 * cd
    else:
        uc = vc = wc = 0.0
    ur = u - uc
    vr = v - vc
    wr = w - wc

    # F_rest: hydrostatics with the free surface (buoyancy scaled by the immersed fraction).
    buoy = c.B_N if z >= 0.5 * c.diameter_m else c.B_N * immersed_fraction(z, c.diameter_m)
    wmb = c.W_N - buoy
    zgw = c.zg_m * c.W_N
    x_hs = -wmb * sth
    y_hs = wmb * cth * sphi
    z_hs = wmb * cth * cphi
    k_hs = -zgw * cth * sphi
    m_hs = -zgw * sth

    # Fins (F_fin) and propeller (F_thrust, paper eq. 7).
    uu = ur * ur
    ds = 0.5 * (dsp + dss)
    an = n if n >= 0.0 else -n
    thrust = c.T0 + n * (c.T1 + c.T2 * an + c.T3 * n * n) if n != 0.0 else 0.0

    aur = ur if ur >= 0.0 else -ur
    avr = vr if vr >= 0.0 else -vr
    awr = wr if wr >= 0.0 else -wr
    ap = p if p >= 0.0 else -p
    aq = q if q >= 0.0 else -q
    ar = r if r >= 0.0 else -r

    m = c.m_kg
    mzg = m * c.zg_m

    # Right-hand sides: statics + damping/lift + added-mass Coriolis + fins + thrust + rigid-body Coriolis.
    fx = (
        x_hs
        + c.Xuu * ur * aur
        + c.Xwq * wr * q
        + c.Xqq * q * q
        + c.Xvr * vr * r
        + c.Xrr * r * r
        + thrust
        + m * (vr * r - wr * q)
        - mzg * p * r
    )
    fy = (
        y_hs
        + c.Yvv * vr * avr
        + c.Yrr * r * ar
        + c.Yuv * ur * vr
        + c.Yur * ur * r
        + c.Ywp * wr * p
        + c.Ypq * p * q
        + c.Yuudr * uu * dr
        + m * (wr * p - ur * r)
        - mzg * q * r
    )
    fz = (
        z_hs
        + c.Zww * wr * awr
        + c.Zqq * q * aq
        + c.Zuw * ur * wr
        + c.Zuq * ur * q
        + c.Zvp * vr * p
        + c.Zrp * r * p
        + c.Zuuds * uu * ds
        + m * (ur * q - vr * p)
        + mzg * (p * p + q * q)
    )
    fk = (
        k_hs
        + c.Kpp * p * ap
        + c.Q2 * n * an
        + c.Kdiff * uu * (dsp - dss)
        - (c.Izz - c.Iyy) * q * r
        + mzg * (ur * r - wr * p)
    )
    fm = (
        m_hs
        + c.Mww * wr * awr
        + c.Mqq * q * aq
        + c.Muw * ur * wr
        + c.Muq * ur * q
        + c.Mvp * vr * p
        + c.Mrp * r * p
        + c.Muuds * uu * ds
        - (c.Ixx - c.Izz) * r * p
        - mzg * (wr * q - vr * r)
    )
    fn = (
        c.Nvv * vr * avr
        + c.Nrr * r * ar
        + c.Nuv * ur * vr
        + c.Nur * ur * r
        + c.Nwp * wr * p
        + c.Npq * p * q
        + c.Nuudr * uu * dr
        - (c.Iyy - c.Ixx) * p * q
    )

    (
        a00, a01, a02, a03, a04, a05,
        a10, a11, a12, a13, a14, a15,
        a20, a21, a22, a23, a24, a25,
        a30, a31, a32, a33, a34, a35,
        a40, a41, a42, a43, a44, a45,
        a50, a51, a52, a53, a54, a55,
    ) = c.minv  # fmt: skip
    du = a00 * fx + a01 * fy + a02 * fz + a03 * fk + a04 * fm + a05 * fn
    dv = a10 * fx + a11 * fy + a12 * fz + a13 * fk + a14 * fm + a15 * fn
    dw = a20 * fx + a21 * fy + a22 * fz + a23 * fk + a24 * fm + a25 * fn
    dp = a30 * fx + a31 * fy + a32 * fz + a33 * fk + a34 * fm + a35 * fn
    dq = a40 * fx + a41 * fy + a42 * fz + a43 * fk + a44 * fm + a45 * fn
    dr_ = a50 * fx + a51 * fy + a52 * fz + a53 * fk + a54 * fm + a55 * fn

    # nu_dot = nu_dot_r + d(nu_c)/dt, with d(nu_c)/dt = -omega x nu_c for a current constant in NED.
    if uc or vc or wc:
        du -= q * wc - r * vc
        dv -= r * uc - p * wc
        dw -= p * vc - q * uc

    # Kinematics eta_dot = J(eta) nu (Fossen eq. 2.40); singular at theta = +-90 deg (not reached by an AUV).
    tth = sth / cth
    return (
        r11 * u + r12 * v + r13 * w,
        r21 * u + r22 * v + r23 * w,
        r31 * u + r32 * v + r33 * w,
        p + (q * sphi + r * cphi) * tth,
        q * cphi - r * sphi,
        (q * sphi + r * cphi) / cth,
        du,
        dv,
        dw,
        dp,
        dq,
        dr_,
    )
