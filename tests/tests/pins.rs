//! The pin map against the board (issue 45): every pin the firmware uses
//! is on the Feather's header and carries its function by the datasheet,
//! no two signals share a pin or a timer, and `bsp/board.rs` sets up
//! exactly the pins and timers `firmware::pins` lists (so the book's pin
//! map and wiring diagram, drawn from that list, are the firmware's).

use firmware::pins::{label, ALTERNATE, FEATHER, TIMERS, UNCONNECTED, USED};
use std::collections::BTreeSet;

fn board_rs() -> String {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/src/bsp/board.rs");
    let text = std::fs::read_to_string(p).expect("firmware/src/bsp/board.rs");
    // The code only (comments name pins too), without whitespace.
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<String>()
        .split_whitespace()
        .collect()
}

/// The port pins `board.rs` takes from the HAL's GPIO split
/// (`gpioa.pa5` and the like).
fn pins_in(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices("gpio") {
        let b = code.as_bytes();
        let port = b.get(i + 4).copied();
        if !matches!(port, Some(b'a'..=b'i')) || b.get(i + 5) != Some(&b'.') {
            continue;
        }
        if b.get(i + 6) != Some(&b'p') || b.get(i + 7).copied() != port {
            continue;
        }
        let digits: String = code[i + 8..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        if !digits.is_empty() {
            let p = char::from(port.unwrap_or(b'a')).to_ascii_uppercase();
            out.insert(format!("P{p}{digits}"));
        }
    }
    out
}

/// The timers `board.rs` takes (`dp.TIMn`).
fn timers_in(code: &str) -> BTreeSet<String> {
    code.match_indices("dp.TIM")
        .map(|(i, _)| {
            let n: String = code[i + 6..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            format!("TIM{n}")
        })
        .collect()
}

#[test]
fn every_pin_the_firmware_uses_is_on_the_feathers_header() {
    for u in USED {
        let on = FEATHER.iter().find(|p| p.pin == u.pin);
        let on =
            on.unwrap_or_else(|| panic!("{} on {}: not on the Feather's header", u.signal, u.pin));
        assert!(on.lqfp > 0, "{}: {} is not an MCU pin", u.signal, on.label);
        assert!(!UNCONNECTED.contains(&u.pin));
        // Its function by the datasheet's table (a GPIO or EXTI needs none).
        if let Some(af) = u.af {
            assert!(
                ALTERNATE.contains(&(u.pin, af, u.function)),
                "{} on {}: AF{af} is not {}",
                u.signal,
                u.pin,
                u.function
            );
        }
    }
    // The motor's PWM was on PA8 (TIM1 CH1), on no net of the Feather.
    assert!(label("PA8").is_none() && UNCONNECTED.contains(&"PA8"));
    assert_eq!(label("PB8"), Some("D9"));
}

#[test]
fn no_two_signals_share_a_pin_or_a_timer() {
    let pins: BTreeSet<_> = USED.iter().map(|u| u.pin).collect();
    assert_eq!(pins.len(), USED.len(), "a pin used twice");
    let timers: BTreeSet<_> = TIMERS.iter().map(|t| t.0).collect();
    assert_eq!(timers.len(), TIMERS.len(), "a timer listed twice");
    // Every timer function of a used pin is on a timer listed for it, and
    // each timer's channels serve one listed use.
    for u in USED.iter().filter(|u| u.function.starts_with("TIM")) {
        let tim = u.function.split('_').next().unwrap_or("");
        assert!(timers.contains(tim), "{}: {tim} not listed", u.signal);
    }
    let pwm: Vec<_> = USED
        .iter()
        .filter(|u| u.function.starts_with("TIM10"))
        .collect();
    let enc: Vec<_> = USED
        .iter()
        .filter(|u| u.function.starts_with("TIM4"))
        .collect();
    assert_eq!((pwm.len(), enc.len()), (1, 2));
    // The direction pin is a GPIO: its timer channel (TIM8 CH1) is free.
    assert!(!timers.contains("TIM8") && !timers.contains("TIM1"));
}

#[test]
fn board_rs_sets_up_exactly_the_listed_pins_and_timers() {
    let code = board_rs();
    let want: BTreeSet<String> = USED.iter().map(|u| u.pin.to_string()).collect();
    assert_eq!(pins_in(&code), want);
    let want: BTreeSet<String> = TIMERS.iter().map(|t| t.0.to_string()).collect();
    assert_eq!(timers_in(&code), want);
    // The scan itself sees a pin split over lines and a timer.
    assert_eq!(
        pins_in("letcs=gpioa.pa4.into_push_pull_output();"),
        BTreeSet::from(["PA4".to_string()])
    );
}

#[test]
fn the_books_pin_map_and_wiring_are_drawn_from_the_list() {
    for (path, want) in rins_tests::hardware::generated() {
        let got =
            std::fs::read_to_string(rins_tests::hardware::root().join(path)).unwrap_or_default();
        assert!(
            got == want,
            "{path} is not what the pin list draws: run `cargo run -p rins-tests --bin hardware-docs` and commit it"
        );
    }
}
