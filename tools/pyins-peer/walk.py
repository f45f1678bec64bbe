#!/usr/bin/env python3
"""The real walk through pyins's INS/GNSS filter (PyPI `python-ins`), on
the same recording and the same outages as `rins navigate --gnss`: an
independent implementation to set rins's figures beside
(`tools/pyins-peer/compare` runs it, in CI too).

    python3 -m venv /tmp/pyins && /tmp/pyins/bin/pip install python-ins
    rins import rtklib ... --out runs/walk          (see the README)
    /tmp/pyins/bin/python tools/pyins-peer/walk.py runs/walk \
        --outage 20:10 --outage 45:10 --outage 70:10 --outage 95:10 \
        --lever-arm 0.025,0.039,-0.037

What pyins gets, and from where (rins's own recording, nothing more):
- the IMU samples of imu.csv (already in the base frame, FRD), as rates;
- the fixes of gnss.csv outside the outages: positions (RTK fixed and
  float as two measurements, each with its floor: 0.02 and 0.3 m, the
  floors rins applies) and NED velocities (0.05 m/s), each at the time
  it was valid when told (`--velocity-lag`, the lags rins found and took);
- the start attitude from an alignment of its own (`align` below: level
  from the still start's mean specific force, heading from the first
  seconds of walking by turning pyins's own strapdown velocity changes
  onto the fixes'), not rins's; the sensor's datasheet noise and turn-on
  biases (sensors/icm42605.toml's figures);
- the antenna's lever arm rins navigated with (`--lever-arm X,Y,Z`, m in
  the body frame, forward-right-down in both: `rins navigate
  --estimate-lever-arm` reports it), or none.
It prints, per outage, the horizontal error at its end against the
withheld fix, pyins's 1-sigma there and the share of the outage inside 3
sigma: the columns rins's summary prints.
"""
import argparse
import csv
import json
import math

import numpy as np
import pandas as pd
import pyins
from pyins import filters, inertial_sensor, measurements, strapdown, transform

DEG = math.pi / 180
G0 = 9.80665


class FloatPosition(measurements.Position):
    """RTK float fixes (their own sigma)."""


class PartVelocity(measurements.NedVelocity):
    """Some components of the fixes' NED velocity (`rows`), each fix's at
    the time it was valid (`--velocity-lag`)."""
    rows = [0, 1, 2]

    def compute_matrices(self, time, pva, error_model):
        ret = super().compute_matrices(time, pva, error_model)
        if ret is None:
            return None
        z, H, R = ret
        k = self.rows
        return np.asarray(z)[k], np.asarray(H)[k], np.asarray(R)[np.ix_(k, k)]


class HorizontalVelocity(PartVelocity):
    rows = [0, 1]


class VerticalVelocity(PartVelocity):
    rows = [2]


