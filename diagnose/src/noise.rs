//! The residual's noise model: white + first-order Gauss-Markov on the block
//! means, fitted by maximum likelihood, and the Kalman filter that whitens a
//! series under it (generalised least squares).
//!
//! Block means `z_k` (block length `T`) of a channel's residual are modelled
//! as `z_k = x_k + v_k + (e_{k+1} - e_k)`, `x_{k+1} = phi x_k + w_k` with
//! `Var v = r` (white: the sensor's white noise and its output
//! quantisation), `Var w = lambda r` (the wandering bias; `phi = exp(-T /
//! tau)`, `phi = 1` a random walk) and `Var e = quant`, known: the encoder's
//! quantisation at the block's edges (the table's rate over a block comes
//! from the two edge angles, so its error is the difference of two
//! independent quantisation errors: zero at low frequency, largest at the
//! block rate; modelled as white it would swamp the slow signals on the
//! table-axis gyro). Plain least squares on such a series takes the wander for
//! signal and raises false alarms; the filter's innovations are white, and
//! the same linear filter applied to every regressor turns the regression
//! into generalised least squares.

/// A fitted noise model of one channel's block means (physical units of
/// the channel: rad/s or m/s^2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// Block length, s.
    pub block_s: f64,
    /// White variance of one block mean, unit^2.
    pub r: f64,
    /// Gauss-Markov driving variance over white variance (0: white only).
    pub lambda: f64,
    /// Gauss-Markov correlation per block, `exp(-block / tau)`.
    pub phi: f64,
    /// Log-likelihood of the series under this model.
    pub loglik: f64,
    /// Variance of the encoder quantisation at one block edge, unit^2
    /// (known from the encoder's count; 0 on channels the table rate does
    /// not reach).
    pub quant: f64,
}

impl Noise {
    /// The model of a channel that was not recorded: no noise, nothing
    /// fitted.
    pub fn none(block_s: f64) -> Self {
        Self {
            block_s,
            r: 0.0,
            lambda: 0.0,
            phi: 0.0,
            loglik: 0.0,
            quant: 0.0,
        }
    }

    /// White noise density, unit x sqrt(s) (ARW rad/sqrt(s), VRW m/s/sqrt(s)).
    pub fn white_density(&self) -> f64 {
        (self.r * self.block_s).sqrt()
    }

    /// Stationary standard deviation of the Gauss-Markov bias, unit (for a
    /// random walk, `phi = 1`, its standard deviation after one hour).
    pub fn gm_sigma(&self) -> f64 {
        let q = self.lambda * self.r;
        if self.phi < 1.0 {
            (q / (1.0 - self.phi * self.phi)).sqrt()
        } else {
            (q * 3600.0 / self.block_s).sqrt()
        }
    }

    /// Gauss-Markov correlation time, s (infinite for a random walk).
    pub fn tau_s(&self) -> f64 {
        if self.phi < 1.0 {
            -self.block_s / self.phi.ln()
        } else {
            f64::INFINITY
        }
    }

    /// The filter's gains and innovation variances (in units of `r`) for a
    /// series of `n` blocks.
    pub fn gains(&self, n: usize) -> Gains {
        gains3(self.phi, self.lambda, self.quant / self.r.max(1e-300), n)
    }
}

/// Kalman gains and innovation variances (units of `r`) of the model, per
/// block until the filter is steady, then the last ones hold. The state is
/// (bias, edge error at the block's start, edge error at its end).
#[derive(Clone, Debug, Default)]
pub struct Gains {
    /// Correlation per block.
    pub phi: f64,
    /// Gain per block (until steady).
    pub k: Vec<[f64; 3]>,
    /// Innovation variance per block, units of `r` (until steady).
    pub s: Vec<f64>,
}

fn gains3(phi: f64, lambda: f64, q: f64, n: usize) -> Gains {
    use nalgebra::{Matrix3, RowVector3, Vector3};
    let h = RowVector3::new(1.0, -1.0, 1.0);
    let f = Matrix3::new(phi, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0);
    let qm = Matrix3::from_diagonal(&Vector3::new(lambda, 0.0, q));
    let mut p = Matrix3::from_diagonal(&Vector3::new(prior(phi, lambda), q, q));
    let (mut k, mut s) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let sk = (h * p * h.transpose())[(0, 0)] + 1.0;
        let kk: Vector3<f64> = p * h.transpose() / sk;
        let post = p - kk * sk * kk.transpose();
        let steady = k.last().is_some_and(|l: &[f64; 3]| {
            (0..3).all(|i| (l[i] - kk[i]).abs() <= 1e-12 * (1.0 + kk[i].abs()))
        });
        if steady && s.last().is_some_and(|l: &f64| (l - sk).abs() <= 1e-12 * sk) {
            break;
        }
        k.push([kk[0], kk[1], kk[2]]);
        s.push(sk);
        p = f * post * f.transpose() + qm;
    }
    Gains { phi, k, s }
}

