//! One self-contained HTML report to share (`--html FILE.html` of `calibrate`, `diagnose`
//! and `identify`): the recording's summary, the numbers as tables, the plots inline as
//! SVG, the command that made it. No script, no font, no request to anywhere: the file
//! opens the same in any browser, offline, years later.

pub mod reports;

use std::fmt::Write as _;

use crate::record::Recording;

/// The report's style: plain, readable, printable.
const STYLE: &str = "body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:1.5em;border-bottom:2px solid #1f5fbf;padding-bottom:.2em}h2{font-size:1.2em;margin-top:1.8em;color:#1f5fbf}\
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left;vertical-align:top}\
th{background:#f0f3f8}td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}\
pre{background:#f6f6f6;border:1px solid #ddd;padding:.6em;overflow-x:auto;font-size:.85em}\
figure{margin:1em 0}figure svg{max-width:100%;height:auto;border:1px solid #eee}\
.good{color:#17692f}.bad{color:#a33}.note{color:#555}";

/// A report being written: a title and its sections, in order.
pub struct Document {
    title: String,
    body: String,
    /// Figures inlined so far: each figure's ids are prefixed with its number.
    figures: usize,
}

/// A table cell: text, or a number set right-aligned.
pub enum Cell {
    /// Plain text.
    Text(String),
    /// A number (already formatted), right-aligned.
    Num(String),
}

impl From<String> for Cell {
    fn from(s: String) -> Cell {
        Cell::Text(s)
    }
}

impl From<&str> for Cell {
    fn from(s: &str) -> Cell {
        Cell::Text(s.to_string())
    }
}

/// Text escaped for HTML.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

impl Document {
    /// A report titled `title`.
    pub fn new(title: &str) -> Document {
        Document {
            title: title.to_string(),
            body: String::new(),
            figures: 0,
        }
    }

    /// A section heading.
    pub fn heading(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<h2>{}</h2>", escape(text));
        self
    }

    /// A paragraph of text (`class`: `good`, `bad`, `note` or empty).
    pub fn paragraph(&mut self, text: &str, class: &str) -> &mut Self {
        if class.is_empty() {
            let _ = writeln!(self.body, "<p>{}</p>", escape(text));
        } else {
            let _ = writeln!(self.body, "<p class=\"{class}\">{}</p>", escape(text));
        }
        self
    }

    /// A table with a header row.
    pub fn table(&mut self, header: &[&str], rows: Vec<Vec<Cell>>) -> &mut Self {
        self.body.push_str("<table>\n<tr>");
        for h in header {
            let _ = write!(self.body, "<th>{}</th>", escape(h));
        }
        self.body.push_str("</tr>\n");
        for row in rows {
            self.body.push_str("<tr>");
            for c in row {
                let _ = match c {
                    Cell::Text(t) => write!(self.body, "<td>{}</td>", escape(&t)),
                    Cell::Num(t) => write!(self.body, "<td class=\"num\">{}</td>", escape(&t)),
                };
            }
            self.body.push_str("</tr>\n");
        }
        self.body.push_str("</table>\n");
        self
    }

    /// Preformatted text (a report as the command printed it).
    pub fn pre(&mut self, text: &str) -> &mut Self {
        let _ = writeln!(self.body, "<pre>{}</pre>", escape(text.trim_end()));
        self
    }

    /// The figures inline, each under its file name as caption.
    pub fn figures(&mut self, figures: &[crate::plot::Figure]) -> &mut Self {
        for f in figures {
            // An SVG document inline: its root element, no XML prolog.
            let svg = f.svg.trim_start();
            let svg = svg
                .strip_prefix("<?xml")
                .and_then(|r| r.split_once("?>").map(|(_, rest)| rest))
                .unwrap_or(svg);
            self.figures += 1;
            let svg = scoped_ids(svg, &format!("fig{}-", self.figures));
            let _ = writeln!(self.body, "<figure>{svg}</figure>");
        }
        self
    }

