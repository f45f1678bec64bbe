//! The table's motion as the encoder recorded it: angle, rate and
//! acceleration at any time from the encoder reads of a recording. The one
//! table model that diagnose predicts through and that the twin
//! (`twin::simulate_like`) re-simulates a recording's own run with.
//!
//! A table profile is piecewise constant acceleration (ramps, cruise,
//! reversals); its knots, where the acceleration jumps, fall anywhere
//! between two reads. Between reads `i` and `i + 1` the angle is fitted on
//! the eight reads around them (`i - 3 ..= i + 4`) by one quadratic, or, when
//! that quadratic leaves more than the encoder's quantisation explains
//! (chi-square, 0.1 %), by a quadratic with one knot: `theta(t) = c0 + c1 d +
//! c2 d^2 + c3 max(0, t - tau)^2` (angle and rate continuous, the
//! acceleration jumps by `2 c3` at `tau`), `tau` searched on a grid between
//! every pair of reads of the window. Where neither fits (a profile that is
//! not piecewise quadratic at the reads' spacing: a servo's wobble, a
//! glitch), the interval is marked: [`EncoderTrack::unfollowed`] says where
//! the prediction cannot follow the table.
//!
//! The angle passes exactly through every read (the read is what the
//! encoder said, quantisation and all); between reads it follows the fitted
//! shape, corrected linearly to the two reads. Rate and acceleration are the
//! fitted shape's derivatives.

use rayon::prelude::*;

/// Reads on each side of an interval used by its fit.
const HALF: usize = 4;
/// Knot positions tried between two reads.
const KNOT_GRID: usize = 8;
/// Chi-square 0.1 % point for 5 degrees of freedom (8 reads, 3
/// parameters): above it, one quadratic does not explain the reads.
const CHI2_5_999: f64 = 20.5;
/// The same for 3 degrees of freedom (8 reads, 4 parameters and the knot's
/// place, 5 in all): above it, one knot does not either.
const CHI2_3_999: f64 = 16.3;
/// The least variance assumed for a read, rad^2: an unquantised encoder
/// still has f64 rounding of its angles and the table's own wobble
/// (1 urad).
const MIN_READ_VAR: f64 = 1e-12;

/// Angle, rate and acceleration of the table, rad, rad/s, rad/s^2.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TableMotion {
    /// Angle, rad (unwrapped, as the encoder reads it).
    pub theta: f64,
    /// Rate, rad/s.
    pub rate: f64,
    /// Acceleration, rad/s^2.
    pub accel: f64,
}

/// The fitted shape on one interval between reads.
#[derive(Clone, Copy, Debug, Default)]
struct Piece {
    t_ref: f64,
    c: [f64; 3],
    /// Knot: (time, coefficient of `max(0, t - tau)^2`).
    knot: Option<(f64, f64)>,
    /// Read residuals (read minus shape) at the interval's two ends.
    res: [f64; 2],
}

impl Piece {
    fn eval(&self, t: f64) -> TableMotion {
        let d = t - self.t_ref;
        let [c0, c1, c2] = self.c;
        let mut m = TableMotion {
            theta: c0 + c1 * d + c2 * d * d,
            rate: c1 + 2.0 * c2 * d,
            accel: 2.0 * c2,
        };
        if let Some((tau, c3)) = self.knot {
            let e = (t - tau).max(0.0);
            m.theta += c3 * e * e;
            m.rate += 2.0 * c3 * e;
            if t > tau {
                m.accel += 2.0 * c3;
            }
        }
        m
    }
}

/// The table's motion from a recording's encoder reads.
#[derive(Clone, Debug, Default)]
pub struct EncoderTrack {
    t: Vec<f64>,
    a: Vec<f64>,
    pieces: Vec<Piece>,
    /// Intervals (start, end of the reads' interval, s) neither shape fits.
    unfollowed: Vec<(f64, f64)>,
    /// The read variance assumed, rad^2.
    read_var: f64,
}

/// A `P x P` matrix and a `P` vector (the normal equations).
type Normal<const P: usize> = (nalgebra::SMatrix<f64, P, P>, nalgebra::SVector<f64, P>);

/// The normal equations `(A^T A, A^T y)` of `rows` (regressors, the rows of
/// `A`) against `y`, summed row by row.
fn normal<const P: usize>(rows: &[[f64; P]], y: &[f64]) -> Normal<P> {
    let mut ata = nalgebra::SMatrix::<f64, P, P>::zeros();
    let mut aty = nalgebra::SVector::<f64, P>::zeros();
    for (r, yv) in rows.iter().zip(y) {
        for (i, ri) in r.iter().enumerate() {
            for (j, rj) in r.iter().enumerate() {
                ata[(i, j)] += ri * rj;
            }
            aty[i] += ri * yv;
        }
    }
    (ata, aty)
}