impl Gains {
    fn at(&self, b: usize) -> ([f64; 3], f64) {
        let i = b.min(self.k.len().saturating_sub(1));
        (
            self.k.get(i).copied().unwrap_or([0.0; 3]),
            self.s.get(i).copied().unwrap_or(1.0),
        )
    }

    /// Runs the filter over `z`, calling `out(innovation, its variance)`.
    fn run(&self, z: &[f64], mut out: impl FnMut(f64, f64)) {
        let mut x = [0.0f64; 3];
        for (b, zk) in z.iter().enumerate() {
            let (kk, sk) = self.at(b);
            let e = zk - (x[0] - x[1] + x[2]);
            out(e, sk);
            let post = [x[0] + kk[0] * e, x[1] + kk[1] * e, x[2] + kk[2] * e];
            x = [self.phi * post[0], post[2], 0.0];
        }
    }

    /// Whitens `z` (innovations over their standard deviation, units of
    /// `sqrt(r)`), into `out`.
    pub fn whiten_into(&self, z: &[f64], out: &mut Vec<f64>) {
        out.clear();
        self.run(z, |e, s| out.push(e / s.sqrt()));
    }

    /// The one-step-ahead prediction errors of `z` (physical units): each
    /// block predicted from the blocks before it only.
    pub fn innovations(&self, z: &[f64]) -> Vec<f64> {
        let mut v = Vec::with_capacity(z.len());
        self.run(z, |e, _| v.push(e));
        v
    }
}

/// Concentrated log-likelihood of `z` under (phi, lambda) with `r`
/// estimated: returns (loglik, r). The filter runs to its steady state and
/// then keeps its gain (to 1e-12), so no gains are stored.
fn loglik(z: &[f64], phi: f64, lambda: f64) -> (f64, f64) {
    let [one] = logliks(z, [(phi, lambda)]);
    one
}

/// [`loglik`] for several (phi, lambda) in one pass over `z`: the filters'
/// recursions are independent, so the processor overlaps them (each one's
/// arithmetic is [`loglik`]'s, to the bit).
fn logliks<const N: usize>(z: &[f64], points: [(f64, f64); N]) -> [(f64, f64); N] {
    let mut f = points.map(|(phi, lambda)| Filter {
        phi,
        lambda,
        p: prior(phi, lambda),
        x: 0.0,
        sum: 0.0,
        logdet: 0.0,
        steady: false,
        kk: 0.0,
        sk: 1.0,
        lns: 0.0,
    });
    for zk in z {
        for f in f.iter_mut() {
            if !f.steady {
                f.sk = f.p + 1.0;
                f.kk = f.p / f.sk;
                f.lns = f.sk.ln();
                let pn = f.phi * f.phi * f.p * (1.0 - f.kk) + f.lambda;
                // Steady to 1e-10: the likelihood changes by far less than
                // one unit over a million blocks.
                f.steady = (pn - f.p).abs() <= 1e-10 * f.p.max(1e-300);
                f.p = pn;
            }
            let e = zk - f.x;
            f.sum += e * e / f.sk;
            f.logdet += f.lns;
            f.x = f.phi * (f.x + f.kk * e);
        }
    }
    let n = z.len().max(1) as f64;
    f.map(|f| {
        let r = (f.sum / n).max(1e-300);
        let ll = -0.5 * n * (r.ln() + 1.0 + (2.0 * core::f64::consts::PI).ln()) - 0.5 * f.logdet;
        (ll, r)
    })
}

/// One filter of [`logliks`]: its model, state and sums.
#[derive(Clone, Copy)]
struct Filter {
    phi: f64,
    lambda: f64,
    p: f64,
    x: f64,
    sum: f64,
    logdet: f64,
    steady: bool,
    kk: f64,
    sk: f64,
    lns: f64,
}

/// The filter's prior variance of the bias, units of `r`.
fn prior(phi: f64, lambda: f64) -> f64 {
    if lambda <= 0.0 {
        0.0
    } else if phi < 1.0 {
        lambda / (1.0 - phi * phi)
    } else {
        // A random walk starts unknown: a diffuse prior, many times the
        // white variance (the intercept is fitted separately).
        1e6
    }
}

