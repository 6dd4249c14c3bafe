//! Shared plumbing of the figure builders: fonts, colours, legends, axis ranges and the
//! two-backend (SVG + PNG) renderer.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use crate::error::{Error, Result};

/// The files written by one figure builder.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureFiles {
    /// The vector figure, `<stem>.svg`.
    pub svg: PathBuf,
    /// The raster figure, `<stem>.png`, same size in pixels as the SVG.
    pub png: PathBuf,
    /// Number of non-finite input values (NaN, ±inf) that were left out of the figure.
    pub skipped_non_finite: usize,
}

/// Font family name under which DejaVu Sans is registered for plotters.
pub(crate) const FONT: &str = "sans-serif";

static FONTS: Once = Once::new();

/// Registers DejaVu Sans regular and bold (from the `dejavu` crate, embedded bytes; fonts under
/// the Bitstream Vera licence, DejaVu changes public domain) as plotters' `sans-serif`. Other
/// styles fall back to regular.
///
/// The bitmap backend rasterizes text with ab_glyph, which has no system font lookup; the SVG
/// backend also uses the registered metrics to lay out labels.
pub(crate) fn ensure_fonts() {
    FONTS.call_once(|| {
        // The bytes are a valid TrueType font shipped by the crate: failure is a build defect,
        // not user input, and would show as missing text rather than a panic.
        let _ = register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

/// A drawing failure, with the backend's message.
#[derive(Debug)]
pub(crate) struct DrawError(pub String);

impl<E: std::error::Error + Send + Sync> From<DrawingAreaErrorKind<E>> for DrawError {
    fn from(e: DrawingAreaErrorKind<E>) -> Self {
        DrawError(e.to_string())
    }
}

/// Result of drawing on one backend.
pub(crate) type DrawResult = std::result::Result<(), DrawError>;

/// A figure that can be drawn on any plotters backend (drawn twice: SVG then PNG).
pub(crate) trait Figure {
    /// Canvas size, pixels.
    fn size(&self) -> (u32, u32);
    /// Draws the whole figure on `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult;
}

/// Checks that a file stem is a plain file name (no directory part, not empty).
fn check_stem(stem: &str) -> Result<()> {
    if stem.is_empty() || stem.contains('/') || stem.contains('\\') || stem == "." || stem == ".." {
        return Err(Error::InvalidStem {
            stem: stem.to_string(),
        });
    }
    Ok(())
}

/// Writes `<dir>/<stem>.svg` and `<dir>/<stem>.png` for `fig`.
pub(crate) fn render(
    dir: &Path,
    stem: &str,
    fig: &impl Figure,
    skipped_non_finite: usize,
) -> Result<FigureFiles> {
    check_stem(stem)?;
    ensure_fonts();
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let svg = dir.join(format!("{stem}.svg"));
    let png = dir.join(format!("{stem}.png"));
    let (w, h) = fig.size();
    if w == 0 || h == 0 {
        return Err(Error::InvalidFigure {
            figure: stem.to_string(),
            message: format!("empty canvas {w}x{h}"),
        });
    }
    let fail = |path: &Path, e: DrawError| Error::Render {
        path: path.to_path_buf(),
        message: e.0,
    };
    {
        let root = SVGBackend::new(&svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(&svg, e.into()))?;
        fig.draw(&root).map_err(|e| fail(&svg, e))?;
        root.present().map_err(|e| fail(&svg, e.into()))?;
    }
    {
        let root = BitMapBackend::new(&png, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(&png, e.into()))?;
        fig.draw(&root).map_err(|e| fail(&png, e))?;
        root.present().map_err(|e| fail(&png, e.into()))?;
    }
    Ok(FigureFiles {
        svg,
        png,
        skipped_non_finite,
    })
}

// ---------------------------------------------------------------- text sizes

/// Figure title.
pub(crate) fn title_style() -> TextStyle<'static> {
    title_style_sized(TITLE_SIZE)
}
/// The title's size in drawing units.
const TITLE_SIZE: f64 = 26.0;
/// A bold sans-serif glyph's mean advance, as a share of the font size: an estimate on the
/// wide side, since a viewer picks its own sans-serif font and a title too long is clipped.
const TITLE_ADVANCE: f64 = 0.62;
fn title_style_sized(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().style(FontStyle::Bold).into()
}
/// The title's style for a canvas `width` wide: its own size where it fits, else smaller
/// (down to 14) so that a long dataset name does not push it off both edges.
pub(crate) fn title_style_fitting(title: &str, width: u32) -> TextStyle<'static> {
    let needed = title.chars().count() as f64 * TITLE_ADVANCE * TITLE_SIZE;
    let room = width.saturating_sub(16) as f64;
    if needed <= room {
        title_style()
    } else {
        title_style_sized((TITLE_SIZE * room / needed).max(14.0))
    }
}
/// Panel caption.
pub(crate) fn caption_style() -> TextStyle<'static> {
    (FONT, 20).into_font().into()
}
/// Axis description (quantity and unit).
pub(crate) fn axis_desc_style() -> TextStyle<'static> {
    (FONT, 18).into_font().into()
}
/// Tick labels.
pub(crate) fn tick_style() -> TextStyle<'static> {
    (FONT, 15).into_font().into()
}
/// Small annotations (sample counts, line labels).
pub(crate) fn note_style() -> TextStyle<'static> {
    (FONT, 14).into_font().into()
}

