//! How often the proof's printed intervals hold the machine's value: per kind and key,
//! the realised share within 1 and 1.96 standard deviations (the nominal 68.3 % and 95 %
//! intervals) with its Monte Carlo error.

use std::fmt::Write as _;

use super::Outcome;

/// Share of the fitted keys whose 1-sigma interval holds the machine's value, and how many
/// keys were counted.
pub fn coverage(outcomes: &[Outcome]) -> (f64, usize) {
    let judged: Vec<bool> = outcomes
        .iter()
        .flat_map(|o| o.keys.iter())
        .filter(|k| !k.conditional)
        .filter_map(|k| k.std.map(|s| (k.calibrated - k.truth).abs() <= s))
        .collect();
    let n = judged.len();
    let covered = judged.iter().filter(|&&c| c).count();
    (covered as f64 / n.max(1) as f64, n)
}

/// Realised coverage of the printed intervals over round trips, for one key of one kind
/// (or `all keys` of it): how many fitted values had a standard deviation, and how many
/// of those held the machine's value within 1 and within 1.96 of it (the nominal 68.3 %
/// and 95 % intervals), in all and per seed.
#[derive(Debug, Clone, PartialEq)]
pub struct CoverageRow {
    /// The kind's name.
    pub kind: &'static str,
    /// The scene key, or `all keys`.
    pub key: String,
    /// Fitted values with a standard deviation.
    pub n: usize,
    /// Of them, within one standard deviation of the truth.
    pub within_68: usize,
    /// Of them, within 1.96 standard deviations.
    pub within_95: usize,
    /// The same counts for each seed's round trips, by seed.
    pub per_seed: Vec<SeedCounts>,
}

/// One seed's counts of a [`CoverageRow`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeedCounts {
    /// The seed.
    pub seed: u64,
    /// Fitted values with a standard deviation.
    pub n: usize,
    /// Of them, within one standard deviation.
    pub within_68: usize,
    /// Of them, within 1.96 standard deviations.
    pub within_95: usize,
}

impl CoverageRow {
    /// The realised share of the 68.3 % intervals and its Monte Carlo standard error.
    pub fn share_68(&self) -> (f64, f64) {
        self.share(self.within_68, |c| c.within_68)
    }

    /// The realised share of the 95 % intervals and its Monte Carlo standard error.
    pub fn share_95(&self) -> (f64, f64) {
        self.share(self.within_95, |c| c.within_95)
    }

    /// The share `k / n` and its Monte Carlo standard error: the larger of the binomial
    /// share's, `sqrt(p (1 - p) / n)`, and the one from the spread between seeds,
    /// `sqrt(G / (G - 1) sum_g (k_g - p n_g)^2) / n` over the `G` seeds. The cases of one
    /// seed share its inputs, noise and beliefs, so their keys miss together and count as
    /// fewer than their number; the binomial error alone would understate the error.
    fn share(&self, k: usize, of: impl Fn(&SeedCounts) -> usize) -> (f64, f64) {
        let n = self.n.max(1) as f64;
        let p = k as f64 / n;
        let binomial = (p * (1.0 - p) / n).sqrt();
        let g = self.per_seed.len();
        if g < 2 {
            return (p, binomial);
        }
        let spread: f64 = self
            .per_seed
            .iter()
            .map(|c| (of(c) as f64 - p * c.n as f64).powi(2))
            .sum();
        let between_seeds = (g as f64 / (g as f64 - 1.0) * spread).sqrt() / n;
        (p, binomial.max(between_seeds))
    }
}

/// The coverage of every fitted key's interval in `outcomes`, by kind: one row per key,
/// then `all keys` of the kind.
pub fn coverage_table(outcomes: &[Outcome]) -> Vec<CoverageRow> {
    let mut rows: Vec<CoverageRow> = vec![];
    let mut add = |kind: &'static str, key: &str, seed: u64, z: f64| {
        let r = slot(
            &mut rows,
            |r| r.kind == kind && r.key == key,
            || CoverageRow {
                kind,
                key: key.to_string(),
                n: 0,
                within_68: 0,
                within_95: 0,
                per_seed: vec![],
            },
        );
        r.n += 1;
        r.within_68 += usize::from(z <= 1.0);
        r.within_95 += usize::from(z <= 1.96);
        let c = slot(
            &mut r.per_seed,
            |c| c.seed == seed,
            || SeedCounts {
                seed,
                n: 0,
                within_68: 0,
                within_95: 0,
            },
        );
        c.n += 1;
        c.within_68 += usize::from(z <= 1.0);
        c.within_95 += usize::from(z <= 1.96);
    };
    for o in outcomes {
        let kind = o.case.kind.name();
        for k in o.keys.iter().filter(|k| !k.conditional) {
            if let Some(z) = k.z().map(f64::abs) {
                add(kind, &k.key, o.seed, z);
                add(kind, ALL_KEYS, o.seed, z);
            }
        }
    }
    // Each kind's keys, then its total.
    rows.sort_by(|a, b| (a.kind, a.key == ALL_KEYS).cmp(&(b.kind, b.key == ALL_KEYS)));
    rows
}

