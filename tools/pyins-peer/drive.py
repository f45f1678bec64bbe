#!/usr/bin/env python3
"""A simulated drive through pyins's INS/GNSS filter (PyPI `python-ins`):
the peer of `rins navigate --gnss` on our simulator's recordings, as
walk.py is on the real walk. `tools/pyins-peer/drives` runs both.

    drive.py REC --sensor sensors/icm42688.toml --outage 100:30 ...

What pyins gets, from the recording and the sensor file only:
- imu.csv's samples as rates: the table must stand still (`simulate
  --scheme still`), so that the sensor's frame is the body's (pyins knows
  no table); refused otherwise;
- gnss.csv's fixes outside the outages: positions with their horizontal
  sigma (pyins takes one sigma for the three axes) and NED velocities with
  theirs; the antenna lever arm of meta.toml;
- the start: truth.csv's first row (the reference) with rins's start
  sigmas (position 1 m, velocity 0.05 m/s, level 0.5 deg, heading 2 deg);
- the sensor file's datasheet figures: white noise, turn-on bias and
  instability, scale and cross-axis (pyins's random walk of the bias at
  the instability's density, as rins's).
It prints, per outage, the horizontal error at its end against truth.csv.
"""
import argparse
import csv
import math
import tomllib

import numpy as np
import pandas as pd
from pyins import filters, inertial_sensor, measurements, strapdown, transform

DEG = math.pi / 180
G0 = 9.80665


def table(path):
    with open(path) as f:
        return pd.DataFrame(list(csv.DictReader(f))).astype(float).set_index("t_s")


def model(spec, rate_unit, bias_unit):
    """pyins's estimation model of one triad from the sensor file."""
    noise = spec.get(f"noise_density_{rate_unit}") * bias_unit[0]
    bias = spec.get(f"turn_on_bias_{bias_unit[1]}", 0.0) * bias_unit[2]
    bi = spec.get(f"bias_instability_{bias_unit[3]}", 0.0) * bias_unit[4]
    tau = spec.get("bias_tau_s", 100.0)
    scale = spec.get("scale_pct", 0.0) / 100
    cross = spec.get("cross_axis_pct", 0.0) / 100 / math.sqrt(2)
    sm = np.full((3, 3), cross) + np.diag([scale - cross] * 3)
    return inertial_sensor.EstimationModel(
        bias_sd=math.hypot(bias, bi), noise=noise, bias_walk=math.sqrt(2 / tau) * bi,
        scale_misal_sd=sm)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rec")
    ap.add_argument("--sensor", required=True, help="a sensor file (rins-sensor/1)")
    ap.add_argument("--outage", action="append", default=[], help="START:LEN, s")
    a = ap.parse_args()
    outages = [tuple(float(x) for x in o.split(":")) for o in a.outage]
    with open(f"{a.rec}/meta.toml", "rb") as f:
        meta = tomllib.load(f)
    with open(a.sensor, "rb") as f:
        sensor = tomllib.load(f)
    if (table(f"{a.rec}/table.csv")["angle_rad"] != 0).any():
        raise SystemExit("drive.py: the table turns: pyins knows no table (simulate --scheme still)")

    imu = table(f"{a.rec}/imu.csv").rename(columns={
        "gyro_x_radps": "gyro_x", "gyro_y_radps": "gyro_y", "gyro_z_radps": "gyro_z",
        "accel_x_mps2": "accel_x", "accel_y_mps2": "accel_y", "accel_z_mps2": "accel_z"})
    increments = strapdown.compute_increments_from_imu(
        imu[["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]], "rate")
    grid = increments.index.values
    fixes = table(f"{a.rec}/gnss.csv")
    inside = np.zeros(len(fixes), dtype=bool)
    for s, l in outages:
        inside |= (fixes.index >= s) & (fixes.index < s + l)
    used = fixes[~inside]
    used = used[(used.index > grid[0]) & (used.index < grid[-1])]
    # A fix on a sample's time would duplicate that time in pyins's
    # trajectory (walk.py drops those; a simulated receiver's are all on
    # samples): moved 1 us later.
    on = np.isin(used.index.values, grid)
    used.index = np.where(on, used.index.values + 1e-6, used.index.values)
    lever = np.array(meta.get("gnss", {}).get("antenna_b_m", [0.0, 0.0, 0.0]))
    lla = used.rename(columns={"lat_deg": "lat", "lon_deg": "lon", "height_m": "alt"})
    vel = used.rename(columns={"vn_mps": "VN", "ve_mps": "VE", "vd_mps": "VD"})
    meas = [
        measurements.Position(lla[["lat", "lon", "alt"]], float(used["sigma_h_m"].median()),
                              imu_to_antenna_b=lever),
        measurements.NedVelocity(vel[["VN", "VE", "VD"]], float(used["sigma_vel_mps"].median()),
                                 imu_to_antenna_b=lever),
    ]

    site = meta["site"]
    origin = np.array([site["latitude_deg"], site["longitude_deg"], site["height_m"]])
    truth = table(f"{a.rec}/truth.csv")
    t0 = truth.iloc[0]
    pva = pd.Series({
        "lat": origin[0], "lon": origin[1], "alt": origin[2] - t0["down_m"],
        "VN": t0["vn_mps"], "VE": t0["ve_mps"], "VD": t0["vd_mps"],
        "roll": t0["roll_deg"], "pitch": t0["pitch_deg"], "heading": t0["heading_deg"]})
    pva.name = imu.index[0]
    gyro = model(sensor["gyro"], "dps_rthz", (DEG, "dps", DEG, "deg_h", DEG / 3600))
    accel = model(sensor["accel"], "ug_rthz", (1e-6 * G0, "mg", 1e-3 * G0, "mg", 1e-3 * G0))
    r = filters.run_feedback_filter(pva, 1.0, 0.05, 0.5, 2.0, increments, gyro, accel, meas,
                                    time_step=10 * float(np.median(np.diff(grid))))
    traj = r.trajectory
    for s, l in outages:
        # The last sample inside the outage (rins's summary's end: the
        # fixes' return corrects the next).
        k = int(np.searchsorted(traj.index.values, s + l - 1e-6)) - 1
        j = truth.index.get_indexer([traj.index[k]], method="nearest")[0]
        tr = truth.iloc[j]
        truth_lla = transform.perturb_lla(origin, [tr["north_m"], tr["east_m"], tr["down_m"]])
        e = transform.compute_lla_difference(traj.iloc[k][["lat", "lon", "alt"]], truth_lla)
        print(f"pyins: outage at {s:.0f} s for {l:.0f} s: horizontal error at its end "
              f"{math.hypot(e[0], e[1]):.2f} m")


if __name__ == "__main__":
    main()