/// Least squares from the normal equations `ne` of `rows` against `y`:
/// coefficients and the residual sum of squares (`None` when singular).
fn solve<const P: usize>(ne: Normal<P>, rows: &[[f64; P]], y: &[f64]) -> Option<([f64; P], f64)> {
    let (ata, aty) = ne;
    let sol = ata.cholesky()?.solve(&aty);
    let rss = rows
        .iter()
        .zip(y)
        .map(|(r, yv)| {
            let fit: f64 = r.iter().zip(sol.iter()).map(|(x, c)| x * c).sum();
            (yv - fit).powi(2)
        })
        .sum();
    let mut out = [0.0; P];
    out.copy_from_slice(sol.as_slice());
    Some((out, rss))
}

/// The normal equations of a quadratic with one knot: the quadratic's
/// (`quad`, from the same reads) bordered by the knot's column, the last
/// of each of `rows`, summed row by row as [`normal`] sums them.
fn bordered(quad: &Normal<3>, rows: &[[f64; 4]], y: &[f64]) -> Normal<4> {
    let mut ata = nalgebra::SMatrix::<f64, 4, 4>::zeros();
    let mut aty = nalgebra::SVector::<f64, 4>::zeros();
    ata.fixed_view_mut::<3, 3>(0, 0).copy_from(&quad.0);
    aty.fixed_rows_mut::<3>(0).copy_from(&quad.1);
    for (r, yv) in rows.iter().zip(y) {
        let e2 = r[3];
        for (i, ri) in r.iter().enumerate() {
            ata[(i, 3)] += ri * e2;
        }
        aty[3] += e2 * yv;
    }
    for i in 0..3 {
        ata[(3, i)] = ata[(i, 3)];
    }
    (ata, aty)
}

/// The relative misfit within which two knots are the same fit: far above
/// what rounding the stamps (1e-13 s at 1000 s) does to a misfit, far
/// below any difference a read can make.
const TIE: f64 = 1e-6;

impl EncoderTrack {
    /// The track through reads at times `t_s` (s, increasing) with angles
    /// `angle_rad` (rad, unwrapped), whose quantum is `quantum_rad` (0 for
    /// an encoder whose angles are not on a grid).
    pub fn new(t_s: Vec<f64>, angle_rad: Vec<f64>, quantum_rad: f64) -> Self {
        let n = t_s.len().min(angle_rad.len());
        let read_var = (quantum_rad * quantum_rad / 12.0).max(MIN_READ_VAR);
        let mut tr = Self {
            t: t_s[..n].to_vec(),
            a: angle_rad[..n].to_vec(),
            pieces: vec![],
            unfollowed: vec![],
            read_var,
        };
        // Each interval's fit reads only the reads: in parallel (a stepper's
        // every interval searches the knot grid), then in order.
        let fits: Vec<(Piece, bool)> = (0..n.saturating_sub(1))
            .into_par_iter()
            .map(|i| tr.fit_interval(i))
            .collect();
        for (i, (p, ok)) in fits.into_iter().enumerate() {
            if !ok {
                match tr.unfollowed.last_mut() {
                    Some(last) if (last.1 - tr.t[i]).abs() < 1e-9 => last.1 = tr.t[i + 1],
                    _ => tr.unfollowed.push((tr.t[i], tr.t[i + 1])),
                }
            }
            tr.pieces.push(p);
        }
        tr
    }

