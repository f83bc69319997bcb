//! Sweep plots draw every combination: more lines than one plot holds are split over
//! several files, each saying which part it is; none is dropped silently (issue 32).

use std::collections::BTreeSet;
use std::process::Command;

#[test]
fn every_combination_is_drawn_and_a_split_plot_says_so() {
    let out = std::env::temp_dir().join(format!("agvsim_sweep_plots_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let o = Command::new(env!("CARGO_BIN_EXE_agvsim"))
        .args([
            "sweep",
            "scenes/lab_offset_120mm.toml",
            "--vary",
            "controller.gain_scale=2,6",
            "--vary",
            "tyre.peak_mu=0.3,0.6,0.9",
            "--vary",
            "tyre.sliding_ratio=0.6,0.7,0.8,0.9",
            "--duration",
            "1",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Twelve combinations of the keys not along x, each a line.
    let mut combos = BTreeSet::new();
    for mu in ["0.3", "0.6", "0.9"] {
        for r in ["0.6", "0.7", "0.8", "0.9"] {
            combos.insert(format!("peak_mu={mu} sliding_ratio={r}"));
        }
    }
    let plots = out.join("plots");
    let mut metrics = BTreeSet::new();
    for e in std::fs::read_dir(&plots).unwrap() {
        let name = e.unwrap().file_name().to_string_lossy().into_owned();
        let metric = name.trim_end_matches(".svg");
        let metric = metric.split("_part").next().unwrap().to_string();
        metrics.insert(metric);
    }
    assert!(metrics.contains("sliding_fraction"), "{metrics:?}");
    for metric in ["sliding_fraction", "distance_m", "battery_energy_J"] {
        let mut drawn = BTreeSet::new();
        let mut part = 1;
        loop {
            let file = if part == 1 {
                plots.join(format!("{metric}.svg"))
            } else {
                plots.join(format!("{metric}_part{part}.svg"))
            };
            let Ok(svg) = std::fs::read_to_string(&file) else {
                break;
            };
            let here: BTreeSet<String> = combos
                .iter()
                .filter(|c| svg.contains(&format!(">{c}<")))
                .cloned()
                .collect();
            if here.len() < combos.len() {
                assert!(
                    svg.contains(&format!("part {part}/")),
                    "{} draws {} of {} lines without saying it is a part",
                    file.display(),
                    here.len(),
                    combos.len()
                );
            }
            drawn.extend(here);
            part += 1;
        }
        assert_eq!(drawn, combos, "{metric}: lines missing from every part");
    }
}