/// Height of the figure title band, pixels.
pub(crate) const TITLE_H: u32 = 44;
/// Height of the legend band, pixels.
pub(crate) const LEGEND_H: u32 = 34;

/// Formats a tick value compactly (no trailing zeros, no `-0`).
pub(crate) fn fmt_tick(v: &f64) -> String {
    let v = if v.abs() < 1e-12 { 0.0 } else { *v };
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        return format!("{v:.1e}");
    }
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

// ---------------------------------------------------------------- colours

/// Colours of the paper's terrain figures (asphalt grey, grass green, gravel brown, sand
/// orange, ice blue) and a few more; matched case-insensitively as a word inside a label.
const KEYWORD_COLOURS: &[(&str, RGBColor)] = &[
    ("asphalt", RGBColor(127, 127, 127)),
    ("grass", RGBColor(44, 160, 44)),
    ("gravel", RGBColor(140, 86, 75)),
    ("sand", RGBColor(255, 127, 14)),
    ("ice", RGBColor(31, 119, 180)),
    ("snow", RGBColor(23, 190, 207)),
    ("mud", RGBColor(90, 60, 30)),
    ("concrete", RGBColor(188, 189, 34)),
    ("warthog", RGBColor(230, 120, 20)),
    ("husky", RGBColor(225, 190, 30)),
    ("sim", RGBColor(148, 103, 189)),
    ("ideal", RGBColor(0, 0, 0)),
];

/// Fallback cycle for labels without a keyword: none of the keyword colours, so that an
/// unknown terrain never looks like a known one.
const CYCLE: &[RGBColor] = &[
    RGBColor(214, 39, 40),
    RGBColor(27, 158, 119),
    RGBColor(117, 112, 179),
    RGBColor(231, 41, 138),
    RGBColor(128, 0, 0),
    RGBColor(85, 107, 47),
    RGBColor(227, 119, 194),
];

/// Colour of the pooled "all" group: white boxes with black outlines, as in the paper.
pub(crate) const ALL_COLOUR: RGBColor = RGBColor(255, 255, 255);

fn words(label: &str) -> impl Iterator<Item = String> + '_ {
    label
        .split(|c: char| !c.is_alphanumeric())
        .filter(|w| !w.is_empty())
        .map(|w| w.to_lowercase())
}

/// The colour a scenario label gets in every figure.
///
/// Labels naming a terrain (`"ice"`, `"Warthog asphalt"`, ...) get the paper's terrain colour;
/// `"all"` is white; other labels get a colour from a fixed cycle chosen by a stable hash of the
/// label, so the same label has the same colour in every figure and every run.
pub fn scenario_colour(label: &str) -> RGBColor {
    if words(label).any(|w| w == "all") {
        return ALL_COLOUR;
    }
    // Keywords in table order: a terrain wins over a robot name in "Warthog ice".
    let ws: Vec<String> = words(label).collect();
    if let Some((_, c)) = KEYWORD_COLOURS.iter().find(|(k, _)| ws.iter().any(|w| w == k)) {
        return *c;
    }
    // FNV-1a: stable across runs and platforms, unlike std's RandomState.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in label.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    CYCLE[(h % CYCLE.len() as u64) as usize]
}