    /// Fits the shape on interval `i` (reads `i`, `i + 1`); false when
    /// neither shape explains the reads.
    fn fit_interval(&self, i: usize) -> (Piece, bool) {
        let n = self.t.len();
        let lo = i.saturating_sub(HALF - 1).min(n.saturating_sub(2 * HALF));
        let hi = (lo + 2 * HALF).min(n);
        let t_ref = 0.5 * (self.t[i] + self.t[(i + 1).min(n - 1)]);
        let ts = &self.t[lo..hi];
        let y0 = self.a[i];
        // The window's reads relative to read i, on the stack (at most
        // 2 HALF of them).
        let mut ys_buf = [0.0; 2 * HALF];
        for (y, a) in ys_buf.iter_mut().zip(&self.a[lo..hi]) {
            *y = a - y0;
        }
        let ys = &ys_buf[..ts.len().min(2 * HALF)];
        let finish = |c: [f64; 3], knot: Option<(f64, f64)>| {
            let mut p = Piece {
                t_ref,
                c: [c[0] + y0, c[1], c[2]],
                knot,
                res: [0.0; 2],
            };
            for (e, r) in [i, i + 1].into_iter().enumerate() {
                if let (Some(tt), Some(aa)) = (self.t.get(r), self.a.get(r)) {
                    p.res[e] = aa - p.eval(*tt).theta;
                }
            }
            p
        };
        if ts.len() < 3 {
            let rate = if ts.len() == 2 {
                (ys[1] - ys[0]) / (ts[1] - ts[0])
            } else {
                0.0
            };
            return (
                finish([ys[0] - rate * (ts[0] - t_ref), rate, 0.0], None),
                true,
            );
        }
        let mut quad = [[0.0; 3]; 2 * HALF];
        for (q, t) in quad.iter_mut().zip(ts) {
            let d = t - t_ref;
            *q = [1.0, d, d * d];
        }
        let quad = &quad[..ys.len()];
        let quad_ne = normal(quad, ys);
        let Some((c, rss)) = solve(quad_ne, quad, ys) else {
            return (finish([0.0; 3], None), false);
        };
        let dof = ts.len().saturating_sub(3) as f64;
        // A short window (the run's ends) has fewer degrees of freedom.
        let chi2 = |k: f64| -> f64 {
            if dof >= 5.0 {
                k
            } else {
                k * dof.max(1.0) / 5.0 + 6.6
            }
        };
        if rss <= chi2(CHI2_5_999) * self.read_var || ts.len() < 6 {
            return (finish(c, None), rss <= chi2(CHI2_5_999) * self.read_var);
        }
        // One knot, its time on a grid between every pair of reads.
        let mut best: Option<([f64; 4], f64, f64)> = None;
        for w in ts.windows(2) {
            for g in 0..KNOT_GRID {
                let tau = w[0] + (w[1] - w[0]) * (g as f64 + 0.5) / KNOT_GRID as f64;
                let mut rows = [[0.0; 4]; 2 * HALF];
                for (row, t) in rows.iter_mut().zip(ts) {
                    let d = t - t_ref;
                    let e = (t - tau).max(0.0);
                    *row = [1.0, d, d * d, e * e];
                }
                let rows = &rows[..ys.len()];
                if let Some((ck, r)) = solve(bordered(&quad_ne, rows, ys), rows, ys) {
                    // A knot must fit better by more than the stamps'
                    // rounding can move the misfit (TIE): else near-equal
                    // knots swap with the clock's origin and the rate at
                    // a step jumps with them.
                    if best.is_none_or(|b| r < b.1 * (1.0 - TIE)) {
                        best = Some((ck, r, tau));
                    }
                }
            }
        }
        match best {
            Some((ck, r, tau)) if r < rss => (
                finish([ck[0], ck[1], ck[2]], Some((tau, ck[3]))),
                r <= CHI2_3_999 * self.read_var,
            ),
            _ => (finish(c, None), false),
        }
    }

    /// The track's own error variance at a read, rad^2: the mean square of
    /// the reads' misfit from the pieces through them (the encoder's
    /// rounding and any motion the pieces' shapes cannot follow), at least
    /// the rounding's `q^2 / 12` it was built with.
    pub fn misfit_var(&self) -> f64 {
        let (ss, n) = self
            .pieces
            .iter()
            .flat_map(|p| p.res)
            .fold((0.0, 0usize), |(s, k), r| (s + r * r, k + 1));
        (ss / n.max(1) as f64).max(self.read_var)
    }

    /// The track through `rec`'s encoder reads (the quantum found from the
    /// steps between reads).
    pub fn of(rec: &crate::Recording) -> Self {
        let t: Vec<f64> = rec.table.iter().map(|r| r.t_s).collect();
        let a: Vec<f64> = rec.table.iter().map(|r| r.angle_rad).collect();
        let q = encoder_quantum(&a);
        Self::new(t, a, q)
    }

    /// The 1-sigma of one encoder read, rad (its quantum's `q / sqrt(12)`,
    /// at least the floor a read without a grid is given).
    pub fn read_sigma_rad(&self) -> f64 {
        self.read_var.sqrt()
    }

    /// Encoder read times, s.
    pub fn times(&self) -> &[f64] {
        &self.t
    }

    /// Encoder angles as read, rad.
    pub fn angles(&self) -> &[f64] {
        &self.a
    }

    /// Intervals between reads (start, end, s) where neither one quadratic
    /// nor one with a knot explains the reads: the prediction does not
    /// follow the table there.
    pub fn unfollowed(&self) -> &[(f64, f64)] {
        &self.unfollowed
    }

    /// Is `t` (s) inside an interval the track does not follow?
    pub fn follows(&self, t: f64) -> bool {
        let j = self.unfollowed.partition_point(|u| u.1 < t);
        self.unfollowed.get(j).is_none_or(|u| t < u.0)
    }

