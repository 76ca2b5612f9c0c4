//! PNG figures for reports and tests: a [`Figure`] of one or more stacked [`Panel`]s, each with
//! a title, axis labels, linear or log axes, named line/marker series in automatically chosen
//! colours, shaded bands (confidence intervals), reference lines and a legend that places
//! itself where it covers the least data. [`bode`] builds a magnitude/phase figure in one call.
//!
//! The font (DejaVu Sans, licence in `tools/plot/assets`) is compiled in, so rendering needs no
//! system fonts. Everything is drawn in transformed coordinates (log10 of the value on a log
//! axis) and clipped to the plot area here, so NaN, infinite and, on log axes, non-positive
//! values simply break a line instead of failing or drawing over the axes.
//!
//! ```no_run
//! use antenna_plot::{Figure, Panel};
//! let f = [0.1, 1.0, 10.0];
//! let psd = [1.0, 0.05, 0.002];
//! Figure::new(900, 600)
//!     .panel(
//!         Panel::new("Wind speed PSD")
//!             .x_label("Frequency (Hz)")
//!             .y_label("PSD ((m/s)^2/Hz)")
//!             .log_x()
//!             .log_y()
//!             .line("measured", &f, &psd),
//!     )
//!     .save_png("psd.png")
//!     .unwrap();
//! ```

use antenna_dsp::{unwrap_phase_deg, Complex64, ResponseComparison};
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::Shift;
use plotters::element::{Circle, DashedPathElement, EmptyElement, IntoDynElement, Polygon, Rectangle};
use plotters::prelude::{
    BitMapBackend, ChartBuilder, Color, DashedLineSeries, DrawingArea, DrawingBackend, IntoDrawingArea, LineSeries,
    RGBColor, SeriesLabelPosition, ShapeStyle, BLACK, TRANSPARENT, WHITE,
};
use plotters::style::{FontStyle, IntoFont, TextStyle};
use std::fmt;
use std::path::Path;
use std::sync::OnceLock;

/// The compiled-in font, registered with plotters under [`FONT_FAMILY`].
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
/// Font family name every text element of a figure uses.
const FONT_FAMILY: &str = "DejaVu Sans";

/// Registers the embedded font once per process. It is also registered as "sans-serif",
/// plotters' default family, so no text can fall back to a font that is not there.
fn register_embedded_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        [FONT_FAMILY, "sans-serif"]
            .iter()
            .all(|name| plotters::style::register_font(name, FontStyle::Normal, FONT_BYTES).is_ok())
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::FontNotLoaded)
    }
}

/// Why a figure could not be drawn or written.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PlotError {
    #[error("plot: the embedded DejaVu Sans font could not be loaded")]
    FontNotLoaded,
    #[error("plot: figure {width}x{height} is too small to draw axes in (at least 200x150)")]
    TooSmall { width: u32, height: u32 },
    #[error("plot: figure has no panels")]
    NoPanels,
    #[error("plot: cannot write {}: {message}", path.display())]
    Write { path: std::path::PathBuf, message: String },
    /// The drawing backend refused an element (its message, as plotters gives it).
    #[error("plot: {0}")]
    Drawing(String),
}

fn plot_error(error: impl fmt::Display) -> PlotError {
    PlotError::Drawing(error.to_string())
}

/// An sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Colour {
    /// Red, 0-255.
    pub r: u8,
    /// Green, 0-255.
    pub g: u8,
    /// Blue, 0-255.
    pub b: u8,
}

impl Colour {
    /// A colour from its red, green and blue components.
    pub const fn rgb(r: u8, g: u8, b: u8) -> Self {
        Self { r, g, b }
    }

    fn to_plotters(self) -> RGBColor {
        RGBColor(self.r, self.g, self.b)
    }
}

/// The colours given to series in order (the "tab10" palette, distinguishable in print and for
/// most colour-blind readers in its first four entries).
pub const PALETTE: [Colour; 10] = [
    Colour::rgb(0x1f, 0x77, 0xb4),
    Colour::rgb(0xff, 0x7f, 0x0e),
    Colour::rgb(0x2c, 0xa0, 0x2c),
    Colour::rgb(0xd6, 0x27, 0x28),
    Colour::rgb(0x94, 0x67, 0xbd),
    Colour::rgb(0x8c, 0x56, 0x4b),
    Colour::rgb(0xe3, 0x77, 0xc2),
    Colour::rgb(0x7f, 0x7f, 0x7f),
    Colour::rgb(0xbc, 0xbd, 0x22),
    Colour::rgb(0x17, 0xbe, 0xcf),
];

/// Linear or logarithmic (base 10) axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scale {
    /// Linear axis.
    #[default]
    Linear,
    /// Base-10 logarithmic axis; non-positive values are not drawn.
    Log,
}

impl Scale {
    /// The value in plot coordinates, or None if it cannot be shown on this axis.
    fn transform(self, value: f64) -> Option<f64> {
        match self {
            Scale::Linear if value.is_finite() => Some(value),
            Scale::Log if value.is_finite() && value > 0.0 => Some(value.log10()),
            _ => None,
        }
    }
}

/// How a series' points are joined.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// Continuous line.
    #[default]
    Solid,
    /// Dashed line, for models and references.
    Dashed,
    /// Dotted line.
    Dotted,
    /// No line (markers only).
    None,
}

/// One named data series of a panel.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    name: String,
    x: Vec<f64>,
    y: Vec<f64>,
    line: LineStyle,
    markers: bool,
    colour: Option<Colour>,
    width: u32,
}

impl Series {
    /// A solid line through the points `(x[i], y[i])`; extra points of the longer slice are
    /// ignored. An empty name keeps the series out of the legend.
    pub fn new(name: &str, x: &[f64], y: &[f64]) -> Self {
        let len = x.len().min(y.len());
        Self {
            name: name.to_string(),
            x: x[..len].to_vec(),
            y: y[..len].to_vec(),
            line: LineStyle::Solid,
            markers: false,
            colour: None,
            width: 2,
        }
    }

    /// Draws the line dashed.
    pub fn dashed(mut self) -> Self {
        self.line = LineStyle::Dashed;
        self
    }

    /// Draws the line dotted.
    pub fn dotted(mut self) -> Self {
        self.line = LineStyle::Dotted;
        self
    }

    /// Adds a marker at every point.
    pub fn with_markers(mut self) -> Self {
        self.markers = true;
        self
    }

    /// Markers only, no line.
    pub fn markers_only(mut self) -> Self {
        self.markers = true;
        self.line = LineStyle::None;
        self
    }

    /// A fixed colour instead of the next palette colour.
    pub fn colour(mut self, colour: Colour) -> Self {
        self.colour = Some(colour);
        self
    }

    /// Line width in pixels (default 2).
    pub fn width(mut self, pixels: u32) -> Self {
        self.width = pixels.max(1);
        self
    }
}

/// A shaded region between two curves, e.g. a confidence band.
#[derive(Debug, Clone, PartialEq)]
struct Band {
    name: String,
    x: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    colour: Colour,
}

/// A vertical or horizontal reference line across the whole panel.
#[derive(Debug, Clone, PartialEq)]
struct ReferenceLine {
    name: String,
    value: f64,
    vertical: bool,
    colour: Colour,
}

/// Where a panel's legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LegendPosition {
    /// The corner that covers the fewest data points.
    #[default]
    Auto,
    /// Top left corner.
    UpperLeft,
    /// Top right corner.
    UpperRight,
    /// Bottom left corner.
    LowerLeft,
    /// Bottom right corner.
    LowerRight,
    /// No legend.
    Hidden,
}

/// One plot area with its axes, data and legend. Built with chained calls; colours are taken
/// from [`PALETTE`] in the order series and bands are added.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Panel {
    title: String,
    x_label: String,
    y_label: String,
    x_scale: Scale,
    y_scale: Scale,
    x_range: Option<(f64, f64)>,
    y_range: Option<(f64, f64)>,
    series: Vec<Series>,
    bands: Vec<Band>,
    references: Vec<ReferenceLine>,
    legend: LegendPosition,
    next_colour: usize,
}

