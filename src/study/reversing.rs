//! Reversing along the wire: steering on the front coil pair only (the thesis's "backing a
//! trailer knowing only the towbar": unstable), the thesis's "swing away" strategy on the
//! same pair (steer the axle onto a wire assumed straight), and a second pair at the rear;
//! from several start offsets, on a straight wire and on one that bends.

use super::{md_table, study_sweep, value_of, write_summary, StudyOptions, StudyOutput};
use crate::model::chassis::Pose;
use crate::sweep::SweepError;

/// The scene reversing with the P-D law on the front pair.
pub const FRONT_ONLY: &str = include_str!("../../scenes/studies/reversing_front_only.toml");
/// The scene reversing with the swing-away strategy.
pub const SWING_AWAY: &str = include_str!("../../scenes/studies/reversing_swing_away.toml");
/// The scene reversing with the P-D law on a rear pair.
pub const REAR_PAIR: &str = include_str!("../../scenes/studies/reversing_rear_pair.toml");

/// One reversing configuration.
struct Configuration {
    name: &'static str,
    scene_file: &'static str,
    scene_text: &'static str,
    /// A P-D loop that `agvsim linearize` can close.
    pd_loop: bool,
}

const CONFIGURATIONS: [Configuration; 3] = [
    Configuration {
        name: "front_only",
        scene_file: "scenes/studies/reversing_front_only.toml",
        scene_text: FRONT_ONLY,
        pd_loop: true,
    },
    Configuration {
        name: "swing_away",
        scene_file: "scenes/studies/reversing_swing_away.toml",
        scene_text: SWING_AWAY,
        pd_loop: false,
    },
    Configuration {
        name: "rear_pair",
        scene_file: "scenes/studies/reversing_rear_pair.toml",
        scene_text: REAR_PAIR,
        pd_loop: true,
    },
];

/// The bend's radius, m: gentle enough that the rear pair's P-D law follows it at the lab
/// speed.
pub const BEND_RADIUS_M: f64 = 15.0;
/// The angle the bend turns through, rad.
pub const BEND_ANGLE_RAD: f64 = std::f64::consts::PI / 6.0;
/// Straight wire behind the start before the bend, m.
const BEND_AFTER_M: f64 = 4.0;

/// The bent wire's vertices, m, from its far end to 2 m ahead of the start (the start is
/// at the origin, reversing towards -x): straight for `BEND_AFTER_M`, an arc of
/// `radius_m` through `angle_rad` turning towards +y, then 30 m straight on.
pub fn bent_wire_points(radius_m: f64, angle_rad: f64) -> Vec<[f64; 2]> {
    let mut pts = vec![[2.0, 0.0], [-BEND_AFTER_M, 0.0]];
    let n = 16;
    for k in 1..=n {
        let th = angle_rad * k as f64 / n as f64;
        pts.push([
            -BEND_AFTER_M - radius_m * th.sin(),
            radius_m * (1.0 - th.cos()),
        ]);
    }
    let [x, y] = pts[pts.len() - 1];
    pts.push([x - 30.0 * angle_rad.cos(), y + 30.0 * angle_rad.sin()]);
    pts.reverse();
    pts
}

/// The scene override that lays the bent wire.
fn bent_wire_set() -> String {
    let pts: Vec<String> = bent_wire_points(BEND_RADIUS_M, BEND_ANGLE_RAD)
        .iter()
        .map(|[x, y]| format!("[{x:.4}, {y:.4}]"))
        .collect();
    format!("wire.points_m=[{}]", pts.join(", "))
}

/// One run: configuration, wire (`straight` or `bent`), start offset m, lost the wire, RMS
/// lateral error over the second half m, final lateral error m.
#[derive(Debug, Clone)]
pub struct ReversingRun {
    /// Front pair, swing away or rear pair.
    pub configuration: &'static str,
    /// The wire: straight or bending.
    pub wire: &'static str,
    /// Start offset from the wire, m.
    pub start_offset_m: f64,
    /// The sensors lost the wire.
    pub lost_wire: bool,
    /// RMS lateral error over the second half, m.
    pub late_rms_m: f64,
    /// Lateral error at the end, m.
    pub final_error_m: f64,
}