const ALL_KEYS: &str = "all keys";

/// The element of `v` that `is` picks, pushed from `new` where there is none.
fn slot<T>(v: &mut Vec<T>, is: impl Fn(&T) -> bool, new: impl FnOnce() -> T) -> &mut T {
    let at = match v.iter().position(is) {
        Some(i) => i,
        None => {
            v.push(new());
            v.len() - 1
        }
    };
    &mut v[at]
}

/// [`coverage_table`] as text: nominal and realised coverage with the Monte Carlo error
/// ([`CoverageRow::share_95`]).
pub fn render_coverage(rows: &[CoverageRow]) -> String {
    let mut s = format!(
        "{:<16} {:<34} {:>5}  {:>22}  {:>22}\n",
        "kind", "key", "n", "68.3 % nominal: real", "95 % nominal: real"
    );
    for r in rows {
        let cell = |(p, e): (f64, f64)| format!("{:.1} ± {:.1} %", 100.0 * p, 100.0 * e);
        let _ = writeln!(
            s,
            "{:<16} {:<34} {:>5}  {:>22}  {:>22}",
            r.kind,
            r.key,
            r.n,
            cell(r.share_68()),
            cell(r.share_95())
        );
    }
    s
}

/// [`coverage_table`] as two figures: `coverage.svg`, each kind's keys together, and
/// `coverage_keys.svg`, every key. A dot per nominal level at its realised share, the
/// whisker its Monte Carlo error times 1.96, the nominal shares as dashed lines.
pub fn coverage_figures(rows: &[CoverageRow]) -> Vec<crate::plot::Figure> {
    let kinds: Vec<&CoverageRow> = rows.iter().filter(|r| r.key == ALL_KEYS).collect();
    let keys: Vec<&CoverageRow> = rows.iter().filter(|r| r.key != ALL_KEYS).collect();
    vec![
        crate::plot::Figure {
            file: "coverage.svg".into(),
            svg: coverage_chart(
                "Realised coverage of the printed intervals, by kind",
                &kinds,
                |r| format!("{} (n {})", r.kind, r.n),
            ),
        },
        crate::plot::Figure {
            file: "coverage_keys.svg".into(),
            svg: coverage_chart(
                "Realised coverage of the printed intervals, by key",
                &keys,
                |r| format!("{}: {} (n {})", r.kind, r.key, r.n),
            ),
        },
    ]
}

fn coverage_chart(
    title: &str,
    rows: &[&CoverageRow],
    label: impl Fn(&CoverageRow) -> String,
) -> String {
    use crate::plot::{interval_chart, IntervalRow, Reference};
    const C68: &str = "#1f5fbf";
    const C95: &str = "#d08000";
    let dot = |(p, e): (f64, f64)| {
        let pct = 100.0 * p;
        Some((
            pct,
            (pct - 196.0 * e).max(0.0),
            (pct + 196.0 * e).min(100.0),
        ))
    };
    let rows: Vec<IntervalRow> = rows
        .iter()
        .map(|r| IntervalRow {
            label: label(r),
            values: vec![dot(r.share_68()), dot(r.share_95())],
        })
        .collect();
    interval_chart(
        title,
        "dot: the share of fitted values within the interval of the machine's value; whisker: 1.96 x its Monte Carlo error",
        "realised coverage, %",
        &[("1-std intervals (68.3 % nominal)", C68), ("1.96-std intervals (95 % nominal)", C95)],
        &rows,
        &[
            Reference { x: 68.3, colour: C68, label: "68.3 %" },
            Reference { x: 95.0, colour: C95, label: "95 %" },
        ],
        (0.0, 100.0),
    )
}

