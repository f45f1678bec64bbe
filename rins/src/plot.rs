//! Charts: line and point series on linear or log axes, with optional
//! error bars, a title, axis labels and a legend, drawn by `plotters` into
//! SVG and PNG from the same description. Text is set in an embedded font
//! (DejaVu Sans, `assets/`), so PNGs render on a machine without fonts.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

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

/// Size of one chart, pixels.
const SIZE: (u32, u32) = (900, 480);

/// The embedded font, registered once as "sans-serif".
fn font() -> &'static str {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // A font that cannot be parsed would only lose the text of the
        // plots; the test `png_has_text` keeps this from happening unseen.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        );
    });
    "sans-serif"
}

/// A plotting failure, as text (plotters' errors borrow the backend).
#[derive(Debug)]
pub struct PlotError(pub String);

impl std::fmt::Display for PlotError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "plot: {}", self.0)
    }
}

impl std::error::Error for PlotError {}

fn err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError(e.to_string())
}

fn color(k: usize) -> RGBColor {
    const C: [(u8, u8, u8); 12] = [
        (0x1f, 0x77, 0xb4),
        (0xd6, 0x27, 0x28),
        (0x2c, 0xa0, 0x2c),
        (0xff, 0x7f, 0x0e),
        (0x94, 0x67, 0xbd),
        (0x8c, 0x56, 0x4b),
        (0xe3, 0x77, 0xc2),
        (0x7f, 0x7f, 0x7f),
        (0xbc, 0xbd, 0x22),
        (0x17, 0xbe, 0xcf),
        (0x00, 0x00, 0x00),
        (0xaa, 0x66, 0x00),
    ];
    let (r, g, b) = C[k % C.len()];
    RGBColor(r, g, b)
}

impl Chart {
    /// Is a point drawable on this chart's axes?
    fn ok(&self, x: f64, y: f64) -> bool {
        x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0) && (!self.log_y || y > 0.0)
    }

    /// The axis ranges: padded for linear axes, whole decades for log.
    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let (mut xs, mut ys) = (vec![], vec![]);
        for s in &self.series {
            for (i, (x, y)) in s.points.iter().enumerate() {
                if !self.ok(*x, *y) {
                    continue;
                }
                xs.push(*x);
                ys.push(*y);
                if let Some((lo, hi)) = s.bars.as_ref().and_then(|b| b.get(i)) {
                    for v in [*lo, *hi] {
                        if self.ok(*x, v) {
                            ys.push(v);
                        }
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
                return if log { (0.1, 1.0) } else { (0.0, 1.0) };
            }
            if log {
                let (a, b) = (lo.log10().floor(), hi.log10().ceil());
                (10f64.powf(a), 10f64.powf(if b > a { b } else { a + 1.0 }))
            } else {
                if lo == hi {
                    lo -= 1.0;
                    hi += 1.0;
                }
                let pad = (hi - lo) * 0.05;
                (lo - pad, hi + pad)
            }
        };
        (range(&xs, self.log_x), range(&ys, self.log_y))
    }

    /// Draws the chart on `area`.
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        area.fill(&WHITE).map_err(err)?;
        let ((x0, x1), (y0, y1)) = self.ranges();
        match (self.log_x, self.log_y) {
            (false, false) => self.draw_on(area, x0..x1, y0..y1),
            (true, false) => self.draw_on(area, (x0..x1).log_scale(), y0..y1),
            (false, true) => self.draw_on(area, x0..x1, (y0..y1).log_scale()),
            (true, true) => self.draw_on(area, (x0..x1).log_scale(), (y0..y1).log_scale()),
        }
    }

    fn draw_on<DB, X, Y>(
        &self,
        area: &DrawingArea<DB, Shift>,
        xr: X,
        yr: Y,
    ) -> Result<(), PlotError>
    where
        DB: DrawingBackend,
        X: AsRangedCoord<Value = f64>,
        Y: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
        Y::CoordDescType: ValueFormatter<f64>,
    {
        let f = font();
        let mut cc = ChartBuilder::on(area)
            .caption(&self.title, (f, 17))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(78)
            .build_cartesian_2d(xr, yr)
            .map_err(err)?;
        cc.configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .label_style((f, 12))
            .axis_desc_style((f, 13))
            .light_line_style(RGBColor(0xee, 0xee, 0xee))
            .draw()
            .map_err(err)?;
        for (k, s) in self.series.iter().enumerate() {
            let c = color(k);
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| self.ok(*x, *y))
                .collect();
            let style = c.stroke_width(2);
            let legend = move |(x, y): (i32, i32)| {
                PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(3))
            };
            if s.markers {
                // Dashed markers: hollow (e.g. "after" beside "before").
                let fill = if s.dashed {
                    c.stroke_width(1)
                } else {
                    c.filled()
                };
                cc.draw_series(pts.iter().map(|p| Circle::new(*p, 3, fill)))
                    .map_err(err)?
                    .label(s.label.as_str())
                    .legend(legend);
            } else if s.dashed {
                cc.draw_series(DashedLineSeries::new(pts, 6, 4, style))
                    .map_err(err)?
                    .label(s.label.as_str())
                    .legend(legend);
            } else {
                cc.draw_series(LineSeries::new(pts, style))
                    .map_err(err)?
                    .label(s.label.as_str())
                    .legend(legend);
            }
            if let Some(bars) = &s.bars {
                let bars: Vec<_> = s
                    .points
                    .iter()
                    .zip(bars)
                    .filter(|((x, y), (lo, hi))| {
                        self.ok(*x, *y) && self.ok(*x, *lo) && self.ok(*x, *hi)
                    })
                    .map(|((x, y), (lo, hi))| ErrorBar::new_vertical(*x, *lo, *y, *hi, c, 6))
                    .collect();
                cc.draw_series(bars).map_err(err)?;
            }
        }
        if self.series.iter().any(|s| !s.label.is_empty()) {
            cc.configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .label_font((f, 12))
                .draw()
                .map_err(err)?;
        }
        Ok(())
    }

    /// The chart as SVG text.
    ///
    /// # Errors
    /// A drawing failure.
    pub fn svg(&self) -> Result<String, PlotError> {
        Figure::one(self.clone()).svg()
    }

    /// Writes `<stem>.svg` and `<stem>.png`; returns both paths.
    ///
    /// # Errors
    /// A drawing failure or a file that cannot be written.
    pub fn write(&self, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
        Figure::one(self.clone()).write(stem)
    }
}

