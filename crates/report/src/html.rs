//! A self-contained HTML report: sections of paragraphs, key-figure tables and figures
//! embedded inline as SVG (one file, no external resource).

use std::fmt::Display;
use std::path::{Path, PathBuf};

use super::FigureFiles;
use crate::error::{Error, Result};

/// One row of a key-figure table.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct KeyFigure {
    /// What the number is, e.g. `"median ρ on ice"`.
    pub label: String,
    /// The value, formatted by the caller with the precision it deserves (e.g. `"0.42 ± 0.03"`).
    pub value: String,
    /// SI unit; empty for dimensionless values.
    pub unit: String,
}

impl KeyFigure {
    /// Builds a row; `value` is formatted with `Display` (format it beforehand to control
    /// the precision).
    pub fn new(label: impl Into<String>, value: impl Display, unit: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            value: value.to_string(),
            unit: unit.into(),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Block {
    Paragraph(String),
    Table { caption: String, rows: Vec<KeyFigure> },
    Comparison(Comparison),
    Figure { caption: String, svg: String },
}

/// A table with one column per dataset: a row per quantity, its unit, then a value per column.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Comparison {
    /// Caption above the table.
    pub caption: String,
    /// Column headings (e.g. the datasets).
    pub columns: Vec<String>,
    /// (quantity, unit, one formatted value per column).
    pub rows: Vec<(String, String, Vec<String>)>,
}

#[derive(Debug, Clone, PartialEq)]
struct Section {
    heading: String,
    blocks: Vec<Block>,
}

/// Builder of a single-file HTML report.
///
/// ```no_run
/// # use drive_sim_report::{HtmlReport, KeyFigure};
/// let mut r = HtmlReport::new("DRIVE on ice");
/// r.section("Unpredictability")
///     .paragraph("ρ per step, steady-state windows.")
///     .table("Key figures", &[KeyFigure::new("median ρ", "0.42", "")]);
/// r.write(std::path::Path::new("out")).unwrap();
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct HtmlReport {
    title: String,
    sections: Vec<Section>,
}

/// Escapes text for HTML element content and attribute values.
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// Returns the `<svg ...>...</svg>` element of an SVG document (drops an XML prolog and
/// comments before it), or an error if there is none.
fn svg_element(text: &str, origin: &str) -> Result<String> {
    let start = text.find("<svg").ok_or_else(|| Error::Svg {
        origin: origin.to_string(),
        message: "no <svg> element",
    })?;
    let end = text.rfind("</svg>").ok_or_else(|| Error::Svg {
        origin: origin.to_string(),
        message: "<svg> element is not closed",
    })?;
    if end < start {
        return Err(Error::Svg {
            origin: origin.to_string(),
            message: "malformed SVG",
        });
    }
    Ok(text[start..end + "</svg>".len()].to_string())
}

const CSS: &str = "body{font-family:'DejaVu Sans',sans-serif;max-width:1400px;margin:2em auto;\
padding:0 1em;color:#222;line-height:1.45}h1{border-bottom:2px solid #444}\
h2{margin-top:2em;border-bottom:1px solid #bbb}figure{margin:1.5em 0}\
figure svg{max-width:100%;height:auto;display:block}figcaption{font-size:.92em;color:#444;\
margin-top:.4em}table{border-collapse:collapse;margin:1em 0}caption{text-align:left;\
font-weight:bold;margin-bottom:.3em}td,th{border:1px solid #ccc;padding:.25em .7em}\
td.v{text-align:right;font-variant-numeric:tabular-nums}";

impl HtmlReport {
    /// Starts a report with a title (also the page title).
    pub fn new(title: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            sections: vec![],
        }
    }

    fn current(&mut self) -> &mut Section {
        if self.sections.is_empty() {
            self.sections.push(Section {
                heading: String::new(),
                blocks: vec![],
            });
        }
        let last = self.sections.len() - 1;
        &mut self.sections[last]
    }

    /// Starts a new section; following blocks go into it.
    pub fn section(&mut self, heading: impl Into<String>) -> &mut Self {
        self.sections.push(Section {
            heading: heading.into(),
            blocks: vec![],
        });
        self
    }

    /// Adds a paragraph of plain text (escaped).
    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut Self {
        self.current().blocks.push(Block::Paragraph(text.into()));
        self
    }

    /// Adds a key-figure table (label, value, unit).
    pub fn table(&mut self, caption: impl Into<String>, rows: &[KeyFigure]) -> &mut Self {
        self.current().blocks.push(Block::Table {
            caption: caption.into(),
            rows: rows.to_vec(),
        });
        self
    }

    /// Adds a comparison table (quantities as rows, e.g. datasets as columns).
    pub fn comparison(&mut self, table: Comparison) -> &mut Self {
        self.current().blocks.push(Block::Comparison(table));
        self
    }

    /// Embeds a figure written by a builder: its SVG is read and inlined. The caption says how
    /// many non-finite values the figure left out, if any.
    pub fn figure(&mut self, caption: impl Into<String>, files: &FigureFiles) -> Result<&mut Self> {
        let text = std::fs::read_to_string(&files.svg).map_err(|e| Error::io(&files.svg, e))?;
        let mut caption = caption.into();
        if files.skipped_non_finite > 0 {
            caption.push_str(&format!(
                " ({} non-finite values left out.)",
                files.skipped_non_finite
            ));
        }
        self.figure_svg(caption, &text, &files.svg.display().to_string())
    }