def align(imu, increments, fixes, first_fix):
    """pyins's start attitude: (roll, pitch, heading) deg and the level's
    and heading's 1-sigma, deg.

    Level: the mean specific force over the still start (the first 2 s;
    FRD, at rest f = -g down). Heading: pyins's strapdown from rest with
    heading 0 over the first 10 s of walking (from the first fix faster
    than 0.5 m/s; the fixes outside the outages in it); its horizontal
    velocity changes over each 1 s between
    fixes are a rotation of the fixes' by the heading (the least-squares
    angle in closed form); its 1-sigma the spread of the single pairs'
    angles (not divided down: the strapdown's drift over the window is
    common to them)."""
    still = imu[imu.index < imu.index[0] + 2.0]
    f = still[["accel_x", "accel_y", "accel_z"]].mean().values
    roll = math.degrees(math.atan2(-f[1], -f[2]))
    pitch = math.degrees(math.atan2(f[0], math.hypot(f[1], f[2])))
    level_sd = math.degrees(float(still[["accel_x", "accel_y"]].std().max()) / G0)
    speed = np.hypot(fixes["vn_mps"], fixes["ve_mps"])
    t_move = float(fixes.index[speed > 0.5][0])
    pva = first_fix.copy()
    pva["roll"], pva["pitch"], pva["heading"] = roll, pitch, 0.0
    ins = strapdown.Integrator(pva).integrate(increments[increments.index <= t_move + 11.0])
    win = fixes[(fixes.index >= t_move) & (fixes.index <= t_move + 10.0)]
    cross = dot = 0.0
    angles = []
    for t in win.index:
        t1 = t + 1.0
        if t1 > win.index[-1]:
            break
        i0, i1 = ins.index.get_indexer([t, t1], method="nearest")
        a = ins.iloc[i1][["VN", "VE"]].values - ins.iloc[i0][["VN", "VE"]].values
        g = win.iloc[win.index.get_indexer([t1], method="nearest")[0]]
        if abs(g.name - t1) > 0.1:
            continue  # no fix a second on: an outage withholds it
        b = np.array([g["vn_mps"], g["ve_mps"]]) - np.array(
            [win.loc[t]["vn_mps"], win.loc[t]["ve_mps"]])
        cross += a[0] * b[1] - a[1] * b[0]
        dot += a @ b
        angles.append(math.atan2(a[0] * b[1] - a[1] * b[0], a @ b))
    heading = math.degrees(math.atan2(cross, dot)) % 360.0
    mean = math.atan2(cross, dot)
    spread = [math.degrees((x - mean + math.pi) % (2 * math.pi) - math.pi) for x in angles]
    heading_sd = float(np.sqrt(np.mean(np.square(spread))))
    return roll, pitch, heading, max(level_sd, 0.05), heading_sd


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def datasheet_models():
    """sensors/icm42605.toml's datasheet figures: gyro 0.0038 deg/s/sqrt(Hz),
    turn-on 1 deg/s; accel 70 ug/sqrt(Hz), turn-on 20 mg; scale 0.5 %,
    cross-axis 1.25 %; the bias walk of the instability alone."""
    gyro = inertial_sensor.EstimationModel(
        bias_sd=1.0 * DEG, noise=0.0038 * DEG, bias_walk=5 * DEG / 3600 / 10,
        scale_misal_sd=np.full((3, 3), 0.0125 / math.sqrt(2)) + np.diag([0.005 - 0.0125 / math.sqrt(2)] * 3))
    accel = inertial_sensor.EstimationModel(
        bias_sd=20e-3 * G0, noise=70e-6 * G0, bias_walk=0.04e-3 * G0 / 10,
        scale_misal_sd=np.full((3, 3), 0.01 / math.sqrt(2)) + np.diag([0.005 - 0.01 / math.sqrt(2)] * 3))
    return gyro, accel


def rins_models(path, run_s):
    """The process noise rins's filter started from (`process_noise` in
    `rins navigate --json`), every term: white noise, turn-on bias, the
    bias random walk, scale and misalignment. The warm-up's drift, a
    random walk whose density falls off as e^(-t/tau) in rins, is given
    to pyins (whose bias walk is constant) as its mean density over the
    run, sigma^2 (1 - e^(-T/tau)) / T: the same variance added by the
    run's end. (Its drift of the gyro scales is not given: pyins has no
    scale walk, and the walk has no table to turn it into a heading.)"""
    with open(path) as f:
        n = json.load(f)["process_noise"]
    tau = n["warmup_tau_s"]
    share = (1.0 - math.exp(-run_s / tau)) / run_s if tau > 0 else 0.0

    def walk(instability, warm):
        return math.sqrt(instability ** 2 + warm ** 2 * share)

    def scale_misal(scale, misal):
        return np.full((3, 3), misal) + np.diag([scale - misal] * 3)

    gyro = inertial_sensor.EstimationModel(
        bias_sd=n["gyro_bias_init_radps"], noise=n["gyro_white_rad_rts"],
        bias_walk=walk(n["gyro_bias_walk_radps_rts"], n["warmup_gyro_bias_radps"]),
        scale_misal_sd=scale_misal(n["gyro_scale"], n["gyro_misalignment_rad"]))
    accel = inertial_sensor.EstimationModel(
        bias_sd=n["accel_bias_init_mps2"], noise=n["accel_white_mps_rts"],
        bias_walk=walk(n["accel_bias_walk_mps2_rts"], n["warmup_accel_bias_mps2"]),
        scale_misal_sd=scale_misal(n["accel_scale"], n["accel_misalignment_rad"]))
    print(f"pyins: rins's process noise ({path}): gyro bias walk "
          f"{gyro.bias_walk if hasattr(gyro, 'bias_walk') else 'set'}")
    with open(path) as f:
        v = json.load(f).get("vertical_noise") or {}
    if v.get("used"):
        add_vertical_noise(v["q_mps_rts"] ** 2)
    return gyro, accel