impl Panel {
    /// An empty panel with a title (may be empty).
    pub fn new(title: &str) -> Self {
        Self { title: title.to_string(), ..Self::default() }
    }

    /// X-axis label, with its unit, e.g. "Frequency (Hz)".
    pub fn x_label(mut self, label: &str) -> Self {
        self.x_label = label.to_string();
        self
    }

    /// Y-axis label, with its unit.
    pub fn y_label(mut self, label: &str) -> Self {
        self.y_label = label.to_string();
        self
    }

    /// Logarithmic x axis.
    pub fn log_x(mut self) -> Self {
        self.x_scale = Scale::Log;
        self
    }

    /// Logarithmic y axis.
    pub fn log_y(mut self) -> Self {
        self.y_scale = Scale::Log;
        self
    }

    /// Fixed x range instead of auto-ranging (data outside is clipped).
    pub fn x_range(mut self, low: f64, high: f64) -> Self {
        self.x_range = Some((low, high));
        self
    }

    /// Fixed y range instead of auto-ranging (data outside is clipped).
    pub fn y_range(mut self, low: f64, high: f64) -> Self {
        self.y_range = Some((low, high));
        self
    }

    /// Legend placement (default [`LegendPosition::Auto`]).
    pub fn legend(mut self, position: LegendPosition) -> Self {
        self.legend = position;
        self
    }

    fn take_colour(&mut self) -> Colour {
        let colour = PALETTE[self.next_colour % PALETTE.len()];
        self.next_colour += 1;
        colour
    }

    /// Adds a series configured with [`Series`]'s builder methods.
    pub fn series(mut self, mut series: Series) -> Self {
        if series.colour.is_none() {
            series.colour = Some(self.take_colour());
        }
        self.series.push(series);
        self
    }

    /// Adds a solid line.
    pub fn line(self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.series(Series::new(name, x, y))
    }

    /// Adds a dashed line (models, references).
    pub fn dashed(self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.series(Series::new(name, x, y).dashed())
    }

    /// Adds markers without a line.
    pub fn markers(self, name: &str, x: &[f64], y: &[f64]) -> Self {
        self.series(Series::new(name, x, y).markers_only())
    }

    /// Adds a shaded band between `lower` and `upper` in its own colour.
    pub fn band(mut self, name: &str, x: &[f64], lower: &[f64], upper: &[f64]) -> Self {
        let colour = self.take_colour();
        self.push_band(name, x, lower, upper, colour);
        self
    }

    /// Adds a line with markers and, in the same colour, its shaded band (e.g. an estimate with
    /// its confidence interval); `band_name` is the band's legend entry (empty to omit it).
    pub fn line_with_band(
        mut self,
        name: &str,
        x: &[f64],
        y: &[f64],
        lower: &[f64],
        upper: &[f64],
        band_name: &str,
    ) -> Self {
        let colour = self.take_colour();
        self.push_band(band_name, x, lower, upper, colour);
        self.series.push(Series::new(name, x, y).with_markers().colour(colour));
        self
    }

    fn push_band(&mut self, name: &str, x: &[f64], lower: &[f64], upper: &[f64], colour: Colour) {
        let len = x.len().min(lower.len()).min(upper.len());
        self.bands.push(Band {
            name: name.to_string(),
            x: x[..len].to_vec(),
            lower: lower[..len].to_vec(),
            upper: upper[..len].to_vec(),
            colour,
        });
    }

    /// Adds a dashed vertical line across the panel at `x`.
    pub fn vertical_line(mut self, name: &str, x: f64) -> Self {
        let colour = self.take_colour();
        self.vertical_line_coloured(name, x, colour)
    }

    /// Adds a dashed horizontal line across the panel at `y`.
    pub fn horizontal_line(mut self, name: &str, y: f64) -> Self {
        let colour = self.take_colour();
        self.horizontal_line_coloured(name, y, colour)
    }

    /// Adds a dashed vertical line at `x` in a given colour (a marker that belongs to a curve
    /// drawn in that colour, say).
    pub fn vertical_line_coloured(mut self, name: &str, x: f64, colour: Colour) -> Self {
        self.references.push(ReferenceLine { name: name.to_string(), value: x, vertical: true, colour });
        self
    }

    /// Adds a dashed horizontal line at `y` in a given colour.
    pub fn horizontal_line_coloured(mut self, name: &str, y: f64, colour: Colour) -> Self {
        self.references.push(ReferenceLine { name: name.to_string(), value: y, vertical: false, colour });
        self
    }
}

/// A figure: panels stacked vertically, an optional overall title, a size in pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    width: u32,
    height: u32,
    title: Option<String>,
    panels: Vec<Panel>,
}

impl Figure {
    /// An empty figure of `width` x `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, title: None, panels: Vec::new() }
    }

    /// A title above all panels.
    pub fn title(mut self, title: &str) -> Self {
        self.title = Some(title.to_string());
        self
    }

    /// Appends a panel below the existing ones; panels share the height equally.
    pub fn panel(mut self, panel: Panel) -> Self {
        self.panels.push(panel);
        self
    }

    /// Image size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Renders the figure and writes it as a PNG file.
    pub fn save_png(&self, path: impl AsRef<Path>) -> Result<(), PlotError> {
        self.check_size()?;
        let path = path.as_ref();
        let root = BitMapBackend::new(path, (self.width, self.height)).into_drawing_area();
        self.draw(&root)?;
        root.present().map_err(|e| PlotError::Write { path: path.to_path_buf(), message: e.to_string() })
    }

    /// Renders the figure into an RGB buffer (3 bytes per pixel, row by row), e.g. to inspect
    /// pixels in a test without touching the file system.
    pub fn render_rgb(&self) -> Result<Vec<u8>, PlotError> {
        self.check_size()?;
        let mut buffer = vec![0u8; self.width as usize * self.height as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut buffer, (self.width, self.height)).into_drawing_area();
            self.draw(&root)?;
            root.present().map_err(plot_error)?;
        }
        Ok(buffer)
    }

    fn check_size(&self) -> Result<(), PlotError> {
        if self.width < 200 || self.height < 150 {
            return Err(PlotError::TooSmall { width: self.width, height: self.height });
        }
        if self.panels.is_empty() {
            return Err(PlotError::NoPanels);
        }
        Ok(())
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), PlotError>
    where
        DB::ErrorType: 'static,
    {
        register_embedded_font()?;
        root.fill(&WHITE).map_err(plot_error)?;
        let body = match &self.title {
            Some(title) => root.titled(title, text_style(22)).map_err(plot_error)?,
            None => root.clone(),
        };
        let areas = body.split_evenly((self.panels.len(), 1));
        for (panel, area) in self.panels.iter().zip(&areas) {
            draw_panel(area, panel)?;
        }
        Ok(())
    }
}

fn text_style(size: u32) -> TextStyle<'static> {
    (FONT_FAMILY, size).into_font().color(&BLACK)
}

/// An axis in plot coordinates with its tick positions.
#[derive(Debug, Clone, PartialEq)]
struct Axis {
    scale: Scale,
    low: f64,
    high: f64,
    /// Labelled ticks with grid lines.
    major: Vec<f64>,
    /// Grid lines without labels.
    minor: Vec<f64>,
    /// Spacing of the major ticks on a linear axis (sets the decimals shown).
    step: f64,
}

impl Axis {
    /// Builds an axis covering `values` (already in plot coordinates) or the fixed `range`
    /// (data units), padded so no point sits on the frame.
    fn new(scale: Scale, values: &[f64], range: Option<(f64, f64)>, target_ticks: usize) -> Self {
        let fixed = range.and_then(|(a, b)| Some((scale.transform(a)?, scale.transform(b)?))).filter(|(a, b)| b > a);
        let (low, high) = match fixed {
            Some(bounds) => bounds,
            None => auto_range(scale, values),
        };
        Self::from_bounds(scale, low, high, target_ticks)
    }