    /// Embeds SVG text directly; `origin` names it in errors.
    pub fn figure_svg(&mut self, caption: impl Into<String>, svg: &str, origin: &str) -> Result<&mut Self> {
        let svg = svg_element(svg, origin)?;
        self.current().blocks.push(Block::Figure {
            caption: caption.into(),
            svg,
        });
        Ok(self)
    }

    /// The whole document.
    pub fn to_html(&self) -> String {
        let mut h = String::new();
        h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
        h.push_str(&format!("<title>{}</title>\n", escape(&self.title)));
        h.push_str(&format!("<style>{CSS}</style>\n</head>\n<body>\n"));
        h.push_str(&format!("<h1>{}</h1>\n", escape(&self.title)));
        let mut fig_no = 0;
        for s in &self.sections {
            h.push_str("<section>\n");
            if !s.heading.is_empty() {
                h.push_str(&format!("<h2>{}</h2>\n", escape(&s.heading)));
            }
            for b in &s.blocks {
                match b {
                    Block::Paragraph(t) => h.push_str(&format!("<p>{}</p>\n", escape(t))),
                    Block::Table { caption, rows } => {
                        h.push_str("<table>\n");
                        if !caption.is_empty() {
                            h.push_str(&format!("<caption>{}</caption>\n", escape(caption)));
                        }
                        h.push_str("<tr><th>quantity</th><th>value</th><th>unit</th></tr>\n");
                        for r in rows {
                            h.push_str(&format!(
                                "<tr><td>{}</td><td class=\"v\">{}</td><td>{}</td></tr>\n",
                                escape(&r.label),
                                escape(&r.value),
                                escape(&r.unit)
                            ));
                        }
                        h.push_str("</table>\n");
                    }
                    Block::Comparison(c) => {
                        h.push_str("<table class=\"comparison\">\n");
                        if !c.caption.is_empty() {
                            h.push_str(&format!("<caption>{}</caption>\n", escape(&c.caption)));
                        }
                        h.push_str("<tr><th>quantity</th><th>unit</th>");
                        for col in &c.columns {
                            h.push_str(&format!("<th>{}</th>", escape(col)));
                        }
                        h.push_str("</tr>\n");
                        for (label, unit, values) in &c.rows {
                            h.push_str(&format!(
                                "<tr><td>{}</td><td>{}</td>",
                                escape(label),
                                escape(unit)
                            ));
                            for v in values {
                                h.push_str(&format!("<td class=\"v\">{}</td>", escape(v)));
                            }
                            h.push_str("</tr>\n");
                        }
                        h.push_str("</table>\n");
                    }
                    Block::Figure { caption, svg } => {
                        fig_no += 1;
                        h.push_str("<figure>\n");
                        h.push_str(svg);
                        h.push_str(&format!(
                            "\n<figcaption>Figure {fig_no}. {}</figcaption>\n</figure>\n",
                            escape(caption)
                        ));
                    }
                }
            }
            h.push_str("</section>\n");
        }
        h.push_str("</body>\n</html>\n");
        h
    }

    /// Writes `<dir>/report.html` (creating `dir`) and returns its path.
    pub fn write(&self, dir: &Path) -> Result<PathBuf> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let path = dir.join("report.html");
        std::fs::write(&path, self.to_html()).map_err(|e| Error::io(&path, e))?;
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_and_structure() {
        let mut r = HtmlReport::new("a <b> & \"c\"");
        r.paragraph("before any section")
            .section("S1 <x>")
            .paragraph("x < y && y > z")
            .table("t", &[KeyFigure::new("ρ's median", 0.5, "")])
            .comparison(Comparison {
                caption: "c".into(),
                columns: vec!["ice".into(), "mud".into()],
                rows: vec![("ρ".into(), "".into(), vec!["0.5".into(), "0.1".into()])],
            });
        r.figure_svg(
            "cap",
            "<?xml version=\"1.0\"?>\n<svg width=\"1\"><rect/></svg>\n",
            "mem",
        )
        .unwrap();
        let h = r.to_html();
        assert!(h.contains("<title>a &lt;b&gt; &amp; &quot;c&quot;</title>"));
        assert!(h.contains("<p>x &lt; y &amp;&amp; y &gt; z</p>"));
        assert!(h.contains("<td>ρ&#39;s median</td><td class=\"v\">0.5</td>"));
        assert!(h.contains("<figure>\n<svg width=\"1\"><rect/></svg>"));
        assert!(!h.contains("<?xml"));
        assert!(h.contains("Figure 1. cap"));
        assert!(h.contains("<th>ice</th><th>mud</th>"));
        assert!(h.contains("<tr><td>ρ</td><td></td><td class=\"v\">0.5</td><td class=\"v\">0.1</td></tr>"));
        assert!(r.figure_svg("bad", "<html></html>", "mem").is_err());
        assert!(r.figure_svg("bad", "<svg>", "mem").is_err());
    }
}
