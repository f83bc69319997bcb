//! The study's `summary.md`.

use std::fmt::Write as _;

use super::reference::CASE1;
use super::ThesisDcmcResult;
use crate::scene::Scene;
use crate::study::{md_table, opt};

pub(super) fn summary(r: &ThesisDcmcResult, scene: &Scene) -> String {
    let mut s =
        String::from("# The thesis's DCMC (section 5.2.1, case 1) and agvsim's machine\n\n");
    s.push_str("Reference (`case1_reference.csv`): the thesis's case-1 model (agvsim's signs) driven by random demand levels (up to 90 % forward, 45 % turn, held 0.5-1.5 s), encoder speeds every 25 ms, white noise at the thesis's loss.\n\n");
    s.push_str("## Each form of the DCMC's slow response, fitted to the reference through the lifted-wheel simulator\n\n");
    s.push_str("Then, with the fitted keys: the machine's own thesis-like lifted-wheel run identified with case 1 (`--model gain`), the firmware's P-D loop at the thesis's gain linearised (`agvsim linearize`), and the lab floor run (120 mm start, gain 1, complex level, 12 s).\n\n");
    forms_table(&mut s, r);
    s.push_str("\nThe case-1 structure has one time constant per side for both demands, so a fit to the reference puts the forward lag on the turn demand too, and then the firmware cannot hold the wire; with the turn demand at once the fit must shrink the turn gain to mimic the lag, and the machine no longer identifies as the thesis's.\n\n");
    s.push_str("## The shipped machine: matched so that it identifies as the thesis's\n\n");
    matched(&mut s, r);
    turn_lag(&mut s, r);
    s.push_str(
        "## Case-1 A and B: thesis, the reference identified, the shipped machine identified\n\n",
    );
    case1_table(&mut s, r, scene);
    s
}

/// Each form of the slow response as fitted, beside the thesis.
fn forms_table(s: &mut String, r: &ThesisDcmcResult) {
    let t = CASE1;
    let (tt, ct) = (t.time_constants_s(), t.column_ratios());
    let mut rows = Vec::new();
    for f in &r.forms {
        let keys = f
            .fitted
            .iter()
            .map(|(k, v, sd)| {
                format!(
                    "`{}` {v:.4} +- {}",
                    k.trim_start_matches("dcmc."),
                    opt(*sd, 4)
                )
            })
            .collect::<Vec<_>>()
            .join("<br>");
        let (tau, ratio) = (
            f.identified.time_constants_s(),
            f.identified.column_ratios(),
        );
        let floor = if f.floor.lost_wire {
            "loses the wire".to_string()
        } else {
            format!(
                "holds it: RMS {:.0} mm{}",
                1e3 * f.floor.rms_lateral_error_m,
                if f.floor.settling_distance_m.is_some() {
                    ", settled"
                } else {
                    ""
                }
            )
        };
        rows.push(vec![
            f.form.name().to_string(),
            keys,
            format!("{:.1} / {:.1}", f.replay_fit_pct[0], f.replay_fit_pct[1]),
            format!("{:.3} / {:.3}", tau[0], tau[1]),
            format!("{:.3} / {:.3}", ratio[0], ratio[1]),
            f.rightmost_pole_1_s.map_or("-".into(), |p| {
                format!("{p:+.3} ({})", if p < 0.0 { "stable" } else { "UNSTABLE" })
            }),
            floor,
        ]);
    }
    rows.push(vec![
        "thesis".into(),
        "-".into(),
        "-".into(),
        format!("{:.3} / {:.3}", tt[0], tt[1]),
        format!("{:.3} / {:.3}", ct[0], ct[1]),
        "-".into(),
        "followed the wire (Runs #1-#3)".into(),
    ]);
    s.push_str(&md_table(
        &[
            "form",
            "fitted keys",
            "replay fit L / R, %",
            "identified time constants L / R, s",
            "turn/forward L / R",
            "loop pole at gain 1, 1/s",
            "lab floor run",
        ],
        &rows,
    ));
}

/// The shipped machine's indirect fit.
fn matched(s: &mut String, r: &ThesisDcmcResult) {
    let m = &r.matched;
    let _ = writeln!(
        s,
        "Indirect fit ({} iterations): the forward and turn gains and one forward-demand lag for both sides, chosen so that the machine's thesis-like lifted runs (`--peak-demand 90 --hold 20..60`, seeds 1-4), identified with case 1 and averaged, give the thesis's A and B; the turn demand passes at once. Result: `forward_gain_V_pct` {:.4}, `turn_gain_V_pct` {:.4}, `response_time_left_s` = `response_time_right_s` {:.3}. Distances of A11, A22, B11, B12, B21, B22 from the thesis's, in its standard deviations: {}.\n",
        m.iterations,
        m.values[0],
        m.values[1],
        m.values[2],
        m.z.iter().map(|z| format!("{z:+.1}")).collect::<Vec<_>>().join(", ")
    );
}