/// Colours for the series of one figure: [`scenario_colour`] unless two different labels would
/// share a colour, in which case the later one takes the next unused colour of the cycle.
pub(crate) fn assign_colours<S: AsRef<str>>(labels: &[S]) -> Vec<RGBColor> {
    let mut out: Vec<RGBColor> = Vec::with_capacity(labels.len());
    for (i, l) in labels.iter().enumerate() {
        let mut c = scenario_colour(l.as_ref());
        let clash = |c: &RGBColor, out: &[RGBColor]| {
            out.iter()
                .zip(labels)
                .any(|(o, ol)| o == c && ol.as_ref() != l.as_ref())
        };
        if clash(&c, &out[..i]) {
            if let Some(free) = CYCLE.iter().find(|k| !clash(k, &out[..i]) && !out.contains(k)) {
                c = *free;
            }
        }
        out.push(c);
    }
    out
}

/// Outline colour for a fill colour: black for white/light fills so that they stay visible.
pub(crate) fn outline_for(c: RGBColor) -> RGBColor {
    let lum = 0.299 * f64::from(c.0) + 0.587 * f64::from(c.1) + 0.114 * f64::from(c.2);
    if lum > 200.0 {
        BLACK
    } else {
        c
    }
}

/// Colour maps for values drawn as colours (heat maps, coloured scatter).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ColourMap {
    /// Sequential, perceptually uniform (matplotlib's viridis); for ρ and magnitudes.
    #[default]
    Viridis,
    /// Blue-white-red (Moreland's cool-warm), centred on zero; for signed slips.
    Diverging,
}

const VIRIDIS: &[(u8, u8, u8)] = &[
    (68, 1, 84),
    (70, 50, 127),
    (54, 92, 141),
    (39, 127, 143),
    (31, 162, 136),
    (74, 194, 110),
    (160, 219, 57),
    (254, 232, 37),
];
const COOL_WARM: &[(u8, u8, u8)] = &[
    (59, 76, 192),
    (124, 159, 249),
    (192, 212, 245),
    (242, 242, 242),
    (242, 203, 183),
    (238, 132, 104),
    (180, 4, 38),
];

impl ColourMap {
    /// Colour at `t` in [0, 1] (clamped; NaN maps to the low end).
    pub fn at(self, t: f64) -> RGBColor {
        let table = match self {
            ColourMap::Viridis => VIRIDIS,
            ColourMap::Diverging => COOL_WARM,
        };
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let x = t * (table.len() - 1) as f64;
        let i = (x.floor() as usize).min(table.len() - 2);
        let f = x - i as f64;
        let lerp = |a: u8, b: u8| (f64::from(a) + f * (f64::from(b) - f64::from(a))).round() as u8;
        let (a, b) = (table[i], table[i + 1]);
        RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
    }

    /// Default colour range for data spanning `[lo, hi]`: symmetric about zero for the
    /// diverging map, the data range otherwise (widened when degenerate).
    pub(crate) fn default_range(self, lo: f64, hi: f64) -> (f64, f64) {
        match self {
            ColourMap::Viridis => widen(lo, hi),
            ColourMap::Diverging => {
                let m = lo.abs().max(hi.abs());
                if m > 0.0 {
                    (-m, m)
                } else {
                    (-1.0, 1.0)
                }
            }
        }
    }
}

// ---------------------------------------------------------------- ranges

/// Widens a degenerate range (`lo == hi`) so that axes and colour scales stay valid.
pub(crate) fn widen(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    // Keep spans (and 5 % margins) finite: axis tick generation loops on infinite spans.
    const LIM: f64 = f64::MAX / 8.0;
    let (lo, hi) = (lo.clamp(-LIM, LIM), hi.clamp(-LIM, LIM));
    if hi > lo {
        (lo, hi)
    } else {
        let d = if lo.abs() > 0.0 { lo.abs() * 0.1 } else { 0.5 };
        (lo - d, hi + d)
    }
}

/// Min and max of the finite values, if any.
pub(crate) fn finite_extent(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Axis range covering the finite `values` with a 5 % margin on each side.
pub(crate) fn padded(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = finite_extent(values).unwrap_or((0.0, 1.0));
    let (lo, hi) = widen(lo, hi);
    let m = 0.05 * (hi - lo);
    (lo - m, hi + m)
}

// ---------------------------------------------------------------- legend

/// How a legend entry's swatch is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Swatch {
    /// A filled dot.
    Dot,
    /// A solid line.
    Line,
    /// A dashed line.
    Dashed,
    /// A filled square with an outline.
    Square,
}

