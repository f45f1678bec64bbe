//! The Hardware chapter's generated parts: the Feather's pin map and the
//! wiring diagram, drawn from the firmware's pin list
//! (`firmware::pins`), and the table's section drawing, drawn from the
//! dimensions below. `cargo run -p rins-tests --bin hardware-docs` writes
//! them into `docs/src/generated/`; a test (`tests/tests/pins.rs`) fails
//! when the committed copies are not what these draw.

use firmware::pins::{FEATHER, TIMERS, USED};
use std::fmt::Write as _;
use std::path::PathBuf;

/// The repository's root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every generated file: its path from the root and its text.
pub fn generated() -> Vec<(&'static str, String)> {
    vec![
        ("docs/src/generated/feather-pins.md", pins_markdown()),
        ("docs/src/generated/wiring.svg", wiring_svg()),
        ("docs/src/generated/table-section.svg", table_svg()),
    ]
}

const STAMP: &str = "Drawn by `cargo run -p rins-tests --bin hardware-docs` from";

/// The pin map: every header pin, what the board connects it to, and what
/// the firmware puts on it.
pub fn pins_markdown() -> String {
    let mut s = format!(
        "*{STAMP} `firmware/src/pins.rs` (the Feather's schematic, Adafruit's Eagle files at commit f10cfb4). Do not edit by hand (a test checks it).*\n\n\
| header | MCU pin | LQFP64 | on the board | the firmware's use | function |\n| --- | --- | --- | --- | --- | --- |\n"
    );
    for p in FEATHER {
        let used = USED.iter().find(|u| u.pin == p.pin && p.lqfp > 0);
        let (sig, f) = used.map_or(("", String::new()), |u| {
            let af = u.af.map_or(String::new(), |a| format!(" (AF{a})"));
            (u.signal, format!("{}{af}", u.function))
        });
        let lqfp = if p.lqfp > 0 {
            p.lqfp.to_string()
        } else {
            String::new()
        };
        let _ = writeln!(
            s,
            "| {} | {} | {lqfp} | {} | {sig} | {f} |",
            p.label, p.pin, p.also
        );
    }
    s.push_str("\nTimers the firmware takes, each for one thing: ");
    let t: Vec<String> = TIMERS.iter().map(|(t, w)| format!("{t} ({w})")).collect();
    s.push_str(&t.join(", "));
    s.push_str(".\n");
    s
}

/// An SVG's text element.
fn text(x: f64, y: f64, anchor: &str, size: u32, t: &str) -> String {
    format!("<text x=\"{x}\" y=\"{y}\" text-anchor=\"{anchor}\" font-size=\"{size}\">{t}</text>\n")
}

fn rect(x: f64, y: f64, w: f64, h: f64, style: &str) -> String {
    format!("<rect x=\"{x}\" y=\"{y}\" width=\"{w}\" height=\"{h}\" {style}/>\n")
}

fn line(x1: f64, y1: f64, x2: f64, y2: f64, style: &str) -> String {
    format!("<line x1=\"{x1}\" y1=\"{y1}\" x2=\"{x2}\" y2=\"{y2}\" {style}/>\n")
}

/// The parts the signals go to, in the diagram's order: (name, the
/// prefixes of [`firmware::pins::Use::to`] it takes, on the table).
const PARTS: [(&str, &str, &str); 4] = [
    ("IMU breakout (ICM-42688-P)", "IMU", "VCC 3.3 V (3V), GND"),
    ("quadrature encoder", "encoder", "VCC 3.3 V (3V), GND"),
    (
        "motor driver (PWM + DIR)",
        "driver",
        "VM 12 V supply; OUT A/B to the motor",
    ),
    (
        "USB-UART (3.3 V)",
        "USB-UART",
        "GND (its VCC not connected)",
    ),
];

