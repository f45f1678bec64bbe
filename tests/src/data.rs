//! Where the tests' reference data lives: one place for every test.
//!
//! - **Bundled** ([`bundled`]): real recordings whose licence allows
//!   redistribution, in `tests/data/` with their origin and licence
//!   (imucal's Ferraris session, MIT; imu_tk's Xsens session, BSD). Always
//!   there; a missing bundled file is a broken checkout and fails the test.
//! - **External** ([`external`]): data that must not be copied into the
//!   repository ([`EXTERNAL`]: the ADIS16405 hours are CC BY-NC-SA, the
//!   Stable32 tables come from an LGPL package). Read from one directory:
//!   `RINS_DATA` if set, else `../shared/data` beside the checkout. When it
//!   is absent the test says so on stderr and returns (skipped); the last
//!   test binary (`zz_external_data`) prints one line naming what was skipped
//!   and how to get it. With `RINS_DATA_REQUIRED=1` (CI sets it) a missing
//!   dataset fails the test instead: a skip never hides a failure there.

use std::path::PathBuf;

/// A dataset the repository does not carry.
#[derive(Clone, Copy, Debug)]
pub struct Dataset {
    /// Directory name under the data root (`RINS_DATA`).
    pub dir: &'static str,
    /// A file whose presence says the dataset is there.
    pub probe: &'static str,
    /// Why it is not in the repository.
    pub licence: &'static str,
    /// The tests that read it (`binary::test`).
    pub used_by: &'static [&'static str],
}

/// Every external dataset a test reads.
pub const EXTERNAL: [Dataset; 5] = [
    Dataset {
        dir: "adis16405_static",
        probe: "adis_16405_imu1_f32le_1000000x6.bin",
        licence: "CC BY-NC-SA 4.0 (SMAC-Group/imudata): not redistributable here",
        used_by: &[
            "allan_reference::adis16405_bench_noise_terms",
            "diagnose::adis16405_bench_hour_shows_bias_instability",
            "diagnose_real_noise::real_noise_nulls_name_nothing",
            "cli_walk::study",
            "diagnose_real_noise::a_long_step_profile_on_real_drift_is_not_a_warm_up",
            "diagnose_real_noise::a_warm_up_on_real_drift_is_still_found",
            "diagnose_real_noise::cross_axis_g_sensitivity_on_a_horizontal_axis_is_g_sensitivity",
            "diagnose_real_noise::sharp_reversals_from_an_independent_generator_name_nothing",
            "diagnose_real_noise::a_true_time_offset_on_reversals_is_named_alone",
            "diagnose_real_noise::g_sensitivity_and_encoder_error_on_a_one_way_run_are_look_alikes",
            "twin::on_real_noise_every_hidden_effect_gives_a_close_twin",
            "own_data::a_real_static_log_from_a_plain_csv_round_trips_through_a_sensor_file",
            "own_data::a_log_stamped_on_arrival_in_bursts_gives_the_regular_logs_allan_figures",
        ],
    },
    Dataset {
        dir: "allan_reference_stable32",
        probe: "ocxo/ocxo_frequency.txt",
        licence: "LGPL-3.0 (allantools test tables): kept outside the MIT/Apache tree",
        used_by: &[
            "allan_reference::overlapping_adev_matches_stable32_all_tau",
            "allan_reference::non_overlapping_adev_matches_stable32_octaves",
        ],
    },
    Dataset {
        dir: "mpu6050_stepper_roll_slow",
        probe: "recording/imu.csv",
        licence: "MIT (Song, Pei, Hsiao-Wecksler 2022); its first 300 s are bundled in tests/data",
        used_by: &[
            "diagnose_inject_real::an_accelerometer_nonlinearity_hidden_in_the_whole_real_run_is_found_at_its_size",
            "diagnose_never_worse::real_runs_claim_only_the_channels_they_improve",
        ],
    },
    Dataset {
        dir: "mpu6050_stepper_roll_fast",
        probe: "recording/imu.csv",
        licence: "MIT (Song, Pei, Hsiao-Wecksler 2022); 18 MB, read from the shared data",
        used_by: &[
            "diagnose_inject_real::a_lever_arm_hidden_in_the_real_stepper_runs_is_found_at_its_size",
            "diagnose_inject_real::a_g_sensitivity_hidden_in_the_real_stepper_runs_is_found_at_its_size",
            "diagnose_inject_real::an_accelerometer_nonlinearity_hidden_in_the_whole_real_run_is_found_at_its_size",
            "diagnose_inject_real::a_further_accelerometer_latency_hidden_in_the_real_stepper_runs_is_found_at_its_size",
            "diagnose_inject_real::a_warm_up_hidden_in_the_real_stepper_runs_is_found_at_its_size",
            "diagnose_inject_real::a_further_gyro_latency_hidden_in_the_real_stepper_runs_is_found_at_its_size",
            "diagnose_inject_real::two_effects_hidden_at_once_in_the_real_stepper_runs_are_both_sized",
            "diagnose_inject_real::a_mount_wobble_hidden_in_the_real_stepper_runs_is_found_at_its_size",
            "diagnose_real_table::the_table_axis_bias_instability_is_not_taken_from_the_tables_motion",
        ],
    },
    Dataset {
        dir: "../spec",
        probe: "diagnose-v1.md",
        licence:
            "the team's contracts (shared/spec); tests/data carries a copy of the diagnose example",
        used_by: &["diagnose::json_example_copy_equals_the_spec"],
    },
];

