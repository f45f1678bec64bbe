//! No silently ignored option: every option of every command (read from
//! the help texts themselves) either changes the result, is documented as
//! not changing it (`--threads`: bit-identical by design, checked on each
//! command's first comparison), or is refused with its reason. Each command's walk runs its cases against small
//! fixtures (simulated runs, the bundled real walk, the board's program on
//! the host behind a socket); a case that cannot be run here names the
//! test that walks it.

mod common;

use common::{every_help, options, rins, s};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// What an option must do.
#[derive(Clone, Copy, Debug)]
enum Expect {
    /// The result (stdout and these files under the run's `{out}`)
    /// differs from `against`'s.
    Changes(&'static [&'static str]),
    /// The same result as `against`'s (documented as not changing it).
    Same(&'static [&'static str]),
    /// Refused, its stderr holding these words.
    Refused(&'static [&'static str]),
    /// Succeeds and writes this file under `{out}`, holding these words.
    Writes(&'static str, &'static [&'static str]),
    /// Succeeds, its stdout holding these words.
    Prints(&'static [&'static str]),
    /// Walked by another test: (its file in rins/tests, its function).
    Elsewhere(&'static str, &'static str),
}

/// One case: `option` in `args` (after the command), compared with
/// `against` where the expectation compares.
#[derive(Clone, Copy, Debug)]
struct Case {
    option: &'static str,
    args: &'static [&'static str],
    against: &'static [&'static str],
    expect: Expect,
}

/// A command's walk: its path and its cases.
struct Walk {
    cmd: &'static [&'static str],
    cases: &'static [Case],
}

const fn changes(
    option: &'static str,
    args: &'static [&'static str],
    against: &'static [&'static str],
    files: &'static [&'static str],
) -> Case {
    Case {
        option,
        args,
        against,
        expect: Expect::Changes(files),
    }
}

const fn same(
    option: &'static str,
    args: &'static [&'static str],
    against: &'static [&'static str],
    files: &'static [&'static str],
) -> Case {
    Case {
        option,
        args,
        against,
        expect: Expect::Same(files),
    }
}

const fn refused(
    option: &'static str,
    args: &'static [&'static str],
    words: &'static [&'static str],
) -> Case {
    Case {
        option,
        args,
        against: &[],
        expect: Expect::Refused(words),
    }
}

const fn writes(
    option: &'static str,
    args: &'static [&'static str],
    file: &'static str,
    words: &'static [&'static str],
) -> Case {
    Case {
        option,
        args,
        against: &[],
        expect: Expect::Writes(file, words),
    }
}

const fn prints(
    option: &'static str,
    args: &'static [&'static str],
    words: &'static [&'static str],
) -> Case {
    Case {
        option,
        args,
        against: &[],
        expect: Expect::Prints(words),
    }
}

const fn elsewhere(option: &'static str, file: &'static str, test: &'static str) -> Case {
    Case {
        option,
        args: &[],
        against: &[],
        expect: Expect::Elsewhere(file, test),
    }
}

// Placeholders: {fix} the shared fixtures' directory ({rec} a 200 s
// continuous run with a 60 s still start, {spike} the same with one
// impossible gyro reading, {nosigma} the same without its base's stated
// sigmas, {still} a 300 s still run, {drive} a 150 s city drive with GNSS,
// {fix}/walkrec the bundled real walk imported),
// {walk} the bundled real walk, {out} the run's own output directory,
// {board} a fresh board on a socket (`unix:PATH`).

#[rustfmt::skip]
const CALIBRATE: Walk = Walk {
    cmd: &["calibrate"],
    cases: &[
        changes("--keep-implausible", &["{spike}", "--keep-implausible"], &["{spike}"], &[]),
        writes("--json", &["{rec}", "--json", "{out}/c.json"], "c.json", &["rins-calibration/1", "not_estimated"]),
        changes("--method", &["{rec}", "--method", "paper"], &["{rec}"], &[]),
        changes("--from-s", &["{rec}", "--from-s", "20"], &["{rec}"], &[]),
        changes("--to-s", &["{rec}", "--to-s", "150"], &["{rec}"], &[]),
        refused("--rate-dps", &["{rec}", "--rate-dps", "45"], &["commanded 45.000 deg/s"]),
        same("--rate-dps", &["{rec}", "--rate-dps", "30"], &["{rec}"], &[]),
        changes("--sensor", &["{rec}", "--sensor", "nav440"], &["{rec}"], &[]),
        refused("--sensor", &["{rec}", "--sensor", "no-such-sensor"], &["no-such-sensor"]),
        refused("--rest-s", &["{rec}", "--rest-s", "50"], &["--rest-s", "multiposition"]),
        elsewhere("--rest-s", "cli_multipos.rs", "a_real_hand_turned_session_calibrates_from_the_cli"),
        refused("--method", &["{rec}", "--method", "multiposition"], &["rests found"]),
    ],
};

#[rustfmt::skip]
const DIAGNOSE: Walk = Walk {
    cmd: &["diagnose"],
    cases: &[
        changes("--keep-implausible", &["{spike}", "--keep-implausible"], &["{spike}"], &[]),
        changes("--model", &["{rec}", "--model", "{fix}/model.toml"], &["{rec}"], &[]),
        writes("--json", &["{rec}", "--json", "{out}/d.json"], "d.json", &["rins-diagnose/1"]),
        writes("--plots", &["{rec}", "--plots", "{out}/p"], "p/residual_gyro.png", &[]),
        changes("--block-s", &["{rec}", "--block-s", "0.5"], &["{rec}"], &[]),
        refused("--block-s", &["{rec}", "--block-s", "0"], &["--block-s"]),
        writes("--resim", &["{rec}", "--resim", "{out}/r"], "r/imu.csv", &["t_s"]),
        writes("--sim-model", &["{rec}", "--sim-model", "{out}/m.toml"], "m.toml", &["rins-sim-model/1"]),
        refused("--seed", &["{rec}", "--seed", "2"], &["--sim-model"]),
        changes("--seed", &["{rec}", "--sim-model", "{out}/m.toml", "--seed", "2"], &["{rec}", "--sim-model", "{out}/m.toml"], &[]),
        writes("--sensor-out", &["{rec}", "--sensor-out", "{out}/s.toml"], "s.toml", &["rins-sensor/2"]),
        changes("--sensor", &["{rec}", "--sensor-out", "{out}/s.toml", "--sensor", "nav440"], &["{rec}", "--sensor-out", "{out}/s.toml"], &["s.toml"]),
        refused("--sensor", &["{rec}", "--sensor", "nav440"], &["--sensor-out"]),
    ],
};

#[rustfmt::skip]
const NAV: &[&str] = &["{out}/n/trajectory.csv"];

