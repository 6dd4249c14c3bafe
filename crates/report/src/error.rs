//! What can fail while drawing a figure or writing a report.

use std::path::PathBuf;

/// Errors of figures and reports. A figure is named by its file stem.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A bad file, an I/O or JSON failure on a path (the errors every stage shares).
    #[error(transparent)]
    Model(#[from] drive_sim_model::Error),
    /// A figure asked for with nothing at all to draw.
    #[error("report: {figure}: no {what} to draw")]
    NothingToDraw {
        /// The figure's file stem.
        figure: String,
        /// What it would have drawn: "bar", "box", "scenario", ...
        what: &'static str,
    },
    /// A figure's data or parameters that cannot be drawn (a series of the wrong length, a
    /// band whose low is above its high, a bin count out of range, an empty canvas, ...).
    #[error("report: {figure}: {message}")]
    InvalidFigure {
        /// The figure's file stem.
        figure: String,
        /// What is wrong with it.
        message: String,
    },
    /// A figure file stem that is not a plain file name (empty, `.`, `..`, or with a directory
    /// part), so the figure would be written outside its directory or nowhere.
    #[error("report: figure file stem `{stem}` must be a plain, non-empty file name")]
    InvalidStem {
        /// The stem as given.
        stem: String,
    },
    /// A shape inside a figure that cannot be computed: a grid with a bad axis, a contour
    /// spacing or level, an ellipse's covariance or centre, a colour range.
    #[error("report: {0}")]
    InvalidShape(String),
    /// The plotting backend failed to draw or encode a figure file.
    #[error("report: {}: {message}", path.display())]
    Render {
        /// The SVG or PNG file being written.
        path: PathBuf,
        /// The backend's message.
        message: String,
    },
    /// An SVG file to inline into a report that is not one.
    #[error("report: {origin}: {message}")]
    Svg {
        /// Where the SVG came from.
        origin: String,
        /// What is wrong with it.
        message: &'static str,
    },
    /// A report asked for with no analysed log.
    #[error("report: nothing to report: no analysed log")]
    NothingToReport,
}

drive_sim_model::shared_error_constructors!(Error);

impl Error {
    /// The shared error this one carries, however deep (an interrupt, a bad file, ...), if any.
    pub fn model(&self) -> Option<&drive_sim_model::Error> {
        match self {
            Error::Model(e) => Some(e),
            _ => None,
        }
    }

    /// Whether the user's input is at fault (exit code 2); a figure that cannot be drawn is
    /// not the user's input.
    pub fn is_bad_input(&self) -> bool {
        match self {
            Error::Model(e) => e.is_bad_input(),
            _ => false,
        }
    }
}

/// Result of the report crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
