//! The calibration's figures: each fitted output measured, replayed on the original and
//! on the calibrated scene, and the path.

use crate::calibrate::Calibration;
use crate::record::channels as chan;

/// `DIR/OUTPUT_calibrated.svg` per fitted output: measured (wide, pale) under the
/// original scene's and the calibrated scene's replays.
pub fn write_plots(
    dir: &std::path::Path,
    c: &Calibration,
    rec_name: &str,
) -> std::io::Result<Vec<std::path::PathBuf>> {
    crate::plot::write_figures(dir, &figures(c, rec_name))
}

/// The figures of [`write_plots`]: per fitted output, the recording replayed on the
/// original and on the calibrated scene.
pub fn figures(c: &Calibration, rec_name: &str) -> Vec<crate::plot::Figure> {
    use crate::plot::{svg, Figure, Series, Style};
    let mut files = vec![];
    for name in &c.outputs {
        let (Some(b), Some(a)) = (c.before.output(name), c.after.output(name)) else {
            continue;
        };
        let (t, y) = crate::plot::measured_points(&c.before.t_s, &b.measured);
        let orig = format!("original scene ({:.1} %)", b.fit_pct);
        let cal = format!("calibrated scene ({:.1} %)", a.fit_pct);
        let doc = svg(
            &format!("{name}: {rec_name} replayed on the original and the calibrated scene"),
            "t (s)",
            name,
            &[
                Series::line("measured", &t, &y, "#555").with_style(Style::Measured),
                Series::line(&orig, &c.before.t_s, &b.simulated, "#d08000"),
                Series::line(&cal, &c.after.t_s, &a.simulated, "#1f5fbf"),
            ],
            None,
        );
        files.push(Figure {
            file: format!("{name}_calibrated.svg"),
            svg: doc,
        });
    }
    files.extend(path_figure(c, rec_name));
    files
}

/// The path seen from above (x against y, to scale): measured, replayed on the original
/// scene and on the calibrated one, where the recording has a pose that was fitted.
fn path_figure(c: &Calibration, rec_name: &str) -> Option<crate::plot::Figure> {
    use crate::plot::{Figure, Plot, Series, Style};
    let (bx, by) = (c.before.output(chan::X_M)?, c.before.output(chan::Y_M)?);
    let (ax, ay) = (c.after.output(chan::X_M)?, c.after.output(chan::Y_M)?);
    let (mx, my): (Vec<f64>, Vec<f64>) = bx
        .measured
        .iter()
        .zip(&by.measured)
        .filter_map(|(x, y)| Some(((*x)?, (*y)?)))
        .unzip();
    let orig = format!(
        "original scene (x {:.1} %, y {:.1} %)",
        bx.fit_pct, by.fit_pct
    );
    let cal = format!(
        "calibrated scene (x {:.1} %, y {:.1} %)",
        ax.fit_pct, ay.fit_pct
    );
    let title = format!("path of {rec_name} seen from above, to scale: measured and replayed");
    let series = [
        Series::line("measured", &mx, &my, "#555").with_style(Style::Measured),
        Series::line(&orig, &bx.simulated, &by.simulated, "#d08000"),
        Series::line(&cal, &ax.simulated, &ay.simulated, "#1f5fbf"),
    ];
    let svg = Plot {
        title: &title,
        x_label: "x (m)",
        y_label: "y (m)",
        series: &series,
        band: None,
        flags: None,
        empty_note: "no pose measured",
    }
    .render_to_scale();
    Some(Figure {
        file: "path_calibrated.svg".into(),
        svg,
    })
}