def add_vertical_noise(q2):
    """rins's vertical ride noise (`vertical_noise` in its --json: a
    vertical velocity random walk of density q2, (m/s)^2/s, learnt from
    the fixes) added to pyins's vertical velocity error (its DV3) at each
    propagation, as rins adds it to its own."""
    base = filters._compute_error_propagation_matrices

    def with_vertical(pva, gyro, accel, time_delta, error_model, gyro_model, accel_model):
        Phi, Qd = base(pva, gyro, accel, time_delta, error_model, gyro_model, accel_model)
        Qd = np.array(Qd, copy=True)
        Qd[error_model.DV3, error_model.DV3] += q2 * time_delta
        return Phi, Qd

    filters._compute_error_propagation_matrices = with_vertical
    print(f"pyins: rins's vertical ride noise {math.sqrt(q2):.4f} m/s/sqrt(s) added")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("rec")
    ap.add_argument("--outage", action="append", default=[], help="START:LEN, s")
    ap.add_argument("--lever-arm", default=None,
                    help="X,Y,Z: the antenna from the IMU in the body frame, m")
    ap.add_argument("--velocity-lag", default="0,0",
                    help="H,V: how long before its time tag each fix's velocity "
                         "was valid, horizontal and vertical, s (rins's summary: "
                         "fix_velocity_lag, the lags it took)")
    ap.add_argument("--noise-from", default=None,
                    help="rins navigate --json output: pyins gets the process "
                         "noise rins's filter started from (every term) and "
                         "the vertical ride noise it learnt")
    a = ap.parse_args()
    lever = None
    if a.lever_arm is not None:
        lever = np.array([float(x) for x in a.lever_arm.split(",")])
    outages = [tuple(float(x) for x in o.split(":")) for o in a.outage]
    lag_h, lag_v = (float(x) for x in a.velocity_lag.split(","))

    imu = pd.DataFrame(read_csv(f"{a.rec}/imu.csv")).astype(float)
    imu = imu.set_index("t_s")
    imu = imu.rename(columns={
        "gyro_x_radps": "gyro_x", "gyro_y_radps": "gyro_y", "gyro_z_radps": "gyro_z",
        "accel_x_mps2": "accel_x", "accel_y_mps2": "accel_y", "accel_z_mps2": "accel_z"})
    increments = strapdown.compute_increments_from_imu(imu, "rate")

    fixes = pd.DataFrame(read_csv(f"{a.rec}/gnss.csv")).astype(float).set_index("t_s")
    inside = np.zeros(len(fixes), dtype=bool)
    for s, l in outages:
        inside |= (fixes.index >= s) & (fixes.index < s + l)
    used = fixes[~inside]
    # Fixes at their own times, inside the increments' span and off the
    # samples' (pyins predicts to a fix between two samples; a fix on a
    # sample's time duplicates that time in its trajectory).
    grid = increments.index.values
    lla = used.rename(columns={"lat_deg": "lat", "lon_deg": "lon", "height_m": "alt"})
    lla = lla[(lla.index > grid[0]) & (lla.index < grid[-1])]
    lla = lla[~np.isin(lla.index.values, grid)]
    meas = []
    # One class per solution type: pyins files innovations by class name.
    kinds = [(1, 0.02, measurements.Position), (2, 0.3, FloatPosition)]
    for q, sd, kind in kinds:
        part = lla[lla["quality"] == q] if "quality" in lla else lla
        if len(part):
            meas.append(kind(part[["lat", "lon", "alt"]], sd, imu_to_antenna_b=lever))
    if "vn_mps" in lla:
        v = lla.rename(columns={"vn_mps": "VN", "ve_mps": "VE", "vd_mps": "VD"})[["VN", "VE", "VD"]]
        # Each part at the time it was valid: its tag less the lag. A
        # velocity valid inside an outage is not taken there: its fix is
        # tagged after the outage's end, and a filter running forward has
        # it only then (rins takes it at its tag, compared with the state
        # at its lag); pyins applies a measurement at its own time, so it
        # is left out (before, the fix tagged at an outage's end put its
        # vertical velocity 0.29 s inside it, ahead of the last withheld
        # fix the height's end is measured at).
        for kind, lag in ((HorizontalVelocity, lag_h), (VerticalVelocity, lag_v)):
            part = v.copy()
            part.index = part.index - lag
            valid_inside = np.zeros(len(part), dtype=bool)
            for s, l in outages:
                valid_inside |= (part.index >= s) & (part.index < s + l)
            part = part[~valid_inside]
            part = part[(part.index > grid[0]) & (part.index < grid[-1])]
            part = part[~np.isin(part.index.values, grid)]
            meas.append(kind(part, 0.05, imu_to_antenna_b=lever))

    # The start and the alignment from the fixes outside the outages only
    # (before, the alignment's window read the withheld ones when an
    # outage cut into it).
    f0 = used.iloc[0]
    pva = pd.Series({
        "lat": f0["lat_deg"], "lon": f0["lon_deg"], "alt": f0["height_m"],
        "VN": 0.0, "VE": 0.0, "VD": 0.0, "roll": 0.0, "pitch": 0.0, "heading": 0.0})
    pva.name = imu.index[0]  # the first increment ends at the second sample
    roll, pitch, heading, level_sd, heading_sd = align(imu, increments, used, pva)
    print(f"pyins: own alignment roll {roll:.2f} pitch {pitch:.2f} heading {heading:.1f} deg, "
          f"1-sigma level {level_sd:.2f} heading {heading_sd:.1f} deg")
    pva["roll"], pva["pitch"], pva["heading"] = roll, pitch, heading

    if a.noise_from is None:
        gyro, accel = datasheet_models()
    else:
        gyro, accel = rins_models(a.noise_from, float(imu.index[-1] - imu.index[0]))
    r = filters.run_feedback_filter(
        pva, 1.0, 0.05, level_sd, heading_sd,
        increments, gyro, accel, meas, time_step=10 * float(np.median(np.diff(grid))))
    traj, sd = r.trajectory, r.trajectory_sd

    for s, l in outages:
        w = fixes[(fixes.index >= s) & (fixes.index < s + l)]
        rows = []
        for t, f in w.iterrows():
            k = traj.index.get_indexer([t], method="nearest")[0]
            e = transform.compute_lla_difference(
                traj.iloc[k][["lat", "lon", "alt"]],
                pd.Series({"lat": f["lat_deg"], "lon": f["lon_deg"], "alt": f["height_m"]}))
            j = sd.index.get_indexer([t], method="nearest")[0]
            sig = math.hypot(sd.iloc[j]["north"], sd.iloc[j]["east"])
            rows.append((math.hypot(e[0], e[1]), sig, abs(e[2]), sd.iloc[j]["down"]))
        end, sig = rows[-1][:2]
        share = sum(1 for e, sg, _, _ in rows if e <= 3 * sg) / len(rows)
        print(f"pyins: outage at {s:.0f} s for {l:.0f} s: horizontal error at its end "
              f"{end:.2f} m, 1-sigma {sig:.1f} m, {100 * share:.0f} % inside 3 sigma")
        # The height as rins's summary gives it (not "at its end": the
        # compare script reads that line as the horizontal's).
        ev, sv = rows[-1][2:]
        vshare = sum(1 for _, _, e, sg in rows if e <= 3 * sg) / len(rows)
        print(f"pyins:   its height: {ev:.2f} m off when it ended (sigma {sv:.2f} m), "
              f"{100 * vshare:.0f} % of it inside 3 sigma")


if __name__ == "__main__":
    main()
