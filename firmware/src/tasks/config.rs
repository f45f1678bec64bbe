//! What is compiled in (the tuning), the factory configuration, and the
//! navigation's configuration made from them and the stored one.

use super::*;

/// Everything compiled in: the chip's and the table's tuning, not the
/// site's (that is [`BoardConfig`], set by commands and stored).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tuning {
    /// The tick's settings.
    pub control: ControlConfig,
    /// Navigation's settings apart from the configuration's.
    pub nav: NavConfig,
    /// The aided filter's noise model for this IMU.
    pub filter: AidedConfig,
}

/// The configuration a blank board starts with: the equator at sea level,
/// a level base heading north, 30 deg/s continuous, not aided. A user sets
/// their own with `rins command` (it is stored).
pub const FACTORY: BoardConfig = BoardConfig {
    lat_e7: 0,
    height_mm: 0,
    base_deg: [0.0; 3],
    scheme: SchemeKind::Continuous,
    rate_dps: 30.0,
    count: 0,
    aided: false,
    lon_e7: 0,
};

/// Navigation's settings for a configuration.
pub fn nav_config(c: &BoardConfig, t: &Tuning) -> NavConfig {
    let lat = f64::from(c.lat_e7) * 1e-7;
    let h = f64::from(c.height_mm) * 1e-3;
    let rate = match scheme(c) {
        core_nav::scheme::Scheme::Continuous { rate } => rate,
        s => s.peak_rate(),
    };
    NavConfig {
        lat_deg: lat,
        height_m: h,
        base_deg: c.base_deg.map(f64::from),
        scheme_rate_radps: rate,
        aided: c.aided.then_some(BoardAided {
            origin: OriginE7 {
                lat_e7: c.lat_e7,
                lon_e7: c.lon_e7,
                height_mm: c.height_mm,
            },
            cfg: t.filter,
        }),
        ..t.nav
    }
}
