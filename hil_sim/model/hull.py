"""Myring hull geometry: radius profile, displaced volume, centre of buoyancy and rigid-body inertia.

Computed in code from the hull numbers of the paper's Table 1 (no hand calculation), as issue 3 asks.

Myring profile (Myring 1976; the form used by Prestero 2001, eqs. 2.1-2.2), x measured aft from the nose tip:

- nose, 0 <= x <= a:          r(x) = d/2 * (1 - ((x - a)/a)^2)^(1/n)
- middle, a <= x <= a + b:    r(x) = d/2
- tail, 0 <= xi = x-a-b <= c: r(xi) = d/2 - (3d/(2c^2) - tan(theta)/c) xi^2 + (d/c^3 - tan(theta)/c^2) xi^3

n is the nose exponent and theta the tail half-angle at the tail point. The tail ends in a point at x = a+b+c.

Inertia model: a homogeneous solid of revolution of the vehicle's mass (density m/V). It reproduces Prestero's
REMUS Iyy within 3 % and its Ixx within 28 % (roll inertia factor in the params file corrects it; see
``tests/unit/sim/test_hull.py``), as good as an assumption gets without a mass budget for ISiMI100.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

_GAUSS_POINTS = 48


@dataclass(frozen=True, slots=True)
class MyringHull:
    """Myring body of revolution (metres, radians).

    Attributes:
        nose_length_m: a, nose section length.
        mid_length_m: b, cylindrical mid-section length.
        tail_length_m: c, tail section length (ends in a point).
        diameter_m: d, maximum diameter.
        nose_exponent: n, Myring nose exponent (n = 2: ellipsoidal nose).
        tail_half_angle_rad: theta, half-angle of the tail cone at the tail point.
    """

    nose_length_m: float
    mid_length_m: float
    tail_length_m: float
    diameter_m: float
    nose_exponent: float
    tail_half_angle_rad: float

    @property
    def body_length_m(self) -> float:
        """a + b + c, nose tip to tail point (m)."""
        return self.nose_length_m + self.mid_length_m + self.tail_length_m

    def radius_m(self, x_from_nose_m: float) -> float:
        """Hull radius (m) at ``x_from_nose_m`` (m aft of the nose tip); 0 outside the body."""
        return float(_radius(self, np.asarray([x_from_nose_m], dtype=float))[0])


@dataclass(frozen=True, slots=True)
class HullProperties:
    """Integrated properties of a :class:`MyringHull` (SI).

    Attributes:
        volume_m3: displaced volume nabla.
        x_cb_from_nose_m: centre of buoyancy (volume centroid), m aft of the nose tip.
        radius_moment_4_m5: integral of pi r^4 dx, used for the roll inertia of a solid of revolution.
        second_moment_about_cb_m5: integral of pi r^2 (x - x_cb)^2 dx (pitch/yaw inertia, slice offsets).
        wetted_area_m2: lateral surface area of the body.
    """

    volume_m3: float
    x_cb_from_nose_m: float
    radius_moment_4_m5: float
    second_moment_about_cb_m5: float
    wetted_area_m2: float

    def solid_inertia_kgm2(self, mass_kg: float) -> tuple[float, float, float]:
        """(Ixx, Iyy, Izz) in kg m^2 about the centre of buoyancy of a homogeneous solid of ``mass_kg``."""
        density = mass_kg / self.volume_m3
        ixx = density * 0.5 * self.radius_moment_4_m5
        iyy = density * (0.25 * self.radius_moment_4_m5 + self.second_moment_about_cb_m5)
        return ixx, iyy, iyy


def _radius(hull: MyringHull, x: np.ndarray) -> np.ndarray:
    a, b, c = hull.nose_length_m, hull.mid_length_m, hull.tail_length_m
    half_d = 0.5 * hull.diameter_m
    d = hull.diameter_m
    tan_t = math.tan(hull.tail_half_angle_rad)
    r = np.zeros_like(x)
    nose = (x >= 0.0) & (x < a)
    r[nose] = half_d * np.clip(1.0 - ((x[nose] - a) / a) ** 2, 0.0, None) ** (1.0 / hull.nose_exponent)
    mid = (x >= a) & (x <= a + b)
    r[mid] = half_d
    tail = (x > a + b) & (x <= a + b + c)
    xi = x[tail] - a - b
    r[tail] = half_d - (3.0 * d / (2.0 * c * c) - tan_t / c) * xi**2 + (d / c**3 - tan_t / (c * c)) * xi**3
    return np.maximum(r, 0.0)


def _gauss(lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    nodes, weights = np.polynomial.legendre.leggauss(_GAUSS_POINTS)
    half = 0.5 * (hi - lo)
    return lo + half * (nodes + 1.0), half * weights


def hull_properties(hull: MyringHull) -> HullProperties:
    """Integrate volume, centroid, inertia moments and wetted area of ``hull`` (Gauss-Legendre per section).

    Each section is smooth (the n = 2 nose is even polynomial in r^2), so 48 points per section give the
    integrals to machine precision except the wetted area near the nose tip (better than 1e-4 relative).
    """
    a, b, c = hull.nose_length_m, hull.mid_length_m, hull.tail_length_m
    xs, ws = [], []
    for lo, hi in ((0.0, a), (a, a + b), (a + b, a + b + c)):
        x, w = _gauss(lo, hi)
        xs.append(x)
        ws.append(w)
    x = np.concatenate(xs)
    w = np.concatenate(ws)
    r = _radius(hull, x)
    area = math.pi * r * r
    volume = float(np.sum(w * area))
    x_cb = float(np.sum(w * area * x)) / volume
    r4 = float(np.sum(w * math.pi * r**4))
    second = float(np.sum(w * area * (x - x_cb) ** 2))
    dr = np.gradient(r, x)
    wetted = float(np.sum(w * 2.0 * math.pi * r * np.sqrt(1.0 + np.minimum(dr * dr, 1e6))))
    return HullProperties(
        volume_m3=volume,
        x_cb_from_nose_m=x_cb,
        radius_moment_4_m5=r4,
        second_moment_about_cb_m5=second,
        wetted_area_m2=wetted,
    )


def immersed_fraction(depth_m: float, diameter_m: float) -> float:
    """Fraction (0..1) of the hull cross-section below the free surface (simple free-surface model).

    The hull is treated as a horizontal circular cylinder of ``diameter_m`` whose axis is at ``depth_m``
    (NED z, positive down): 1 when fully submerged (z >= d/2), 0 when fully out (z <= -d/2), and the
    circular-segment area fraction in between. Continuous with a continuous slope, so RK4 stays accurate.
    """
    radius = 0.5 * diameter_m
    if depth_m >= radius:
        return 1.0
    if depth_m <= -radius:
        return 0.0
    h = depth_m + radius  # submerged height of the section
    k = radius - h
    seg = radius * radius * math.acos(k / radius) - k * math.sqrt(max(2.0 * radius * h - h * h, 0.0))
    return seg / (math.pi * radius * radius)