    /// An axis from `low` to `high` in plot coordinates.
    fn from_bounds(scale: Scale, low: f64, high: f64, target_ticks: usize) -> Self {
        match scale {
            Scale::Linear => {
                let (major, minor, step) = linear_ticks(low, high, target_ticks);
                Self { scale, low, high, major, minor, step }
            }
            Scale::Log => {
                let (major, minor) = log_ticks(low, high);
                Self { scale, low, high, major, minor, step: 1.0 }
            }
        }
    }

    fn label(&self, value: f64) -> String {
        match self.scale {
            Scale::Linear => format_linear(value, self.step),
            Scale::Log => format_log(value),
        }
    }

    /// Position of a plot coordinate as a fraction of the axis length.
    fn fraction(&self, value: f64) -> f64 {
        (value - self.low) / (self.high - self.low)
    }
}

/// Data extent with 4 % padding; a flat or empty extent gets a sensible span.
fn auto_range(scale: Scale, values: &[f64]) -> (f64, f64) {
    let (mut low, mut high) =
        values.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if !low.is_finite() {
        return match scale {
            Scale::Linear => (0.0, 1.0),
            Scale::Log => (0.0, 1.0),
        };
    }
    if high - low < 1e-12 * (1.0 + low.abs()) {
        let half_span = match scale {
            Scale::Linear => 0.5 * low.abs().max(1.0),
            Scale::Log => 0.5,
        };
        low -= half_span;
        high += half_span;
    }
    let pad = 0.04 * (high - low);
    (low - pad, high + pad)
}

/// Ticks at multiples of 1, 2 or 5 times a power of ten, about `target` of them, with four or
/// five minor grid lines between major ones.
fn linear_ticks(low: f64, high: f64, target: usize) -> (Vec<f64>, Vec<f64>, f64) {
    let raw_step = (high - low) / target.max(2) as f64;
    let magnitude = 10f64.powf(raw_step.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * magnitude).find(|s| *s >= raw_step).unwrap_or(10.0 * magnitude);
    let minor_step = if (step / magnitude - 2.0).abs() < 1e-9 { step / 4.0 } else { step / 5.0 };
    let multiples = |spacing: f64| -> Vec<f64> {
        let first = (low / spacing).ceil() as i64;
        let last = (high / spacing).floor() as i64;
        // Snapping to exact multiples keeps 0.1 + 0.2 from labelling as 0.30000000000000004.
        (first..=last).map(|i| i as f64 * spacing).collect()
    };
    let major = multiples(step);
    let minor = multiples(minor_step);
    (major, minor, step)
}

/// Log-axis ticks in log10 coordinates: decades as major ticks (every other decade when the
/// axis spans more than eight), 2..9 times each decade as minor grid lines; on an axis shorter
/// than about a decade and a half, 2 and 5 times a decade are labelled as well.
fn log_ticks(low: f64, high: f64) -> (Vec<f64>, Vec<f64>) {
    let first = low.floor() as i64;
    let last = high.ceil() as i64;
    let decades = high - low;
    let decade_stride = if decades > 8.0 { 2 } else { 1 };
    let mut major = Vec::new();
    let mut minor = Vec::new();
    for exponent in first..=last {
        for mantissa in 1..10 {
            let value = exponent as f64 + (mantissa as f64).log10();
            if value < low || value > high {
                continue;
            }
            let labelled = if mantissa == 1 {
                exponent % decade_stride == 0
            } else if decades < 1.5 {
                mantissa == 2 || mantissa == 5 || (decades < 0.6 && mantissa <= 9)
            } else {
                false
            };
            if labelled {
                major.push(value);
            } else if decades <= 12.0 {
                minor.push(value);
            }
        }
    }
    (major, minor)
}

fn format_linear(value: f64, step: f64) -> String {
    let value = if value.abs() < 1e-9 * step { 0.0 } else { value };
    if value.abs() >= 1e5 || (step < 1e-4 && value != 0.0) {
        return format_scientific(value);
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    format!("{value:.decimals$}")
}

/// Labels a log-axis tick given as log10 of the value: plain decimals from 0.001 to 10000,
/// powers of ten with superscript exponents beyond.
fn format_log(log_value: f64) -> String {
    let exponent = log_value.floor();
    let mantissa = (10f64.powf(log_value - exponent) * 1e6).round() / 1e6;
    let (mantissa, exponent) = if mantissa >= 10.0 { (mantissa / 10.0, exponent + 1.0) } else { (mantissa, exponent) };
    let exponent = exponent as i32;
    if (-3..=4).contains(&exponent) {
        let decimals = (-exponent).max(0) as usize;
        let value = mantissa * 10f64.powi(exponent);
        let text = format!("{value:.decimals$}");
        return trim_decimals(&text);
    }
    let power = format!("10{}", superscript(exponent));
    if (mantissa - 1.0).abs() < 1e-9 {
        power
    } else {
        format!("{}×{power}", trim_decimals(&format!("{mantissa:.2}")))
    }
}

fn format_scientific(value: f64) -> String {
    let text = format!("{value:.2e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) => format!("{}e{exponent}", trim_decimals(mantissa)),
        None => text,
    }
}

fn trim_decimals(text: &str) -> String {
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text.to_string()
    }
}

fn superscript(exponent: i32) -> String {
    exponent
        .to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            '9' => '⁹',
            other => other,
        })
        .collect()
}

type Point = (f64, f64);

/// Splits a series into runs of drawable points in plot coordinates.
fn drawable_runs(x: &[f64], y: &[f64], x_scale: Scale, y_scale: Scale) -> Vec<Vec<Point>> {
    let mut runs = Vec::new();
    let mut current = Vec::new();
    for (&xv, &yv) in x.iter().zip(y) {
        match (x_scale.transform(xv), y_scale.transform(yv)) {
            (Some(px), Some(py)) => current.push((px, py)),
            _ => {
                if !current.is_empty() {
                    runs.push(std::mem::take(&mut current));
                }
            }
        }
    }
    if !current.is_empty() {
        runs.push(current);
    }
    runs
}

/// The plot rectangle in plot coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    x_low: f64,
    x_high: f64,
    y_low: f64,
    y_high: f64,
}

impl Rect {
    fn contains(&self, (x, y): Point) -> bool {
        x >= self.x_low && x <= self.x_high && y >= self.y_low && y <= self.y_high
    }
}

/// Clips a polyline to the rectangle (Liang-Barsky per segment), splitting it where it leaves.
fn clip_polyline(points: &[Point], rect: &Rect) -> Vec<Vec<Point>> {
    let mut pieces: Vec<Vec<Point>> = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    if points.len() == 1 {
        if rect.contains(points[0]) {
            pieces.push(vec![points[0]]);
        }
        return pieces;
    }
    for pair in points.windows(2) {
        match clip_segment(pair[0], pair[1], rect) {
            Some((a, b)) => {
                let continues = current.last().is_some_and(|last| *last == a);
                if !continues {
                    if current.len() > 1 {
                        pieces.push(std::mem::take(&mut current));
                    }
                    current.clear();
                    current.push(a);
                }
                current.push(b);
                if b != pair[1] {
                    pieces.push(std::mem::take(&mut current));
                }
            }
            None => {
                if current.len() > 1 {
                    pieces.push(std::mem::take(&mut current));
                }
                current.clear();
            }
        }
    }
    if current.len() > 1 {
        pieces.push(current);
    }
    pieces
}

fn clip_segment(a: Point, b: Point, rect: &Rect) -> Option<(Point, Point)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let mut t0: f64 = 0.0;
    let mut t1: f64 = 1.0;
    for (p, q) in [(-dx, a.0 - rect.x_low), (dx, rect.x_high - a.0), (-dy, a.1 - rect.y_low), (dy, rect.y_high - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| {
        if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        }
    };
    Some((at(t0), at(t1)))
}

