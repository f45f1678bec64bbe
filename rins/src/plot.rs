//! Charts: line and point series on linear or log axes, with optional
//! error bars, a title, axis labels and a legend, drawn by `plotters` into
//! SVG and PNG from the same description. Text is set in an embedded font
//! (DejaVu Sans, `assets/`), so PNGs render on a machine without fonts.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// A line's dash pattern. Series that do not ask for one get one by their
/// place in the chart, so that no two series share both colour and dash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dash {
    /// Unbroken.
    Solid,
    /// Short dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Long dashes.
    LongDash,
}

impl Dash {
    const ALL: [Dash; 4] = [Dash::Solid, Dash::Dashed, Dash::Dotted, Dash::LongDash];

    /// (dash, gap) in pixels; `None` for a solid line.
    fn pattern(self) -> Option<(u32, u32)> {
        match self {
            Dash::Solid => None,
            Dash::Dashed => Some((7, 4)),
            Dash::Dotted => Some((2, 3)),
            Dash::LongDash => Some((16, 5)),
        }
    }
}

/// One series.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
    /// Optional (low, high) per point, drawn as error bars.
    pub bars: Option<Vec<(f64, f64)>>,
    /// Optional (low, high) per point, drawn as a shaded band (e.g. +-3
    /// sigma) under the line.
    pub band: Option<Vec<(f64, f64)>>,
    /// Draw markers instead of a line.
    pub markers: bool,
    /// Hollow markers (e.g. "after" beside filled "before").
    pub hollow: bool,
    /// The dash pattern; `None`: by the series' place in the chart.
    pub dash: Option<Dash>,
}

impl Series {
    /// A line.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            bars: None,
            band: None,
            markers: false,
            hollow: false,
            dash: None,
        }
    }

    /// Points drawn as markers.
    pub fn points(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            markers: true,
            ..Self::line(label, points)
        }
    }

    /// The same series with this dash pattern.
    #[must_use]
    pub fn with_dash(mut self, dash: Dash) -> Self {
        self.dash = Some(dash);
        self
    }
}

/// A chart.
#[derive(Clone, Debug, Default)]
pub struct Chart {
    /// Title.
    pub title: String,
    /// x label, with its unit in brackets.
    pub x_label: String,
    /// y label, with its unit in brackets.
    pub y_label: String,
    /// Log x axis.
    pub log_x: bool,
    /// Log y axis.
    pub log_y: bool,
    /// One unit is as long on both axes (a map).
    pub equal_scale: bool,
    /// The lowest value a log y axis shows (default: six decades below
    /// its highest); lower values run off the bottom of the plot.
    pub y_floor: Option<f64>,
    /// x intervals shaded from top to bottom (e.g. GNSS outages).
    pub shaded: Vec<(f64, f64)>,
    /// The legend's name for the shaded intervals.
    pub shaded_label: String,
    /// Series.
    pub series: Vec<Series>,
}

/// Size of one chart, pixels.
const SIZE: (u32, u32) = (960, 480);

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

/// The Okabe-Ito palette (colour-blind safe), without its yellow, which
/// does not show on white.
const PALETTE: [(u8, u8, u8); 7] = [
    (0x00, 0x72, 0xb2), // blue
    (0xd5, 0x5e, 0x00), // vermillion
    (0x00, 0x9e, 0x73), // bluish green
    (0xcc, 0x79, 0xa7), // reddish purple
    (0xe6, 0x9f, 0x00), // orange
    (0x56, 0xb4, 0xe9), // sky blue
    (0x00, 0x00, 0x00), // black
];

/// The colour and the default dash of the `k`-th series: the pair is
/// unique for the first 28 series (7 colours by 4 dashes, both cycling).
fn look(k: usize) -> (RGBColor, Dash) {
    let (r, g, b) = PALETTE[k % PALETTE.len()];
    (RGBColor(r, g, b), Dash::ALL[k % Dash::ALL.len()])
}