/// The wiring: each used pin of the Feather to its part, power and ground
/// besides, the slip ring's boundary around what turns.
pub fn wiring_svg() -> String {
    let row = 26.0;
    let (fx, fw) = (20.0, 210.0);
    let (px, pw) = (520.0, 240.0);
    let n = USED.len() as f64;
    let h = 170.0 + row * (n + 12.0);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"800\" height=\"{h}\" font-family=\"sans-serif\">\n<desc>{STAMP} firmware/src/pins.rs; do not edit.</desc>\n"
    );
    s += &rect(0.0, 0.0, 800.0, h, "fill=\"white\"");
    s += &text(390.0, 24.0, "middle", 16, "rins: the board's wiring");
    s += &rect(
        fx,
        50.0,
        fw,
        row * (n + 3.0),
        "fill=\"#eef\" stroke=\"black\"",
    );
    s += &text(
        fx + fw / 2.0,
        70.0,
        "middle",
        13,
        "Feather STM32F405 Express",
    );
    // The part boxes, stacked, each as tall as its signals.
    let mut y_part = 50.0;
    let mut pin_y = Vec::new();
    for (i, u) in USED.iter().enumerate() {
        let y = 95.0 + row * i as f64;
        let lab = firmware::pins::label(u.pin).unwrap_or("?");
        s += &text(
            fx + fw - 8.0,
            y + 4.0,
            "end",
            12,
            &format!("{lab} ({})", u.pin),
        );
        pin_y.push(y);
    }
    for (name, prefix, power) in PARTS {
        let mine: Vec<usize> = (0..USED.len())
            .filter(|&i| USED.get(i).is_some_and(|u| u.to.starts_with(prefix)))
            .collect();
        let bh = row * (mine.len() as f64 + 2.0);
        s += &rect(px, y_part, pw, bh, "fill=\"#efe\" stroke=\"black\"");
        s += &text(px + pw / 2.0, y_part + 18.0, "middle", 13, name);
        for (k, &i) in mine.iter().enumerate() {
            let (Some(u), Some(&y0)) = (USED.get(i), pin_y.get(i)) else {
                continue;
            };
            let y1 = y_part + 40.0 + row * k as f64;
            let pin = u.to.trim_start_matches(prefix).trim();
            s += &text(px + 8.0, y1 + 4.0, "start", 12, pin);
            s += &line(fx + fw, y0, px, y1, "stroke=\"#236\" stroke-width=\"1.5\"");
            let mid = (fx + fw + px) / 2.0;
            let ym = y0 + (y1 - y0) * (mid - fx - fw) / (px - fx - fw) - 3.0;
            s += &text(mid, ym, "middle", 10, u.signal);
        }
        let y1 = y_part + 40.0 + row * mine.len() as f64;
        s += &text(px + 8.0, y1 + 4.0, "start", 11, power);
        y_part += bh + 12.0;
    }
    // The slip ring: what crosses to the IMU on the table.
    let ring_x = (fx + fw + px) / 2.0 + 70.0;
    s += &line(
        ring_x,
        46.0,
        ring_x,
        50.0 + row * 6.0,
        "stroke=\"#a33\" stroke-dasharray=\"6 4\" stroke-width=\"2\"",
    );
    s += &text(
        ring_x,
        42.0,
        "middle",
        11,
        "slip ring (continuous rotation): 7 circuits",
    );
    let yb = y_part.max(50.0 + row * (n + 3.0)) + 24.0;
    let notes = [
        "Grounds joined: Feather GND, IMU, encoder, driver logic ground, USB-UART and the 12 V supply's negative.",
        "The encoder and the IMU take 3.3 V from the Feather's 3V pin; the driver's motor supply is the 12 V supply.",
        "The driver's PWM and DIR need pull-downs (10 kOhm) so the motor stays off while the MCU resets.",
        "Cross TX and RX: the Feather's TX (PB10) to the adapter's RX, its RX (PB11) to the adapter's TX.",
        "SWD probe: the Feather's SWDIO and SWCLK pads (or its 2x5 1.27 mm footprint), GND and 3V.",
    ];
    for (i, t) in notes.iter().enumerate() {
        s += &text(20.0, yb + 18.0 * i as f64, "start", 12, t);
    }
    s.push_str("</svg>\n");
    s
}

/// The table's dimensions, mm (the section drawing's source; the book's
/// bill of materials names the parts).
pub struct TableDims {
    /// The platter's diameter and thickness.
    pub platter: (f64, f64),
    /// The base plate's width and thickness.
    pub base: (f64, f64),
    /// The bearing's outer diameter and width (6805-2RS: 37 x 7).
    pub bearing: (f64, f64),
    /// The shaft's diameter (the bearing's bore: 25).
    pub shaft: f64,
    /// The motor's diameter and length.
    pub motor: (f64, f64),
    /// The slip ring's capsule diameter and length (on the bridge).
    pub slip_ring: (f64, f64),
    /// The bridge's height above the platter.
    pub bridge: f64,
}

/// The drawn table.
pub const TABLE: TableDims = TableDims {
    platter: (150.0, 8.0),
    base: (220.0, 10.0),
    bearing: (37.0, 7.0),
    shaft: 25.0,
    motor: (42.0, 60.0),
    slip_ring: (22.0, 20.0),
    bridge: 70.0,
};

