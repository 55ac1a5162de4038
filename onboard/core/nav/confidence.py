"""Confidence regions of the horizontal position estimate: the one owner of the chi-square figures.

The filter's two axes are independent (:mod:`onboard.core.nav.estimator`), so the 2-D covariance is
diag(P_xx, P_yy). For a 2-D Gaussian the squared Mahalanobis distance is chi-square with 2 degrees of freedom,
whose CDF is 1 - exp(-d2 / 2): the quantile is closed-form, ``-2 ln(1 - p)`` (no statistics library).

- The 95 % region is the ellipse d2 <= 5.99; it fits inside a circle of radius R around the goal when
  ``distance + sqrt(5.99) * sigma_max <= R`` (the major semi-axis, 2.448 sigma_max, towards the goal's edge):
  :func:`confidence_radius_m`, the arrival gate's and START's figure.
- The NEES (normalised estimation error squared) e' P^-1 e of a consistent filter is chi-square(2): mean 2,
  95 % of the samples within ``[chi2_2(0.025), chi2_2(0.975)] = [0.051, 7.38]`` (:data:`NEES_BAND`).
"""

from __future__ import annotations

import math


def chi2_2dof(p: float) -> float:
    """The ``p`` quantile of the chi-square distribution with 2 degrees of freedom."""
    return -2.0 * math.log1p(-p)


#: The confidence level of arrival and START (95 %) and the scale of the 1-sigma major semi-axis it gives.
CONFIDENCE = 0.95
CONFIDENCE_SCALE = math.sqrt(chi2_2dof(CONFIDENCE))  # 2.448
#: The two-sided 95 % band of a 2-dof NEES sample.
NEES_BAND = (chi2_2dof(0.025), chi2_2dof(0.975))


def confidence_radius_m(sigma_max_m: float) -> float:
    """The 95 % region's major semi-axis (m) for a 1-sigma major axis ``sigma_max_m`` (inf stays inf)."""
    return CONFIDENCE_SCALE * sigma_max_m


def nees(ex_m: float, ey_m: float, var_x_m2: float, var_y_m2: float) -> float:
    """The NEES of one sample: error (truth - estimate, m) against the diagonal covariance (m^2)."""
    return ex_m * ex_m / var_x_m2 + ey_m * ey_m / var_y_m2
