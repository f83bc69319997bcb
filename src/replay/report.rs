//! A replay's files and text: the simulated recording beside the measured one (same
//! columns), a plot per output, and the fit table.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::Replay;
use crate::plot::{svg, Series, Style};
use crate::record::channels as chan;
use crate::record::Recording;

pub use crate::output::write_atomically;

/// The simulated recording: the measured file's time, inputs (as held) and compared
/// outputs, with the replay named in its metadata.
pub fn simulated_csv(r: &Replay, rec: &Recording, scene_path: &Path) -> String {
    let mut columns = vec![chan::T_S];
    columns.extend(r.drive.columns().iter().copied());
    columns.extend(r.outputs.iter().map(|o| o.name.as_str()));
    let mut s = crate::record::header(
        rec.rig,
        &[
            (
                "description",
                format!(
                    "agvsim replay of {} on {}",
                    rec.path.display(),
                    scene_path.display()
                ),
            ),
            (
                "source",
                format!(
                    "agvsim {} simulation driven by the recording's inputs",
                    env!("CARGO_PKG_VERSION")
                ),
            ),
        ],
        &columns,
    );
    for k in 0..r.t_s.len() {
        let mut row = vec![format!("{}", r.t_s[k])];
        row.extend(r.inputs.iter().map(|col| format!("{}", col[k])));
        row.extend(r.outputs.iter().map(|o| format!("{:.6}", o.simulated[k])));
        let _ = writeln!(s, "{}", row.join(","));
    }
    s
}

/// Why an output has no fit: fewer than two measured cells, or no spread to score.
fn unscored(o: &crate::replay::ReplayedOutput) -> String {
    match crate::ident::evaluate::constant_value(&o.measured) {
        Some(v) => format!(
            "constant at {}: no spread to score (a stuck sensor?), left out of the mean",
            crate::param::plain_number(v)
        ),
        None => "not measured: simulated only".to_string(),
    }
}

/// The fit table `agvsim replay` prints.
pub fn render(r: &Replay) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{:<28} {:>8} {:>16}", "output", "fit %", "RMS error");
    for o in &r.outputs {
        if o.fit_pct.is_finite() {
            let _ = writeln!(
                s,
                "{:<28} {:>8.1} {:>16}",
                o.name,
                o.fit_pct,
                crate::numtext::quantity(o.rms_error, 4, crate::numtext::unit_of_name(&o.name))
            );
        } else {
            let _ = writeln!(s, "{:<28} {:>8}   {}", o.name, "-", unscored(o));
        }
    }
    if r.mean_fit_pct().is_finite() {
        let _ = writeln!(s, "{:<28} {:>8.1}", "mean", r.mean_fit_pct());
    }
    for n in &r.notes {
        let _ = writeln!(s, "note: {n}");
    }
    if !r.not_compared.is_empty() {
        let _ = writeln!(
            s,
            "not compared: {} (inputs of another kind, empty, or no such simulator output)",
            r.not_compared.join(", ")
        );
    }
    s
}

/// `plots/OUTPUT_replay.svg` per output: measured (wide, pale) under simulated.
pub fn write_plots(dir: &Path, r: &Replay, rec_name: &str) -> std::io::Result<Vec<PathBuf>> {
    let pdir = dir.join("plots");
    std::fs::create_dir_all(&pdir)?;
    let mut files = vec![];
    for o in &r.outputs {
        let (t, y) = crate::plot::measured_points(&r.t_s, &o.measured);
        // The title keeps to a line: the table says why in full.
        let fit = if o.fit_pct.is_finite() {
            format!("fit {:.1} %", o.fit_pct)
        } else if crate::ident::evaluate::constant_value(&o.measured).is_some() {
            "constant: no fit".to_string()
        } else {
            "not measured".to_string()
        };
        let doc = svg(
            &format!(
                "{}: measured and replayed in the simulator ({rec_name}, {fit})",
                o.name
            ),
            "t (s)",
            &o.name,
            &[
                Series::line("measured", &t, &y, "#555").with_style(Style::Measured),
                Series::line("simulated", &r.t_s, &o.simulated, "#1f5fbf"),
            ],
            None,
        );
        let f = pdir.join(format!("{}_replay.svg", o.name));
        write_atomically(&f, &doc)?;
        files.push(f);
    }
    Ok(files)
}