/// The table in section through its axis: base plate, bearing, hub and
/// platter, the motor below on standoffs with the coupling, the encoder on
/// the motor's rear shaft, the slip ring above on a bridge, the IMU at the
/// axis, the cable's path.
pub fn table_svg() -> String {
    let d = &TABLE;
    let k = 2.0; // px per mm
    let cx = 300.0;
    let y_base = 300.0;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"860\" height=\"560\" font-family=\"sans-serif\">\n<desc>{STAMP} tests/src/hardware.rs (TABLE); do not edit.</desc>\n"
    );
    s += &rect(0.0, 0.0, 860.0, 560.0, "fill=\"white\"");
    s += &text(430.0, 24.0, "middle", 16, "rins: the table in section (mm)");
    let grey = "fill=\"#ddd\" stroke=\"black\"";
    // Base plate with the bearing's housing bore.
    let (bw, bt) = d.base;
    s += &rect(cx - bw / 2.0 * k, y_base, bw * k, bt * k, grey);
    // Bearing (in the plate's bore), shaft through it.
    let (bo, bwid) = d.bearing;
    s += &rect(
        cx - bo / 2.0 * k,
        y_base,
        bo * k,
        bwid * k,
        "fill=\"#9bd\" stroke=\"black\"",
    );
    let sh = d.shaft * k;
    s += &rect(
        cx - sh / 2.0,
        y_base - 30.0,
        sh,
        bt * k + 60.0,
        "fill=\"#bbb\" stroke=\"black\"",
    );
    // Platter on its hub.
    let (pd, pt) = d.platter;
    let y_pl = y_base - 30.0 - pt * k;
    s += &rect(cx - pd / 2.0 * k, y_pl, pd * k, pt * k, grey);
    // IMU at the axis on the platter.
    s += &rect(
        cx - 15.0,
        y_pl - 12.0,
        30.0,
        12.0,
        "fill=\"#6a6\" stroke=\"black\"",
    );
    // The bridge and the slip ring above.
    let y_br = y_pl - d.bridge * k;
    let span = pd / 2.0 * k + 30.0;
    s += &rect(cx - span, y_br, 2.0 * span, 8.0, grey);
    s += &rect(cx - span, y_br, 8.0, y_base - y_br, grey);
    s += &rect(cx + span - 8.0, y_br, 8.0, y_base - y_br, grey);
    let (rd, rl) = d.slip_ring;
    s += &rect(
        cx - rd / 2.0 * k,
        y_br + 8.0,
        rd * k,
        rl * k,
        "fill=\"#d96\" stroke=\"black\"",
    );
    // Cable: slip ring rotor down to the IMU; stator up to the Feather.
    s += &line(
        cx,
        y_br + 8.0 + rl * k,
        cx,
        y_pl - 12.0,
        "stroke=\"#a33\" stroke-width=\"2\" stroke-dasharray=\"4 3\"",
    );
    s += &line(
        cx,
        y_br + 8.0,
        cx,
        y_br - 30.0,
        "stroke=\"#a33\" stroke-width=\"2\" stroke-dasharray=\"4 3\"",
    );
    // Coupling, motor, encoder below.
    let y_c = y_base + bt * k + 30.0;
    s += &rect(cx - 14.0, y_c, 28.0, 30.0, "fill=\"#cc8\" stroke=\"black\"");
    let (md, ml) = d.motor;
    let y_m = y_c + 30.0;
    s += &rect(
        cx - md / 2.0 * k,
        y_m,
        md * k,
        ml * k / 2.0,
        "fill=\"#888\" stroke=\"black\"",
    );
    s += &rect(
        cx - 20.0,
        y_m + ml * k / 2.0,
        40.0,
        16.0,
        "fill=\"#c9c\" stroke=\"black\"",
    );
    // Standoffs from the base plate to the motor's flange.
    for x in [cx - md / 2.0 * k - 10.0, cx + md / 2.0 * k + 4.0] {
        s += &rect(x, y_base + bt * k, 6.0, y_m - y_base - bt * k, grey);
    }
    // Labels with leaders.
    let labels: [(f64, String); 10] = [
        (
            y_br - 34.0,
            "cable to the Feather (slip ring stator)".into(),
        ),
        (
            y_br + 20.0,
            format!("slip ring, {rd} mm capsule, rotor down"),
        ),
        (
            y_pl - 8.0,
            "IMU breakout on the axis (screwed, no foam)".into(),
        ),
        (y_pl + 6.0, format!("platter {pd} x {pt} mm, balanced")),
        (
            y_base + 6.0,
            format!("bearing 6805-2RS ({bo} x {bwid} mm) in the base plate"),
        ),
        (
            y_base + bt * k + 4.0,
            format!("base plate {bw} x {bt} mm, levelled, on feet"),
        ),
        (
            y_base - 20.0,
            format!("hub shaft {} mm, the platter's and the bearing's", d.shaft),
        ),
        (y_c + 16.0, "flexible beam coupling".into()),
        (y_m + 20.0, "motor on standoffs (direct drive)".into()),
        (
            y_m + ml * k / 2.0 + 10.0,
            "encoder on the motor's rear shaft".into(),
        ),
    ];
    for (y, t) in &labels {
        s += &line(
            cx + 40.0,
            *y,
            520.0,
            *y,
            "stroke=\"#555\" stroke-width=\"0.7\"",
        );
        s += &text(524.0, y + 4.0, "start", 11, t);
    }
    s += &text(
        430.0,
        545.0,
        "middle",
        11,
        "The bridge holds the slip ring's stator; its rotor and the platter turn together.",
    );
    s.push_str("</svg>\n");
    s
}