#[rustfmt::skip]
const NAVIGATE: Walk = Walk {
    cmd: &["navigate"],
    cases: &[
        changes("--keep-implausible", &["{spike}", "--keep-implausible", "--out", "{out}/n"], &["{spike}", "--out", "{out}/n"], NAV),
        changes("--calibration", &["{rec}", "--calibration", "{fix}/cal.json", "--out", "{out}/n"], &["{rec}", "--out", "{out}/n"], NAV),
        writes("--out", &["{rec}", "--out", "{out}/n"], "n/trajectory.csv", &["t_s"]),
        changes("--start-s", &["{rec}", "--start-s", "100", "--out", "{out}/n"], &["{rec}", "--out", "{out}/n"], NAV),
        changes("--end-s", &["{rec}", "--end-s", "150", "--out", "{out}/n"], &["{rec}", "--out", "{out}/n"], NAV),
        changes("--f32", &["{rec}", "--f32", "--out", "{out}/n"], &["{rec}", "--out", "{out}/n"], NAV),
        changes("--hold-height", &["{rec}", "--hold-height", "--out", "{out}/n"], &["{rec}", "--out", "{out}/n"], NAV),
        changes("--attitude-from-meta", &["{nosigma}", "--attitude-from-meta", "--out", "{out}/n"], &["{nosigma}", "--out", "{out}/n"], NAV),
        writes("--json", &["{rec}", "--json", "{out}/n.json", "--out", "{out}/n"], "n.json", &["h_pos_end_m"]),
        writes("--gnss", &["{drive}", "--gnss", "--out", "{out}/n"], "n/trajectory.csv", &["sigma"]),
        refused("--gnss", &["{drive}", "--out", "{out}/n"], &["--gnss"]),
        changes("--no-zupt", &["{drive}", "--gnss", "--no-zupt", "--out", "{out}/n"], &["{drive}", "--gnss", "--out", "{out}/n"], NAV),
        refused("--no-zupt", &["{rec}", "--no-zupt", "--out", "{out}/n"], &["--gnss"]),
        changes("--sensor", &["{rec}", "--sensor", "nav440", "--out", "{out}/n"], &["{rec}", "--out", "{out}/n"], &[]),
        changes("--gnss-outage", &["{drive}", "--gnss", "--gnss-outage", "60:20", "--out", "{out}/n"], &["{drive}", "--gnss", "--out", "{out}/n"], NAV),
        elsewhere("--gnss-outage", "cli_options.rs", "navigate_gnss_honours_its_span_and_refuses_what_it_cannot_use"),
        refused("--gnss-floor-m", &["{drive}", "--gnss", "--gnss-floor-m", "50,50,50,50", "--out", "{out}/n"], &["no quality column"]),
        changes("--gnss-floor-m", &["{fix}/walkrec", "--gnss", "--gnss-floor-m", "5,5,5,5", "--out", "{out}/n"], &["{fix}/walkrec", "--gnss", "--out", "{out}/n"], NAV),
        changes("--gate-sigma", &["{drive}", "--gnss", "--gate-sigma", "0.5", "--out", "{out}/n"], &["{drive}", "--gnss", "--out", "{out}/n"], NAV),
        changes("--gnss-position-only", &["{drive}", "--gnss", "--gnss-position-only", "--out", "{out}/n"], &["{drive}", "--gnss", "--out", "{out}/n"], NAV),
        changes("--time-offset-s", &["{drive}", "--gnss", "--time-offset-s", "0.2", "--out", "{out}/n"], &["{drive}", "--gnss", "--out", "{out}/n"], NAV),
        changes("--estimate-time-offset", &["{drive}", "--gnss", "--time-offset-s", "0.2", "--estimate-time-offset", "--out", "{out}/n"], &["{drive}", "--gnss", "--time-offset-s", "0.2", "--out", "{out}/n"], NAV),
        changes("--estimate-lever-arm", &["{fix}/walkrec", "--gnss", "--estimate-lever-arm", "--out", "{out}/n"], &["{fix}/walkrec", "--gnss", "--keep-given-arm", "--out", "{out}/n"], NAV),
        // The walk's fixes refute its author's arm: by default navigate
        // takes theirs, told to keep the given one it does.
        changes("--keep-given-arm", &["{fix}/walkrec", "--gnss", "--keep-given-arm", "--out", "{out}/n"], &["{fix}/walkrec", "--gnss", "--out", "{out}/n"], NAV),
        refused("--keep-given-arm", &["{fix}/walkrec", "--gnss", "--keep-given-arm", "--estimate-lever-arm", "--out", "{out}/n"], &["cannot be used with"]),
        refused("--keep-given-arm", &["{rec}", "--keep-given-arm", "--out", "{out}/n"], &["--gnss"]),
        refused("--keep-given-arm", &["{fix}/walkrec", "--gnss", "--keep-given-arm", "--estimate-time-offset", "--out", "{out}/n"], &["cannot be used with"]),
        refused("--estimate-lever-arm", &["{rec}", "--estimate-lever-arm", "--out", "{out}/n"], &["--gnss"]),
        refused("--estimate-lever-arm", &["{fix}/walkrec", "--gnss", "--time-offset-s", "0.1", "--estimate-lever-arm", "--out", "{out}/n"], &["no arm found", "fit no arm"]),
        // Both: estimated together (rins::aided::joint), not one after the other.
        changes("--estimate-time-offset", &["{drive}", "--gnss", "--time-offset-s", "0.2", "--estimate-time-offset", "--estimate-lever-arm", "--out", "{out}/n"], &["{drive}", "--gnss", "--time-offset-s", "0.2", "--estimate-lever-arm", "--out", "{out}/n"], NAV),
        changes("--learn-noise", &["{fix}/walkrec", "--gnss", "--learn-noise", "--out", "{out}/n"], &["{fix}/walkrec", "--gnss", "--out", "{out}/n"], NAV),
        refused("--learn-noise", &["{rec}", "--learn-noise", "--out", "{out}/n"], &["--gnss"]),
        // The walk's heights refute the file's vertical noise: learnt and
        // added unless told to keep the file's.
        changes("--vertical-noise", &["{fix}/walkrec", "--gnss", "--vertical-noise", "file", "--out", "{out}/n"], &["{fix}/walkrec", "--gnss", "--out", "{out}/n"], NAV),
        refused("--vertical-noise", &["{rec}", "--vertical-noise", "file", "--out", "{out}/n"], &["--gnss"]),
        refused("--vertical-noise", &["{fix}/walkrec", "--gnss", "--vertical-noise", "sometimes", "--out", "{out}/n"], &["sometimes"]),
        changes("--vehicle", &["{drive}", "--gnss", "--vehicle", "car", "--out", "{out}/n"], &["{drive}", "--gnss", "--out", "{out}/n"], NAV),
        refused("--vehicle", &["{drive}", "--gnss", "--vehicle", "boat", "--out", "{out}/n"], &["boat"]),
        refused("--vehicle", &["{drive}", "--vehicle", "car", "--out", "{out}/n"], &["--gnss"]),
    ],
};

#[rustfmt::skip]
const SIM: &[&str] = &["{out}/r/imu.csv", "{out}/r/meta.toml"];
#[rustfmt::skip]
const SIM_GNSS: &[&str] = &["{out}/r/gnss.csv"];

