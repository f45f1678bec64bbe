//! Earth model: WGS-84 ellipsoid, normal gravity with height, earth rate,
//! radii of curvature, transport rate, and geodetic / ECEF / local-NED
//! conversions.
//!
//! Sources: NIMA TR8350.2 (WGS-84, 3rd ed.) Eq. 4-1 (Somigliana) and 4-3
//! (height correction); Groves, *Principles of GNSS, Inertial, and
//! Multisensor Integrated Navigation Systems*, 2nd ed., Eq. 2.105-2.106
//! (radii of curvature), 5.44 (transport rate).

use crate::real::{sin_cos, Real};
use nalgebra::Vector3;

/// WGS-84 semi-major axis, m.
pub const WGS84_A_M: f64 = 6_378_137.0;
/// WGS-84 flattening (dimensionless).
pub const WGS84_F: f64 = 1.0 / 298.257_223_563;
/// WGS-84 first eccentricity squared (dimensionless).
pub const WGS84_E2: f64 = 6.694_379_990_14e-3;
/// Earth rotation rate, rad/s (WGS-84; the recording spec's `Omega_e`).
pub const EARTH_RATE_RADPS: f64 = 7.292_115e-5;
/// Normal gravity at the equator, m/s^2 (TR8350.2 Eq. 4-1).
pub const GAMMA_E_MPS2: f64 = 9.780_325_335_9;
/// Somigliana constant k (dimensionless, TR8350.2 Eq. 4-1).
pub const SOMIGLIANA_K: f64 = 1.931_852_652_41e-3;
/// m = omega^2 a^2 b / GM (dimensionless, TR8350.2 Table 3.4).
pub const WGS84_M: f64 = 3.449_786_506_84e-3;

/// WGS-84 normal gravity magnitude, m/s^2, from `sin^2(lat)` and height above
/// the ellipsoid in m (TR8350.2 Eq. 4-1 and 4-3; valid to ~20 km height).
pub fn normal_gravity<T: Real>(sin2_lat: T, height_m: T) -> T {
    let e2 = T::lit(WGS84_E2);
    let g0 = T::lit(GAMMA_E_MPS2) * (T::one() + T::lit(SOMIGLIANA_K) * sin2_lat)
        / (T::one() - e2 * sin2_lat).sqrt_cr();
    let a = T::lit(WGS84_A_M);
    let lin = T::lit(2.0) / a
        * (T::one() + T::lit(WGS84_F) + T::lit(WGS84_M) - T::lit(2.0 * WGS84_F) * sin2_lat);
    g0 * (T::one() - lin * height_m + T::lit(3.0) * height_m * height_m / (a * a))
}

/// Meridian (north-south) and transverse (east-west) radii of curvature
/// `(R_M, R_N)`, m, from `sin^2(lat)` (Groves Eq. 2.105, 2.106).
pub fn radii<T: Real>(sin2_lat: T) -> (T, T) {
    let e2 = T::lit(WGS84_E2);
    let w2 = T::one() - e2 * sin2_lat;
    let r_n = T::lit(WGS84_A_M) / w2.sqrt_cr();
    let r_m = r_n * (T::one() - e2) / w2;
    (r_m, r_n)
}

/// Earth rate in the local NED frame, `w_ie_n`, rad/s.
pub fn earth_rate_n<T: Real>(sin_lat: T, cos_lat: T) -> Vector3<T> {
    let we = T::lit(EARTH_RATE_RADPS);
    Vector3::new(we * cos_lat, T::zero(), -we * sin_lat)
}

/// Transport rate `w_en_n`, rad/s, from the velocity relative to the earth
/// `v_n` (NED, m/s), the radii (m), height (m) and latitude (Groves Eq. 5.44).
pub fn transport_rate_n<T: Real>(
    v_n: &Vector3<T>,
    r_m: T,
    r_n: T,
    height_m: T,
    tan_lat: T,
) -> Vector3<T> {
    let rn_h = r_n + height_m;
    Vector3::new(
        v_n.y / rn_h,
        -v_n.x / (r_m + height_m),
        -v_n.y * tan_lat / rn_h,
    )
}

