//! The paper's experiment in simulation (reduced: 4 runs at 10, 50 and
//! 100 deg/s; `rins reproduce` runs the whole grid): the orderings the
//! paper reports and its NAV440 figures within a factor of two.

use hal_sim::imu::ImuSpec;
use rins::reproduce::{mode_mean, reproduce};

#[test]
fn nav440_reproduces_the_papers_figures_and_orderings() {
    let rows = reproduce(
        &ImuSpec::nav440(),
        4,
        11,
        &[10.0, 50.0, 100.0],
        rins::shard::Shard::ALL,
        &|_| {},
    )
    .unwrap();
    let m = |mode| mode_mean(&rows, mode).unwrap();
    let (conv, partial, full, best, floor) = (
        m("conventional"),
        m("rotary-partial"),
        m("rotary-full"),
        m("rotary-best"),
        m("noise-floor"),
    );
    println!("NAV440 mean RMS position [m]: conventional {:.0}, partial {:.0} (paper 544.8), full {:.0} (paper 213.8), best {:.0}, floor {:.0}", conv.0, partial.0, full.0, best.0, floor.0);
    // The paper's orderings: rotation beats the conventional INS; the
    // scale / installation calibration beats biases only. How much it
    // beats them depends on the draws of scale and misalignment: the
    // ratio of 12-run means was 1.25 to 2.6 over five seeds (the paper's
    // 2.5 at the top), so the ordering is asserted, with a 10 % margin.
    assert!(conv.0 > 2.0 * partial.0);
    assert!(
        partial.0 > 1.1 * full.0,
        "partial {} full {}",
        partial.0,
        full.0
    );
    // Its figures, within a factor of two (a simulation of datasheet
    // sensors against two real units).
    assert!(
        (0.5..2.0).contains(&(partial.0 / 544.8)),
        "partial {}",
        partial.0
    );
    assert!((0.5..2.0).contains(&(full.0 / 213.8)), "full {}", full.0);
    // Best is never worse than the paper's full calibration and stays near
    // the white-noise floor (issue goal 1.25x; 1.5x here for 12 runs a mode).
    assert!(best.0 <= 1.05 * full.0);
    assert!(best.0 / floor.0 < 1.5, "best {} floor {}", best.0, floor.0);
    // (Headings: the earth-aware calibration removes the earth rate's
    // 7.6 deg/h from the z bias, checked exactly in calibration.rs; here the
    // z warm-up drift of random sign dominates a 2-run heading RMS.)
}