/// Log-likelihood with a known quantisation variance `quant` and white
/// variance `r` (absolute units).
fn loglik_q(z: &[f64], phi: f64, lambda: f64, r: f64, quant: f64) -> f64 {
    let g = gains3(phi, lambda, quant / r, z.len());
    let mut sum = 0.0;
    g.run(z, |e, s| sum += e * e / s);
    let n = z.len() as f64;
    // The innovation variances change until the filter is steady, then
    // hold the last one: their log-determinant without a log per block.
    let steady = g.s.last().copied().unwrap_or(1.0);
    let logdet =
        g.s.iter().map(|s| s.ln()).sum::<f64>() + (n - g.s.len() as f64).max(0.0) * steady.ln();
    -0.5 * (sum / r + n * r.ln() + logdet + n * (2.0 * core::f64::consts::PI).ln())
}

/// Refines (r, lambda, tau) by coordinate search on the likelihood with the
/// known quantisation, from `start`.
fn refine_q(z: &[f64], start: Noise, quant: f64, white_only: bool) -> Noise {
    let block_s = start.block_s;
    let mut best = start;
    best.quant = quant;
    // The white variance without the quantisation's share (the
    // differenced edge errors add 2 quant to one block's variance).
    best.r = (best.r - 2.0 * quant).max(best.r * 1e-3);
    let eval = |n: &Noise| loglik_q(z, n.phi, n.lambda, n.r, quant);
    best.loglik = eval(&best);
    let mut step = 1.0f64; // in ln units
    for _ in 0..40 {
        let mut improved = false;
        for dim in 0..3 {
            if white_only && dim > 0 {
                continue;
            }
            for sgn in [-1.0, 1.0] {
                let mut c = best;
                let f = (sgn * step).exp();
                match dim {
                    0 => c.r *= f,
                    1 => c.lambda = if c.lambda > 0.0 { c.lambda * f } else { 1e-6 },
                    _ => {
                        let tau = (c.tau_s() * f).clamp(2.0 * block_s, 1e5);
                        c.phi = (-block_s / tau).exp();
                    }
                }
                let ll = eval(&c);
                if ll > best.loglik {
                    c.loglik = ll;
                    best = c;
                    improved = true;
                }
            }
        }
        if !improved {
            step *= 0.5;
            if step < 0.02 {
                break;
            }
        }
    }
    best
}

/// Fits the white-only model (with the known quantisation).
pub fn fit_white(z: &[f64], block_s: f64, quant: f64) -> Noise {
    let (ll, r) = loglik(z, 0.0, 0.0);
    let n = Noise {
        block_s,
        r,
        lambda: 0.0,
        phi: 0.0,
        loglik: ll,
        quant: 0.0,
    };
    if quant > 0.0 {
        refine_q(z, n, quant, true)
    } else {
        n
    }
}

/// Fits white + Gauss-Markov by maximum likelihood: a grid over the
/// correlation time (decades from two blocks to 1e5 s, and a random walk)
/// and the variance ratio (decades), refined around the best point
/// (tenth-decades, half a decade either way). `r` is concentrated out.
pub fn fit(z: &[f64], block_s: f64, quant: f64) -> Noise {
    let start = fit_plain(z, block_s);
    if quant > 0.0 {
        let mut s = start;
        if s.lambda <= 0.0 {
            s.lambda = 1e-6;
            s.phi = (-block_s / 100.0).exp();
        }
        refine_q(z, s, quant, false)
    } else {
        start
    }
}