/// The external data root: `RINS_DATA`, else `../shared/data` beside the
/// checkout.
pub fn root() -> PathBuf {
    let r = match std::env::var_os("RINS_DATA") {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"),
    };
    // Shown in messages: the absolute path when it exists.
    r.canonicalize().unwrap_or(r)
}

/// A file of the bundled data (`tests/data/<rel>`).
pub fn bundled(rel: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("data")
        .join(rel)
}

/// Missing external data fails instead of skipping (`RINS_DATA_REQUIRED=1`).
pub fn required() -> bool {
    std::env::var("RINS_DATA_REQUIRED").is_ok_and(|v| v == "1" || v == "true")
}

/// The dataset registered under `dir`.
///
/// # Panics
/// An unregistered directory (a test must list its data in [`EXTERNAL`]).
pub fn dataset(dir: &str) -> &'static Dataset {
    EXTERNAL
        .iter()
        .find(|d| d.dir == dir)
        .unwrap_or_else(|| panic!("external dataset {dir:?} is not registered in EXTERNAL"))
}

/// Is the dataset at the root?
pub fn present(d: &Dataset) -> bool {
    root().join(d.dir).join(d.probe).is_file()
}

/// The path of `rel` in the external dataset `dir`, for test `test`
/// (`binary::name`, as listed in [`Dataset::used_by`]). `None` when the
/// dataset is absent: the caller returns (the test is skipped, and said so
/// on stderr).
///
/// # Panics
/// The dataset is absent and [`required`]; the test is not registered as a
/// user of the dataset.
pub fn external(test: &str, dir: &str, rel: &str) -> Option<PathBuf> {
    let d = dataset(dir);
    assert!(
        d.used_by.contains(&test),
        "{test} reads {dir} but is not listed in its Dataset::used_by"
    );
    if present(d) {
        return Some(root().join(dir).join(rel));
    }
    let msg = format!(
        "{test}: external data {dir} not found under {} ({}); set RINS_DATA to the shared data directory",
        root().display(),
        d.licence
    );
    assert!(!required(), "RINS_DATA_REQUIRED: {msg}");
    eprintln!("SKIPPED {msg}");
    None
}

/// `rins import rtklib`'s arguments for the bundled real walk into `out`:
/// the book's command (`docs/src/aided.md`), one home for the tests that
/// run it.
pub fn walk_import_args(out: &std::path::Path) -> Vec<String> {
    let d = |f: &str| {
        bundled("gnss_imu_walk_0827")
            .join(f)
            .to_string_lossy()
            .into_owned()
    };
    [
        "import".to_string(),
        "rtklib".into(),
        "--pos".into(),
        d("gnss_1730_sf.pos"),
        "--imu-file".into(),
        d("imu_1730.csv"),
        "--columns".into(),
        d("columns.toml"),
        "--sensor".into(),
        d("sensor.toml"),
        "--geoid-m".into(),
        "-21.39".into(),
        "--out".into(),
        out.to_string_lossy().into_owned(),
    ]
    .to_vec()
}