/// A tick label: the shortest text that keeps the value (no "-0", no
/// "50.0", no "0.30000000000000004"); powers of ten below 0.001 or from
/// 100,000 on as "1e-5".
pub fn tick(v: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    let a = v.abs();
    if a < 1e-12 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.4e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        return format!("{m}e{e}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

/// Characters on one line of the legend; a longer label wraps at spaces.
const LEGEND_CHARS: usize = 30;

/// A legend label in lines of at most [`LEGEND_CHARS`] (a longer word
/// keeps its own line).
fn wrap(label: &str) -> Vec<String> {
    let mut lines: Vec<String> = vec![];
    for w in label.split_whitespace() {
        match lines.last_mut() {
            Some(l) if l.chars().count() + 1 + w.chars().count() <= LEGEND_CHARS => {
                l.push(' ');
                l.push_str(w);
            }
            _ => lines.push(w.to_string()),
        }
    }
    lines
}

/// Width of the legend panel for these labels, pixels (none without).
fn legend_width(labels: &[&str]) -> u32 {
    let longest = labels
        .iter()
        .flat_map(|l| wrap(l))
        .map(|l| l.chars().count())
        .max()
        .unwrap_or(0);
    if longest == 0 {
        0
    } else {
        (longest as u32 * 15 / 2 + 56).max(110)
    }
}

impl Chart {
    /// An Allan deviation chart: log-log, tau in s against the deviation
    /// in `unit` (the book's units table: deg/h, ug).
    pub fn allan(title: String, unit: &str, series: Vec<Series>) -> Self {
        Self {
            title,
            x_label: "averaging time tau [s]".into(),
            y_label: format!("Allan deviation [{unit}]"),
            log_x: true,
            log_y: true,
            series,
            ..Self::default()
        }
    }

    /// Is a point drawable on this chart's axes?
    fn ok(&self, x: f64, y: f64) -> bool {
        x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0) && (!self.log_y || y > 0.0)
    }

    /// Every drawable (x, y) of the chart: points, bars, bands.
    fn extent(&self) -> (Vec<f64>, Vec<f64>) {
        let (mut xs, mut ys) = (vec![], vec![]);
        for s in &self.series {
            for (i, (x, y)) in s.points.iter().enumerate() {
                if !self.ok(*x, *y) {
                    continue;
                }
                xs.push(*x);
                ys.push(*y);
                let extra = [s.bars.as_ref(), s.band.as_ref()];
                for (lo, hi) in extra.into_iter().flatten().filter_map(|b| b.get(i)) {
                    ys.extend([*lo, *hi].into_iter().filter(|v| self.ok(*x, *v)));
                }
            }
        }
        (xs, ys)
    }

    /// The axis ranges: padded for linear axes, whole decades for log;
    /// widened to one scale on both axes for a map (`px`: the plotting
    /// area's width and height in pixels).
    fn ranges(&self, px: (u32, u32)) -> ((f64, f64), (f64, f64)) {
        let (xs, ys) = self.extent();
        let (mut xr, mut yr) = (range(&xs, self.log_x), range(&ys, self.log_y));
        if let Some(f) = self.y_floor.filter(|f| self.log_y && *f > 0.0 && *f < yr.1) {
            yr.0 = f;
        }
        if self.equal_scale && !self.log_x && !self.log_y {
            let (w, h) = (f64::from(px.0.max(1)), f64::from(px.1.max(1)));
            let per_px = ((xr.1 - xr.0) / w).max((yr.1 - yr.0) / h);
            let widen = |(lo, hi): (f64, f64), n: f64| {
                let (mid, half) = ((lo + hi) / 2.0, per_px * n / 2.0);
                (mid - half, mid + half)
            };
            xr = widen(xr, w);
            yr = widen(yr, h);
        }
        (xr, yr)
    }

    /// Draws the chart, its title and its legend on `area`.
    fn draw<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> Result<(), PlotError> {
        area.fill(&WHITE).map_err(err)?;
        let f = font();
        let body = area.titled(&self.title, (f, 17)).map_err(err)?;
        let mut labels: Vec<&str> = self.series.iter().map(|s| s.label.as_str()).collect();
        if !self.shaded.is_empty() {
            labels.push(self.shaded_label.as_str());
        }
        labels.retain(|l| !l.is_empty());
        let (w, h) = body.dim_in_pixel();
        let lw = legend_width(&labels).min(w / 2);
        let (plot, legend) = body.split_horizontally(w - lw);
        // The plotting area's pixels: the body less label areas and margins.
        let px = (
            (w - lw).saturating_sub(LABEL_Y + 2 * MARGIN),
            h.saturating_sub(LABEL_X + 2 * MARGIN),
        );
        let ((x0, x1), (y0, y1)) = self.ranges(px);
        match (self.log_x, self.log_y) {
            (false, false) => self.draw_on(&plot, x0..x1, y0..y1)?,
            (true, false) => self.draw_on(&plot, (x0..x1).log_scale(), y0..y1)?,
            (false, true) => self.draw_on(&plot, x0..x1, (y0..y1).log_scale())?,
            (true, true) => self.draw_on(&plot, (x0..x1).log_scale(), (y0..y1).log_scale())?,
        }
        self.draw_legend(&legend)
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
            .margin(MARGIN)
            .x_label_area_size(LABEL_X)
            .y_label_area_size(LABEL_Y)
            .build_cartesian_2d(xr, yr)
            .map_err(err)?;
        let fmt = |v: &f64| tick(*v);
        cc.configure_mesh()
            .x_desc(self.x_label.as_str())
            .y_desc(self.y_label.as_str())
            .x_label_formatter(&fmt)
            .y_label_formatter(&fmt)
            .label_style((f, 12))
            .axis_desc_style((f, 13))
            .max_light_lines(1)
            .light_line_style(RGBColor(0xf2, 0xf2, 0xf2))
            .bold_line_style(RGBColor(0xdd, 0xdd, 0xdd))
            .draw()
            .map_err(err)?;
        let (ylo, yhi) = {
            let r = cc.y_range();
            (r.start, r.end)
        };
        let shade = RGBColor(0x99, 0x99, 0x99).mix(0.22).filled();
        cc.draw_series(
            self.shaded
                .iter()
                .map(|(a, b)| Rectangle::new([(*a, ylo), (*b, yhi)], shade)),
        )
        .map_err(err)?;
        for (k, s) in self.series.iter().enumerate() {
            self.draw_series(&mut cc, k, s)?;
        }
        Ok(())
    }

    fn draw_series<DB, X, Y>(
        &self,
        cc: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
        k: usize,
        s: &Series,
    ) -> Result<(), PlotError>
    where
        DB: DrawingBackend,
        X: Ranged<ValueType = f64>,
        Y: Ranged<ValueType = f64>,
    {
        let (c, auto) = look(k);
        let keep = |(x, y): &(f64, f64)| self.ok(*x, *y);
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(keep).collect();
        if let Some(band) = &s.band {
            let (lo, hi): (Vec<_>, Vec<_>) = s
                .points
                .iter()
                .zip(band)
                .filter(|((x, _), (l, h))| self.ok(*x, *l) && self.ok(*x, *h))
                .map(|((x, _), (l, h))| ((*x, *l), (*x, *h)))
                .unzip();
            let outline: Vec<_> = hi.into_iter().chain(lo.into_iter().rev()).collect();
            cc.draw_series(std::iter::once(Polygon::new(outline, c.mix(0.18).filled())))
                .map_err(err)?;
        }
        // A dense line is drawn 1 px wide: the bitmap backend joins wide
        // segments with mitres, and a spiky series' sharp turns then shoot
        // spikes out of the axes and over the title (the real 1500 s
        // stepper run's residuals).
        let width = if pts.len() > 500 { 1 } else { 2 };
        let style = c.stroke_width(width);
        if s.markers {
            let fill = if s.hollow {
                c.stroke_width(1)
            } else {
                c.filled()
            };
            cc.draw_series(pts.iter().map(|p| Circle::new(*p, 3, fill)))
                .map_err(err)?;
        } else {
            match s.dash.unwrap_or(auto).pattern() {
                None => cc.draw_series(LineSeries::new(pts, style)).map_err(err)?,
                Some((d, g)) => cc
                    .draw_series(DashedLineSeries::new(pts, d, g, style))
                    .map_err(err)?,
            };
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
        Ok(())
    }

    /// The legend, in its own panel right of the plot (never over the
    /// data): each series' colour, dash or marker, and its label.
    fn draw_legend<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
    ) -> Result<(), PlotError> {
        let f = font();
        let text = (f, 12).into_font().color(&BLACK);
        let (x, mut y) = (8i32, MARGIN as i32 + 8);
        let row = 20;
        const LINE: i32 = 15;
        for (k, s) in self.series.iter().enumerate() {
            if s.label.is_empty() {
                continue;
            }
            let (c, auto) = look(k);
            if s.band.is_some() {
                area.draw(&Rectangle::new(
                    [(x, y - 6), (x + 24, y + 6)],
                    c.mix(0.18).filled(),
                ))
                .map_err(err)?;
            }
            if s.markers {
                let fill = if s.hollow {
                    c.stroke_width(1)
                } else {
                    c.filled()
                };
                area.draw(&Circle::new((x + 12, y), 4, fill)).map_err(err)?;
            } else {
                let line = vec![(x, y), (x + 24, y)];
                match s.dash.unwrap_or(auto).pattern() {
                    None => area.draw(&PathElement::new(line, c.stroke_width(2))),
                    Some((d, g)) => {
                        area.draw(&DashedPathElement::new(line, d, g, c.stroke_width(2)))
                    }
                }
                .map_err(err)?;
            }
            for line in wrap(&s.label) {
                area.draw(&Text::new(line, (x + 32, y - 7), text.clone()))
                    .map_err(err)?;
                y += LINE;
            }
            y += row - LINE;
        }
        if !self.shaded.is_empty() && !self.shaded_label.is_empty() {
            let shade = RGBColor(0x99, 0x99, 0x99).mix(0.22).filled();
            area.draw(&Rectangle::new([(x, y - 7), (x + 24, y + 7)], shade))
                .map_err(err)?;
            area.draw(&Text::new(self.shaded_label.clone(), (x + 32, y - 7), text))
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

/// Margin around a chart's plot, pixels.
const MARGIN: u32 = 12;
/// Height of the x axis' tick labels and description, pixels.
const LABEL_X: u32 = 42;
/// Width of the y axis' tick labels and description, pixels.
const LABEL_Y: u32 = 78;

/// An axis range over `v`: padded by 5 % when linear, whole decades when
/// log (six at most); a unit range around nothing.
fn range(v: &[f64], log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = v
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(*x), b.max(*x))
        });
    if !lo.is_finite() {
        return if log { (0.1, 1.0) } else { (0.0, 1.0) };
    }
    if log {
        // At most six decades: a value that starts at zero (an error at
        // t = 0) would otherwise stretch the axis to 1e-15.
        let b = hi.log10().ceil();
        let a = lo.log10().floor().max(b - 6.0);
        (10f64.powf(a), 10f64.powf(if b > a { b } else { a + 1.0 }))
    } else {
        if lo == hi {
            lo -= 1.0;
            hi += 1.0;
        }
        let pad = (hi - lo) * 0.05;
        (lo - pad, hi + pad)
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
        let d = Series::line("b", vec![(1.0, 2.0), (40.0, 0.5), (f64::NAN, 1.0)])
            .with_dash(Dash::Dashed);
        Chart {
            title: "test chart".into(),
            x_label: "x [s]".into(),
            y_label: "y [m]".into(),
            log_x: true,
            log_y: true,
            series: vec![s, d],
            ..Chart::default()
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

    #[test]
    fn a_spiky_dense_line_stays_inside_its_axes() {
        // 1462 one-second means that flip sign each step (the real 1500 s
        // stepper run's residual): drawn into a bitmap, no pixel of the
        // series' colour lies in the title's band above the plot (mitred
        // wide joins used to shoot spikes there).
        let pts: Vec<(f64, f64)> = (0..1462)
            .map(|i| {
                (
                    f64::from(i),
                    if i % 2 == 0 { 1.0 } else { -1.0 } * f64::from(i % 7 + 1),
                )
            })
            .collect();
        let c = Chart {
            title: "spiky".into(),
            series: vec![Series::line("a", pts)],
            ..Chart::default()
        };
        let (w, h) = (960u32, 480u32);
        let mut buf = vec![0u8; (w * h * 3) as usize];
        {
            let area = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            c.draw(&area).unwrap();
            area.present().unwrap();
        }
        let (r, g, b) = PALETTE[0];
        let band = 30usize;
        let hits = buf
            .chunks_exact(3)
            .take(band * w as usize)
            .filter(|p| p[0] == r && p[1] == g && p[2] == b)
            .count();
        assert_eq!(hits, 0, "{hits} pixels of the line in the title's band");
    }

    #[test]
    fn ticks_are_the_shortest_faithful_text() {
        for (v, t) in [
            (-0.0, "0"),
            (1e-17, "0"),
            (50.0, "50"),
            (0.1 + 0.2, "0.3"),
            (-2.5, "-2.5"),
            (1e-5, "1e-5"),
            (2.5e-5, "2.5e-5"),
            (250_000.0, "2.5e5"),
            (12_000.0, "12000"),
            (0.001, "0.001"),
        ] {
            assert_eq!(tick(v), t, "{v}");
        }
    }

    #[test]
    fn no_two_series_share_colour_and_dash() {
        let looks: Vec<_> = (0..28).map(look).collect();
        for (i, a) in looks.iter().enumerate() {
            for b in &looks[..i] {
                assert!(a != b, "series {i} repeats {a:?}");
            }
        }
    }

    /// The x of every `<text>` whose content is `t` in an SVG.
    fn text_x(svg: &str, t: &str) -> Vec<f64> {
        let lines: Vec<&str> = svg.lines().collect();
        lines
            .windows(2)
            .filter(|w| w[1].trim() == t && w[0].contains("<text"))
            .filter_map(|w| {
                let a = w[0].split("x=\"").nth(1)?;
                a.split('"').next()?.parse().ok()
            })
            .collect()
    }

    #[test]
    fn the_legend_is_right_of_the_plot() {
        // The plot's x axis ends where its last tick is; every legend label
        // starts right of that.
        let svg = chart().svg().unwrap();
        let legend = text_x(&svg, "a")[0].min(text_x(&svg, "b")[0]);
        let axis_end = text_x(&svg, "10")
            .into_iter()
            .chain(text_x(&svg, "100"))
            .fold(0.0, f64::max);
        assert!(axis_end > 100.0, "no tick label found: {axis_end}");
        assert!(legend > axis_end, "legend at {legend}, axis to {axis_end}");
    }

    #[test]
    fn a_map_has_one_scale() {
        let c = Chart {
            equal_scale: true,
            series: vec![Series::line("", vec![(0.0, 0.0), (100.0, 10.0)])],
            ..Chart::default()
        };
        let px = (800, 400);
        let ((x0, x1), (y0, y1)) = c.ranges(px);
        let (sx, sy) = ((x1 - x0) / 800.0, (y1 - y0) / 400.0);
        assert!((sx - sy).abs() < 1e-12 * sx, "{sx} m/px against {sy}");
        assert!(x0 <= 0.0 && x1 >= 100.0 && y0 <= 0.0 && y1 >= 10.0);
    }
}