/// A point on the earth: geodetic latitude and longitude (rad), height above
/// the WGS-84 ellipsoid (m). Always `f64`: it is only stored and used at
/// initialisation, never integrated (see [`crate::strapdown`] for how
/// position is carried).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct GeoPoint {
    /// Geodetic latitude, rad, positive north.
    pub lat_rad: f64,
    /// Longitude, rad, positive east.
    pub lon_rad: f64,
    /// Height above the WGS-84 ellipsoid, m.
    pub height_m: f64,
}

impl GeoPoint {
    /// A point from latitude and longitude in degrees and height in m.
    pub fn from_deg(lat_deg: f64, lon_deg: f64, height_m: f64) -> Self {
        Self {
            lat_rad: lat_deg.to_radians(),
            lon_rad: lon_deg.to_radians(),
            height_m,
        }
    }

    /// ECEF position, m (Groves Eq. 2.112).
    pub fn to_ecef(&self) -> Vector3<f64> {
        let (sl, cl) = crate::real::sin_cos(self.lat_rad);
        let (so, co) = crate::real::sin_cos(self.lon_rad);
        let (_, r_n) = radii(sl * sl);
        let h = self.height_m;
        Vector3::new(
            (r_n + h) * cl * co,
            (r_n + h) * cl * so,
            (r_n * (1.0 - WGS84_E2) + h) * sl,
        )
    }

    /// The point at ECEF position `r_e` (m): latitude by fixed-point
    /// iteration of Groves Eq. 2.113 (`tan lat = z (R_E + h) / (p (R_E
    /// (1 - e^2) + h))`), six rounds: from the spherical guess each round
    /// gains about three digits (e^2 / 2), below 1e-12 rad (6 um) at any
    /// height below 1000 km; `None` on the polar axis or a non-finite
    /// input.
    pub fn from_ecef(r_e: &Vector3<f64>) -> Option<Self> {
        let p = libm::hypot(r_e.x, r_e.y);
        if !(p > 0.0 && r_e.z.is_finite()) {
            return None;
        }
        let lon = libm::atan2(r_e.y, r_e.x);
        let mut lat = libm::atan2(r_e.z, p * (1.0 - WGS84_E2));
        let mut h = 0.0;
        for _ in 0..6 {
            let sl = libm::sin(lat);
            let (_, r_n) = radii(sl * sl);
            h = p / libm::cos(lat) - r_n;
            lat = libm::atan2(r_e.z * (r_n + h), p * (r_n * (1.0 - WGS84_E2) + h));
        }
        Some(Self {
            lat_rad: lat,
            lon_rad: lon,
            height_m: h,
        })
    }

    /// Rotation from ECEF to the local NED frame at this point, `C_e_n`.
    pub fn c_e_n(&self) -> nalgebra::Matrix3<f64> {
        let (sl, cl) = crate::real::sin_cos(self.lat_rad);
        let (so, co) = crate::real::sin_cos(self.lon_rad);
        nalgebra::Matrix3::new(
            -sl * co,
            -sl * so,
            cl, //
            -so,
            co,
            0.0, //
            -cl * co,
            -cl * so,
            -sl,
        )
    }

    /// The vector from `self` to `other` in the local NED frame at `self`
    /// (the tangent plane at the start point), m.
    pub fn ned_to(&self, other: &GeoPoint) -> Vector3<f64> {
        self.tangent().ned_to(other)
    }

    /// The local NED frame at this point, for many [`Tangent::ned_to`]s.
    pub fn tangent(&self) -> Tangent {
        Tangent {
            ecef: self.to_ecef(),
            c_e_n: self.c_e_n(),
        }
    }
}

/// The local NED frame at a point ([`GeoPoint::tangent`]): its ECEF
/// position (m) and `C_e_n`, made once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tangent {
    ecef: Vector3<f64>,
    c_e_n: nalgebra::Matrix3<f64>,
}

impl Tangent {
    /// [`GeoPoint::ned_to`]: the vector to `other` in this NED frame, m.
    pub fn ned_to(&self, other: &GeoPoint) -> Vector3<f64> {
        self.c_e_n * (other.to_ecef() - self.ecef)
    }
}