    /// The table's motion at `t` (s): before the first read and after the
    /// last, the end pieces extended.
    pub fn at(&self, t: f64) -> TableMotion {
        let n = self.t.len();
        if n == 0 {
            return TableMotion::default();
        }
        if n == 1 {
            return TableMotion {
                theta: self.a[0],
                ..TableMotion::default()
            };
        }
        let i = self
            .t
            .partition_point(|x| *x <= t)
            .saturating_sub(1)
            .min(n - 2);
        let Some(p) = self.pieces.get(i) else {
            return TableMotion::default();
        };
        let mut m = p.eval(t);
        // Through the reads: the residuals at the two ends, linearly.
        let (t0, t1) = (self.t[i], self.t[i + 1]);
        let u = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        m.theta += p.res[0] + u * (p.res[1] - p.res[0]);
        m
    }

    /// Angle at `t`, rad: the read itself at a read's stamp (to 1 us).
    pub fn angle(&self, t: f64) -> f64 {
        let j = self.t.partition_point(|x| *x < t);
        for c in [j.saturating_sub(1), j.min(self.t.len().saturating_sub(1))] {
            if let (Some(tc), Some(ac)) = (self.t.get(c), self.a.get(c)) {
                if (tc - t).abs() < 1e-6 {
                    return *ac;
                }
            }
        }
        self.at(t).theta
    }
}

/// The encoder's quantum, rad: the largest step of which every step
/// between consecutive reads is a whole multiple (the smallest non-zero
/// step divided by 1 ..= 64: a table that starts from rest may first move
/// several counts in one read); 0 for an encoder whose angles are not on a
/// grid.
pub fn encoder_quantum(a: &[f64]) -> f64 {
    let steps: Vec<f64> = a
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-12)
        .take(20_000)
        .collect();
    let m = steps.iter().copied().fold(f64::INFINITY, f64::min);
    if !m.is_finite() {
        return 0.0;
    }
    (1..=64)
        .map(|k| m / k as f64)
        .find(|q| {
            steps
                .iter()
                .all(|d| ((d / q) - (d / q).round()).abs() < 1e-3)
        })
        .unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trapezoid reversal: +w for 1 s, ramp at -a to -w, hold. Closed
    /// form, knots between the 50 Hz reads.
    fn reversal(t: f64) -> (f64, f64, f64) {
        let (w, a, t1) = (90f64.to_radians(), 400f64.to_radians(), 1.003);
        let t2 = t1 + 2.0 * w / a;
        if t < t1 {
            (w * t, w, 0.0)
        } else if t < t2 {
            let d = t - t1;
            (w * t1 + w * d - 0.5 * a * d * d, w - a * d, -a)
        } else {
            let d = t2 - t1;
            let th2 = w * t1 + w * d - 0.5 * a * d * d;
            (th2 - w * (t - t2), -w, 0.0)
        }
    }

    #[test]
    fn follows_a_reversal_between_reads() {
        let q = 2.0 * std::f64::consts::PI / 16_384.0;
        let t: Vec<f64> = (0..150).map(|k| k as f64 / 50.0).collect();
        let a: Vec<f64> = t.iter().map(|t| (reversal(*t).0 / q).floor() * q).collect();
        let tr = EncoderTrack::new(t, a, q);
        assert!(tr.unfollowed().is_empty(), "{:?}", tr.unfollowed());
        // Rate at every 10 ms: quantisation of 0.38 mrad over a 20 ms
        // spacing limits the rate to ~q / (h sqrt(n)) ~ 10 mrad/s.
        let mut worst: f64 = 0.0;
        for k in 10..280 {
            let tt = k as f64 * 0.01;
            worst = worst.max((tr.at(tt).rate - reversal(tt).1).abs());
        }
        assert!(worst < 0.02, "worst rate error {worst} rad/s");
        // Angles between reads: within a quantum.
        for k in 10..280 {
            let tt = k as f64 * 0.01 + 0.005;
            assert!((tr.angle(tt) - reversal(tt).0).abs() < 1.5 * q);
        }
    }

    #[test]
    fn the_quantum_when_the_table_starts_with_several_counts() {
        let q = std::f64::consts::TAU / 16_384.0;
        let counts = [0i64, 0, 4, 13, 30, 111, 192, 273, 354];
        let a: Vec<f64> = counts.iter().map(|c| *c as f64 * q).collect();
        assert!((encoder_quantum(&a) - q).abs() < 1e-15);
        assert_eq!(encoder_quantum(&[0.0, 0.1, 0.2 + 1e-4, 0.31]), 0.0);
    }

    #[test]
    fn says_where_it_cannot_follow() {
        // A 5 mrad glitch on one read: neither shape explains it.
        let t: Vec<f64> = (0..100).map(|k| k as f64 / 50.0).collect();
        let mut a: Vec<f64> = t.iter().map(|t| 0.5 * t).collect();
        a[50] += 5e-3;
        let tr = EncoderTrack::new(t, a, 0.0);
        assert!(!tr.unfollowed().is_empty());
        assert!(!tr.follows(1.0));
        assert!(tr.follows(0.2) && tr.follows(1.9));
    }
}