/// One legend entry.
pub(crate) struct LegendEntry {
    pub label: String,
    pub colour: RGBColor,
    pub swatch: Swatch,
}

impl LegendEntry {
    pub(crate) fn new(label: impl Into<String>, colour: RGBColor, swatch: Swatch) -> Self {
        Self {
            label: label.into(),
            colour,
            swatch,
        }
    }
}

/// Legend text font.
fn legend_font() -> FontDesc<'static> {
    (FONT, 16).into_font()
}

const SWATCH_W: i32 = 26;
const LEGEND_GAP: i32 = 22;

/// Width of each entry and the greedy line breaking of the legend at canvas width `width`.
fn legend_layout(width: u32, entries: &[LegendEntry]) -> (Vec<i32>, Vec<Vec<usize>>) {
    ensure_fonts();
    let font = legend_font();
    let widths: Vec<i32> = entries
        .iter()
        .map(|e| {
            let tw = font
                .box_size(&e.label)
                .map(|(x, _)| x as i32)
                .unwrap_or(9 * e.label.chars().count() as i32);
            SWATCH_W + 6 + tw
        })
        .collect();
    let mut lines: Vec<Vec<usize>> = vec![];
    let mut used = 0;
    for (i, wi) in widths.iter().enumerate() {
        if lines.is_empty() || used + LEGEND_GAP + wi > width as i32 - 20 {
            lines.push(vec![i]);
            used = *wi;
        } else {
            used += LEGEND_GAP + wi;
            if let Some(l) = lines.last_mut() {
                l.push(i);
            }
        }
    }
    (widths, lines)
}

/// Draws the legend centred in its own band (outside the plots, so it never covers data),
/// wrapping onto several lines when wide.
pub(crate) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
) -> DrawResult {
    if entries.is_empty() {
        return Ok(());
    }
    let (w, _) = area.dim_in_pixel();
    let (widths, lines) = legend_layout(w, entries);
    let sw = SWATCH_W;
    let line_h = LEGEND_H as i32;
    for (li, line) in lines.iter().enumerate() {
        let total: i32 = line.iter().map(|&i| widths[i]).sum::<i32>() + LEGEND_GAP * (line.len() as i32 - 1);
        let mut x = (w as i32 - total) / 2;
        let y = line_h * li as i32 + line_h / 2;
        for &i in line {
            let e = &entries[i];
            let c = e.colour;
            match e.swatch {
                Swatch::Dot => {
                    area.draw(&Circle::new((x + sw / 2, y), 5, c.filled()))?;
                    area.draw(&Circle::new((x + sw / 2, y), 5, outline_for(c)))?;
                }
                Swatch::Line => {
                    area.draw(&PathElement::new(vec![(x, y), (x + sw, y)], c.stroke_width(3)))?;
                }
                Swatch::Dashed => {
                    for k in 0..3 {
                        let x0 = x + k * 10;
                        area.draw(&PathElement::new(vec![(x0, y), (x0 + 6, y)], c.stroke_width(3)))?;
                    }
                }
                Swatch::Square => {
                    area.draw(&Rectangle::new([(x + 4, y - 8), (x + sw - 4, y + 8)], c.filled()))?;
                    area.draw(&Rectangle::new(
                        [(x + 4, y - 8), (x + sw - 4, y + 8)],
                        BLACK.stroke_width(1),
                    ))?;
                }
            }
            area.draw(&Text::new(
                e.label.clone(),
                (x + sw + 6, y),
                TextStyle::from(legend_font()).pos(Pos::new(HPos::Left, VPos::Center)),
            ))?;
            x += widths[i] + LEGEND_GAP;
        }
    }
    Ok(())
}

/// Height of the legend band for `entries` at canvas width `width`, pixels (0 if no entry).
pub(crate) fn legend_height(width: u32, entries: &[LegendEntry]) -> u32 {
    if entries.is_empty() {
        0
    } else {
        LEGEND_H * legend_layout(width, entries).1.len() as u32
    }
}

/// Splits the root into a title band, a legend band and the body; draws title and legend.
pub(crate) fn title_legend_body<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    legend: &[LegendEntry],
) -> std::result::Result<DrawingArea<DB, Shift>, DrawError> {
    let (w, _) = root.dim_in_pixel();
    let (top, rest) = root.split_vertically(TITLE_H);
    top.draw(&Text::new(
        title.to_string(),
        (w as i32 / 2, TITLE_H as i32 / 2 + 2),
        title_style_fitting(title, w).pos(Pos::new(HPos::Center, VPos::Center)),
    ))?;
    let lh = legend_height(w, legend);
    if lh == 0 {
        return Ok(rest);
    }
    let (leg, body) = rest.split_vertically(lh);
    draw_legend(&leg, legend)?;
    Ok(body)
}