/// The earth quantities at a reference point, precomputed once in `T` so the
/// per-step path needs no trigonometry: position offsets from this point are
/// turned into latitude by a short series.
#[derive(Clone, Copy, Debug)]
pub struct LocalEarth<T: Real> {
    /// The reference point.
    pub origin: GeoPoint,
    /// `sin(lat0)`, `cos(lat0)`.
    pub sin_lat0: T,
    /// See `sin_lat0`.
    pub cos_lat0: T,
    /// `R_M(lat0) + h0`, m: metres of north offset per rad of latitude.
    pub rm_h0: T,
    /// `(R_N(lat0) + h0) cos(lat0)`, m: metres of east offset per rad of longitude.
    pub rn_h0_cos: T,
    /// Gravity scale: 1 for normal gravity, else `g_given / gamma(lat0, h0)`.
    pub gravity_scale: T,
    /// The reference height in `T`, m (converted once: on the board an
    /// f64 conversion per step is a soft-float call).
    pub height0_m: T,
}

impl LocalEarth<f32> {
    /// All zeros in a `const` (a board's static in `.bss`, replaced
    /// before use: no point of the earth until then).
    pub const BLANK: Self = Self {
        origin: GeoPoint {
            lat_rad: 0.0,
            lon_rad: 0.0,
            height_m: 0.0,
        },
        sin_lat0: 0.0,
        cos_lat0: 0.0,
        rm_h0: 0.0,
        rn_h0_cos: 0.0,
        gravity_scale: 0.0,
        height0_m: 0.0,
    };
}

/// The earth quantities at one point, m, rad, m/s^2, rad/s.
#[derive(Clone, Copy, Debug)]
pub struct EarthAt<T: Real> {
    /// `sin(lat)`.
    pub sin_lat: T,
    /// `cos(lat)`.
    pub cos_lat: T,
    /// Meridian radius of curvature, m.
    pub r_m: T,
    /// Transverse radius of curvature, m.
    pub r_n: T,
    /// Height above the ellipsoid, m.
    pub height_m: T,
    /// Gravity magnitude (down), m/s^2.
    pub gravity: T,
}

impl<T: Real> LocalEarth<T> {
    /// Precomputes the earth at `origin`. `gravity_mps2`, when given, replaces
    /// normal gravity at the origin (the recording's measured `g`); the
    /// height and latitude variation of normal gravity is kept around it.
    pub fn new(origin: GeoPoint, gravity_mps2: Option<f64>) -> Self {
        let (sl, cl) = crate::real::sin_cos(origin.lat_rad);
        let (r_m, r_n) = radii(sl * sl);
        let gamma0 = normal_gravity(sl * sl, origin.height_m);
        let scale = gravity_mps2.map_or(1.0, |g| g / gamma0);
        Self {
            origin,
            sin_lat0: T::lit(sl),
            cos_lat0: T::lit(cl),
            rm_h0: T::lit(r_m + origin.height_m),
            rn_h0_cos: T::lit((r_n + origin.height_m) * cl),
            gravity_scale: T::lit(scale),
            height0_m: T::lit(origin.height_m),
        }
    }

    /// The earth at a curvilinear offset `p_n` = (north, east, down), m, from
    /// the origin (see [`crate::strapdown::NavState::p_n`]).
    pub fn at(&self, p_n: &Vector3<T>) -> EarthAt<T> {
        let dlat = p_n.x / self.rm_h0;
        let (sd, cd) = sin_cos(dlat);
        let sin_lat = self.sin_lat0 * cd + self.cos_lat0 * sd;
        let cos_lat = self.cos_lat0 * cd - self.sin_lat0 * sd;
        let s2 = sin_lat * sin_lat;
        let (r_m, r_n) = radii(s2);
        let height_m = self.height0_m - p_n.z;
        let gravity = normal_gravity(s2, height_m) * self.gravity_scale;
        EarthAt {
            sin_lat,
            cos_lat,
            r_m,
            r_n,
            height_m,
            gravity,
        }
    }