/// Every fitted key of every round trip, a row each: the case, its seed, the key, the
/// machine's value, the calibrated value, its standard deviation (empty where the fit gave
/// none), `z`, the error in standard deviations, and whether the interval was said to hold
/// only given a held key, and whether the round trip's model check failed (the coverage
/// table's input, for a reader who wants to see which keys miss and by how much).
pub fn coverage_csv(outcomes: &[Outcome]) -> String {
    let mut s = String::from(
        "case,seed,key,truth,calibrated,std,z,conditional_on_held,model_check_failed\n",
    );
    for o in outcomes {
        for k in &o.keys {
            let z = k.z().map_or(String::new(), |z| format!("{z:.4}"));
            let _ = writeln!(
                s,
                "{},{},{},{:e},{:e},{},{z},{},{}",
                o.case.name,
                o.seed,
                k.key,
                k.truth,
                k.calibrated,
                k.std.map_or(String::new(), |s| format!("{s:e}")),
                k.conditional,
                o.model_flagged()
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibrate::prove::{Case, Excitation, FittedKey, Kind};

    fn outcome(kind: Kind, keys: &[(&str, f64, f64, Option<f64>)]) -> Outcome {
        seeded(kind, 1, keys)
    }

    fn seeded(kind: Kind, seed: u64, keys: &[(&str, f64, f64, Option<f64>)]) -> Outcome {
        let case = Case {
            name: "x".into(),
            kind,
            excitation: Excitation::CmdVelSteps,
            effect: None,
            truth: None,
            machine: vec![],
            common: vec![],
            noise: crate::calibrate::prove::SensorNoise::White,
            left_out: false,
        };
        Outcome {
            case,
            seed,
            accepted: vec![],
            key_error: None,
            keys: keys
                .iter()
                .map(|(k, t, v, s)| FittedKey {
                    key: k.to_string(),
                    truth: *t,
                    calibrated: *v,
                    std: *s,
                    conditional: k.starts_with('c'),
                })
                .collect(),
            fit_pct: (0.0, 0.0),
            residual_link: None,
            passed: true,
        }
    }

    /// Each key's interval is judged at 1 and at 1.96 of its standard deviation, per kind,
    /// with the kind's total last; a key without a deviation, or whose interval was said to
    /// hold only given a held key (named `c` here), is not counted; the Monte Carlo error
    /// is the binomial share's.
    #[test]
    fn coverage_counts_each_interval_by_kind_and_key() {
        let outcomes = [
            // z = 0.5 and z = 1.5
            outcome(
                Kind::BaseRig,
                &[
                    ("m", 10.0, 10.5, Some(1.0)),
                    ("k", 1.0, 1.15, Some(0.1)),
                    // Said to hold only given a held key: not counted.
                    ("c", 1.0, 1.5, Some(0.1)),
                ],
            ),
            // z = 3, and a key the fit could not give a deviation
            outcome(
                Kind::BaseRig,
                &[("m", 10.0, 7.0, Some(1.0)), ("k", 1.0, 2.0, None)],
            ),
            outcome(Kind::AxisVoltage, &[("r", 1.0, 1.0, Some(0.1))]),
        ];
        let rows = coverage_table(&outcomes);
        let find = |kind: &str, key: &str| {
            rows.iter()
                .find(|r| r.kind == kind && r.key == key)
                .unwrap()
        };
        let m = find("base_rig", "m");
        assert_eq!((m.n, m.within_68, m.within_95), (2, 1, 1));
        let k = find("base_rig", "k");
        assert_eq!((k.n, k.within_68, k.within_95), (1, 0, 1));
        assert!(rows.iter().all(|r| r.key != "c"));
        assert_eq!(coverage(&outcomes), (2.0 / 4.0, 4));
        let all = find("base_rig", "all keys");
        assert_eq!((all.n, all.within_68, all.within_95), (3, 1, 2));
        assert_eq!(rows.last().unwrap().key, "all keys");
        // One seed: the binomial error.
        let (p, e) = all.share_95();
        assert!((p - 2.0 / 3.0).abs() < 1e-12);
        assert!((e - (p * (1.0 - p) / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(find("axis_voltage", "all keys").within_68, 1);
    }

    /// Keys that miss together: two seeds, one whose four keys all hold and one whose four
    /// all miss. The share is a half either way, but eight keys from two seeds are worth
    /// two draws, not eight: the error from the spread between seeds, sqrt(2 (2^2 + 2^2))
    /// / 8 = 0.5, exceeds the binomial sqrt(0.25 / 8) = 0.18, and is the one given.
    #[test]
    fn keys_of_one_seed_that_miss_together_widen_the_monte_carlo_error() {
        let hold = [("a", 1.0, 1.0, Some(0.1)); 4];
        let miss = [("a", 1.0, 2.0, Some(0.1)); 4];
        let rows = coverage_table(&[
            seeded(Kind::BaseRig, 1, &hold),
            seeded(Kind::BaseRig, 2, &miss),
        ]);
        let a = rows.iter().find(|r| r.key == "a").unwrap();
        assert_eq!(a.per_seed.len(), 2);
        let (p, e) = a.share_68();
        assert!((p - 0.5).abs() < 1e-12);
        assert!((e - 0.5).abs() < 1e-12, "{e}");
        // Misses spread evenly over the seeds: the binomial error stands.
        let mixed = [
            ("a", 1.0, 1.0, Some(0.1)),
            ("a", 1.0, 1.0, Some(0.1)),
            ("a", 1.0, 2.0, Some(0.1)),
            ("a", 1.0, 2.0, Some(0.1)),
        ];
        let rows = coverage_table(&[
            seeded(Kind::BaseRig, 1, &mixed),
            seeded(Kind::BaseRig, 2, &mixed),
        ]);
        let (p, e) = rows[0].share_68();
        assert!((e - (p * (1.0 - p) / 8.0).sqrt()).abs() < 1e-12, "{e}");
    }
}
