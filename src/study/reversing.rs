//! Reversing along the wire: steering on the front coil pair only (the thesis's "backing a
//! trailer knowing only the towbar": unstable) against a second pair at the rear, from
//! several start offsets.

use super::{md_table, study_sweep, value_of, write_summary, StudyOptions, StudyOutput};
use crate::sweep::SweepError;

pub const FRONT_ONLY: &str = include_str!("../../scenes/studies/reversing_front_only.toml");
pub const REAR_PAIR: &str = include_str!("../../scenes/studies/reversing_rear_pair.toml");

/// The two configurations: name, scene file, scene text.
const CONFIGURATIONS: [(&str, &str, &str); 2] = [
    (
        "front_only",
        "scenes/studies/reversing_front_only.toml",
        FRONT_ONLY,
    ),
    (
        "rear_pair",
        "scenes/studies/reversing_rear_pair.toml",
        REAR_PAIR,
    ),
];

/// One run: configuration, start offset m, lost the wire, RMS lateral error over the
/// second half m, final lateral error m.
#[derive(Debug, Clone)]
pub struct ReversingRun {
    pub configuration: &'static str,
    pub start_offset_m: f64,
    pub lost_wire: bool,
    pub late_rms_m: f64,
    pub final_error_m: f64,
}

pub fn run(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<ReversingRun>, StudyOutput), SweepError> {
    let offsets = if opts.quick { "0.05" } else { "0.02,0.05,0.1" };
    let varies = vec![format!("start.y_m={offsets}")];
    let mut runs = vec![];
    for (name, label, text) in CONFIGURATIONS {
        let (o, results) = study_sweep(opts, name, label, text, &[], &varies, true, progress)?;
        for r in &results {
            let (Ok(s), Some(t)) = (&r.outcome, &r.trace) else {
                continue;
            };
            let half = t.lateral_error_m.len() / 2;
            let late = &t.lateral_error_m[half..];
            runs.push(ReversingRun {
                configuration: name,
                start_offset_m: value_of(&o, r, "start.y_m").parse().unwrap_or(f64::NAN),
                lost_wire: s.lost_wire,
                late_rms_m: (late.iter().map(|e| e * e).sum::<f64>() / late.len().max(1) as f64)
                    .sqrt(),
                final_error_m: s.final_lateral_error_m,
            });
        }
    }
    let rows: Vec<Vec<String>> = runs
        .iter()
        .map(|r| {
            vec![
                r.configuration.replace('_', " "),
                format!("{:.0}", 1000.0 * r.start_offset_m),
                if r.lost_wire { "yes" } else { "no" }.into(),
                format!("{:.1}", 1000.0 * r.late_rms_m),
                format!("{:.1}", 1000.0 * r.final_error_m),
            ]
        })
        .collect();
    let mut summary = String::from(
        "# Reversing\n\nThe AGV reverses along a straight wire at the lab speed (full level, 20 s), \
         steering on the front coil pair only or on a rear pair 0.45 m behind the drive axle, \
         from a start offset. Errors are the steering pair's offset from the wire.\n\n",
    );
    summary.push_str(&md_table(
        &[
            "configuration",
            "start offset mm",
            "lost wire",
            "RMS error, second half, mm",
            "final error mm",
        ],
        &rows,
    ));
    summary.push_str(&linear_analysis()?);
    summary.push_str(
        "\nNot modelled: the thesis's \"swing away\" reversing strategy (turn away from the \
         wire first) and its failure on a curved path; the firmware here has no such mode.\n",
    );
    let files = vec![write_summary(&opts.out_dir, &summary)?];
    Ok((runs, StudyOutput { summary, files }))
}

/// The same two configurations by linear analysis (`agvsim linearize`): the rightmost pole
/// of the P-D loop closed around the linearised plant.
fn linear_analysis() -> Result<String, SweepError> {
    use crate::sim::linearize::{close_loop, linearise};
    let mut rows = vec![];
    for (name, label, text) in CONFIGURATIONS {
        let scene = crate::scene::Scene::from_toml(text, std::path::Path::new(label), &[])?;
        let [pole, verdict] = match linearise(&scene) {
            Ok(l) => match close_loop(&l) {
                Some(c) => [
                    format!("{:+.2}", c.rightmost_re()),
                    if c.stable() { "stable" } else { "unstable" }.to_string(),
                ],
                None => ["-".into(), "not analysed (no P-D loop to close)".into()],
            },
            Err(e) => ["-".into(), format!("not analysed: {e}")],
        };
        rows.push(vec![name.replace('_', " "), pole, verdict]);
    }
    let mut s = String::from(
        "\n## Linear analysis\n\nThe P-D loop closed around the plant linearised on the wire \
         (`agvsim linearize SCENE`; sampling, delay and PWM filter left out, which only cost \
         phase margin):\n\n",
    );
    s.push_str(&md_table(
        &["configuration", "rightmost closed-loop pole 1/s", "loop"],
        &rows,
    ));
    Ok(s)
}