/// Clips a polygon to the rectangle (Sutherland-Hodgman).
fn clip_polygon(polygon: &[Point], rect: &Rect) -> Vec<Point> {
    type Inside = fn(Point, &Rect) -> bool;
    type Intersect = fn(Point, Point, &Rect) -> Point;
    let edges: [(Inside, Intersect); 4] = [
        (|p, r| p.0 >= r.x_low, |a, b, r| intersect_x(a, b, r.x_low)),
        (|p, r| p.0 <= r.x_high, |a, b, r| intersect_x(a, b, r.x_high)),
        (|p, r| p.1 >= r.y_low, |a, b, r| intersect_y(a, b, r.y_low)),
        (|p, r| p.1 <= r.y_high, |a, b, r| intersect_y(a, b, r.y_high)),
    ];
    let mut output = polygon.to_vec();
    for (inside, intersect) in edges {
        let input = std::mem::take(&mut output);
        if input.is_empty() {
            break;
        }
        let mut previous = *input.last().unwrap();
        for &current in &input {
            if inside(current, rect) {
                if !inside(previous, rect) {
                    output.push(intersect(previous, current, rect));
                }
                output.push(current);
            } else if inside(previous, rect) {
                output.push(intersect(previous, current, rect));
            }
            previous = current;
        }
    }
    output
}

fn intersect_x(a: Point, b: Point, x: f64) -> Point {
    let t = (x - a.0) / (b.0 - a.0);
    (x, a.1 + t * (b.1 - a.1))
}

fn intersect_y(a: Point, b: Point, y: f64) -> Point {
    let t = (y - a.1) / (b.1 - a.1);
    (a.0 + t * (b.0 - a.0), y)
}

/// Band polygons in plot coordinates, one per run of points where the band is drawable. On a
/// log y axis a non-positive lower limit means "down to zero" and is drawn to below the axis.
fn band_polygons(band: &Band, x_scale: Scale, y_scale: Scale, y_floor: f64) -> Vec<Vec<Point>> {
    let mut polygons = Vec::new();
    let mut upper_run: Vec<Point> = Vec::new();
    let mut lower_run: Vec<Point> = Vec::new();
    let mut flush = |upper: &mut Vec<Point>, lower: &mut Vec<Point>| {
        if upper.len() > 1 {
            let mut polygon = std::mem::take(upper);
            polygon.extend(lower.drain(..).rev());
            polygons.push(polygon);
        }
        upper.clear();
        lower.clear();
    };
    for i in 0..band.x.len() {
        let x = x_scale.transform(band.x[i]);
        let upper = y_scale.transform(band.upper[i]);
        let lower = match (y_scale, band.lower[i]) {
            (Scale::Log, v) if v.is_finite() && v <= 0.0 => Some(y_floor),
            (scale, v) => scale.transform(v),
        };
        match (x, upper, lower) {
            (Some(px), Some(pu), Some(pl)) => {
                upper_run.push((px, pu));
                lower_run.push((px, pl));
            }
            _ => flush(&mut upper_run, &mut lower_run),
        }
    }
    flush(&mut upper_run, &mut lower_run);
    polygons
}

/// All plot-coordinate values that auto-ranging should cover.
fn extent_values(panel: &Panel) -> (Vec<f64>, Vec<f64>) {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for series in &panel.series {
        for run in drawable_runs(&series.x, &series.y, panel.x_scale, panel.y_scale) {
            for (x, y) in run {
                xs.push(x);
                ys.push(y);
            }
        }
    }
    for band in &panel.bands {
        for i in 0..band.x.len() {
            if let Some(x) = panel.x_scale.transform(band.x[i]) {
                for bound in [band.lower[i], band.upper[i]] {
                    if let Some(y) = panel.y_scale.transform(bound) {
                        xs.push(x);
                        ys.push(y);
                    }
                }
            }
        }
    }
    for reference in &panel.references {
        let (scale, values) = if reference.vertical { (panel.x_scale, &mut xs) } else { (panel.y_scale, &mut ys) };
        if let Some(v) = scale.transform(reference.value) {
            values.push(v);
        }
    }
    (xs, ys)
}

/// Legend text lines of a panel, in drawing order.
fn legend_entries(panel: &Panel) -> Vec<&str> {
    panel
        .bands
        .iter()
        .map(|b| b.name.as_str())
        .chain(panel.series.iter().map(|s| s.name.as_str()))
        .chain(panel.references.iter().map(|r| r.name.as_str()))
        .filter(|name| !name.is_empty())
        .collect()
}

const LEGEND_FONT: u32 = 14;
/// Height of a legend row in plotters' series-label layout at [`LEGEND_FONT`], pixels.
const LEGEND_ROW: f64 = 17.0;
/// Width of a legend glyph plus the gaps around it and the text, pixels.
const LEGEND_GLYPH_WIDTH: f64 = 44.0;
/// Fraction of a legend-sized corner that may be occupied before the data are moved down to
/// make room above them.
const LEGEND_CROWDED: f64 = 0.04;

/// Picks the corner whose legend-sized box covers the least drawn area. `points` are positions
/// of everything drawn as fractions of the plot area; they are counted as occupied cells of a
/// 40 x 40 grid, so a dense series does not outweigh a sparse one that covers as much of the
/// picture. `legend_fraction` is the legend's width and height as fractions of the plot area.
/// Ties go to the upper right, then upper left, lower left, lower right. Also returns the
/// fraction of the chosen box's cells that are occupied.
fn choose_legend_corner(points: &[Point], legend_fraction: (f64, f64)) -> (SeriesLabelPosition, f64) {
    const CELLS: usize = 40;
    let cell = |v: f64| ((v * CELLS as f64).floor().max(0.0) as usize).min(CELLS - 1);
    let mut occupied = vec![false; CELLS * CELLS];
    for &(x, y) in points {
        if (0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&y) {
            occupied[cell(y) * CELLS + cell(x)] = true;
        }
    }
    let (w, h) = (legend_fraction.0.min(1.0) + 0.02, legend_fraction.1.min(1.0) + 0.02);
    let corners = [
        (SeriesLabelPosition::UpperRight, 1.0 - w, 1.0, 1.0 - h, 1.0),
        (SeriesLabelPosition::UpperLeft, 0.0, w, 1.0 - h, 1.0),
        (SeriesLabelPosition::LowerLeft, 0.0, w, 0.0, h),
        (SeriesLabelPosition::LowerRight, 1.0 - w, 1.0, 0.0, h),
    ];
    let mut best = (usize::MAX, SeriesLabelPosition::UpperRight, 1);
    for (position, x0, x1, y0, y1) in corners {
        let (mut covered, mut cells) = (0, 0);
        for row in cell(y0)..=cell(y1 - 1e-9) {
            for column in cell(x0)..=cell(x1 - 1e-9) {
                covered += usize::from(occupied[row * CELLS + column]);
                cells += 1;
            }
        }
        if covered < best.0 {
            best = (covered, position, cells);
        }
    }
    (best.1, best.0 as f64 / best.2 as f64)
}

/// Chooses the legend corner for a legend of `fraction` of the plot area. When every corner is
/// crowded and the y range is automatic, the top of the y axis is raised so the data end below
/// the legend, which then sits in the space made above them. Returns the corner and the
/// (possibly raised) y axis.
fn place_legend(
    panel: &Panel,
    x_axis: &Axis,
    y_axis: Axis,
    fraction: (f64, f64),
    y_ticks: usize,
) -> (SeriesLabelPosition, Axis) {
    let (corner, crowding) = choose_legend_corner(&occupancy_points(panel, x_axis, &y_axis), fraction);
    if crowding <= LEGEND_CROWDED || panel.y_range.is_some() || fraction.1 >= 0.6 {
        return (corner, y_axis);
    }
    let span = (y_axis.high - y_axis.low) / (1.0 - fraction.1 - 0.03);
    let raised = Axis::from_bounds(panel.y_scale, y_axis.low, y_axis.low + span, y_ticks);
    let (corner, _) = choose_legend_corner(&occupancy_points(panel, x_axis, &raised), fraction);
    (corner, raised)
}