/// [`fit`] without quantisation.
fn fit_plain(z: &[f64], block_s: f64) -> Noise {
    let mut best = fit_white(z, block_s, 0.0);
    // The Gauss-Markov part must be correlated over at least two blocks:
    // shorter, it is white noise by another name. Whole decades first; the
    // refinement below searches half a decade either way of the best.
    let mut taus: Vec<f64> = (0..=10)
        .map(|i| 2.0 * block_s * 10f64.powi(i))
        .filter(|t| *t <= 1e5)
        .collect();
    taus.push(f64::INFINITY);
    let phi_of = |tau: f64| {
        if tau.is_finite() {
            (-block_s / tau).exp()
        } else {
            1.0
        }
    };
    let keep = |phi: f64, lambda: f64, ll: f64, r: f64, best: &mut Noise| {
        if ll > best.loglik {
            *best = Noise {
                block_s,
                r,
                lambda,
                phi,
                loglik: ll,
                quant: 0.0,
            };
        }
    };
    for &tau in &taus {
        let phi = phi_of(tau);
        let points: [(f64, f64); 10] = core::array::from_fn(|j| (phi, 10f64.powi(j as i32 - 9)));
        for (&(phi, lambda), (ll, r)) in points.iter().zip(logliks(z, points)) {
            keep(phi, lambda, ll, r, &mut best);
        }
    }
    if best.lambda > 0.0 {
        // Refine: tenth-decades around the grid point.
        let (t0, l0) = (best.tau_s(), best.lambda);
        for i in -5..=5 {
            let tau = if t0.is_finite() {
                t0 * 10f64.powf(0.1 * f64::from(i))
            } else if i == 0 {
                f64::INFINITY
            } else {
                continue;
            };
            let phi = phi_of(tau.max(2.0 * block_s));
            let points: [(f64, f64); 15] =
                core::array::from_fn(|j| (phi, l0 * 10f64.powf(0.08 * f64::from(j as i32 - 7))));
            for (&(phi, lambda), (ll, r)) in points.iter().zip(logliks(z, points)) {
                keep(phi, lambda, ll, r, &mut best);
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded normal stream (hal-sim's generator).
    fn normals(seed: u64, n: usize) -> Vec<f64> {
        let mut r = hal_sim::rng::Rng::new(seed, 0);
        (0..n).map(|_| r.normal()).collect()
    }

    #[test]
    fn recovers_white_and_gauss_markov() {
        // White sigma 1, GM sigma 0.5 with tau 50 blocks, 40,000 blocks.
        let n = 40_000;
        let (w, d) = (normals(1, n), normals(2, n));
        let phi: f64 = (-1.0f64 / 50.0).exp();
        let q = 0.25 * (1.0 - phi * phi);
        let mut x = 0.0;
        let z: Vec<f64> = (0..n)
            .map(|k| {
                x = phi * x + q.sqrt() * d[k];
                x + w[k]
            })
            .collect();
        let m = fit(&z, 1.0, 0.0);
        // Tolerances: the ML estimates' spread on 40,000 blocks (about 800
        // correlation times) is a few per cent for r and sigma, ~15 % for tau;
        // the grid refinement is 0.1 decade (26 %) before interpolation.
        assert!((m.r.sqrt() - 1.0).abs() < 0.03, "{m:?}");
        assert!((m.gm_sigma() - 0.5).abs() < 0.08, "{m:?} {}", m.gm_sigma());
        assert!((m.tau_s() / 50.0 - 1.0).abs() < 0.4, "{m:?} {}", m.tau_s());
        // Whitened innovations have unit variance and no lag-1 correlation.
        let mut out = vec![];
        m.gains(n).whiten_into(&z, &mut out);
        let v = out.iter().map(|e| e * e).sum::<f64>() / n as f64 / m.r;
        let c1 = out.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / n as f64 / m.r;
        assert!((v - 1.0).abs() < 0.03 && c1.abs() < 0.02, "{v} {c1}");
    }

    #[test]
    fn quantisation_of_the_edges_is_modelled() {
        // White sigma 1 plus differenced edge errors of variance 4 (twice
        // the white's variance per block): the filter must recover r = 1
        // and whiten the MA(1) structure.
        let n = 40_000;
        let (w, e) = (normals(5, n), normals(6, n + 1));
        let z: Vec<f64> = (0..n).map(|k| w[k] + 2.0 * (e[k + 1] - e[k])).collect();
        let m = fit_white(&z, 1.0, 4.0);
        // ML on 40,000 blocks: r to a few per cent.
        assert!((m.r - 1.0).abs() < 0.08, "{m:?}");
        let mut out = vec![];
        m.gains(n).whiten_into(&z, &mut out);
        let v = out.iter().map(|x| x * x).sum::<f64>() / n as f64 / m.r;
        let c1 = out.windows(2).map(|p| p[0] * p[1]).sum::<f64>() / n as f64 / m.r;
        assert!((v - 1.0).abs() < 0.05 && c1.abs() < 0.02, "{v} {c1}");
        // Plain white would see variance 9 and a lag-1 correlation of -4/9.
        let plain = fit_white(&z, 1.0, 0.0);
        assert!(plain.r > 8.0, "{plain:?}");
    }

    #[test]
    fn white_series_prefers_white() {
        let z = normals(3, 20_000);
        let m = fit(&z, 1.0, 0.0);
        let w = fit_white(&z, 1.0, 0.0);
        // Two extra parameters: the likelihood may rise by chi2_2 / 2 (a few
        // units) by chance, never by the BIC margin used in diagnose.
        assert!(m.loglik - w.loglik < 0.5 * (2.0 * (20_000f64).ln() + 10.0));
        assert!((w.r - 1.0).abs() < 0.04);
    }
}
