//! The float type the navigation core is generic over (`f32` on the MCU,
//! `f64` for the host twin), and the few elementary functions the per-step
//! path needs, written so they never call libm `sinf` / `cosf` (which run in
//! emulated f64 on the Cortex-M4F, about 1,250 instructions each).

use nalgebra::RealField;

/// A float the navigation core runs in: `f32` (MCU) or `f64` (host twin).
pub trait Real: RealField + Copy + Default + core::fmt::Debug {
    /// Number of Taylor terms that make the series in [`sin_cos`] exact to
    /// this type's precision on `|x| <= pi/4`.
    /// f32: 6 terms, truncation `(pi/4)^13/13! = 7e-12`; f64: 10 terms,
    /// `(pi/4)^21/21! = 3e-22`.
    const SIN_COS_TERMS: usize;

    /// Converts an `f64` constant or configuration value into this type.
    fn lit(x: f64) -> Self;

    /// Widens to `f64` (exact for both implementations).
    fn to_f64(self) -> f64;

    /// [`SIN_COEF`] in this type (rounded once from f64, at compile time:
    /// a run-time `f64 -> f32` conversion is a soft-float call on the
    /// Cortex-M4F).
    const SIN_COEF_T: [Self; 10];
    /// [`COS_COEF`] in this type.
    const COS_COEF_T: [Self; 10];

    /// Rounds half away from zero in this type's own arithmetic (`roundf`
    /// for f32: no detour through emulated f64).
    fn round_native(self) -> Self;

    /// A small whole number (e.g. a quadrant count) as `i64`, saturating.
    fn to_i64(self) -> i64;

    /// Correctly rounded square root. On the Cortex-M4F this is the FPU's
    /// `vsqrt.f32` (14 cycles), bit-identical to `libm::sqrtf`, which is
    /// what the host uses.
    fn sqrt_cr(self) -> Self;
}

impl Real for f32 {
    const SIN_COS_TERMS: usize = 6;
    const SIN_COEF_T: [f32; 10] = to_f32(SIN_COEF);
    const COS_COEF_T: [f32; 10] = to_f32(COS_COEF);

    #[inline(always)]
    fn round_native(self) -> Self {
        libm::roundf(self)
    }

    #[inline(always)]
    fn to_i64(self) -> i64 {
        self as i64
    }

    #[inline(always)]
    fn lit(x: f64) -> Self {
        x as f32
    }

    #[inline(always)]
    fn to_f64(self) -> f64 {
        f64::from(self)
    }

    #[inline(always)]
    fn sqrt_cr(self) -> Self {
        sqrt_f32(self)
    }
}

impl Real for f64 {
    const SIN_COS_TERMS: usize = 10;
    const SIN_COEF_T: [f64; 10] = SIN_COEF;
    const COS_COEF_T: [f64; 10] = COS_COEF;

    #[inline(always)]
    fn round_native(self) -> Self {
        libm::round(self)
    }

    #[inline(always)]
    fn to_i64(self) -> i64 {
        self as i64
    }

    #[inline(always)]
    fn lit(x: f64) -> Self {
        x
    }

    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }

    #[inline(always)]
    fn sqrt_cr(self) -> Self {
        libm::sqrt(self)
    }
}

// `vsqrt.f32` on the hard-float Cortex-M: libm's `sqrtf` is a bitwise
// software routine there and `core` has no stable `sqrt` in `no_std`. The
// target's `vfp4d16sp` feature does not open the `sreg` class to `asm!`, so
// this is a two-instruction routine under the hard-float ABI (x and the
// result in s0).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.rins_vsqrtf,\"ax\",%progbits",
    ".global rins_vsqrtf",
    ".type rins_vsqrtf,%function",
    ".fpu fpv4-sp-d16",
    ".thumb_func",
    "rins_vsqrtf:",
    "vsqrt.f32 s0, s0",
    "bx lr",
    ".size rins_vsqrtf, .-rins_vsqrtf",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
extern "C" {
    fn rins_vsqrtf(x: f32) -> f32;
}

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    // SAFETY: rins_vsqrtf above reads s0 and writes s0 only (AAPCS-VFP).
    unsafe { rins_vsqrtf(x) }
}