/// Runs the study into `opts.out_dir`; `progress` follows its sweeps.
pub fn run(
    opts: &StudyOptions,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<(Vec<ReversingRun>, StudyOutput), SweepError> {
    let offsets = if opts.quick { "0.05" } else { "0.02,0.05,0.1" };
    let varies = vec![format!("start.y_m={offsets}")];
    let bent = bent_wire_set();
    let mut runs = vec![];
    for (wire, sets) in [("straight", vec![]), ("bent", vec![bent.as_str()])] {
        for c in &CONFIGURATIONS {
            let sub = match wire {
                "straight" => c.name.to_string(),
                _ => format!("{}_{wire}", c.name),
            };
            let (o, results) = study_sweep(
                opts,
                &sub,
                c.scene_file,
                c.scene_text,
                &sets,
                &varies,
                true,
                progress,
            )?;
            for r in &results {
                let (Ok(s), Some(t)) = (&r.outcome, &r.trace) else {
                    continue;
                };
                let half = t.lateral_error_m.len() / 2;
                let late = &t.lateral_error_m[half..];
                runs.push(ReversingRun {
                    configuration: c.name,
                    wire,
                    start_offset_m: value_of(&o, r, Pose::y_m.key()).parse().unwrap_or(f64::NAN),
                    lost_wire: s.lost_wire,
                    late_rms_m: (late.iter().map(|e| e * e).sum::<f64>()
                        / late.len().max(1) as f64)
                        .sqrt(),
                    final_error_m: s.final_lateral_error_m,
                });
            }
        }
    }
    let rows: Vec<Vec<String>> = runs
        .iter()
        .map(|r| {
            vec![
                r.configuration.replace('_', " "),
                r.wire.into(),
                format!("{:.0}", 1000.0 * r.start_offset_m),
                if r.lost_wire { "yes" } else { "no" }.into(),
                format!("{:.1}", 1000.0 * r.late_rms_m),
                format!("{:.1}", 1000.0 * r.final_error_m),
            ]
        })
        .collect();
    let mut summary = format!(
        "# Reversing\n\nThe AGV reverses along the wire at the lab speed (full level, 20 s) \
         from a start offset, parallel to the wire, in three configurations:\n\n\
         - **front only**: the lab's P-D law on the front coil pair;\n\
         - **swing away**: the thesis's strategy on the same pair (`controller.kind = \
         \"swing_away\"`): steer the drive axle onto the wire, which first turns the sensor \
         end away from it, keeping track of the wire by dead reckoning from wheel encoders \
         on the assumption that it is straight;\n\
         - **rear pair**: the P-D law on a second pair 0.45 m behind the drive axle.\n\n\
         The wire is straight, or bent: {BEND_AFTER_M} m behind the start it turns through \
         {:.0} degrees on a {BEND_RADIUS_M:.0} m radius. Errors are the steering pair's offset \
         from the wire.\n\n",
        BEND_ANGLE_RAD.to_degrees(),
    );
    summary.push_str(&md_table(
        &[
            "configuration",
            "wire",
            "start offset mm",
            "lost wire",
            "RMS error, second half, mm",
            "final error mm",
        ],
        &rows,
    ));
    summary.push_str(&findings(&runs));
    summary.push_str(&linear_analysis()?);
    let files = vec![write_summary(&opts.out_dir, &summary)?];
    Ok((runs, StudyOutput { summary, files }))
}

/// What the runs show: from how many starts each configuration held the wire, straight
/// and bent.
fn findings(runs: &[ReversingRun]) -> String {
    let held = |c: &str, w: &str| {
        let of: Vec<&ReversingRun> = runs
            .iter()
            .filter(|r| r.configuration == c && r.wire == w)
            .collect();
        let n = of.iter().filter(|r| !r.lost_wire).count();
        format!("{n} of {}", of.len())
    };
    let rows: Vec<Vec<String>> = CONFIGURATIONS
        .iter()
        .map(|c| {
            vec![
                c.name.replace('_', " "),
                held(c.name, "straight"),
                held(c.name, "bent"),
            ]
        })
        .collect();
    let mut s = String::from("\nStarts from which the wire was held to the end:\n\n");
    s.push_str(&md_table(
        &["configuration", "straight wire", "bent wire"],
        &rows,
    ));
    s.push_str(
        "\nThe swing-away strategy is only as right as its picture of the wire. On the bend \
         its dead-reckoned line runs on straight while the wire turns away, and the one pair, \
         which cannot see the heading, cannot tell it (the thesis: \"no knowledge of the \
         curve even after the centre of the AGV is well off the guide wire\").\n",
    );
    s
}

/// The P-D configurations by linear analysis (`agvsim linearize`): the rightmost pole of
/// the P-D loop closed around the linearised plant.
fn linear_analysis() -> Result<String, SweepError> {
    use crate::sim::linearize::{close_loop, linearise};
    let mut rows = vec![];
    for c in CONFIGURATIONS.iter().filter(|c| c.pd_loop) {
        let scene =
            crate::scene::Scene::from_toml(c.scene_text, std::path::Path::new(c.scene_file), &[])?;
        let [pole, verdict] = match linearise(&scene) {
            Ok(l) => match close_loop(&l) {
                Some(cl) => [
                    format!("{:+.2}", cl.rightmost_re()),
                    if cl.stable() { "stable" } else { "unstable" }.to_string(),
                ],
                None => ["-".into(), "not analysed (no P-D loop to close)".into()],
            },
            Err(e) => ["-".into(), format!("not analysed: {e}")],
        };
        rows.push(vec![c.name.replace('_', " "), pole, verdict]);
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