/// Points of everything drawn, as fractions of the plot area, for legend placement. Lines are
/// sampled along their length so a steep line through a corner counts there.
fn occupancy_points(panel: &Panel, x_axis: &Axis, y_axis: &Axis) -> Vec<Point> {
    let rect = Rect { x_low: x_axis.low, x_high: x_axis.high, y_low: y_axis.low, y_high: y_axis.high };
    let to_fraction = |(x, y): Point| (x_axis.fraction(x), y_axis.fraction(y));
    let mut points = Vec::new();
    let mut add_polyline = |run: &[Point]| {
        for piece in clip_polyline(run, &rect) {
            for pair in piece.windows(2) {
                let (a, b) = (to_fraction(pair[0]), to_fraction(pair[1]));
                let steps = (((b.0 - a.0).hypot(b.1 - a.1)) / 0.01).ceil().clamp(1.0, 200.0) as usize;
                for s in 0..steps {
                    let t = s as f64 / steps as f64;
                    points.push((a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)));
                }
            }
            if let Some(&last) = piece.last() {
                points.push(to_fraction(last));
            }
        }
    };
    for series in &panel.series {
        for run in drawable_runs(&series.x, &series.y, panel.x_scale, panel.y_scale) {
            add_polyline(&run);
        }
    }
    for band in &panel.bands {
        for polygon in band_polygons(band, panel.x_scale, panel.y_scale, y_axis.low - 1.0) {
            let half = polygon.len() / 2;
            add_polyline(&polygon[..half]);
            add_polyline(&polygon[half..]);
        }
    }
    for reference in &panel.references {
        let line = reference_segment(reference, panel, x_axis, y_axis);
        if let Some(line) = line {
            add_polyline(&line);
        }
    }
    points
}

fn reference_segment(reference: &ReferenceLine, panel: &Panel, x_axis: &Axis, y_axis: &Axis) -> Option<Vec<Point>> {
    if reference.vertical {
        let x = panel.x_scale.transform(reference.value)?;
        Some(vec![(x, y_axis.low), (x, y_axis.high)])
    } else {
        let y = panel.y_scale.transform(reference.value)?;
        Some(vec![(x_axis.low, y), (x_axis.high, y)])
    }
}

/// Pixel sizes of the areas around a panel's plot, used both to lay it out and to estimate the
/// plot area for legend placement.
const MARGIN: u32 = 14;
const X_LABEL_AREA: u32 = 52;
const Y_LABEL_AREA: u32 = 84;
const CAPTION_HEIGHT: u32 = 30;

/// The axes of a panel and where its legend goes, worked out before anything is drawn.
struct Layout {
    x_axis: Axis,
    y_axis: Axis,
    show_legend: bool,
    legend_position: SeriesLabelPosition,
    /// Pixels per plot-coordinate unit along x and y (approximate: the label areas' exact sizes
    /// are plotters' business), for judging angles as the reader sees them.
    pixels_per_unit: (f64, f64),
}

impl Layout {
    fn rect(&self) -> Rect {
        Rect { x_low: self.x_axis.low, x_high: self.x_axis.high, y_low: self.y_axis.low, y_high: self.y_axis.high }
    }
}

fn layout<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &Panel) -> Layout {
    let (width, height) = area.dim_in_pixel();
    let caption = if panel.title.is_empty() { 0 } else { CAPTION_HEIGHT };
    let plot_width = width.saturating_sub(Y_LABEL_AREA + 2 * MARGIN).max(1) as f64;
    let plot_height = height.saturating_sub(X_LABEL_AREA + caption + 2 * MARGIN).max(1) as f64;

    let (xs, ys) = extent_values(panel);
    let x_axis = Axis::new(panel.x_scale, &xs, panel.x_range, ((plot_width / 110.0).round() as usize).clamp(3, 10));
    let y_ticks = ((plot_height / 60.0).round() as usize).clamp(3, 8);
    let mut y_axis = Axis::new(panel.y_scale, &ys, panel.y_range, y_ticks);

    let entries = legend_entries(panel);
    let show_legend = panel.legend != LegendPosition::Hidden && !entries.is_empty();
    let mut legend_position = match panel.legend {
        LegendPosition::UpperLeft => SeriesLabelPosition::UpperLeft,
        LegendPosition::LowerLeft => SeriesLabelPosition::LowerLeft,
        LegendPosition::LowerRight => SeriesLabelPosition::LowerRight,
        _ => SeriesLabelPosition::UpperRight,
    };
    if show_legend && panel.legend == LegendPosition::Auto {
        let style = text_style(LEGEND_FONT);
        let text_width =
            entries.iter().map(|e| area.estimate_text_size(e, &style).map(|(w, _)| w).unwrap_or(0)).max().unwrap_or(0);
        let legend_width = text_width as f64 + LEGEND_GLYPH_WIDTH;
        let legend_height = LEGEND_ROW * entries.len() as f64 + 12.0;
        let fraction = (legend_width / plot_width, legend_height / plot_height);
        (legend_position, y_axis) = place_legend(panel, &x_axis, y_axis, fraction, y_ticks);
    }
    let pixels_per_unit = (plot_width / (x_axis.high - x_axis.low), plot_height / (y_axis.high - y_axis.low));
    Layout { x_axis, y_axis, show_legend, legend_position, pixels_per_unit }
}

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &Panel) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let layout = layout(area, panel);
    let mut builder = ChartBuilder::on(area);
    builder.margin(MARGIN).x_label_area_size(X_LABEL_AREA).y_label_area_size(Y_LABEL_AREA);
    if !panel.title.is_empty() {
        builder.caption(&panel.title, text_style(18));
    }
    let mut chart = builder
        .build_cartesian_2d(TickedRange::from(&layout.x_axis), TickedRange::from(&layout.y_axis))
        .map_err(plot_error)?;
    let x_formatter = |v: &f64| layout.x_axis.label(*v);
    let y_formatter = |v: &f64| layout.y_axis.label(*v);
    chart
        .configure_mesh()
        .x_desc(panel.x_label.as_str())
        .y_desc(panel.y_label.as_str())
        .x_label_formatter(&x_formatter)
        .y_label_formatter(&y_formatter)
        .label_style(text_style(14))
        .axis_desc_style(text_style(15))
        .bold_line_style(BLACK.mix(0.16))
        .light_line_style(BLACK.mix(0.05))
        .axis_style(BLACK.mix(0.8))
        .draw()
        .map_err(plot_error)?;
    draw_data(&mut chart, panel, &layout)?;
    if layout.show_legend {
        draw_legend(&mut chart, panel, layout.legend_position)?;
    }
    Ok(())
}

/// Bands, then series, then reference lines, each clipped to the plot area.
fn draw_data<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    panel: &Panel,
    layout: &Layout,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let rect = layout.rect();
    // Bands first, so lines and markers stay visible on top of them.
    for band in &panel.bands {
        let colour = band.colour.to_plotters();
        for polygon in band_polygons(band, panel.x_scale, panel.y_scale, layout.y_axis.low - 1.0) {
            let clipped = clip_polygon(&polygon, &rect);
            if clipped.len() >= 3 {
                chart
                    .draw_series(std::iter::once(Polygon::new(clipped, colour.mix(0.22).filled())))
                    .map_err(plot_error)?;
            }
        }
    }
    for series in &panel.series {
        let colour = series.colour.unwrap_or(PALETTE[0]).to_plotters();
        let style = ShapeStyle { color: colour.to_rgba(), filled: false, stroke_width: series.width };
        for run in drawable_runs(&series.x, &series.y, panel.x_scale, panel.y_scale) {
            for piece in clip_polyline(&run, &rect) {
                for stroke in split_at_sharp_turns(&piece, layout.pixels_per_unit) {
                    draw_line(chart, stroke, series.line, style)?;
                }
            }
            if series.markers {
                let inside = run.iter().copied().filter(|p| rect.contains(*p));
                let marker_size = (series.width + 1).max(3) as i32;
                chart.draw_series(inside.map(|p| Circle::new(p, marker_size, colour.filled()))).map_err(plot_error)?;
            }
        }
    }
    for reference in &panel.references {
        if let Some(line) = reference_segment(reference, panel, &layout.x_axis, &layout.y_axis) {
            let style = ShapeStyle { color: reference.colour.to_plotters().to_rgba(), filled: false, stroke_width: 2 };
            for piece in clip_polyline(&line, &rect) {
                draw_line(chart, piece, LineStyle::Dashed, style)?;
            }
        }
    }
    Ok(())
}