#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline(always)]
fn sqrt_f32(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Taylor coefficients `(-1)^k / (2k+1)!` of `sin x / x` in `x^2`.
const SIN_COEF: [f64; 10] = [
    1.0,
    -1.0 / 6.0,
    1.0 / 120.0,
    -1.0 / 5040.0,
    1.0 / 362_880.0,
    -1.0 / 39_916_800.0,
    1.0 / 6_227_020_800.0,
    -1.0 / 1_307_674_368_000.0,
    1.0 / 355_687_428_096_000.0,
    -1.0 / 121_645_100_408_832_000.0,
];

/// Taylor coefficients `(-1)^k / (2k)!` of `cos x` in `x^2`.
const COS_COEF: [f64; 10] = [
    1.0,
    -1.0 / 2.0,
    1.0 / 24.0,
    -1.0 / 720.0,
    1.0 / 40_320.0,
    -1.0 / 3_628_800.0,
    1.0 / 479_001_600.0,
    -1.0 / 87_178_291_200.0,
    1.0 / 20_922_789_888_000.0,
    -1.0 / 6_402_373_705_728_000.0,
];

/// The f64 coefficients rounded to f32 (compile time).
const fn to_f32(c: [f64; 10]) -> [f32; 10] {
    let [a, b, c, d, e, f, g, h, i, j] = c;
    [
        a as f32, b as f32, c as f32, d as f32, e as f32, f as f32, g as f32, h as f32, i as f32,
        j as f32,
    ]
}

/// Evaluates `sum_k coef[k] * y^k` by Horner with the first `n` terms.
#[inline(always)]
fn horner<T: Real>(coef: &[T], n: usize, y: T) -> T {
    let mut acc = T::zero();
    for c in coef.iter().take(n).rev() {
        acc = acc * y + *c;
    }
    acc
}

/// `sin(x)/x` and `1 - cos(x)` from `x^2` by Taylor series, exact to the
/// type's precision for `x^2 <= (pi/4)^2`. `1 - cos` is returned instead of
/// `cos` so that small rotations keep their full precision.
#[inline(always)]
pub fn sinc_omc_sq<T: Real>(x2: T) -> (T, T) {
    let n = T::SIN_COS_TERMS;
    let sinc = horner(&T::SIN_COEF_T, n, x2);
    // 1 - cos x = x^2 (1/2 - x^2/24 + ...): series of cos without its first term.
    let cos = T::COS_COEF_T;
    let omc = -(x2 * horner(cos.get(1..).unwrap_or(&[]), n - 1, x2));
    (sinc, omc)
}

/// `(sin x, cos x)` without libm. Reduces to `|r| <= pi/4` with a two-part
/// `pi/2` (Cody-Waite) and evaluates Taylor series exact to the type's
/// precision. Accurate to a few ulp for `|x| <= 2^10`; larger arguments lose
/// absolute accuracy as `|x| * eps` (keep angles wrapped).
pub fn sin_cos<T: Real>(x: T) -> (T, T) {
    // pi/2 = PIO2_HI + PIO2_LO, PIO2_HI exact in f32 so q * PIO2_HI is exact
    // for |q| < 2^16 in both types.
    const PIO2_HI: f64 = 1.570_796_370_506_286_6;
    const PIO2_LO: f64 = -4.371_139_000_186_241e-8;
    // Small arguments (latitude offsets, half-angles of a step's rotation:
    // most calls) need no reduction: the same bits as quadrant 0 below,
    // without the rounding.
    let x2 = x * x;
    if x2 <= T::lit(core::f64::consts::FRAC_PI_4 * core::f64::consts::FRAC_PI_4) {
        let (sinc, omc) = sinc_omc_sq(x2);
        return (x * sinc, T::one() - omc);
    }
    let q = (x * T::lit(core::f64::consts::FRAC_2_PI)).round_native();
    let r = (x - q * T::lit(PIO2_HI)) - q * T::lit(PIO2_LO);
    let r2 = r * r;
    let (sinc, omc) = sinc_omc_sq(r2);
    let s = r * sinc;
    let c = T::one() - omc;
    // quadrant = q mod 4, for negative q too.
    let quadrant = q.to_i64().rem_euclid(4);
    match quadrant {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Wraps an angle to `(-pi, pi]`, in rad.
pub fn wrap_pi<T: Real>(x: T) -> T {
    let two_pi = T::two_pi();
    let mut y = x - two_pi * (x / two_pi).round_native();
    if y <= -T::pi() {
        y += two_pi;
    } else if y > T::pi() {
        y -= two_pi;
    }
    y
}

/// An f32 matrix of zeros in a `const` (a board's static built at compile
/// time, never on a stack).
pub const fn zeros_f32<const R: usize, const C: usize>() -> nalgebra::SMatrix<f32, R, C> {
    nalgebra::SMatrix::from_array_storage(nalgebra::ArrayStorage([[0.0; R]; C]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sin_cos_matches_libm_f64() {
        // Independent implementation: libm (correctly rounded within 1 ulp).
        // Tolerance 4e-16: a few ulp of |x| <= 8 after reduction.
        let mut x = -8.0_f64;
        while x < 8.0 {
            let (s, c) = sin_cos(x);
            assert!(
                (s - libm::sin(x)).abs() < 4e-16,
                "sin {x}: {s} vs {}",
                libm::sin(x)
            );
            assert!(
                (c - libm::cos(x)).abs() < 4e-16,
                "cos {x}: {c} vs {}",
                libm::cos(x)
            );
            x += 0.001_37;
        }
    }

    #[test]
    fn sin_cos_matches_f64_in_f32() {
        // f32 result against the f64 truth: within 2 ulp of 1 (2.4e-7).
        let mut x = -7.0_f32;
        while x < 7.0 {
            let (s, c) = sin_cos(x);
            let (st, ct) = (libm::sin(f64::from(x)), libm::cos(f64::from(x)));
            assert!((f64::from(s) - st).abs() < 2.4e-7, "sin {x}");
            assert!((f64::from(c) - ct).abs() < 2.4e-7, "cos {x}");
            x += 0.000_71;
        }
    }

    #[test]
    fn wrap_pi_range() {
        for k in -2000..2000 {
            let x = f64::from(k) * 0.0173;
            let w = wrap_pi(x);
            assert!(w > -core::f64::consts::PI && w <= core::f64::consts::PI);
            assert!((libm::sin(w) - libm::sin(x)).abs() < 1e-12);
            assert!((libm::cos(w) - libm::cos(x)).abs() < 1e-12);
        }
    }

    #[test]
    fn sqrt_is_correctly_rounded() {
        for k in 1..10_000 {
            let x = k as f32 * 0.37;
            assert_eq!(x.sqrt_cr(), libm::sqrtf(x));
        }
    }
}