#[rustfmt::skip]
const SIMULATE: Walk = Walk {
    cmd: &["simulate"],
    cases: &[
        changes("--ideal", &["--ideal", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--sensor", &["--sensor", "nav440", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        refused("--sensor", &["--ideal", "--sensor", "nav440", "--out", "{out}/r"], &["--ideal"]),
        changes("--scheme", &["--scheme", "reciprocating", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--axis", &["--axis", "x", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--rate-dps", &["--rate-dps", "60", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        refused("--rate-dps", &["--scheme", "still", "--rate-dps", "60", "--out", "{out}/r"], &["--rate-dps", "still"]),
        refused("--rate-dps", &["--rate-dps", "30,60", "--out", "{out}/r"], &["--rate-dps", "multirate"]),
        changes("--rate-dps", &["--scheme", "multirate", "--rate-dps", "30,-60", "--duration-s", "40", "--out", "{out}/r"], &["--scheme", "multirate", "--rate-dps", "30,60", "--duration-s", "40", "--out", "{out}/r"], SIM),
        refused("--rate-dps", &["--scheme", "multirate", "--rate-dps", "10,20,30,40,50", "--out", "{out}/r"], &["1 to 4 rates"]),
        changes("--duration-s", &["--duration-s", "25", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--static-s", &["--static-s", "10", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--lat-deg", &["--lat-deg", "45", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--height-m", &["--height-m", "2000", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--heading-deg", &["--heading-deg", "90", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--pitch-deg", &["--pitch-deg", "5", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--roll-deg", &["--roll-deg", "5", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--gravity-mps2", &["--gravity-mps2", "9.9", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        changes("--turns", &["--scheme", "reciprocating", "--turns", "2", "--duration-s", "40", "--out", "{out}/r"], &["--scheme", "reciprocating", "--duration-s", "40", "--out", "{out}/r"], SIM),
        refused("--turns", &["--turns", "2", "--out", "{out}/r"], &["--turns", "reciprocating"]),
        changes("--turns", &["--scheme", "multirate", "--rate-dps", "90", "--turns", "2", "--duration-s", "40", "--out", "{out}/r"], &["--scheme", "multirate", "--rate-dps", "90", "--duration-s", "40", "--out", "{out}/r"], SIM),
        changes("--positions", &["--scheme", "indexed", "--positions", "2", "--duration-s", "40", "--out", "{out}/r"], &["--scheme", "indexed", "--duration-s", "40", "--out", "{out}/r"], SIM),
        refused("--positions", &["--positions", "2", "--out", "{out}/r"], &["--positions", "indexed"]),
        changes("--dwell-s", &["--scheme", "indexed", "--dwell-s", "5", "--duration-s", "40", "--out", "{out}/r"], &["--scheme", "indexed", "--duration-s", "40", "--out", "{out}/r"], SIM),
        refused("--dwell-s", &["--scheme", "reciprocating", "--dwell-s", "5", "--out", "{out}/r"], &["--dwell-s", "indexed"]),
        changes("--dwell-s", &["--scheme", "multirate", "--rate-dps", "90", "--dwell-s", "5", "--duration-s", "40", "--out", "{out}/r"], &["--scheme", "multirate", "--rate-dps", "90", "--duration-s", "40", "--out", "{out}/r"], SIM),
        changes("--effect", &["--effect", "lever_arm=0.05", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        refused("--effect", &["--effect", "nope=1", "--out", "{out}/r"], &["nope"]),
        changes("--seed", &["--seed", "2", "--duration-s", "20", "--out", "{out}/r"], &["--duration-s", "20", "--out", "{out}/r"], SIM),
        prints("--list-effects", &["--list-effects"], &["lever_arm", "untracked_table_motion"]),
        refused("--list-effects", &["--list-effects", "--out", "{out}/r"], &["--list-effects"]),
        changes("--drive", &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], &["--duration-s", "30", "--out", "{out}/r"], SIM),
        refused("--drive", &["--drive", "moon", "--out", "{out}/r"], &["city or highway"]),
        changes("--gnss-outage", &["--drive", "city", "--gnss-outage", "10:5", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM_GNSS),
        refused("--gnss-outage", &["--gnss-outage", "10:5", "--out", "{out}/r"], &["--drive"]),
        changes("--lon-deg", &["--drive", "city", "--lon-deg", "10", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM_GNSS),
        refused("--lon-deg", &["--lon-deg", "10", "--out", "{out}/r"], &["--drive"]),
        changes("--mounting-deg", &["--drive", "city", "--mounting-deg", "180,2,-90", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM),
        refused("--mounting-deg", &["--drive", "city", "--mounting-deg", "1,2", "--out", "{out}/r"], &["three values"]),
        refused("--mounting-deg", &["--mounting-deg", "1,2,3", "--out", "{out}/r"], &["--drive"]),
        changes("--imu-ahead-m", &["--drive", "city", "--imu-ahead-m", "1.5", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM_GNSS),
        refused("--imu-ahead-m", &["--drive", "city", "--imu-ahead-m", "20", "--out", "{out}/r"], &["within 10 m"]),
        refused("--imu-ahead-m", &["--imu-ahead-m", "1", "--out", "{out}/r"], &["--drive"]),
        changes("--gnss-rate-hz", &["--drive", "city", "--gnss-rate-hz", "5", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM_GNSS),
        refused("--gnss-rate-hz", &["--drive", "city", "--gnss-rate-hz", "50", "--out", "{out}/r"], &["1-20 Hz"]),
        refused("--gnss-rate-hz", &["--gnss-rate-hz", "5", "--out", "{out}/r"], &["--drive"]),
        changes("--gnss-sigma-m", &["--drive", "city", "--gnss-sigma-m", "0.02,0.04", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM_GNSS),
        refused("--gnss-sigma-m", &["--drive", "city", "--gnss-sigma-m", "0.02", "--out", "{out}/r"], &["two values"]),
        refused("--gnss-sigma-m", &["--gnss-sigma-m", "1,2", "--out", "{out}/r"], &["--drive"]),
        changes("--gnss-early-s", &["--drive", "city", "--gnss-early-s", "0.25", "--duration-s", "30", "--out", "{out}/r"], &["--drive", "city", "--duration-s", "30", "--out", "{out}/r"], SIM_GNSS),
        refused("--gnss-early-s", &["--drive", "city", "--gnss-early-s", "9", "--out", "{out}/r"], &["within 5 s"]),
        refused("--gnss-early-s", &["--gnss-early-s", "0.1", "--out", "{out}/r"], &["--drive"]),
        elsewhere("--like", "cli_options.rs", "simulate_like_refuses_the_flags_the_recording_gives"),
        elsewhere("--sim-model", "cli_options.rs", "simulate_like_refuses_the_flags_the_recording_gives"),
        writes("--out", &["--duration-s", "20", "--out", "{out}/r"], "r/meta.toml", &["rins-recording/1"]),
    ],
};

#[rustfmt::skip]
const ALLAN: Walk = Walk {
    cmd: &["allan"],
    cases: &[
        writes("--json", &["{still}", "--json", "{out}/a.json"], "a.json", &["rins-allan/1", "not_measured"]),
        writes("--plots", &["{still}", "--plots", "{out}/p"], "p/allan.png", &[]),
        writes("--sensor-out", &["{still}", "--sensor-out", "{out}/s.toml"], "s.toml", &["rins-sensor/2", "measured"]),
        changes("--sensor", &["{still}", "--sensor-out", "{out}/s.toml", "--sensor", "nav440"], &["{still}", "--sensor-out", "{out}/s.toml"], &["s.toml"]),
        refused("--sensor", &["{still}", "--sensor", "nav440"], &["--sensor-out"]),
    ],
};

#[rustfmt::skip]
const CSV_REC: &[&str] = &["{out}/r/meta.toml", "{out}/r/imu.csv"];

#[rustfmt::skip]
const IMPORT_CSV: Walk = Walk {
    cmd: &["import", "csv"],
    cases: &[
        refused("--imu-file", &["--imu-file", "{fix}/none.csv", "--columns", "{fix}/columns.toml", "--sensor", "icm42688", "--lat-deg", "30", "--out", "{out}/r"], &["none.csv"]),
        refused("--columns", &["--imu-file", "{still}/imu.csv", "--columns", "{fix}/none.toml", "--sensor", "icm42688", "--lat-deg", "30", "--out", "{out}/r"], &["none.toml"]),
        changes("--sensor", &["--imu-file", "{still}/imu.csv", "--columns", "{fix}/columns.toml", "--sensor", "nav440", "--lat-deg", "30", "--out", "{out}/r"], &["{csv}"], CSV_REC),
        changes("--lat-deg", &["--imu-file", "{still}/imu.csv", "--columns", "{fix}/columns.toml", "--sensor", "icm42688", "--lat-deg", "45", "--out", "{out}/r"], &["{csv}"], CSV_REC),
        changes("--height-m", &["{csv}", "--height-m", "500"], &["{csv}"], CSV_REC),
        changes("--base-deg", &["{csv}", "--base-deg", "0,0,90"], &["{csv}"], CSV_REC),
        changes("--heading-sigma-deg", &["{csv}", "--base-deg", "0,0,90", "--heading-sigma-deg", "2"], &["{csv}", "--base-deg", "0,0,90"], CSV_REC),
        refused("--heading-sigma-deg", &["{csv}", "--heading-sigma-deg", "2"], &["--base-deg"]),
        changes("--level-sigma-deg", &["{csv}", "--base-deg", "0,0,90", "--level-sigma-deg", "1"], &["{csv}", "--base-deg", "0,0,90"], CSV_REC),
        refused("--level-sigma-deg", &["{csv}", "--level-sigma-deg", "1"], &["--base-deg"]),
        writes("--out", &["{csv}"], "r/meta.toml", &["rins-recording/1"]),
        writes("--json", &["{csv}", "--json", "{out}/i.json"], "i.json", &["samples"]),
    ],
};

#[rustfmt::skip]
const WALK_REC: &[&str] = &["{out}/r/meta.toml", "{out}/r/gnss.csv", "{out}/r/imu.csv"];

#[rustfmt::skip]
const IMPORT_RTKLIB: Walk = Walk {
    cmd: &["import", "rtklib"],
    cases: &[
        refused("--pos", &["--pos", "{fix}/none.pos", "--imu-file", "{walk}/imu_1730.csv", "--columns", "{walk}/columns.toml", "--sensor", "{walk}/sensor.toml", "--out", "{out}/r"], &["none.pos"]),
        refused("--imu-file", &["--pos", "{walk}/gnss_1730_sf.pos", "--imu-file", "{fix}/none.csv", "--columns", "{walk}/columns.toml", "--sensor", "{walk}/sensor.toml", "--out", "{out}/r"], &["none.csv"]),
        refused("--columns", &["--pos", "{walk}/gnss_1730_sf.pos", "--imu-file", "{walk}/imu_1730.csv", "--columns", "{fix}/none.toml", "--sensor", "{walk}/sensor.toml", "--out", "{out}/r"], &["none.toml"]),
        same("--imu-tag", &["{rtk}", "--imu-tag", "{walk}/imu_1730.csv.tag"], &["{rtk}"], WALK_REC),
        refused("--imu-tag", &["{rtk}", "--imu-tag", "{fix}/none.tag"], &["none.tag"]),
        changes("--sensor", &["--pos", "{walk}/gnss_1730_sf.pos", "--imu-file", "{walk}/imu_1730.csv", "--columns", "{walk}/columns.toml", "--sensor", "icm42605", "--out", "{out}/r"], &["{rtk}"], WALK_REC),
        changes("--geoid-m", &["{rtk}", "--geoid-m", "-21.39"], &["{rtk}"], WALK_REC),
        writes("--out", &["{rtk}"], "r/gnss.csv", &["t_s"]),
        writes("--json", &["{rtk}", "--json", "{out}/i.json"], "i.json", &["fixes"]),
    ],
};

#[rustfmt::skip]
const KF_REC: &[&str] = &["{out}/r/meta.toml", "{out}/r/gnss.csv", "{out}/r/truth.csv"];

#[rustfmt::skip]
const IMPORT_KF_GINS: Walk = Walk {
    cmd: &["import", "kf-gins"],
    cases: &[
        refused("--imu-file", &["--imu-file", "{fix}/none.txt", "--gnss", "{fix}/kf/gnss.txt", "--sensor", "icm42688", "--out", "{out}/r"], &["none.txt"]),
        refused("--gnss", &["--imu-file", "{fix}/kf/imu.txt", "--gnss", "{fix}/none.txt", "--sensor", "icm42688", "--out", "{out}/r"], &["none.txt"]),
        changes("--truth", &["{kf}", "--truth", "{fix}/kf/truth.txt"], &["{kf}"], KF_REC),
        changes("--sensor", &["--imu-file", "{fix}/kf/imu.txt", "--gnss", "{fix}/kf/gnss.txt", "--sensor", "nav440", "--out", "{out}/r"], &["{kf}"], KF_REC),
        writes("--out", &["{kf}"], "r/meta.toml", &["rins-recording/1"]),
        writes("--json", &["{kf}", "--json", "{out}/i.json"], "i.json", &["fixes"]),
    ],
};

#[rustfmt::skip]
const COMMA_REC: &[&str] = &["{out}/r/meta.toml", "{out}/r/gnss.csv"];

#[rustfmt::skip]
const IMPORT_COMMA: Walk = Walk {
    cmd: &["import", "comma2k19"],
    cases: &[
        refused("--dir", &["--dir", "{fix}/none", "--fix-sigma-m", "2", "--sensor", "icm42605", "--out", "{out}/r"], &["none", "missing"]),
        changes("--fix-sigma-m", &["--dir", "{comma}", "--fix-sigma-m", "1", "--sensor", "icm42605", "--out", "{out}/r"], &["--dir", "{comma}", "--fix-sigma-m", "2", "--sensor", "icm42605", "--out", "{out}/r"], COMMA_REC),
        refused("--fix-sigma-m", &["--dir", "{comma}", "--fix-sigma-m", "0", "--sensor", "icm42605", "--out", "{out}/r"], &["positive"]),
        changes("--sensor", &["--dir", "{comma}", "--fix-sigma-m", "2", "--sensor", "nav440", "--out", "{out}/r"], &["--dir", "{comma}", "--fix-sigma-m", "2", "--sensor", "icm42605", "--out", "{out}/r"], COMMA_REC),
        writes("--out", &["--dir", "{comma}", "--fix-sigma-m", "2", "--sensor", "icm42605", "--out", "{out}/r"], "r/odometer.csv", &["speed_mps"]),
        writes("--json", &["--dir", "{comma}", "--fix-sigma-m", "2", "--sensor", "icm42605", "--out", "{out}/r", "--json", "{out}/i.json"], "i.json", &["fixes"]),
    ],
};

#[rustfmt::skip]
const STUDY_J: &[&str] = &["{out}/s.json"];

#[rustfmt::skip]
const STUDY: Walk = Walk {
    cmd: &["study"],
    cases: &[
        changes("--runs", &["--sensor", "nav440", "--runs", "2", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], STUDY_J),
        changes("--nulls", &["--sensor", "nav440", "--runs", "1", "--nulls", "2", "--shard", "999/1000", "--json", "{out}/s.json"], &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], STUDY_J),
        changes("--sensor", &["--sensor", "mtig", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], STUDY_J),
        changes("--real-noise", &["--real-noise", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], &["--sensor", "adis16405", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], STUDY_J),
        refused("--real-noise-file", &["--real-noise-file", "{fix}/none.bin", "--runs", "1", "--shard", "0/80", "--json", "{out}/s.json"], &["none.bin"]),
        same("--real-noise-file", &["--real-noise-file", "{adis}", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], &["--real-noise", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], STUDY_J),
        changes("--seed", &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--seed", "2", "--shard", "999/1000", "--json", "{out}/s.json"], &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "999/1000", "--json", "{out}/s.json"], STUDY_J),
        changes("--shard", &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "1/80", "--json", "{out}/s.json"], &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "0/80", "--json", "{out}/s.json"], STUDY_J),
        refused("--shard", &["--sensor", "nav440", "--runs", "1", "--shard", "0/80"], &["--shard needs --json"]),
        writes("--json", &["--sensor", "nav440", "--runs", "1", "--nulls", "1", "--shard", "0/80", "--json", "{out}/s.json"], "s.json", &["rins-study-shard/1"]),
        refused("--markdown", &["--sensor", "nav440", "--runs", "1", "--shard", "0/80", "--json", "{out}/s.json", "--markdown", "{out}/s.md"], &["--markdown with --shard"]),
        elsewhere("--markdown", "cli_shards.rs", "the_study_in_shards_merges_to_one_run"),
    ],
};

#[rustfmt::skip]
const OUT_J: &[&str] = &["{out}/o.json"];

#[rustfmt::skip]
const OUTAGES: Walk = Walk {
    cmd: &["outages"],
    cases: &[
        changes("--drive", &["--drive", "highway", "--sensor", "nav440", "--drives", "1", "--json", "{out}/o.json"], &["--sensor", "nav440", "--drives", "1", "--json", "{out}/o.json"], OUT_J),
        refused("--drive", &["--drive", "moon", "--drives", "1"], &["city or highway"]),
        changes("--sensor", &["--sensor", "icm42688", "--drives", "1", "--json", "{out}/o.json"], &["--sensor", "nav440", "--drives", "1", "--json", "{out}/o.json"], OUT_J),
        changes("--drives", &["--sensor", "nav440", "--drives", "2", "--json", "{out}/o.json"], &["--sensor", "nav440", "--drives", "1", "--json", "{out}/o.json"], OUT_J),
        changes("--seed", &["--sensor", "nav440", "--drives", "1", "--seed", "2", "--json", "{out}/o.json"], &["--sensor", "nav440", "--drives", "1", "--json", "{out}/o.json"], OUT_J),
        changes("--shard", &["--sensor", "nav440", "--drives", "2", "--shard", "1/2", "--json", "{out}/o.json"], &["--sensor", "nav440", "--drives", "2", "--json", "{out}/o.json"], OUT_J),
        refused("--shard", &["--sensor", "nav440", "--drives", "2", "--shard", "1/2"], &["--shard needs --json"]),
        writes("--json", &["--sensor", "nav440", "--drives", "1", "--json", "{out}/o.json"], "o.json", &["rins-outages/1"]),
        writes("--markdown", &["--sensor", "nav440", "--drives", "1", "--markdown", "{out}/o.md"], "o.md", &["|"]),
        refused("--markdown", &["--sensor", "nav440", "--drives", "2", "--shard", "1/2", "--json", "{out}/o.json", "--markdown", "{out}/o.md"], &["--markdown with --shard"]),
        writes("--plots", &["--sensor", "nav440", "--drives", "1", "--plots", "{out}/p"], "p/drive_map.png", &[]),
        writes("--vehicle", &["--sensor", "nav440", "--drives", "1", "--vehicle", "car", "--json", "{out}/o.json"], "o.json", &["rins-vehicle-outages/1", "forward_sigmas"]),
        refused("--vehicle", &["--sensor", "nav440", "--drives", "2", "--vehicle", "car", "--shard", "1/2", "--json", "{out}/o.json"], &["--shard"]),
    ],
};

#[rustfmt::skip]
const REP_J: &[&str] = &["{out}/r.json"];

#[rustfmt::skip]
const REPRODUCE: Walk = Walk {
    cmd: &["reproduce"],
    cases: &[
        changes("--sensor", &["--sensor", "mtig", "--runs", "1", "--json", "{out}/r.json"], &["--sensor", "nav440", "--runs", "1", "--json", "{out}/r.json"], REP_J),
        refused("--sensor", &["--sensor", "icm42688", "--runs", "1"], &["mtig or nav440"]),
        changes("--runs", &["--sensor", "nav440", "--runs", "2", "--json", "{out}/r.json"], &["--sensor", "nav440", "--runs", "1", "--json", "{out}/r.json"], REP_J),
        refused("--runs", &["--sensor", "nav440", "--runs", "0"], &["--runs"]),
        changes("--seed", &["--sensor", "nav440", "--runs", "1", "--seed", "2", "--json", "{out}/r.json"], &["--sensor", "nav440", "--runs", "1", "--json", "{out}/r.json"], REP_J),
        changes("--shard", &["--sensor", "nav440", "--runs", "2", "--shard", "1/2", "--json", "{out}/r.json"], &["--sensor", "nav440", "--runs", "2", "--json", "{out}/r.json"], REP_J),
        writes("--json", &["--sensor", "nav440", "--runs", "1", "--json", "{out}/r.json"], "r.json", &["rins-reproduce/1"]),
        writes("--markdown", &["--sensor", "nav440", "--runs", "1", "--markdown", "{out}/r.md"], "r.md", &["|"]),
        refused("--markdown", &["--sensor", "nav440", "--runs", "2", "--shard", "1/2", "--json", "{out}/r.json", "--markdown", "{out}/r.md"], &["--markdown with --shard"]),
        writes("--plots", &["--sensor", "nav440", "--runs", "1", "--plots", "{out}/p"], "p", &[]),
        refused("--plots", &["--sensor", "nav440", "--runs", "2", "--shard", "1/2", "--json", "{out}/r.json", "--plots", "{out}/p"], &["--plots with --shard"]),
    ],
};

#[rustfmt::skip]
const RESULTS: Walk = Walk {
    cmd: &["results"],
    cases: &[
        writes("--out", &["--small", "--only", "reproduce", "--out", "{out}/t"], "t/reproduce-nav440.md", &["Generated by `rins results`"]),
        writes("--small", &["--small", "--only", "reproduce", "--out", "{out}/t"], "t/reproduce-mtig.md", &["small"]),
        refused("--only", &["--small", "--only", "everything", "--out", "{out}/t"], &["--only \"everything\""]),
        elsewhere("--only", "cli_walk.rs", "results_only_writes_the_tables_it_names"),
        same("--threads", &["--threads", "1", "--small", "--only", "reproduce", "--out", "{out}/t"], &["--threads", "3", "--small", "--only", "reproduce", "--out", "{out}/t"], &[]),
    ],
};

#[rustfmt::skip]
const MERGE: Walk = Walk {
    cmd: &["merge"],
    cases: &[
        writes("--json", &["{fix}/rep0.json", "{fix}/rep1.json", "--json", "{out}/m.json"], "m.json", &["rins-reproduce/1"]),
        writes("--markdown", &["{fix}/rep0.json", "{fix}/rep1.json", "--markdown", "{out}/m.md"], "m.md", &["|"]),
        writes("--plots", &["{fix}/rep0.json", "{fix}/rep1.json", "--plots", "{out}/p"], "p", &[]),
        refused("--plots", &["{fix}/out0.json", "{fix}/out1.json", "--plots", "{out}/p"], &["--plots"]),
        elsewhere("--json", "cli_shards.rs", "outages_in_shards_merge_to_one_run"),
        same("--threads", &["--threads", "1", "{fix}/out0.json", "{fix}/out1.json", "--json", "{out}/m.json"], &["--threads", "3", "{fix}/out0.json", "{fix}/out1.json", "--json", "{out}/m.json"], &["{out}/m.json"]),
    ],
};

#[rustfmt::skip]
const DEMO_F: &[&str] = &["{out}/d/trajectory_rotary.csv"];

#[rustfmt::skip]
const DEMO: Walk = Walk {
    cmd: &["demo"],
    cases: &[
        writes("--out", &["--out", "{out}/d"], "d/trajectory_rotary.csv", &["t_s"]),
        changes("--rate-dps", &["--rate-dps", "20", "--out", "{out}/d"], &["--out", "{out}/d"], DEMO_F),
        changes("--seed", &["--seed", "8", "--out", "{out}/d"], &["--out", "{out}/d"], DEMO_F),
    ],
};

#[rustfmt::skip]
const QEMU_REPLAY: Walk = Walk {
    cmd: &["qemu-replay"],
    cases: &[
        changes("--counts-per-rev", &["{rec}", "{out}/r.bin", "--counts-per-rev", "4096"], &["{rec}", "{out}/r.bin"], &["{out}/r.bin"]),
    ],
};

#[rustfmt::skip]
const REC_F: &[&str] = &["{out}/r/meta.toml", "{out}/r/imu.csv"];

#[rustfmt::skip]
const RECORD: Walk = Walk {
    cmd: &["record"],
    cases: &[
        writes("--from-file", &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], "r/imu.csv", &["t_s"]),
        writes("--out", &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], "r/meta.toml", &["rins-recording/1"]),
        changes("--lat-deg", &["--from-file", "{fix}/capture.bin", "--lat-deg", "45", "--out", "{out}/r"], &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], REC_F),
        changes("--height-m", &["--from-file", "{fix}/capture.bin", "--height-m", "100", "--out", "{out}/r"], &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], REC_F),
        changes("--heading-deg", &["--from-file", "{fix}/capture.bin", "--heading-deg", "90", "--out", "{out}/r"], &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], REC_F),
        changes("--pitch-deg", &["--from-file", "{fix}/capture.bin", "--pitch-deg", "1", "--out", "{out}/r"], &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], REC_F),
        changes("--roll-deg", &["--from-file", "{fix}/capture.bin", "--roll-deg", "1", "--out", "{out}/r"], &["--from-file", "{fix}/capture.bin", "--out", "{out}/r"], REC_F),
        writes("--json", &["--from-file", "{fix}/capture.bin", "--out", "{out}/r", "--json", "{out}/l.json"], "l.json", &["frames"]),
        refused("--port", &["--port", "{board}", "--from-file", "{fix}/capture.bin", "--out", "{out}/r"], &["--from-file"]),
        writes("--port", &["--port", "{board}", "--duration-s", "2", "--out", "{out}/r"], "r/imu.csv", &["t_s"]),
        refused("--baud", &["--from-file", "{fix}/capture.bin", "--baud", "9600", "--out", "{out}/r"], &["--from-file"]),
        refused("--baud", &["--port", "{board}", "--baud", "9600", "--out", "{out}/r"], &["a socket has no baud rate"]),
        refused("--duration-s", &["--from-file", "{fix}/capture.bin", "--duration-s", "5", "--out", "{out}/r"], &["--from-file"]),
        refused("--like", &["--from-file", "{fix}/capture.bin", "--like", "{rec}", "--out", "{out}/r"], &["--from-file"]),
        elsewhere("--like", "cli_walk.rs", "record_like_configures_the_board_it_records"),
        refused("--gnss", &["--from-file", "{fix}/capture.bin", "--gnss", "{drive}/gnss.csv", "--out", "{out}/r"], &["--from-file"]),
        refused("--gnss-baud", &["--from-file", "{fix}/capture.bin", "--gnss-baud", "9600", "--out", "{out}/r"], &["--from-file"]),
        refused("--gnss-baud", &["--port", "{board}", "--gnss-baud", "9600", "--out", "{out}/r"], &["--gnss"]),
        refused("--gnss-baud", &["--port", "{board}", "--gnss", "{drive}/gnss.csv", "--gnss-baud", "9600", "--duration-s", "1", "--out", "{out}/r"], &["a file has no baud rate"]),
        refused("--latency-ms", &["--from-file", "{fix}/capture.bin", "--latency-ms", "50", "--out", "{out}/r"], &["--from-file"]),
        refused("--latency-ms", &["--port", "{board}", "--latency-ms", "50", "--out", "{out}/r"], &["--gnss"]),
        refused("--latency-ms", &["--port", "{board}", "--gnss", "{board}", "--latency-ms", "50", "--duration-s", "1", "--out", "{out}/r"], &["relayed as they arrive"]),
    ],
};

#[rustfmt::skip]
const COMMAND: Walk = Walk {
    cmd: &["command"],
    cases: &[
        prints("--port", &["--port", "{board}", "stop"], &["Stop", "Accepted"]),
        refused("--baud", &["--port", "{board}", "--baud", "9600", "stop"], &["a socket has no baud rate"]),
        changes("--json", &["--port", "{board}", "--json", "stop"], &["--port", "{board}", "stop"], &[]),
    ],
};

#[rustfmt::skip]
const COMMAND_SCHEME: Walk = Walk {
    cmd: &["command", "scheme"],
    cases: &[
        changes("--rate-dps", &["--port", "{board}", "scheme", "continuous", "--rate-dps", "20"], &["--port", "{board}", "scheme", "continuous"], &[]),
        changes("--count", &["--port", "{board}", "scheme", "indexed", "--count", "2"], &["--port", "{board}", "scheme", "indexed", "--count", "4"], &[]),
    ],
};

#[rustfmt::skip]
const COMMAND_SITE: Walk = Walk {
    cmd: &["command", "site"],
    cases: &[
        changes("--lat-deg", &["--port", "{board}", "site", "--lat-deg", "45"], &["--port", "{board}", "site", "--lat-deg", "30"], &[]),
        changes("--height-m", &["--port", "{board}", "site", "--lat-deg", "30", "--height-m", "100"], &["--port", "{board}", "site", "--lat-deg", "30"], &[]),
    ],
};

#[rustfmt::skip]
const COMMAND_BASE: Walk = Walk {
    cmd: &["command", "base"],
    cases: &[
        changes("--roll-deg", &["--port", "{board}", "base", "--roll-deg", "1"], &["--port", "{board}", "base"], &[]),
        changes("--pitch-deg", &["--port", "{board}", "base", "--pitch-deg", "1"], &["--port", "{board}", "base"], &[]),
        changes("--heading-deg", &["--port", "{board}", "base", "--heading-deg", "90"], &["--port", "{board}", "base"], &[]),
    ],
};

#[rustfmt::skip]
const COMMAND_AIDED: Walk = Walk {
    cmd: &["command", "aided"],
    cases: &[
        changes("--lon-deg", &["--port", "{board}", "aided", "off", "--lon-deg", "10"], &["--port", "{board}", "aided", "off"], &[]),
    ],
};

#[rustfmt::skip]
const COMMAND_START: Walk = Walk {
    cmd: &["command", "start"],
    cases: &[elsewhere("--threads", "cli_walk.rs", "command")],
};

#[rustfmt::skip]
const COMMAND_STOP: Walk = Walk {
    cmd: &["command", "stop"],
    cases: &[elsewhere("--threads", "cli_walk.rs", "command")],
};

#[rustfmt::skip]
const COMMAND_RECALIBRATE: Walk = Walk {
    cmd: &["command", "recalibrate"],
    cases: &[elsewhere("--threads", "cli_walk.rs", "command")],
};

#[rustfmt::skip]
const IMPORT: Walk = Walk {
    cmd: &["import"],
    cases: &[elsewhere("--threads", "cli_walk.rs", "import_csv")],
};

#[rustfmt::skip]
const TOP: Walk = Walk {
    cmd: &[],
    cases: &[elsewhere("--threads", "cli_walk.rs", "diagnose")],
};

#[rustfmt::skip]
const WALKS: &[&Walk] = &[
    &TOP, &CALIBRATE, &DIAGNOSE, &NAVIGATE, &SIMULATE, &ALLAN, &IMPORT, &IMPORT_CSV,
    &IMPORT_RTKLIB, &IMPORT_KF_GINS, &IMPORT_COMMA, &STUDY, &OUTAGES, &REPRODUCE, &RESULTS, &MERGE, &DEMO,
    &QEMU_REPLAY, &RECORD, &COMMAND, &COMMAND_SCHEME, &COMMAND_SITE, &COMMAND_BASE,
    &COMMAND_AIDED, &COMMAND_START, &COMMAND_STOP, &COMMAND_RECALIBRATE,
];

/// The shared fixtures, made once per test binary.
fn fixtures() -> &'static Path {
    static FIX: OnceLock<PathBuf> = OnceLock::new();
    FIX.get_or_init(make_fixtures)
}

fn ok(args: &[&str]) {
    common::ok(&rins(args));
}

fn make_fixtures() -> PathBuf {
    let d = common::tmp("walk-fixtures");
    std::fs::create_dir_all(&d).unwrap();
    let p = |n: &str| s(&d.join(n));
    ok(&[
        "simulate",
        "--static-s",
        "60",
        "--duration-s",
        "200",
        "--seed",
        "3",
        "--out",
        &p("rec"),
    ]);
    ok(&[
        "simulate",
        "--scheme",
        "still",
        "--static-s",
        "300",
        "--duration-s",
        "300",
        "--seed",
        "4",
        "--out",
        &p("still"),
    ]);
    ok(&[
        "simulate",
        "--drive",
        "city",
        "--duration-s",
        "150",
        "--seed",
        "5",
        "--out",
        &p("drive"),
    ]);
    ok(&["calibrate", &p("rec"), "--json", &p("cal.json")]);
    common::copy_recording(&d.join("rec"), &d.join("spike"));
    spike(&d.join("spike/imu.csv"), 8000);
    common::copy_recording(&d.join("rec"), &d.join("nosigma"));
    let meta = std::fs::read_to_string(d.join("nosigma/meta.toml")).unwrap();
    let meta: String = meta
        .lines()
        .filter(|l| !l.contains("_sigma_deg"))
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(d.join("nosigma/meta.toml"), meta).unwrap();
    std::fs::write(d.join("model.toml"), "earth_rate = false\n").unwrap();
    std::fs::write(
        d.join("columns.toml"),
        "format = \"rins-columns/1\"\nheader = true\ndelimiter = \",\"\nrate_hz = 100.0\n\
         [columns]\ntime = \"t_s\"\ngyro = [\"gyro_x_radps\", \"gyro_y_radps\", \"gyro_z_radps\"]\n\
         accel = [\"accel_x_mps2\", \"accel_y_mps2\", \"accel_z_mps2\"]\n\
         [units]\ntime = \"s\"\ngyro = \"radps\"\naccel = \"mps2\"\n[time]\nsource = \"log\"\n",
    )
    .unwrap();
    kf_gins(&d.join("kf"));
    let walk = rins_tests::data::walk_import_args(&d.join("walkrec"));
    ok(&walk.iter().map(String::as_str).collect::<Vec<_>>());
    capture(&d);
    for (k, name) in [(0, "rep0.json"), (1, "rep1.json")] {
        ok(&[
            "reproduce",
            "--sensor",
            "nav440",
            "--runs",
            "2",
            "--shard",
            &format!("{k}/2"),
            "--json",
            &p(name),
        ]);
    }
    for (k, name) in [(0, "out0.json"), (1, "out1.json")] {
        ok(&[
            "outages",
            "--sensor",
            "nav440",
            "--drives",
            "2",
            "--shard",
            &format!("{k}/2"),
            "--json",
            &p(name),
        ]);
    }
    d
}

/// Sets gyro x of data row `row` of an imu.csv to 10 rad/s: a lone
/// reading no sensor gives between its neighbours.
fn spike(csv: &Path, row: usize) {
    let text = std::fs::read_to_string(csv).unwrap();
    let out: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i != row + 1 {
                return l.to_string();
            }
            let mut f: Vec<&str> = l.split(',').collect();
            f[1] = "10.0";
            f.join(",")
        })
        .collect();
    std::fs::write(csv, out.join("\n") + "\n").unwrap();
}

/// KF-GINS files of a still IMU (front-right-down, 200 Hz, 20 s) with
/// 1 Hz fixes and a reference.
fn kf_gins(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let (sow0, dt, g) = (100_000.0, 0.005, 9.7936);
    let mut imu = String::new();
    for k in 1..=4000 {
        let t = sow0 + k as f64 * dt;
        imu += &format!("{t:.3} 1e-7 -2e-7 3e-7 1e-5 -1e-5 {:.8}\n", -g * dt);
    }
    let (mut gnss, mut truth) = (String::new(), String::new());
    for k in 0..=20 {
        let t = sow0 + k as f64;
        gnss += &format!("{t:.3} 30.5 114.3 20.0 0.5 0.5 1.0\n");
        truth += &format!("2200 {t:.3} 30.5 114.3 20.0 0 0 0 0.1 -0.2 45.0\n");
    }
    std::fs::write(dir.join("imu.txt"), imu).unwrap();
    std::fs::write(dir.join("gnss.txt"), gnss).unwrap();
    std::fs::write(dir.join("truth.txt"), truth).unwrap();
}

/// `capture.bin`: the telemetry the board's program sends on the host as
/// it runs a replay of a short simulated run (`rins qemu-replay`), the
/// bytes `rins record` reads from a port.
fn capture(d: &Path) {
    let p = |n: &str| s(&d.join(n));
    ok(&[
        "simulate",
        "--static-s",
        "10",
        "--duration-s",
        "30",
        "--seed",
        "6",
        "--out",
        &p("short"),
    ]);
    ok(&["qemu-replay", &p("short"), &p("replay.bin")]);
    let bytes = std::fs::read(d.join("replay.bin")).unwrap();
    let r = rins_tests::twin::run(&bytes, rins_tests::twin::TwinOptions::default());
    std::fs::write(d.join("capture.bin"), &r.board.sent).unwrap();
}

/// The importers' arguments one case shares with the next ({csv},
/// {rtk}, {kf}: a whole import into `{out}/r`), or `a` itself.
fn base_args<'a>(a: &'a &'a str) -> Vec<&'a str> {
    match *a {
        "{csv}" => vec![
            "--imu-file",
            "{still}/imu.csv",
            "--columns",
            "{fix}/columns.toml",
            "--sensor",
            "icm42688",
            "--lat-deg",
            "30",
            "--out",
            "{out}/r",
        ],
        "{rtk}" => vec![
            "--pos",
            "{walk}/gnss_1730_sf.pos",
            "--imu-file",
            "{walk}/imu_1730.csv",
            "--columns",
            "{walk}/columns.toml",
            "--sensor",
            "{walk}/sensor.toml",
            "--out",
            "{out}/r",
        ],
        "{kf}" => vec![
            "--imu-file",
            "{fix}/kf/imu.txt",
            "--gnss",
            "{fix}/kf/gnss.txt",
            "--sensor",
            "icm42688",
            "--out",
            "{out}/r",
        ],
        a => vec![a],
    }
}

/// Fills in the placeholders; `{board}` starts a board on a new socket.
fn expand(args: &[&str], out: &Path, boards: &mut Vec<Board>) -> Option<Vec<String>> {
    let fix = fixtures();
    let walk = rins_tests::data::bundled("gnss_imu_walk_0827");
    if args.contains(&"--real-noise") {
        adis()?;
    }
    let mut v = vec![];
    for a in args.iter().flat_map(|a| base_args(a)) {
        let mut a = a
            .replace("{rec}", "{fix}/rec")
            .replace("{spike}", "{fix}/spike")
            .replace("{nosigma}", "{fix}/nosigma")
            .replace("{still}", "{fix}/still")
            .replace("{drive}", "{fix}/drive")
            .replace("{fix}", &s(fix))
            .replace("{walk}", &s(&walk))
            .replace(
                "{comma}",
                &s(&rins_tests::data::bundled("comma2k19_rav4_highway_60s")),
            )
            .replace("{out}", &s(out));
        if a.contains("{adis}") {
            a = a.replace("{adis}", &s(&adis()?));
        }
        if a.contains("{board}") {
            let b = Board::start(out, boards.len());
            a = a.replace("{board}", &format!("unix:{}", s(&b.path)));
            boards.push(b);
        }
        v.push(a);
    }
    Some(v)
}

/// The real ADIS16405 bench file, when the shared data is here.
fn adis() -> Option<PathBuf> {
    rins_tests::data::external(
        "cli_walk::study",
        "adis16405_static",
        "adis_16405_imu1_f32le_1000000x6.bin",
    )
}

/// A board's program on the host behind a socket, for one connection.
struct Board {
    path: PathBuf,
    thread: Option<std::thread::JoinHandle<rins_tests::board::HostBoard>>,
}

impl Board {
    fn start(out: &Path, k: usize) -> Self {
        std::fs::create_dir_all(out).unwrap();
        let path = out.join(format!("board{k}.sock"));
        let replay = std::fs::read(fixtures().join("replay.bin")).unwrap();
        let thread = rins_tests::twin::serve_unix(&path, replay);
        Self {
            path,
            thread: Some(thread),
        }
    }
}

impl Drop for Board {
    fn drop(&mut self) {
        // A board whose command was refused before connecting is waiting
        // in accept: connect and close to end it.
        let _ = std::os::unix::net::UnixStream::connect(&self.path);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A run's result: its exit, stdout and the named files, with the run's
/// own directories written as placeholders.
fn result(
    cmd: &[&str],
    args: &[&str],
    files: &[&str],
    out: &Path,
) -> Option<(bool, String, String)> {
    let _ = std::fs::remove_dir_all(out);
    std::fs::create_dir_all(out).unwrap();
    let mut boards = vec![];
    let a = expand(args, out, &mut boards)?;
    let mut full: Vec<&str> = cmd.to_vec();
    full.extend(a.iter().map(String::as_str));
    // The shared data where the tests find it (a command's own default,
    // ../shared/data, is relative to where it runs).
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(&full)
        .env("RUST_BACKTRACE", "0")
        .env("RINS_DATA", rins_tests::data::root())
        .output()
        .unwrap();
    drop(boards);
    let norm = |t: &str| t.replace(&s(out), "{out}").replace(&s(fixtures()), "{fix}");
    let mut text = norm(&String::from_utf8_lossy(&o.stdout));
    for f in files {
        let p = out.join(f.trim_start_matches("{out}/"));
        text += &format!("== {f}\n");
        text +=
            &std::fs::read(&p).map_or("(missing)".into(), |b| norm(&String::from_utf8_lossy(&b)));
    }
    Some((
        o.status.success(),
        text,
        String::from_utf8_lossy(&o.stderr).into_owned(),
    ))
}

/// A run's exit status, its result (stdout and the files, placeholders
/// put back) and its stderr.
type Outcome = (bool, String, String);

/// Runs one walk's cases; the first comparison's `against` is also run
/// twice to show the command's result is deterministic (else "changes"
/// would be noise). Runs of the same arguments are made once.
fn walk(w: &Walk) {
    let name = if w.cmd.is_empty() {
        "top".to_string()
    } else {
        w.cmd.join("-")
    };
    let scratch = common::tmp(&format!("walk-{name}"));
    // `command`'s own options come before its subcommand: the cases spell
    // the subcommand out.
    let exec: &[&str] = if w.cmd.first() == Some(&"command") {
        &["command"]
    } else {
        w.cmd
    };
    let mut cache: HashMap<String, Option<(Outcome, PathBuf)>> = HashMap::new();
    let mut n = 0;
    let mut run = |args: &[&str], files: &[&str], fresh: bool| {
        let key = format!("{args:?} {files:?}");
        if let (false, Some(r)) = (fresh, cache.get(&key)) {
            return r.clone();
        }
        n += 1;
        let out = scratch.join(n.to_string());
        let r = result(exec, args, files, &out).map(|o| (o, out));
        if let Some(((_, text, _), out)) = &r {
            let mut seen = unmeasured(text);
            for f in written_toml(out) {
                seen.extend(unmeasured(&f));
            }
            assert!(
                seen.is_empty(),
                "rins {} {args:?}: a figure not measured printed as a number:\n{}",
                w.cmd.join(" "),
                seen.join("\n")
            );
        }
        cache.insert(key, r.clone());
        r
    };
    let mut determinism_shown = false;
    for c in w.cases {
        let what = format!("rins {} {}: {:?}", w.cmd.join(" "), c.option, c.args);
        match c.expect {
            Expect::Changes(files) | Expect::Same(files) => {
                let (Some((a, _)), Some((b, _))) =
                    (run(c.args, files, false), run(c.against, files, false))
                else {
                    continue;
                };
                assert!(a.0 && b.0, "{what}: failed\n{}\n{}", a.2, b.2);
                if matches!(c.expect, Expect::Same(_)) {
                    assert!(a.1 == b.1, "{what}: documented as not changing the result");
                    continue;
                }
                assert!(a.1 != b.1, "{what}: the option changed nothing");
                if !determinism_shown {
                    let again = run(c.against, files, true).unwrap_or_default().0;
                    assert!(b.1 == again.1, "{what}: the same run twice differs");
                    // `rins --threads N`, every command's: documented as
                    // bit-identical whatever N.
                    let one: Vec<&str> = ["--threads", "1"].iter().chain(exec).copied().collect();
                    let t = result(&one, c.against, files, &scratch.join("threads"));
                    let t = t.unwrap_or_default().1;
                    assert!(
                        b.1 == t,
                        "rins --threads 1 {}: not the default's result",
                        w.cmd.join(" ")
                    );
                    determinism_shown = true;
                }
            }
            Expect::Elsewhere(..) => {}
            _ => {
                if let Some((r, out)) = run(c.args, &[], false) {
                    single(c.expect, &what, &r, &out);
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
}

/// The lines of `text` that print a figure not measured as a number: a
/// NaN or inf, a zero in exponent form (`0.0000e0`: a term left out), a
/// time of "0 s" a correlation was fitted over, a rate rounded to "(0
/// deg/s)". Unknown is said in words.
fn unmeasured(text: &str) -> Vec<String> {
    let word = |l: &str, w: &str| {
        l.match_indices(w).any(|(i, _)| {
            let before = l[..i].chars().next_back();
            let after = l[i + w.len()..].chars().next();
            !before.is_some_and(char::is_alphanumeric) && !after.is_some_and(char::is_alphanumeric)
        })
    };
    text.lines()
        .filter(|l| {
            word(l, "NaN")
                || word(l, "inf")
                || word(l, "-inf")
                || l.contains("0.0000e0")
                || l.contains(" 0e0")
                || l.contains("over 0 s")
                || l.contains("(0 deg/s)")
        })
        .map(|l| l.chars().take(200).collect())
        .collect()
}

/// The text of the `.toml` files a run wrote under `out` (sensor files:
/// their comments say what was measured).
fn written_toml(out: &Path) -> Vec<String> {
    let mut found = vec![];
    let mut dirs = vec![out.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "toml") {
                found.extend(std::fs::read_to_string(&p).ok());
            }
        }
    }
    found
}

#[test]
fn the_scan_for_unmeasured_figures_finds_what_the_issue_found() {
    // The lines a new user found (issue 46), and their honest forms.
    for bad in [
        "# gyro_x_radps: white 8.5e-5, bias instability B 1.2e-5, rrw 0.0000e0 (SI)",
        "level meta.toml's (+- 0.1 deg stated, the alignment's +- NaN)",
        "white 84.9 ug/sqrt(Hz), Gauss-Markov 25.15 ug over 0 s",
        "imu.csv data row 3 (t = 0.02 s): gyro_x_radps = 0.0000628 rad/s (0 deg/s), stuck",
        "heading inf deg",
    ] {
        assert_eq!(unmeasured(bad).len(), 1, "{bad}");
    }
    for good in [
        "rrw not measured, information: infinite span, NaNo",
        "Gauss-Markov 25.15 ug over 0.4 s; rate 6.28e-5 deg/s (0.0036 deg/s)",
    ] {
        assert!(unmeasured(good).is_empty(), "{good}");
    }
}

/// Checks one run against a refusal, a file written or words printed
/// (`out`: the run's directory).
fn single(expect: Expect, what: &str, (ok, text, err): &Outcome, out: &Path) {
    match expect {
        Expect::Refused(words) => {
            assert!(!ok, "{what}: not refused");
            for wd in words {
                assert!(err.contains(wd), "{what}: {wd:?} not in the refusal: {err}");
            }
        }
        Expect::Writes(file, words) => {
            assert!(ok, "{what}: failed: {err}");
            let p = out.join(file);
            assert!(p.exists(), "{what}: {file} not written");
            if p.is_dir() {
                assert!(
                    std::fs::read_dir(&p).unwrap().count() > 0,
                    "{what}: {file} empty"
                );
            }
            if !words.is_empty() {
                let text = std::fs::read_to_string(&p).unwrap();
                for wd in words {
                    assert!(text.contains(wd), "{what}: {wd:?} not in {file}");
                }
            }
        }
        Expect::Prints(words) => {
            assert!(ok, "{what}: failed: {err}");
            for wd in words {
                assert!(text.contains(wd), "{what}: {wd:?} not in: {text}");
            }
        }
        _ => unreachable!("{what}: compared, not a single run"),
    }
}

#[test]
fn every_option_of_every_command_is_walked() {
    let tests = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests");
    let mut missing = vec![];
    let helps = every_help();
    for (path, text) in &helps {
        let w = WALKS
            .iter()
            .find(|w| w.cmd.iter().map(|x| x.to_string()).eq(path.iter().cloned()));
        for opt in options(text) {
            // `--threads` is checked with every command's first comparison.
            let covered = |w: &Walk| {
                w.cases.iter().any(|c| c.option == opt)
                    || (opt == "--threads"
                        && w.cases
                            .iter()
                            .any(|c| matches!(c.expect, Expect::Changes(_))))
            };
            if !w.is_some_and(|w| covered(w)) {
                missing.push(format!("rins {} {opt}", path.join(" ")));
            }
        }
    }
    assert!(missing.is_empty(), "options no walk covers: {missing:#?}");
    for w in WALKS {
        let (_, text) = helps
            .iter()
            .find(|(p, _)| w.cmd.iter().map(|x| x.to_string()).eq(p.iter().cloned()))
            .unwrap_or_else(|| panic!("rins {}: no such command", w.cmd.join(" ")));
        let opts = options(text);
        for c in w.cases {
            assert!(
                opts.iter().any(|o| o == c.option),
                "rins {} has no {}",
                w.cmd.join(" "),
                c.option
            );
            if let Expect::Elsewhere(file, test) = c.expect {
                let src = std::fs::read_to_string(tests.join(file)).unwrap();
                assert!(
                    src.contains(&format!("fn {test}(")),
                    "{file} has no test {test}"
                );
            }
        }
    }
}

#[test]
fn calibrate() {
    walk(&CALIBRATE);
}

#[test]
fn diagnose() {
    walk(&DIAGNOSE);
}

#[test]
fn navigate() {
    walk(&NAVIGATE);
}

#[test]
fn simulate() {
    walk(&SIMULATE);
}

#[test]
fn allan() {
    walk(&ALLAN);
}

#[test]
fn import_csv() {
    walk(&IMPORT_CSV);
}

#[test]
fn import_rtklib() {
    walk(&IMPORT_RTKLIB);
}

#[test]
fn import_kf_gins() {
    walk(&IMPORT_KF_GINS);
}

#[test]
fn import_comma2k19() {
    walk(&IMPORT_COMMA);
}

#[test]
fn study() {
    walk(&STUDY);
}

#[test]
fn outages() {
    walk(&OUTAGES);
}

#[test]
fn reproduce() {
    walk(&REPRODUCE);
}

#[test]
fn results() {
    walk(&RESULTS);
}

#[test]
fn merge() {
    walk(&MERGE);
}

#[test]
fn demo() {
    walk(&DEMO);
}

#[test]
fn qemu_replay() {
    walk(&QEMU_REPLAY);
}

#[test]
fn record() {
    walk(&RECORD);
}

#[test]
fn command() {
    for w in [
        &COMMAND,
        &COMMAND_SCHEME,
        &COMMAND_SITE,
        &COMMAND_BASE,
        &COMMAND_AIDED,
        &COMMAND_START,
        &COMMAND_STOP,
        &COMMAND_RECALIBRATE,
    ] {
        walk(w);
    }
}

#[test]
fn results_only_writes_the_tables_it_names() {
    let out = common::tmp("walk-results-only");
    common::ok(&rins(&[
        "results",
        "--small",
        "--only",
        "reproduce",
        "--out",
        &s(&out),
    ]));
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["reproduce-mtig.md", "reproduce-nav440.md"]);
    let _ = std::fs::remove_dir_all(&out);
}

/// `record --port --like`: the board is configured like the recording
/// (each command acknowledged) before it records.
#[test]
fn record_like_configures_the_board_it_records() {
    let out = common::tmp("walk-record-like");
    let b = Board::start(&out, 0);
    let rec = s(&fixtures().join("rec"));
    let port = format!("unix:{}", s(&b.path));
    let o = rins(&[
        "record",
        "--port",
        &port,
        "--like",
        &rec,
        "--duration-s",
        "1",
        "--out",
        &s(&out.join("r")),
    ]);
    drop(b);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("configured the board like"),
        "{text}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let _ = std::fs::remove_dir_all(&out);
}