/// The legend: one entry per named band, series and reference line, in that order.
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    panel: &Panel,
    position: SeriesLabelPosition,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    // Empty series carry the legend entries, so every entry appears once even when its data
    // is split into several drawn pieces or lies entirely outside the axes.
    for band in panel.bands.iter().filter(|b| !b.name.is_empty()) {
        let colour = band.colour.to_plotters();
        chart
            .draw_series(std::iter::empty::<Circle<Point, i32>>())
            .map_err(plot_error)?
            .label(band.name.as_str())
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 22, y + 6)], colour.mix(0.3).filled()));
    }
    for series in panel.series.iter().filter(|s| !s.name.is_empty()) {
        let colour = series.colour.unwrap_or(PALETTE[0]).to_plotters();
        let style = ShapeStyle { color: colour.to_rgba(), filled: false, stroke_width: series.width };
        let glyph = LegendGlyph::new(series.line, series.markers, style);
        chart
            .draw_series(std::iter::empty::<Circle<Point, i32>>())
            .map_err(plot_error)?
            .label(series.name.as_str())
            .legend(move |point| glyph.element::<DB>(point));
    }
    for reference in panel.references.iter().filter(|r| !r.name.is_empty()) {
        let style = ShapeStyle { color: reference.colour.to_plotters().to_rgba(), filled: false, stroke_width: 2 };
        let glyph = LegendGlyph::new(LineStyle::Dashed, false, style);
        chart
            .draw_series(std::iter::empty::<Circle<Point, i32>>())
            .map_err(plot_error)?
            .label(reference.name.as_str())
            .legend(move |point| glyph.element::<DB>(point));
    }
    chart
        .configure_series_labels()
        .position(position)
        .margin(8)
        .label_font(text_style(LEGEND_FONT))
        .background_style(WHITE.mix(0.88))
        .border_style(BLACK.mix(0.4))
        .draw()
        .map_err(plot_error)?;
    Ok(())
}

/// How sharply a line may turn before it is drawn as two strokes: the cosine of the angle
/// between the incoming and the outgoing direction. 0: turns of more than 90 deg, which a
/// smooth curve never makes between two samples, but a noisy trace does at every dip; the
/// pixel rounding of short segments makes a turn sharper on screen than it is in the data, so
/// the limit is not set closer to a full reversal.
const SHARP_TURN_COSINE: f64 = 0.0;

/// Splits a polyline where it turns back sharply as the reader sees it (in pixels), each part
/// keeping the turning point. plotters joins the segments of a line wider than a pixel with
/// mitres, and at a near reversal the inner mitre corner lies far beyond both segments: it
/// drew spikes outside the plot area (a stray tick below the Req. 5 axis). Two strokes that
/// meet at the point have no join to get wrong.
fn split_at_sharp_turns(points: &[Point], pixels_per_unit: (f64, f64)) -> Vec<Vec<Point>> {
    let direction = |a: Point, b: Point| {
        let (dx, dy) = ((b.0 - a.0) * pixels_per_unit.0, (b.1 - a.1) * pixels_per_unit.1);
        let length = dx.hypot(dy);
        (length > 0.0).then(|| (dx / length, dy / length))
    };
    let mut strokes = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    let mut incoming: Option<(f64, f64)> = None;
    for &p in points {
        if let Some(&last) = current.last() {
            if let Some(outgoing) = direction(last, p) {
                if incoming.is_some_and(|d| d.0 * outgoing.0 + d.1 * outgoing.1 < SHARP_TURN_COSINE) {
                    strokes.push(std::mem::replace(&mut current, vec![last]));
                }
                incoming = Some(outgoing);
            }
        }
        current.push(p);
    }
    if !current.is_empty() {
        strokes.push(current);
    }
    strokes
}

/// A linear plotters coordinate in plot coordinates whose tick positions are the ones computed
/// here (plotters' own log axis labels every 2..9 multiple and cannot be told otherwise).
#[derive(Debug, Clone, PartialEq)]
struct TickedRange {
    low: f64,
    high: f64,
    major: Vec<f64>,
    minor: Vec<f64>,
}

impl From<&Axis> for TickedRange {
    fn from(axis: &Axis) -> Self {
        Self { low: axis.low, high: axis.high, major: axis.major.clone(), minor: axis.minor.clone() }
    }
}

impl Ranged for TickedRange {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let fraction = (value - self.low) / (self.high - self.low);
        let pixels = f64::from(limit.1 - limit.0) * fraction;
        limit.0 + pixels.round() as i32
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.low..self.high
    }
}

type Chart<'a, DB> =
    plotters::chart::ChartContext<'a, DB, plotters::coord::cartesian::Cartesian2d<TickedRange, TickedRange>>;

fn draw_line<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    points: Vec<Point>,
    line: LineStyle,
    style: ShapeStyle,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    match line {
        LineStyle::Solid => chart.draw_series(LineSeries::new(points, style)).map(|_| ()),
        LineStyle::Dashed => chart.draw_series(DashedLineSeries::new(points, 9, 6, style)).map(|_| ()),
        LineStyle::Dotted => chart.draw_series(DashedLineSeries::new(points, 2, 5, style)).map(|_| ()),
        LineStyle::None => Ok(()),
    }
    .map_err(plot_error)
}

/// How to draw the small picture in front of a legend entry: the series' line style, with a
/// marker if it has markers. Every entry is drawn as the same composite (a dashed path and a
/// dot) so one closure type serves every style: a solid line is one dash as long as the
/// glyph, and the parts a style does not use are transparent.
struct LegendGlyph {
    dash: i32,
    gap: i32,
    line: ShapeStyle,
    marker: ShapeStyle,
}

impl LegendGlyph {
    const LENGTH: i32 = 24;

    fn new(line: LineStyle, markers: bool, style: ShapeStyle) -> Self {
        let transparent = ShapeStyle { color: TRANSPARENT.to_rgba(), filled: true, stroke_width: 0 };
        let (dash, gap, line_style) = match line {
            LineStyle::Solid => (Self::LENGTH, 1, style),
            LineStyle::Dashed => (7, 4, style),
            LineStyle::Dotted => (2, 4, style),
            LineStyle::None => (Self::LENGTH, 1, transparent),
        };
        let marker =
            if markers { ShapeStyle { color: style.color, filled: true, stroke_width: 1 } } else { transparent };
        Self { dash, gap, line: line_style, marker }
    }

    fn element<'a, DB: DrawingBackend + 'a>(&self, (x, y): (i32, i32)) -> impl IntoDynElement<'a, DB, (i32, i32)> + 'a {
        EmptyElement::at((x, y))
            + DashedPathElement::new(vec![(0, 0), (Self::LENGTH, 0)], self.dash, self.gap, self.line)
            + Circle::new((Self::LENGTH / 2, 0), 4, self.marker)
    }
}

/// Bode plot of one or more frequency responses: magnitude in dB (top) and unwrapped phase in
/// degrees (bottom) against log frequency in Hz. Each curve is (name, frequency_hz, response).
pub fn bode(title: &str, curves: &[(&str, &[f64], &[Complex64])]) -> Figure {
    let mut magnitude = Panel::new("Magnitude").x_label("Frequency (Hz)").y_label("Magnitude (dB)").log_x();
    let mut phase = Panel::new("Phase").x_label("Frequency (Hz)").y_label("Phase (deg)").log_x();
    for (name, frequency_hz, response) in curves {
        let db: Vec<f64> = response.iter().map(|h| 20.0 * h.norm().log10()).collect();
        let wrapped: Vec<f64> = response.iter().map(|h| h.arg().to_degrees()).collect();
        magnitude = magnitude.line(name, frequency_hz, &db);
        phase = phase.line(name, frequency_hz, &unwrap_phase_deg(&wrapped));
    }
    Figure::new(1000, 800).title(title).panel(magnitude).panel(phase)
}