/// Charts stacked top to bottom in one picture.
#[derive(Clone, Debug, Default)]
pub struct Figure {
    /// The charts, top first.
    pub charts: Vec<Chart>,
}

impl Figure {
    /// A figure of one chart.
    pub fn one(chart: Chart) -> Self {
        Self {
            charts: vec![chart],
        }
    }

    fn size(&self) -> (u32, u32) {
        (SIZE.0, SIZE.1 * self.charts.len().max(1) as u32)
    }

    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        root.fill(&WHITE).map_err(err)?;
        let areas = root.split_evenly((self.charts.len().max(1), 1));
        for (c, a) in self.charts.iter().zip(&areas) {
            c.draw(a)?;
        }
        root.present().map_err(err)
    }

    /// The figure as SVG text.
    ///
    /// # Errors
    /// A drawing failure.
    pub fn svg(&self) -> Result<String, PlotError> {
        let mut s = String::new();
        self.draw(SVGBackend::with_string(&mut s, self.size()).into_drawing_area())?;
        Ok(s)
    }

    /// Writes the figure as PNG to `path`.
    ///
    /// # Errors
    /// A drawing failure or a file that cannot be written.
    pub fn png(&self, path: &Path) -> Result<(), PlotError> {
        self.draw(BitMapBackend::new(path, self.size()).into_drawing_area())
    }

    /// Writes `<stem>.svg` and `<stem>.png` (creating the directory);
    /// returns both paths.
    ///
    /// # Errors
    /// A drawing failure or a file that cannot be written.
    pub fn write(&self, stem: &Path) -> Result<Vec<PathBuf>, PlotError> {
        if let Some(d) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(d).map_err(|e| PlotError(format!("{}: {e}", d.display())))?;
        }
        let svg = stem.with_extension("svg");
        let png = stem.with_extension("png");
        std::fs::write(&svg, self.svg()?)
            .map_err(|e| PlotError(format!("{}: {e}", svg.display())))?;
        self.png(&png)?;
        Ok(vec![svg, png])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart() -> Chart {
        let mut s = Series::line(
            "a",
            (1..50)
                .map(|i| (f64::from(i), f64::from(i).sqrt()))
                .collect(),
        );
        s.bars = Some(s.points.iter().map(|(_, y)| (y * 0.9, y * 1.1)).collect());
        let mut d = Series::line("b", vec![(1.0, 2.0), (40.0, 0.5), (f64::NAN, 1.0)]);
        d.dashed = true;
        Chart {
            title: "test chart".into(),
            x_label: "x [s]".into(),
            y_label: "y [m]".into(),
            log_x: true,
            log_y: true,
            series: vec![s, d],
        }
    }

    #[test]
    fn svg_has_the_text_and_every_series() {
        let s = chart().svg().unwrap();
        assert!(s.starts_with("<svg"), "{}", &s[..40]);
        // plotters writes each text on its own line inside <text>.
        for t in ["test chart", "x [s]", "y [m]", "a", "b"] {
            assert!(s.lines().any(|l| l.trim() == t), "{t:?} missing");
        }
    }

    #[test]
    fn png_has_text() {
        // A title drawn in black on white: with the embedded font the
        // caption's band holds dark pixels; without it, it would be blank.
        let dir = std::env::temp_dir().join(format!("rins-plot-{}", std::process::id()));
        let files = chart().write(&dir.join("c")).unwrap();
        let png = &files[1];
        let img = std::fs::read(png).unwrap();
        assert_eq!(&img[1..4], b"PNG");
        let mut blank = Chart::default();
        blank.series.clear();
        let mut titled = blank.clone();
        titled.title = "WWWWWWWWWW".into();
        let (pb, pt) = (dir.join("blank.png"), dir.join("titled.png"));
        Figure::one(blank).png(&pb).unwrap();
        Figure::one(titled).png(&pt).unwrap();
        assert_ne!(std::fs::read(&pb).unwrap(), std::fs::read(&pt).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