    /// The recording's summary: file, rig, rows, span, sampling, segments, columns.
    pub fn recording(&mut self, names: &str, rec: &Recording) -> &mut Self {
        let rows = rec.t_s.len();
        let span = match (rec.t_s.first(), rec.t_s.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        };
        let dt = crate::record::median_interval_s(&rec.t_s).unwrap_or(f64::NAN);
        let columns: Vec<String> = rec
            .names
            .iter()
            .zip(&rec.columns)
            .map(|(n, c)| {
                let measured = c.iter().filter(|v| v.is_some()).count();
                if measured == rows {
                    n.clone()
                } else {
                    format!("{n} ({measured} of {rows} rows)")
                }
            })
            .collect();
        let sig = |v: f64| crate::numtext::sig(v, 4);
        self.table(
            &["recording", "value"],
            vec![
                vec!["file".into(), names.into()],
                vec!["rig".into(), rec.rig.as_str().into()],
                vec!["rows".into(), Cell::Num(rows.to_string())],
                vec!["span".into(), Cell::Num(format!("{} s", sig(span)))],
                vec![
                    "sample time (median)".into(),
                    Cell::Num(format!("{} s", sig(dt))),
                ],
                vec![
                    "segments".into(),
                    Cell::Num(rec.segment_starts.len().to_string()),
                ],
                vec!["columns".into(), columns.join(", ").into()],
            ],
        );
        if let Some(d) = rec.meta.get("description") {
            self.paragraph(&format!("Its description: {d}"), "note");
        }
        self
    }

    /// The exact command that made the report.
    pub fn command(&mut self, command: &str) -> &mut Self {
        self.heading("The command");
        self.pre(command);
        self
    }

    /// The whole document.
    pub fn finish(&self) -> String {
        format!(
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"generator\" content=\"agvsim\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n{}</body>\n</html>\n",
            escape(&self.title),
            escape(&self.title),
            self.body
        )
    }
}

/// `svg` with each of its ids (`id="data"`) and the references to them (`url(#data)`,
/// `href="#data"`) prefixed: an HTML page is one document, so figures inlined side by side
/// must not share an id (each plot's clip path would clip to the first figure's frame).
fn scoped_ids(svg: &str, prefix: &str) -> String {
    let mut ids: Vec<&str> = svg
        .split("id=\"")
        .skip(1)
        .filter_map(|rest| rest.split_once('"').map(|(id, _)| id))
        .collect();
    ids.sort_unstable();
    ids.dedup();
    let mut out = svg.to_string();
    for id in ids {
        for (before, after) in [
            (format!("id=\"{id}\""), format!("id=\"{prefix}{id}\"")),
            (format!("url(#{id})"), format!("url(#{prefix}{id})")),
            (format!("href=\"#{id}\""), format!("href=\"#{prefix}{id}\"")),
        ] {
            out = out.replace(&before, &after);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_escaped_and_svg_is_inlined_without_its_prolog() {
        let mut d = Document::new("a <b> & c");
        d.paragraph("x < y", "").figures(&[crate::plot::Figure {
            file: "f.svg".into(),
            svg: "<?xml version=\"1.0\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\"></svg>\n"
                .into(),
        }]);
        let html = d.finish();
        assert!(html.contains("<title>a &lt;b&gt; &amp; c</title>"));
        assert!(html.contains("<p>x &lt; y</p>"));
        assert!(html.contains("<figure>\n<svg xmlns"));
        assert!(!html.contains("<?xml"));
        // Two figures with the same clip path get ids of their own, each used by its own.
        let clip = "<svg><defs><clipPath id=\"data\"><rect/></clipPath></defs><path clip-path=\"url(#data)\"/></svg>";
        let fig = |file: &str| crate::plot::Figure {
            file: file.into(),
            svg: clip.into(),
        };
        d.figures(&[fig("a.svg"), fig("b.svg")]);
        let html = d.finish();
        assert_eq!(html.matches("id=\"data\"").count(), 0, "{html}");
        for k in [2, 3] {
            assert_eq!(html.matches(&format!("id=\"fig{k}-data\"")).count(), 1);
            assert_eq!(html.matches(&format!("url(#fig{k}-data)")).count(), 1);
        }
        // Nothing fetched from anywhere.
        assert!(
            !html.contains("http://")
                || !html
                    .replace("http://www.w3.org/2000/svg", "")
                    .contains("http")
        );
    }
}