/// Total canvas height for a body of `body_h` pixels under the title and legend bands.
pub(crate) fn canvas_height(body_h: u32, width: u32, legend: &[LegendEntry]) -> u32 {
    TITLE_H + legend_height(width, legend) + body_h
}

// ---------------------------------------------------------------- axes

/// A numeric axis, linear or logarithmic, with round tick values on both: plotters' own
/// log axis puts too few labels on spans of one or two decades.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ScaledAxis {
    lo: f64,
    hi: f64,
    log: bool,
}

impl ScaledAxis {
    /// Linear axis over `[lo, hi]` (widened when degenerate).
    pub(crate) fn linear(lo: f64, hi: f64) -> Self {
        let (lo, hi) = widen(lo, hi);
        Self { lo, hi, log: false }
    }
    /// Logarithmic axis over `[lo, hi]`, both positive (fixed up to a decade around 1 when not).
    pub(crate) fn log(lo: f64, hi: f64) -> Self {
        let ok = lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo;
        let (lo, hi) = if ok {
            (lo, hi)
        } else if lo.is_finite() && lo > 0.0 {
            (lo / 2.0, lo * 2.0)
        } else {
            (1.0, 10.0)
        };
        Self { lo, hi, log: true }
    }
    fn t(&self, v: f64) -> f64 {
        if self.log {
            let v = v.max(self.lo * 1e-12);
            (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
}

impl Ranged for ScaledAxis {
    type FormatOption = plotters::coord::ranged1d::NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        // Clamp so that far-away points cannot overflow pixel coordinates.
        let t = self.t(*value).clamp(-100.0, 100.0);
        limit.0 + (t * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if !self.log {
            let inner: plotters::coord::types::RangedCoordf64 = (self.lo..self.hi).into();
            return inner.key_points(hint);
        }
        let max = hint.max_num_points().max(2);
        let d0 = self.lo.log10().floor() as i32;
        let d1 = self.hi.log10().ceil() as i32;
        // Richest mantissa set that fits the hint: 1-2-5, then 1 per decade, then every k-th.
        for mantissas in [&[1.0, 2.0, 5.0][..], &[1.0][..]] {
            let pts: Vec<f64> = (d0..=d1)
                .flat_map(|d| mantissas.iter().map(move |m| m * 10f64.powi(d)))
                .filter(|v| *v >= self.lo * (1.0 - 1e-12) && *v <= self.hi * (1.0 + 1e-12))
                .collect();
            if pts.len() <= max && pts.len() >= 2 {
                return pts;
            }
            if pts.len() < 2 && mantissas.len() == 3 {
                // Less than one 1-2-5 step in range: every integer mantissa.
                let fine: Vec<f64> = (d0..=d1)
                    .flat_map(|d| (1..10).map(move |m| f64::from(m) * 10f64.powi(d)))
                    .filter(|v| *v >= self.lo && *v <= self.hi)
                    .collect();
                if fine.len() <= max {
                    return fine;
                }
                return pts;
            }
        }
        let step = ((d1 - d0) as usize).div_ceil(max).max(1);
        (d0..=d1)
            .step_by(step)
            .map(|d| 10f64.powi(d))
            .filter(|v| *v >= self.lo && *v <= self.hi)
            .collect()
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.lo..self.hi
    }
}

impl plotters::coord::ranged1d::ValueFormatter<f64> for ScaledAxis {
    fn format_ext(&self, value: &f64) -> String {
        fmt_tick(value)
    }
}

/// The Cartesian chart every panel uses.
pub(crate) type XyChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<ScaledAxis, ScaledAxis>>;

/// Builds a panel with linear axes: caption, x/y ranges, light grid, tick labels and axis
/// descriptions.
pub(crate) fn xy_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    x: (f64, f64),
    y: (f64, f64),
    x_desc: &str,
    y_desc: &str,
) -> std::result::Result<XyChart<'a, DB>, DrawError> {
    xy_chart_scaled(
        area,
        caption,
        ScaledAxis::linear(x.0, x.1),
        ScaledAxis::linear(y.0, y.1),
        x_desc,
        y_desc,
    )
}

/// Builds a panel on given (linear or logarithmic) axes.
pub(crate) fn xy_chart_scaled<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: &str,
    x: ScaledAxis,
    y: ScaledAxis,
    x_desc: &str,
    y_desc: &str,
) -> std::result::Result<XyChart<'a, DB>, DrawError> {
    let mut b = ChartBuilder::on(area);
    b.margin(12)
        .margin_right(22)
        .x_label_area_size(52)
        .y_label_area_size(66);
    if !caption.is_empty() {
        b.caption(caption, caption_style());
    }
    let mut chart = b.build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .axis_style(BLACK.stroke_width(1))
        .label_style(tick_style())
        .axis_desc_style(axis_desc_style())
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(8)
        .y_labels(8)
        .draw()?;
    Ok(chart)
}

