"""Track and error plots from a .tlog (matplotlib, Agg backend: no display needed)."""

from __future__ import annotations

import math
from pathlib import Path

from groundstation.tlog import read_tlog


def plot_tlog(tlog: str | Path, out: str | Path, vehicle_system: int = 1) -> dict[str, int]:
    """Draw track (east vs north), depth, cross-track and yaw error over time into ``out`` (PNG/SVG/PDF).

    Raises ValueError (with the reason) for a file that holds no MAVLink packet or no position of the
    vehicle: no empty picture."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pos_t, xs, ys, zs = [], [], [], []
    nav_t, xtrack, depth_err, yaw_err = [], [], [], []
    goals_x, goals_y = [], []
    t0: float | None = None
    packets = 0
    for t, m in read_tlog(tlog):
        packets += 1
        if m.get_srcSystem() != vehicle_system:
            if m.get_type() == "MISSION_ITEM_INT" and m.frame == 1 and m.mission_type == 0:
                goals_x.append(m.x / 1e4)
                goals_y.append(m.y / 1e4)
            continue
        t0 = t if t0 is None else t0
        kind = m.get_type()
        if kind == "LOCAL_POSITION_NED" and math.isfinite(m.x):
            pos_t.append(t - t0)
            xs.append(m.x)
            ys.append(m.y)
            zs.append(m.z)
        elif kind == "NAV_CONTROLLER_OUTPUT":
            nav_t.append(t - t0)
            xtrack.append(m.xtrack_error)
            depth_err.append(m.alt_error)
            yaw_err.append(((m.target_bearing - m.nav_bearing + 180) % 360) - 180)
    if not packets:
        raise ValueError(f"{tlog}: not a tlog (no MAVLink packet in it)")
    if not xs:
        raise ValueError(f"{tlog}: no position of vehicle {vehicle_system} in it: nothing to plot")
    fig, ax = plt.subplots(2, 2, figsize=(11, 8))
    ax[0][0].plot(ys, xs, "-", label="track")
    if goals_x:
        ax[0][0].plot(goals_y, goals_x, "x", label="goals (uploaded)")
    ax[0][0].set_xlabel("east y (m)")
    ax[0][0].set_ylabel("north x (m)")
    ax[0][0].set_aspect("equal", adjustable="datalim")
    ax[0][0].legend()
    ax[0][0].set_title("track")
    ax[0][1].plot(pos_t, zs)
    ax[0][1].invert_yaxis()
    ax[0][1].set_xlabel("t (s)")
    ax[0][1].set_ylabel("depth (m)")
    ax[1][0].plot(nav_t, xtrack, label="cross-track (m)")
    ax[1][0].plot(nav_t, depth_err, label="depth error (m)")
    ax[1][0].set_xlabel("t (s)")
    ax[1][0].legend()
    ax[1][1].plot(nav_t, yaw_err)
    ax[1][1].set_xlabel("t (s)")
    ax[1][1].set_ylabel("yaw error (deg)")
    for a in ax.flat:
        a.grid(True)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return {"positions": len(xs), "nav_samples": len(nav_t), "goals": len(goals_x)}
