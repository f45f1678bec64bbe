//! What several test files share and the tests library cannot hold (it
//! does not depend on `rins`).

/// The bundled real walk's import input (`tests/data/gnss_imu_walk_0827`:
/// its RTKLIB solution, its IMU log through `columns.toml`, its unit's
/// `sensor.toml`). ORIGIN.md: the heights are above mean sea level; the
/// receiver's ellipsoidal height is 21.39 m below.
pub fn walk_input() -> rins::import::RtklibInput {
    let d = rins_tests::data::bundled("gnss_imu_walk_0827");
    let sensor = d.join("sensor.toml");
    rins::import::RtklibInput {
        pos: d.join("gnss_1730_sf.pos"),
        imu: d.join("imu_1730.csv"),
        columns: d.join("columns.toml"),
        imu_tag: None,
        geoid_m: -21.39,
        sensor: hal_sim::sensor::resolve(&sensor.to_string_lossy())
            .unwrap_or_else(|e| panic!("{}: {e}", sensor.display())),
    }
}
