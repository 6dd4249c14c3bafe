//! Figures and reports.
//!
//! Figure builders take plain, domain-named inputs (no analysis types), so that any stage can
//! feed them, and each writes `<stem>.svg` and `<stem>.png` (same pixel size) into an output
//! directory, returning a [`FigureFiles`]. Non-finite values are left out and counted
//! ([`FigureFiles::skipped_non_finite`]); empty series draw as empty panels with a "no data"
//! note; a request with nothing at all to draw, or with an impossible parameter, is an
//! [`Error`] of this crate ([`Error::NothingToDraw`], [`Error::InvalidFigure`], ...); a failure
//! shared with the other stages (I/O, JSON) is its [`Error::Model`].
//!
//! Colours are per scenario label and the same in every figure ([`scenario_colour`]): a
//! label naming a terrain gets the paper's terrain colour (asphalt grey, grass green, gravel
//! brown, sand orange, ice blue), `all` is white, others a stable colour from a fixed cycle.
//!
//! Figures:
//! - [`command_space_figure`]: U, S and T in the wheel frame W and the body frame B, and the
//!   lateral-speed distribution, one row per scenario;
//! - [`box_plots`]: box-and-whisker panels (quartile boxes, median line, 2.5–97.5 % whiskers);
//! - [`heat_maps`]: values over (wz, vx) with contour lines, U outline and a colour bar;
//! - [`value_scatter`]: values at sampled commands coloured by value (e.g. ρ);
//! - [`risk_map`]: median and 95 % ellipse per scenario on (ρ, kinetic energy);
//! - [`histograms`]: overlaid histograms per panel with ± limit lines (accelerations);
//! - [`line_bands`]: mean line with a band per series (errors vs steps, residuals).
//!
//! [`HtmlReport`] assembles sections, key-figure tables and inline SVG figures into one
//! self-contained `report.html`.
//!
//! ```
//! use drive_sim_report::{bar_chart, AxisLabel, BarChart, BarSeries};
//!
//! let dir = std::env::temp_dir().join("drive_sim_report_example");
//! std::fs::create_dir_all(&dir).unwrap();
//! let chart = BarChart {
//!     categories: vec!["asphalt".into(), "gravel".into()],
//!     series: vec![BarSeries { label: "median ρ".into(), values: vec![Some(0.33), Some(0.41)] }],
//!     value: AxisLabel::new("ρ", ""),
//!     log: false,
//!     references: vec![],
//! };
//! // Writes rho.svg and rho.png of the same pixel size.
//! let files = bar_chart(&dir, "rho", "Median ρ by terrain", &chart)?;
//! assert!(files.svg.exists() && files.png.exists());
//! # Ok::<(), drive_sim_report::Error>(())
//! ```

#![warn(missing_docs, unreachable_pub)]

pub mod error;

pub mod analysis_report;
mod bars;
mod boxplot;
mod command_space;
pub mod contour;
pub mod ellipse;
pub mod findings;
mod heatmap;
mod histogram;
mod html;
mod lines;
mod risk;
pub mod stats;
mod style;

pub use bars::{bar_chart, BarChart, BarSeries};
pub use boxplot::{box_plots, BoxPanel};
pub use command_space::{command_space_figure, CommandScenario};
pub use contour::{contour_levels, contour_polylines, contour_segments, ContourSegment, Grid2};
pub use ellipse::{ellipse_axes, ellipse_points, EllipseAxes, CHI2_2DOF_95};
pub use error::{Error, Result};
pub use heatmap::{heat_maps, value_scatter, ColourScale, HeatPanel, ScatterPanel, ValuePoint};
pub use histogram::{histograms, HistPanel};
pub use html::{Comparison, HtmlReport, KeyFigure};
pub use lines::{line_bands, BandPoint, BandSeries, LineAxes};
pub use risk::{risk_map, EnergyAxis, EnergyLimit, RiskEllipse, RiskScenario};
pub use style::{scenario_colour, ColourMap, FigureFiles};

/// A quantity and its unit, for an axis or a colour bar (e.g. `longitudinal slip`, `m/s`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct AxisLabel {
    /// What is measured, e.g. `"lateral acceleration"`.
    pub quantity: String,
    /// SI unit, e.g. `"m/s²"`; empty for dimensionless quantities.
    pub unit: String,
}

impl AxisLabel {
    /// Builds a label from a quantity and its unit.
    pub fn new(quantity: impl Into<String>, unit: impl Into<String>) -> Self {
        Self {
            quantity: quantity.into(),
            unit: unit.into(),
        }
    }
    /// `quantity [unit]`, or `quantity` alone when dimensionless.
    pub fn text(&self) -> String {
        if self.unit.is_empty() {
            self.quantity.clone()
        } else {
            format!("{} [{}]", self.quantity, self.unit)
        }
    }
}

/// A labelled set of scalar samples: one box of a box plot, one series of a histogram.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Samples {
    /// Scenario label (terrain, robot, dataset); decides the colour.
    pub label: String,
    /// The samples; non-finite values are skipped and counted.
    pub values: Vec<f64>,
}

impl Samples {
    /// Builds a labelled sample set.
    pub fn new(label: impl Into<String>, values: Vec<f64>) -> Self {
        Self {
            label: label.into(),
            values,
        }
    }
}

/// One box of a box plot (alias of [`Samples`]).
pub type BoxGroup = Samples;