    /// The geodetic point at a curvilinear offset `p_n` (host-side output, f64).
    pub fn point_at(&self, p_n: &Vector3<T>) -> GeoPoint {
        let o = self.origin;
        let rm_h0 = self.rm_h0.to_f64();
        let rn_h0_cos = self.rn_h0_cos.to_f64();
        GeoPoint {
            lat_rad: o.lat_rad + p_n.x.to_f64() / rm_h0,
            lon_rad: o.lon_rad + p_n.y.to_f64() / rn_h0_cos,
            height_m: o.height_m - p_n.z.to_f64(),
        }
    }
}

#[cfg(test)]
mod ecef_tests {
    use super::*;

    #[test]
    fn ecef_round_trips_to_the_micrometre() {
        // Against to_ecef (Groves Eq. 2.112, closed form): the round trip
        // returns the point within 1e-11 rad and 1e-5 m (the iteration's
        // residual, module docs).
        for (lat, lon, h) in [
            (37.72, -122.47, 31.6),
            (-60.0, 10.0, 5000.0),
            (0.1, 179.9, -30.0),
            (89.0, 45.0, 0.0),
        ] {
            let p = GeoPoint::from_deg(lat, lon, h);
            let q = GeoPoint::from_ecef(&p.to_ecef()).unwrap();
            assert!((q.lat_rad - p.lat_rad).abs() < 1e-11, "{lat}");
            assert!((q.lon_rad - p.lon_rad).abs() < 1e-11, "{lon}");
            assert!((q.height_m - h).abs() < 1e-5, "{h} {}", q.height_m);
        }
        assert_eq!(GeoPoint::from_ecef(&Vector3::new(0.0, 0.0, 6.4e6)), None);
        assert_eq!(GeoPoint::from_ecef(&Vector3::new(f64::NAN, 0.0, 0.0)), None);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_gravity_matches_published_values() {
        // TR8350.2 Table 3.4: gamma_e = 9.7803253359, gamma_p = 9.8321849378.
        assert!((normal_gravity(0.0_f64, 0.0) - 9.780_325_335_9).abs() < 1e-10);
        assert!((normal_gravity(1.0_f64, 0.0) - 9.832_184_937_8).abs() < 1e-9);
        // Free-air gradient ~ -3.086e-6 s^-2 at mid latitude (TR8350.2 4-3).
        let s2 = libm::sin(45f64.to_radians()).powi(2);
        let grad = (normal_gravity(s2, 1000.0) - normal_gravity(s2, 0.0)) / 1000.0;
        assert!((grad + 3.086e-6).abs() < 0.01e-6, "{grad}");
    }

    #[test]
    fn radii_at_equator_and_pole() {
        let (rm, rn) = radii(0.0_f64);
        assert!((rn - WGS84_A_M).abs() < 1e-6);
        assert!((rm - WGS84_A_M * (1.0 - WGS84_E2)).abs() < 1e-6);
        let (rm, rn) = radii(1.0_f64);
        assert!((rm - rn).abs() < 1e-6, "at the pole both radii equal a^2/b");
    }

    #[test]
    fn ned_offset_matches_curvilinear_for_short_distances() {
        let o = GeoPoint::from_deg(45.0, 7.0, 100.0);
        let earth = LocalEarth::<f64>::new(o, None);
        let p = Vector3::new(300.0, -200.0, 0.0);
        let ned = o.ned_to(&earth.point_at(&p));
        // Over 360 m the tangent plane and the curvilinear offsets differ by
        // second-order terms of size d^2 / R: the drop of the surface
        // d^2 / (2R) = 0.0102 m in down, the parallel's curvature
        // e^2 tan(lat) / (2R) = 3.1 mm in north, the parallel shrinking with
        // latitude e n tan(lat) / R = 9.4 mm in east.
        let r = 6.38e6;
        let t = libm::tan(o.lat_rad);
        assert!(
            (ned.x - (300.0 + 200.0 * 200.0 * t / (2.0 * r))).abs() < 2e-4,
            "{ned}"
        );
        assert!(
            (ned.y - (-200.0 + 200.0 * 300.0 * t / r)).abs() < 2e-4,
            "{ned}"
        );
        assert!(
            (ned.z - 360.55_f64.powi(2) / (2.0 * r)).abs() < 2e-4,
            "{}",
            ned.z
        );
    }
}