/// A measured frequency response against its model, up to `max_frequency_hz`: magnitude in dB
/// (the panel `magnitude`, already labelled, which `decorate` may mark up further), unwrapped
/// phase and coherence (with the 0.9 line the comparisons use).
pub fn measured_against_model(
    title: &str,
    comparison: &ResponseComparison,
    max_frequency_hz: f64,
    magnitude: Panel,
    measured_label: &str,
    model_label: &str,
    decorate: impl FnOnce(Panel) -> Panel,
) -> Figure {
    let keep: Vec<usize> =
        (0..comparison.frequency_hz.len()).filter(|&i| comparison.frequency_hz[i] <= max_frequency_hz).collect();
    let f: Vec<f64> = keep.iter().map(|&i| comparison.frequency_hz[i]).collect();
    let db = |h: &[Complex64]| -> Vec<f64> { keep.iter().map(|&i| 20.0 * h[i].norm().log10()).collect() };
    let phase = |h: &[Complex64]| -> Vec<f64> {
        let wrapped: Vec<f64> = keep.iter().map(|&i| h[i].arg().to_degrees()).collect();
        unwrap_phase_deg(&wrapped)
    };
    let coherence: Vec<f64> = keep.iter().map(|&i| comparison.coherence[i]).collect();
    let magnitude = magnitude.log_x().line(measured_label, &f, &db(comparison.measured)).dashed(
        model_label,
        &f,
        &db(comparison.analytic),
    );
    Figure::new(1100, 1000)
        .title(title)
        .panel(decorate(magnitude))
        .panel(
            Panel::new("Phase")
                .x_label("Frequency (Hz)")
                .y_label("Phase (deg)")
                .log_x()
                .line("measured H1", &f, &phase(comparison.measured))
                .dashed(model_label, &f, &phase(comparison.analytic)),
        )
        .panel(
            Panel::new("Coherence")
                .x_label("Frequency (Hz)")
                .y_label("Coherence")
                .log_x()
                .y_range(0.0, 1.05)
                .line("measured", &f, &coherence)
                .horizontal_line("0.9", 0.9),
        )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn temp_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("antenna-tools-plot-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// Decodes a PNG file and returns its size and RGB(A) pixels.
    fn decode_png(path: &Path) -> (u32, u32, Vec<u8>, png::ColorType) {
        let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut pixels).unwrap();
        pixels.truncate(info.buffer_size());
        (info.width, info.height, pixels, info.color_type)
    }

    fn contains_colour(rgb: &[u8], colour: Colour) -> bool {
        rgb.chunks(3).any(|p| p == [colour.r, colour.g, colour.b])
    }

    #[test]
    fn stacked_panels_with_bands_write_a_png_of_the_requested_size() {
        let f: Vec<f64> = (1..400).map(|i| i as f64 * 0.05).collect();
        let psd: Vec<f64> = f.iter().map(|v| 0.1 * v.powf(-5.0 / 3.0)).collect();
        let lower: Vec<f64> = psd.iter().map(|p| 0.7 * p).collect();
        let upper: Vec<f64> = psd.iter().map(|p| 1.5 * p).collect();
        let t: Vec<f64> = (0..500).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|v| v.sin()).collect();
        let figure = Figure::new(900, 700)
            .title("Test figure")
            .panel(
                Panel::new("Spectrum")
                    .x_label("Frequency (Hz)")
                    .y_label("PSD (m²/s²/Hz)")
                    .log_x()
                    .log_y()
                    .line_with_band("estimate", &f, &psd, &lower, &upper, "95 % interval")
                    .dashed("model", &f, &upper)
                    .vertical_line("peak", 1.0),
            )
            .panel(Panel::new("Time series").x_label("Time (s)").y_label("Speed (m/s)").line("sine", &t, &y));
        let dir = temp_dir("stacked");
        let path = dir.join("stacked.png");
        figure.save_png(&path).unwrap();
        let (width, height, pixels, colour_type) = decode_png(&path);
        assert_eq!((width, height), (900, 700));
        assert_eq!(colour_type, png::ColorType::Rgb);
        // The first palette colour (the estimate) and the second (the model) are both drawn.
        assert!(contains_colour(&pixels, PALETTE[0]));
        assert!(contains_colour(&pixels, PALETTE[1]));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn bode_is_a_one_liner_that_writes_a_png() {
        let f: Vec<f64> = (1..200).map(|i| 0.01 * 1.05f64.powi(i)).collect();
        let h: Vec<Complex64> =
            f.iter().map(|v| Complex64::new(1.0, 0.0) / Complex64::new(1.0 - v * v, 0.2 * v)).collect();
        let dir = temp_dir("bode");
        let path = dir.join("bode.png");
        bode("Second-order system", &[("H", &f, &h)]).save_png(&path).unwrap();
        let (width, height, pixels, _) = decode_png(&path);
        assert_eq!((width, height), (1000, 800));
        assert!(contains_colour(&pixels, PALETTE[0]));
        std::fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn rendering_without_a_file_shows_each_series_in_its_palette_colour() {
        let x = [0.0, 1.0, 2.0];
        let figure = Figure::new(400, 300).panel(
            Panel::new("")
                .line("a", &x, &[0.0, 1.0, 0.0])
                .line("b", &x, &[1.0, 0.0, 1.0])
                .legend(LegendPosition::Hidden),
        );
        let rgb = figure.render_rgb().unwrap();
        assert_eq!(rgb.len(), 400 * 300 * 3);
        assert!(contains_colour(&rgb, PALETTE[0]) && contains_colour(&rgb, PALETTE[1]));
        assert!(!contains_colour(&rgb, PALETTE[2]));
    }

    #[test]
    fn auto_range_ignores_nan_infinity_and_non_positive_values_on_log_axes() {
        let panel = Panel::new("")
            .log_y()
            .line("a", &[1.0, 2.0, 3.0, 4.0, 5.0], &[1.0, 100.0, -1.0, 0.0, f64::NAN])
            .line("b", &[f64::INFINITY, 6.0], &[1e6, 10.0]);
        let (xs, ys) = extent_values(&panel);
        let x_axis = Axis::new(panel.x_scale, &xs, None, 5);
        let y_axis = Axis::new(panel.y_scale, &ys, None, 5);
        assert!(x_axis.low < 1.0 && x_axis.low > 0.7 && x_axis.high > 6.0 && x_axis.high < 6.3, "{x_axis:?}");
        // y covers log10 1 = 0 to log10 100 = 2, padded by 4 %.
        assert!((y_axis.low + 0.08).abs() < 1e-12 && (y_axis.high - 2.08).abs() < 1e-12, "{y_axis:?}");
        assert_eq!(y_axis.major, vec![0.0, 1.0, 2.0]);
    }

    #[test]
    fn fixed_ranges_override_auto_ranging() {
        let axis = Axis::new(Scale::Log, &[-5.0, 5.0], Some((0.01, 100.0)), 5);
        assert_eq!((axis.low, axis.high), (-2.0, 2.0));
        let linear = Axis::new(Scale::Linear, &[], Some((-1.0, 1.0)), 5);
        assert_eq!(linear.major, vec![-1.0, -0.5, 0.0, 0.5, 1.0]);
    }

    #[test]
    fn linear_ticks_are_round_numbers() {
        let (major, _, step) = linear_ticks(0.0, 0.97, 5);
        assert_eq!(step, 0.2);
        assert_eq!(major.len(), 5);
        assert_eq!(format_linear(major[3], step), "0.6");
        assert_eq!(format_linear(1234.0, 500.0), "1234");
        assert_eq!(format_linear(2.5e-6, 5e-7), "2.5e-6");
    }

    #[test]
    fn log_ticks_label_decades_or_one_two_five() {
        let (major, minor) = log_ticks(-3.2, 1.1);
        assert_eq!(major, vec![-3.0, -2.0, -1.0, 0.0, 1.0]);
        assert!(minor.contains(&2f64.log10()));
        let (short, _) = log_ticks(0.0, 1.0);
        assert_eq!(short, vec![0.0, 2f64.log10(), 5f64.log10(), 1.0]);
        let (wide, _) = log_ticks(-6.0, 6.0);
        assert_eq!(wide, vec![-6.0, -4.0, -2.0, 0.0, 2.0, 4.0, 6.0]);
    }

    #[test]
    fn log_labels_are_decimals_near_one_and_powers_of_ten_beyond() {
        assert_eq!(format_log(-3.0), "0.001");
        assert_eq!(format_log(0.0), "1");
        assert_eq!(format_log(2f64.log10() + 1.0), "20");
        assert_eq!(format_log(4.0), "10000");
        assert_eq!(format_log(-5.0), "10⁻⁵");
        assert_eq!(format_log(5f64.log10() + 6.0), "5×10⁶");
    }

    #[test]
    fn lines_are_clipped_to_the_plot_area() {
        let rect = Rect { x_low: 0.0, x_high: 1.0, y_low: 0.0, y_high: 1.0 };
        let pieces = clip_polyline(&[(-1.0, 0.5), (0.5, 0.5), (0.5, 2.0), (0.8, 0.2)], &rect);
        assert_eq!(pieces.len(), 2, "{pieces:?}");
        assert_eq!(pieces[0], vec![(0.0, 0.5), (0.5, 0.5), (0.5, 1.0)]);
        assert!(pieces[1].iter().all(|p| rect.contains(*p)));
        assert!(clip_polyline(&[(2.0, 2.0), (3.0, 3.0)], &rect).is_empty());
    }

    #[test]
    fn polygons_are_clipped_to_the_plot_area() {
        let rect = Rect { x_low: 0.0, x_high: 1.0, y_low: 0.0, y_high: 1.0 };
        let clipped = clip_polygon(&[(0.5, -1.0), (2.0, 0.5), (0.5, 2.0), (-1.0, 0.5)], &rect);
        assert!(clipped.iter().all(|p| rect.contains(*p)));
        // The diamond covers the whole unit square except its four corner triangles.
        let area: f64 = (0..clipped.len())
            .map(|i| {
                let (a, b) = (clipped[i], clipped[(i + 1) % clipped.len()]);
                a.0 * b.1 - b.0 * a.1
            })
            .sum::<f64>()
            .abs()
            / 2.0;
        assert!((area - 1.0).abs() < 1e-12, "area {area}");
    }

    #[test]
    fn log_band_reaching_zero_extends_to_the_bottom_of_the_axis() {
        let band = Band {
            name: String::new(),
            x: vec![1.0, 10.0],
            lower: vec![0.0, 1.0],
            upper: vec![10.0, 10.0],
            colour: PALETTE[0],
        };
        let polygons = band_polygons(&band, Scale::Log, Scale::Log, -5.0);
        assert_eq!(polygons, vec![vec![(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, -5.0)]]);
    }

    #[test]
    fn legend_goes_to_the_emptiest_corner() {
        // A falling line leaves the upper right and lower left corners empty; upper right is
        // preferred when corners tie.
        let panel = Panel::new("").line("falling", &[0.0, 1.0], &[1.0, 0.0]);
        let (xs, ys) = extent_values(&panel);
        let x_axis = Axis::new(Scale::Linear, &xs, None, 5);
        let y_axis = Axis::new(Scale::Linear, &ys, None, 5);
        let points = occupancy_points(&panel, &x_axis, &y_axis);
        assert_eq!(choose_legend_corner(&points, (0.3, 0.2)).0, SeriesLabelPosition::UpperRight);
        let rising = Panel::new("").line("rising", &[0.0, 1.0], &[0.0, 1.0]).line("flat top", &[0.0, 1.0], &[1.0, 1.0]);
        let (xs, ys) = extent_values(&rising);
        let points =
            occupancy_points(&rising, &Axis::new(Scale::Linear, &xs, None, 5), &Axis::new(Scale::Linear, &ys, None, 5));
        assert_eq!(choose_legend_corner(&points, (0.3, 0.2)).0, SeriesLabelPosition::LowerRight);
    }

    #[test]
    fn a_crowded_panel_makes_room_for_its_legend_above_the_data() {
        let x: Vec<f64> = (0..400).map(f64::from).collect();
        let y: Vec<f64> = x.iter().map(|v| (v * 0.7).sin() + 0.3 * (v * 2.3).cos()).collect();
        let panel = Panel::new("").line("noise", &x, &y);
        let (xs, ys) = extent_values(&panel);
        let x_axis = Axis::new(Scale::Linear, &xs, None, 5);
        let y_axis = Axis::new(Scale::Linear, &ys, None, 5);
        let fraction = (0.25, 0.2);
        assert!(choose_legend_corner(&occupancy_points(&panel, &x_axis, &y_axis), fraction).1 > LEGEND_CROWDED);
        let (corner, raised) = place_legend(&panel, &x_axis, y_axis.clone(), fraction, 5);
        assert!(raised.high > y_axis.high && raised.low == y_axis.low);
        let (_, crowding) = choose_legend_corner(&occupancy_points(&panel, &x_axis, &raised), fraction);
        assert_eq!(crowding, 0.0);
        assert!(matches!(corner, SeriesLabelPosition::UpperRight | SeriesLabelPosition::UpperLeft));
        // A fixed range is respected even when crowded.
        let fixed = panel.clone().y_range(-2.0, 2.0);
        let fixed_axis = Axis::new(Scale::Linear, &ys, fixed.y_range, 5);
        assert_eq!(place_legend(&fixed, &x_axis, fixed_axis.clone(), fraction, 5).1, fixed_axis);
    }

    #[test]
    fn unusable_figures_are_errors_not_panics() {
        assert!(Figure::new(800, 600).render_rgb().is_err(), "no panels");
        assert!(Figure::new(50, 50).panel(Panel::new("")).render_rgb().is_err(), "too small");
        let missing_dir = std::env::temp_dir().join("antenna-tools-no-such-dir").join("x").join("plot.png");
        assert!(Figure::new(400, 300)
            .panel(Panel::new("").line("a", &[0.0, 1.0], &[0.0, 1.0]))
            .save_png(missing_dir)
            .is_err());
    }

    #[test]
    fn a_line_that_turns_back_sharply_is_drawn_as_two_strokes_meeting_at_the_turn() {
        let spike = [(0.0, 1.0), (1.0, 1.0), (1.05, -3.0), (1.1, 1.0), (2.0, 1.0)];
        let strokes = split_at_sharp_turns(&spike, (10.0, 100.0));
        assert_eq!(strokes, vec![spike[..3].to_vec(), spike[2..].to_vec()]);
        let gentle = [(0.0, 0.0), (1.0, 1.0), (2.0, 1.5), (3.0, 1.0)];
        assert_eq!(split_at_sharp_turns(&gentle, (10.0, 10.0)), vec![gentle.to_vec()]);
    }

    #[test]
    fn a_noisy_line_on_a_log_axis_leaves_nothing_below_the_plot_area() {
        // 70 s of a pointing error at 100 Hz that keeps dipping to the 0.001 arcsec floor and
        // straight back, as the Req. 5 errors do: with mitred joins such dips drew spikes
        // through the x axis into the tick labels.
        let t: Vec<f64> = (0..7000).map(|k| 0.01 * k as f64).collect();
        let mut state: u64 = 1;
        let y: Vec<f64> = t
            .iter()
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let uniform = (state >> 11) as f64 / (1u64 << 53) as f64;
                10f64.powf(-3.0 + 2.5 * uniform)
            })
            .collect();
        let figure = Figure::new(1100, 600).panel(
            Panel::new("Req. 5 pointing error on the sky")
                .x_label("time (s)")
                .y_label("pointing error (arcsec)")
                .log_y()
                .y_range(7e-4, 2e4)
                .line("noisy", &t, &y),
        );
        let pixels = figure.render_rgb().unwrap();
        let (width, height) = figure.size();
        // Below the x axis (the last X_LABEL_AREA + MARGIN rows hold tick labels and the axis
        // title in black and grey) no pixel has the series' colour.
        let colour = PALETTE[0];
        let below_axis = (height - X_LABEL_AREA - MARGIN + 4)..height;
        let painted = below_axis
            .flat_map(|row| (0..width).map(move |column| ((row * width + column) * 3) as usize))
            .filter(|&i| pixels[i] == colour.r && pixels[i + 1] == colour.g && pixels[i + 2] == colour.b)
            .count();
        assert_eq!(painted, 0);
    }
}