/// The matched machine with a lag on the turn demand.
fn turn_lag(s: &mut String, r: &ThesisDcmcResult) {
    s.push_str("### How slow may the turn demand be? The matched machine with a lag on it\n\n");
    let rows: Vec<Vec<String>> = r
        .turn_lag_probe
        .iter()
        .map(|p| {
            let (tau, ratio) = (
                p.identified.time_constants_s(),
                p.identified.column_ratios(),
            );
            vec![
                format!("{:.1}", p.turn_response_time_s),
                format!("{:.3} / {:.3}", tau[0], tau[1]),
                format!("{:.3} / {:.3}", ratio[0], ratio[1]),
                if p.floor.lost_wire {
                    "loses the wire".into()
                } else {
                    format!("holds it: RMS {:.0} mm", 1e3 * p.floor.rms_lateral_error_m)
                },
            ]
        })
        .collect();
    s.push_str(&md_table(
        &[
            "`turn_response_time_s`, s",
            "identified time constants L / R, s",
            "turn/forward L / R",
            "lab floor run (complex level, gain 1)",
        ],
        &rows,
    ));
    s.push_str("\nThe floor runs bound the turn demand's lag; the shipped machine takes none (*assumed*).\n\n");
}

/// Case 1's A and B: the thesis's, the reference's and the shipped machine's identified.
fn case1_table(s: &mut String, r: &ThesisDcmcResult, scene: &Scene) {
    let t = CASE1;
    let (tt, ct) = (t.time_constants_s(), t.column_ratios());
    let b = t.b_agvsim();
    let cell = |v: f64| format!("{v:.4}");
    let mut rows = Vec::new();
    for i in 0..2 {
        rows.push(vec![
            format!("A{}{}", i + 1, i + 1),
            format!("{:.4} +- {:.4}", t.a_1_s[i], t.a_std_1_s[i]),
            cell(r.reference_model.a[(i, i)]),
            cell(r.machine_model.a[(i, i)]),
        ]);
    }
    for (i, side) in ["left", "right"].iter().enumerate() {
        for (j, d) in ["fwd", "turn"].iter().enumerate() {
            rows.push(vec![
                format!("B {side} {d}"),
                format!("{:.4} +- {:.4}", b[i][j], t.b_std[i][j]),
                cell(r.reference_model.b[(i, j)]),
                cell(r.machine_model.b[(i, j)]),
            ]);
        }
    }
    let (tr, tm) = (
        r.reference_model.time_constants_s(),
        r.machine_model.time_constants_s(),
    );
    let (cr, cm) = (
        r.reference_model.column_ratios(),
        r.machine_model.column_ratios(),
    );
    for i in 0..2 {
        let side = ["left", "right"][i];
        rows.push(vec![
            format!("time constant {side}, s"),
            format!("{:.3}", tt[i]),
            format!("{:.3}", tr[i]),
            format!("{:.3}", tm[i]),
        ]);
        rows.push(vec![
            format!("turn / forward column, {side}"),
            format!("{:.3}", ct[i]),
            format!("{:.3}", cr[i]),
            format!("{:.3}", cm[i]),
        ]);
    }
    s.push_str(&md_table(
        &[
            "quantity",
            "thesis (agvsim signs)",
            "reference, identified",
            "shipped machine, identified",
        ],
        &rows,
    ));
    let _ = writeln!(
        s,
        "\nThe shipped machine: `dcmc.forward_gain_V_pct` {}, `turn_gain_V_pct` {}, `response_time_left_s` {}, `response_time_right_s` {}, `turn_response_time_s` {}; its column is the mean of `agvsim experiment lifted-random-demand scenes/lab_offset_120mm.toml --seed N --peak-demand 90 --hold 20..60` identified with `--model gain`, N = 1-4.",
        scene.dcmc.forward_gain_v_pct,
        scene.dcmc.turn_gain_v_pct,
        scene.dcmc.response_time_left_s,
        scene.dcmc.response_time_right_s,
        scene.dcmc.turn_response_time_s
    );
}