/// Draws a "no data" note in the middle of a panel.
pub(crate) fn no_data<DB: DrawingBackend>(chart: &mut XyChart<'_, DB>, what: &str) -> DrawResult {
    let (x, y) = (chart.x_range(), chart.y_range());
    chart.draw_series(std::iter::once(Text::new(
        format!("no data{what}"),
        ((x.start + x.end) / 2.0, (y.start + y.end) / 2.0),
        caption_style()
            .pos(Pos::new(HPos::Center, VPos::Center))
            .color(&BLACK.mix(0.5)),
    )))?;
    Ok(())
}

/// Closes a polygon (repeats the first vertex at the end) for drawing as a path.
pub(crate) fn closed(poly: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut v = poly.to_vec();
    if let Some(&p) = poly.first() {
        v.push(p);
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::coord::ranged1d::Ranged;

    #[test]
    fn log_axis_ticks_are_round() {
        let a = ScaledAxis::log(10.0, 250.0);
        assert_eq!(a.key_points(8usize), vec![10.0, 20.0, 50.0, 100.0, 200.0]);
        // Six decades with room for 4 labels: one label every other decade.
        let b = ScaledAxis::log(1.0, 1e6);
        let k = b.key_points(4usize);
        assert!(k.len() <= 4 && k.len() >= 2, "{k:?}");
        assert!(k.iter().all(|v| (v.log10() - v.log10().round()).abs() < 1e-12));
        // Less than one 1-2-5 step: every integer mantissa.
        assert_eq!(ScaledAxis::log(2.5, 4.5).key_points(8usize), vec![3.0, 4.0]);
        // Pixel mapping: the geometric mean is in the middle on a log axis.
        assert_eq!(ScaledAxis::log(1.0, 100.0).map(&10.0, (0, 200)), 100);
        assert_eq!(ScaledAxis::linear(0.0, 2.0).map(&0.5, (0, 200)), 50);
        // Invalid log ranges fall back to a valid one.
        assert!(ScaledAxis::log(-1.0, 5.0).range().start > 0.0);
    }

    #[test]
    fn tick_format_and_colours() {
        assert_eq!(fmt_tick(&-0.0), "0");
        assert_eq!(fmt_tick(&0.25), "0.25");
        assert_eq!(fmt_tick(&2.0), "2");
        assert_eq!(fmt_tick(&1.0e-5), "1.0e-5");
        assert_eq!(scenario_colour("Warthog ice"), scenario_colour("ice"));
        assert_eq!(scenario_colour("all"), ALL_COLOUR);
        assert_eq!(scenario_colour("my run"), scenario_colour("my run"));
        // Unknown labels never take a keyword colour.
        for l in ["unlabelled", "x", "dataset 7", "husky_2023"] {
            let c = scenario_colour(l);
            assert!(
                KEYWORD_COLOURS.iter().all(|(_, k)| *k != c) || l.contains("husky"),
                "{l}"
            );
        }
        // Two labels whose keyword colours collide get different colours in one figure.
        let c = assign_colours(&["Warthog ice", "Husky ice", "Warthog ice"]);
        assert_ne!(c[0], c[1]);
        assert_eq!(c[0], c[2]);
        assert_eq!(ColourMap::Viridis.at(0.0), RGBColor(68, 1, 84));
        assert_eq!(ColourMap::Viridis.at(2.0), RGBColor(254, 232, 37));
        assert_eq!(ColourMap::Diverging.at(0.5), RGBColor(242, 242, 242));
    }
}
