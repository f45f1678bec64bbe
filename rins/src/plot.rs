//! A small SVG plotter: line and point series on linear or log axes, with
//! optional error bars, a title, axis labels and a legend. No fonts are
//! needed (text stays text in the SVG), so it works on any machine.

use std::path::Path;

/// One series.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Optional (low, high) per point, drawn as error bars.
    pub bars: Option<Vec<(f64, f64)>>,
    /// Draw markers instead of a line.
    pub markers: bool,
    /// Dashed line.
    pub dashed: bool,
}

impl Series {
    /// A line.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            bars: None,
            markers: false,
            dashed: false,
        }
    }
}

/// A chart.
#[derive(Clone, Debug, Default)]
pub struct Chart {
    /// Title.
    pub title: String,
    /// x label.
    pub x_label: String,
    /// y label.
    pub y_label: String,
    /// Log x axis.
    pub log_x: bool,
    /// Log y axis.
    pub log_y: bool,
    /// Series.
    pub series: Vec<Series>,
}

const COLORS: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
];
const W: f64 = 780.0;
const H: f64 = 440.0;
const L: f64 = 80.0;
const R: f64 = 230.0;
const T: f64 = 40.0;
const B: f64 = 60.0;

fn nice_ticks(lo: f64, hi: f64, log: bool) -> Vec<f64> {
    if log {
        let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        return (a..=b)
            .map(|e| 10f64.powi(e))
            .filter(|v| *v >= lo * 0.999 && *v <= hi * 1.001)
            .collect();
    }
    let span = (hi - lo).max(1e-300);
    let raw = span / 6.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 7.0)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() * step;
    (0..20)
        .map(|k| first + k as f64 * step)
        .take_while(|v| *v <= hi + step * 1e-9)
        .collect()
}

fn fmt_tick(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

impl Chart {
    /// The SVG text.
    pub fn svg(&self) -> String {
        let mut xs = vec![];
        let mut ys = vec![];
        for s in &self.series {
            for (i, (x, y)) in s.points.iter().enumerate() {
                if x.is_finite()
                    && y.is_finite()
                    && (!self.log_x || *x > 0.0)
                    && (!self.log_y || *y > 0.0)
                {
                    xs.push(*x);
                    ys.push(*y);
                    if let Some((lo, hi)) = s.bars.as_ref().and_then(|b| b.get(i)) {
                        if !self.log_y || *lo > 0.0 {
                            ys.push(*lo);
                        }
                        ys.push(*hi);
                    }
                }
            }
        }
        let range = |v: &[f64], log: bool| {
            let (mut lo, mut hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(*x), b.max(*x))
                });
            if !lo.is_finite() {
                return (if log { 0.1 } else { 0.0 }, 1.0);
            }
            if log {
                (
                    10f64.powf(lo.log10().floor()),
                    10f64.powf(hi.log10().ceil()),
                )
            } else {
                if lo == hi {
                    lo -= 1.0;
                    hi += 1.0;
                }
                let pad = (hi - lo) * 0.05;
                (lo - pad, hi + pad)
            }
        };
        let (x0, x1) = range(&xs, self.log_x);
        let (y0, y1) = range(&ys, self.log_y);
        let tx = |x: f64| {
            let f = if self.log_x {
                (x.log10() - x0.log10()) / (x1.log10() - x0.log10())
            } else {
                (x - x0) / (x1 - x0)
            };
            L + f * (W - L - R)
        };
        let ty = |y: f64| {
            let f = if self.log_y {
                (y.log10() - y0.log10()) / (y1.log10() - y0.log10())
            } else {
                (y - y0) / (y1 - y0)
            };
            H - B - f * (H - T - B)
        };
        let mut o = String::new();
        o.push_str(&format!(r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{H}" font-family="sans-serif" font-size="12">"#));
        o.push_str(&format!(r#"<rect width="{W}" height="{H}" fill="white"/>"#));
        o.push_str(&format!(
            r#"<text x="{}" y="22" text-anchor="middle" font-size="15">{}</text>"#,
            (W - R + L) / 2.0,
            esc(&self.title)
        ));
        for v in nice_ticks(x0, x1, self.log_x) {
            let x = tx(v);
            o.push_str(&format!(
                r##"<line x1="{x:.1}" y1="{T}" x2="{x:.1}" y2="{}" stroke="#e5e5e5"/>"##,
                H - B
            ));
            o.push_str(&format!(
                r#"<text x="{x:.1}" y="{}" text-anchor="middle">{}</text>"#,
                H - B + 16.0,
                fmt_tick(v)
            ));
        }
        for v in nice_ticks(y0, y1, self.log_y) {
            let y = ty(v);
            o.push_str(&format!(
                r##"<line x1="{L}" y1="{y:.1}" x2="{}" y2="{y:.1}" stroke="#e5e5e5"/>"##,
                W - R
            ));
            o.push_str(&format!(
                r#"<text x="{}" y="{:.1}" text-anchor="end">{}</text>"#,
                L - 6.0,
                y + 4.0,
                fmt_tick(v)
            ));
        }
        o.push_str(&format!(
            r#"<rect x="{L}" y="{T}" width="{}" height="{}" fill="none" stroke="black"/>"#,
            W - L - R,
            H - T - B
        ));
        o.push_str(&format!(
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            (W - R + L) / 2.0,
            H - 18.0,
            esc(&self.x_label)
        ));
        o.push_str(&format!(
            r#"<text transform="translate(18,{}) rotate(-90)" text-anchor="middle">{}</text>"#,
            (H - B + T) / 2.0,
            esc(&self.y_label)
        ));
        for (k, s) in self.series.iter().enumerate() {
            let c = COLORS[k % COLORS.len()];
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .filter(|(x, y)| {
                    x.is_finite()
                        && y.is_finite()
                        && (!self.log_x || *x > 0.0)
                        && (!self.log_y || *y > 0.0)
                })
                .map(|(x, y)| (tx(*x), ty(*y)))
                .collect();
            if s.markers {
                for (x, y) in &pts {
                    o.push_str(&format!(
                        r#"<circle cx="{x:.1}" cy="{y:.1}" r="3" fill="{c}"/>"#
                    ));
                }
            } else if !pts.is_empty() {
                let d: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
                let dash = if s.dashed {
                    r#" stroke-dasharray="6,4""#
                } else {
                    ""
                };
                o.push_str(&format!(
                    r#"<polyline fill="none" stroke="{c}" stroke-width="1.5"{dash} points="{}"/>"#,
                    d.join(" ")
                ));
            }
            if let Some(bars) = &s.bars {
                for ((x, _), (lo, hi)) in s.points.iter().zip(bars) {
                    if x.is_finite() && (!self.log_y || *lo > 0.0) {
                        o.push_str(&format!(r#"<line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{2:.1}" stroke="{c}"/>"#, tx(*x), ty(*lo), ty(*hi)));
                    }
                }
            }
            let ly = T + 14.0 + 18.0 * k as f64;
            o.push_str(&format!(
                r#"<line x1="{}" y1="{ly}" x2="{}" y2="{ly}" stroke="{c}" stroke-width="3"/>"#,
                W - R + 10.0,
                W - R + 30.0
            ));
            o.push_str(&format!(
                r#"<text x="{}" y="{}">{}</text>"#,
                W - R + 36.0,
                ly + 4.0,
                esc(&s.label)
            ));
        }
        o.push_str("</svg>\n");
        o
    }

    /// Writes the SVG to `path`.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        std::fs::write(path, self.svg())
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}
