//! Whether the calibrated model is right enough for its intervals: what it leaves of each
//! output must not follow a signal the model knows, an input or the model's own predicted
//! outputs (its state, free of the sensors' noise). The intervals assume a right model; a
//! model that lacks some physics leaves a residual that those signals drive, while a
//! sensor's noise, white or coloured, does not depend on them. So unlike a whiteness test,
//! this one does not fire on an encoder's quantisation or a low-passed current.
//!
//! Both series are averaged over blocks of [`BLOCK_S`] first (an input and a residual of
//! 1 kHz rows vary over the dynamics' time constants, not over a sample). Then two looks:
//!
//! - **in levels**: the signal's values cut into [`BINS`] bins, the residual's mean in each
//!   against its standard error (a one-way analysis of variance; [`strongest_bin`]), which
//!   catches what no linear filter shows (a friction stepping with the speed's sign, a
//!   supply clipping at high commands);
//! - **at lags**: the cross-correlation with each input up to [`LAG_SPAN_S`] either side,
//!   against the 99 % band of [`crate::ident::resid::independence`] (Ljung's test, MATLAB's
//!   `resid`), which accounts for the residual's and the input's own correlation.

use crate::ident::data::Dataset;
use crate::ident::resid;
use crate::ident::weighting::correlation_factor;

/// The averaging block, s: shorter than a drive's time constants (tens of ms and more).
pub const BLOCK_S: f64 = 0.01;
/// The lags looked at either side, s: a motor's and a chassis's response and a loop's
/// dead time all fall within it.
pub const LAG_SPAN_S: f64 = 0.5;
/// How far outside the 99 % band a lagged correlation must reach to say the model is
/// wrong: twice its half-width, a 5.2-sigma excursion that an independent residual
/// practically never makes over all the lags and pairs looked at (one outside the band
/// alone would, at 1 % a lag).
pub const FLAG_BAND_MULTIPLE: f64 = 2.0;
/// Bins of a signal's values in which the residual's mean is looked at.
pub const BINS: usize = 8;
/// How many standard errors a bin's mean residual must be from zero to say the model is
/// wrong: with a few hundred bins looked at over the outputs and signals, an independent
/// residual reaches it about once in ten thousand calibrations.
pub const FLAG_BIN_Z: f64 = 5.0;

/// How a residual was found to follow a signal.
#[derive(Debug, Clone, PartialEq)]
pub enum How {
    /// Linearly, at a lag: the normalised cross-correlation and the 99 % band an
    /// independent residual stays in.
    Lagged {
        /// The lag of the peak, s (positive: the signal leads).
        lag_s: f64,
        /// The normalised correlation there.
        correlation: f64,
        /// The band's half-width.
        band: f64,
    },
    /// In its level: where the signal lies in `[from, to]` (a bin of its values), the
    /// residual's mean is off zero by `mean`, with a standard error `std_error` that
    /// counts the residual's own correlation in time.
    Binned {
        /// The bin's lower end, in the signal's unit.
        from: f64,
        /// The bin's upper end.
        to: f64,
        /// The residual's mean there, in the output's unit.
        mean: f64,
        /// Its standard error.
        std_error: f64,
    },
}

/// The strongest link found between an output's residual and a signal the model knows
/// (an input, or an output as the model predicts it: its state, free of the noise).
#[derive(Debug, Clone, PartialEq)]
pub struct ResidualLink {
    /// The output whose residual it is.
    pub output: String,
    /// The signal it follows: an input's name, or `predicted OUTPUT`.
    pub signal: String,
    /// How.
    pub how: How,
}

impl How {
    /// The link's score: the correlation in multiples of its band's half-width, or the
    /// bin's mean in standard errors.
    pub fn score(&self) -> f64 {
        match *self {
            How::Lagged {
                correlation, band, ..
            } => correlation.abs() / band,
            How::Binned {
                mean, std_error, ..
            } => mean.abs() / std_error,
        }
    }
}

impl ResidualLink {
    /// The link's [`How::score`] over the score that says the model is wrong
    /// ([`FLAG_BAND_MULTIPLE`], [`FLAG_BIN_Z`]): above 1, it does.
    pub fn strength(&self) -> f64 {
        let limit = match self.how {
            How::Lagged { .. } => FLAG_BAND_MULTIPLE,
            How::Binned { .. } => FLAG_BIN_Z,
        };
        self.how.score() / limit
    }

    /// Whether the link is strong enough to say the model lacks something.
    pub fn says_model_wrong(&self) -> bool {
        self.strength() > 1.0
    }

    /// The link in words, with its numbers.
    pub fn describe(&self) -> String {
        let n = crate::numtext::sig;
        let score = self.how.score();
        match self.how {
            How::Lagged {
                lag_s, correlation, ..
            } => format!(
                "the residual of {} follows {} (correlation {:+.3} at a lag of {:.2} s, {:.1} times the 99 % band an independent residual stays in)",
                self.output,
                self.signal,
                correlation,
                lag_s,
                score
            ),
            How::Binned { from, to, mean, .. } => format!(
                "the residual of {} is {} on average where {} lies in [{}, {}] ({:.1} standard errors off zero)",
                self.output,
                n(mean, 3),
                self.signal,
                n(from, 3),
                n(to, 3),
                score
            ),
        }
    }
}

/// The strongest link of each output's residual, strongest first: `predicted` against
/// the measured outputs of `data`, each residual against every input at lags
/// ([`How::Lagged`]) and in bins of every input and predicted output ([`How::Binned`]).
/// An output with too few blocks to judge (under four lag spans) is left out.
///
/// `windows` are the pose windows ([`super::pose_windows`]) where the pose is compared
/// over them: each window restarted from one noisy estimate of its start, the pose's
/// residual carries a noise that stays for a whole window, so a bin filled from few
/// windows is judged against the whole residual ([`strongest_bin`]).
pub fn residual_links(
    data: &Dataset,
    predicted: &[Vec<f64>],
    windows: Option<&super::pose_windows::PoseWindows>,
) -> Vec<ResidualLink> {
    let dt = data.median_interval_s();
    if dt <= 0.0 {
        return vec![];
    }
    let rows_per_block = ((BLOCK_S / dt).round() as usize).max(1);
    let block_s = rows_per_block as f64 * dt;
    let lags = ((LAG_SPAN_S / block_s).round() as usize).max(1);
    let signals: Vec<(String, &[f64])> = data
        .input_names
        .iter()
        .zip(&data.inputs)
        .map(|(n, u)| (n.clone(), u.as_slice()))
        .chain(
            data.output_names
                .iter()
                .zip(predicted)
                .map(|(n, p)| (format!("predicted {n}"), p.as_slice())),
        )
        .collect();
    let mut links: Vec<ResidualLink> = data
        .output_names
        .iter()
        .enumerate()
        .filter_map(|(j, output)| {
            let (measured, e) = data.measured_residual(j, &predicted[j]);
            let blocks = block_means(&e, rows_per_block);
            if blocks.len() < 4 * lags {
                return None;
            }
            // Each block's pose window, where this output is compared over windows (a
            // block without one is a stretch of its own).
            let stretch: Option<Vec<usize>> =
                windows.filter(|w| w.outputs().contains(&j)).map(|w| {
                    (0..blocks.len())
                        .map(|b| {
                            let row = measured[b * rows_per_block];
                            w.window_of(row).unwrap_or(usize::MAX - b)
                        })
                        .collect()
                });
            let lagged = data.input_names.iter().enumerate().map(|(i, input)| {
                let u: Vec<f64> = measured.iter().map(|&k| data.inputs[i][k]).collect();
                let check = resid::independence(&block_means(&u, rows_per_block), &blocks, lags);
                strongest_lag(output, input, &check, block_s, blocks.len())
            });
            let binned = signals.iter().filter_map(|(name, x)| {
                let x: Vec<f64> = measured.iter().map(|&k| x[k]).collect();
                strongest_bin(
                    &blocks,
                    &block_means(&x, rows_per_block),
                    stretch.as_deref(),
                )
                .map(|how| ResidualLink {
                    output: output.clone(),
                    signal: name.clone(),
                    how,
                })
            });
            lagged
                .chain(binned)
                .max_by(|a, b| a.strength().total_cmp(&b.strength()))
        })
        .collect();
    links.sort_by(|a, b| b.strength().total_cmp(&a.strength()));
    links
}

/// The lag of `check` (over `n` blocks) where the correlation is furthest outside its band.
fn strongest_lag(
    output: &str,
    input: &str,
    check: &resid::CorrelationCheck,
    block_s: f64,
    n: usize,
) -> ResidualLink {
    let (lag, correlation) = check
        .lags
        .iter()
        .zip(&check.values)
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        .map_or((0, 0.0), |(&l, &v)| (l, v));
    ResidualLink {
        output: output.to_string(),
        signal: input.to_string(),
        how: How::Lagged {
            lag_s: lag as f64 * block_s,
            correlation,
            // Bartlett's band, `sqrt(sum r_u r_e / N)`, shrinks towards zero where the
            // residual's neighbours anti-correlate (an encoder's count: its errors telescope
            // over a block), and the approximation with it; a white residual's band is the
            // narrowest kept.
            band: check.band.max(resid::Z_99 / (n.max(1) as f64).sqrt()),
        },
    }
}

/// The bin of `x`'s values ([`BINS`] of equal count, in order of `x`) where the mean of
/// `e` is most standard errors off zero (a one-way analysis of variance). The standard
/// error of a bin of `m` residuals is `sd sqrt(f / m)` with `sd` and `f` (how many
/// neighbouring residuals count as one, [`correlation_factor`]) of the residual less its
/// bins' means: what the signal's level explains is the finding, not its noise, so a
/// model error that follows `x` does not widen its own yardstick. Where the residual's
/// noise stays the same over stretches of time (`stretch`: each sample's; a pose window,
/// restarted from one noisy estimate of its start), a bin filled from fewer than
/// [`MIN_VISITS`] of them is judged against the whole residual instead; and every bin's
/// standard error counts the stretches it holds, the draws of that noise
/// ([`design_effect`]). `None` where `x` does not vary.
fn strongest_bin(e: &[f64], x: &[f64], stretch: Option<&[usize]>) -> Option<How> {
    let n = e.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let (lo, hi) = (x[*order.first()?], x[*order.last()?]);
    if !(hi > lo) || n < 4 * BINS {
        return None;
    }
    let bins: Vec<&[usize]> = (0..BINS)
        .map(|b| &order[b * n / BINS..(b + 1) * n / BINS])
        .collect();
    let means: Vec<f64> = bins
        .iter()
        .map(|bin| bin.iter().map(|&k| e[k]).sum::<f64>() / bin.len() as f64)
        .collect();
    let mut within = e.to_vec();
    for (bin, m) in bins.iter().zip(&means) {
        for &k in *bin {
            within[k] -= m;
        }
    }
    let sd = (within.iter().map(|v| v * v).sum::<f64>() / (n - BINS) as f64).sqrt();
    if sd == 0.0 {
        return None;
    }
    let f = correlation_factor(&within);
    // A bin the signal fills in few separate stretches of time cannot tell the signal's
    // level from a slow noise that happened then (a tracked pose's window, restarted from
    // one noisy estimate, is off by the same amount throughout): its mean is judged
    // against the whole residual's spread and correlation instead, as one draw of it.
    let plain = std::cell::OnceCell::new();
    // The share of the residual's variance that stays the same over a stretch, from the
    // residual less the bins' means (what the signal explains is the finding).
    let shared = stretch.map_or(0.0, |st| intraclass_correlation(&within, st));
    bins.iter()
        .zip(&means)
        .map(|(bin, &mean)| {
            let (sd, f) = match stretch.map(|st| visits(bin, st)) {
                None => (sd, f),
                Some(visits) => {
                    let (sd, f) = if visits < MIN_VISITS {
                        *plain.get_or_init(|| whole_residual(e))
                    } else {
                        (sd, f)
                    };
                    // The stretches' slow noise is one draw per stretch, however small
                    // its correlation at one lag: under `weighting::DECORRELATED` the
                    // correlation factor stops counting, though a correlation of 0.04
                    // held over a 2 s window of 200 samples adds 8 to it.
                    (sd, f.max(design_effect(bin.len(), visits, shared)))
                }
            };
            How::Binned {
                from: x[bin[0]],
                to: x[bin[bin.len() - 1]],
                mean,
                std_error: sd * (f / bin.len() as f64).sqrt(),
            }
        })
        .max_by(|a, b| a.score().total_cmp(&b.score()))
}

/// Fewest of a slow noise's stretches a bin's samples must come from for its mean to be
/// judged against the residual less the bins' means ([`strongest_bin`]).
const MIN_VISITS: f64 = 4.0;

/// How many of the slow noise's stretches a bin's samples (indices) come from, each weighed
/// by its share: `(sum n_i)^2 / sum n_i^2` over the stretches' counts `n_i`, so one
/// stretch with a few brief returns elsewhere counts as about one.
fn visits(bin: &[usize], stretch: &[usize]) -> f64 {
    let mut counts = std::collections::BTreeMap::<usize, usize>::new();
    for &k in bin {
        *counts.entry(stretch[k]).or_default() += 1;
    }
    let total: usize = counts.values().sum();
    (total * total) as f64 / counts.values().map(|c| c * c).sum::<usize>() as f64
}

/// The intraclass correlation of `e` over its stretches: the share of its variance that
/// is one draw per stretch, from the stretches' sums `S_c` against their counts `n_c`,
/// `(sum S_c^2 - sum e^2) / ((sum n_c^2 - N) var e)` (the moment estimate; 0 for a white
/// residual, 1 for one constant over each stretch), within [0, 1].
fn intraclass_correlation(e: &[f64], stretch: &[usize]) -> f64 {
    let n = e.len() as f64;
    let m = e.iter().sum::<f64>() / n.max(1.0);
    let mut sums = std::collections::BTreeMap::<usize, (f64, f64)>::new();
    for (v, &c) in e.iter().zip(stretch) {
        let s = sums.entry(c).or_default();
        s.0 += v - m;
        s.1 += 1.0;
    }
    let ss: f64 = e.iter().map(|v| (v - m) * (v - m)).sum();
    let (sum_sq, count_sq) = sums
        .values()
        .fold((0.0, 0.0), |(a, b), (s, c)| (a + s * s, b + c * c));
    let den = (count_sq - n) * ss / n;
    if den <= 0.0 {
        return 0.0;
    }
    ((sum_sq - ss) / den).clamp(0.0, 1.0)
}

/// How many times a white residual's variance a bin's mean has where a share `shared` of
/// the residual's variance is one draw per stretch: `1 + shared (sum n_c^2 / m - 1)` for
/// the bin's `m` samples, `n_c` of them from stretch `c` (the design effect of a cluster
/// sample), `sum n_c^2 / m` being `m` over the bin's [`visits`].
fn design_effect(m: usize, visits: f64, shared: f64) -> f64 {
    1.0 + shared * (m as f64 / visits - 1.0)
}

/// The residual's standard deviation and [`correlation_factor`], its mean taken out.
fn whole_residual(e: &[f64]) -> (f64, f64) {
    let n = e.len();
    let m = e.iter().sum::<f64>() / n as f64;
    let sd = (e.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1).max(1) as f64).sqrt();
    (sd, correlation_factor(e))
}

/// Means of consecutive blocks of `n` values (a last partial block dropped).
fn block_means(x: &[f64], n: usize) -> Vec<f64> {
    x.chunks_exact(n)
        .map(|c| c.iter().sum::<f64>() / n as f64)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A first-order plant `y' = (u - y) / tau` on a random-step input, sampled at 1 kHz.
    fn plant(u: &[f64], dt: f64, tau_s: f64) -> Vec<f64> {
        let mut y = 0.0;
        u.iter()
            .map(|&v| {
                y += dt * (v - y) / tau_s;
                y
            })
            .collect()
    }

    fn dataset(u: Vec<f64>, y: Vec<f64>, dt: f64) -> Dataset {
        Dataset {
            name: "test".into(),
            t_s: (0..u.len()).map(|k| k as f64 * dt).collect(),
            input_names: vec!["u".into()],
            inputs: vec![u],
            output_names: vec!["y".into()],
            outputs: vec![y.into_iter().map(Some).collect()],
            segment_starts: vec![0],
        }
    }

    /// A tracked pose's window restarted from a noisy estimate: its residual is off by
    /// the same amount throughout the window, while the vehicle sits still (a signal at one
    /// value). A bin that holds just that stretch cannot tell the signal's level from the
    /// window's error, so the offset does not say the model is wrong; the same offset
    /// returning each time the signal takes that value does.
    #[test]
    fn one_stretch_of_slow_noise_is_not_a_level_but_a_returning_one_is() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let noise = Normal::new(0.0, 1.0).unwrap();
        let n = 2000;
        // The signal: at rest (0) for the first 250 samples, then a sine of 126 samples.
        let x: Vec<f64> = (0..n)
            .map(|k| {
                if k < 250 {
                    0.0
                } else {
                    (k as f64 * 0.05).sin()
                }
            })
            .collect();
        let white: Vec<f64> = (0..n).map(|_| noise.sample(&mut rng)).collect();
        // Windows of 250 samples.
        let stretch: Vec<usize> = (0..n).map(|k| k / 250).collect();
        // The first window's offset: 1.5 deviations for its 250 samples.
        let once: Vec<f64> = white
            .iter()
            .enumerate()
            .map(|(k, v)| v + if k < 250 { 1.5 } else { 0.0 })
            .collect();
        let how = strongest_bin(&once, &x, Some(&stretch)).unwrap();
        assert!(how.score() < FLAG_BIN_Z, "{how:?}");
        // An offset wherever the sine is near its top: a level the signal brings back.
        let returning: Vec<f64> = white
            .iter()
            .zip(&x)
            .map(|(v, s)| v + if *s > 0.9 { 1.5 } else { 0.0 })
            .collect();
        let how = strongest_bin(&returning, &x, Some(&stretch)).unwrap();
        assert!(how.score() > FLAG_BIN_Z, "{how:?}");
    }

    /// Windows of 200 samples, each off by its own small offset (a start error of a fifth
    /// of the white noise's deviation: a correlation of 0.04 at one lag, under what the
    /// correlation factor counts), on a slow sine that fills each bin from about twenty
    /// windows. A bin's mean then varies as `sqrt(sigma_w^2 / m + sigma_s^2 sum n_c^2 /
    /// m^2)`, 2.2 times the white noise's `sigma_w / sqrt(m)`. With the windows' shared
    /// noise counted ([`design_effect`]), the strongest of the eight bins passes 3.5
    /// standard errors about as rarely as the largest of eight normal variables does
    /// (0.4 %; a few per cent with the estimate's own scatter); judged by the white
    /// yardstick alone, in most draws.
    #[test]
    fn a_bins_standard_error_counts_the_offsets_of_the_windows_it_holds() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let normal = Normal::new(0.0, 1.0).unwrap();
        let (n, window) = (16_000, 200);
        let x: Vec<f64> = (0..n).map(|k| (k as f64 * 0.0037).sin()).collect();
        let stretch: Vec<usize> = (0..n).map(|k| k / window).collect();
        let (mut counted, mut white) = (0, 0);
        for _ in 0..200 {
            let offsets: Vec<f64> = (0..n / window)
                .map(|_| 0.2 * normal.sample(&mut rng))
                .collect();
            let e: Vec<f64> = (0..n)
                .map(|k| normal.sample(&mut rng) + offsets[stretch[k]])
                .collect();
            if strongest_bin(&e, &x, Some(&stretch)).unwrap().score() > 3.5 {
                counted += 1;
            }
            if strongest_bin(&e, &x, None).unwrap().score() > 3.5 {
                white += 1;
            }
        }
        assert!(counted <= 12, "{counted} of 200 past 3.5 standard errors");
        assert!(white >= 80, "{white} of 200 with the white yardstick");
    }

    /// A model with the plant's time constant, against noise white or low-passed over
    /// 20 ms (a current sensor's), leaves a residual the input does not drive; one whose
    /// time constant is 20 % short leaves the difference of two responses, which it does,
    /// and so does a friction the model lacks (half the noise's deviation).
    #[test]
    fn a_wrong_time_constant_or_a_missing_friction_is_flagged_and_coloured_noise_is_not() {
        let dt = 1e-3;
        let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
        let step = Normal::new(0.0, 1.0).unwrap();
        let u: Vec<f64> = (0..30_000)
            .scan(0.0, |v, k| {
                if k % 300 == 0 {
                    *v = step.sample(&mut rng);
                }
                Some(*v)
            })
            .collect();
        let truth = plant(&u, dt, 0.1);
        let white: Vec<f64> = (0..u.len()).map(|_| 0.02 * step.sample(&mut rng)).collect();
        let coloured = plant(&white, dt, 0.02);
        let coloured_sd = (coloured.iter().map(|v| v * v).sum::<f64>() / 30_000.0).sqrt();
        for noise in [
            white.clone(),
            coloured.iter().map(|v| 0.02 * v / coloured_sd).collect(),
        ] {
            let y: Vec<f64> = truth.iter().zip(&noise).map(|(a, b)| a + b).collect();
            let data = dataset(u.clone(), y, dt);
            let right = residual_links(&data, std::slice::from_ref(&truth), None);
            assert!(!right[0].says_model_wrong(), "{:?}", right[0]);
            let wrong = residual_links(&data, &[plant(&u, dt, 0.08)], None);
            assert!(wrong[0].says_model_wrong(), "{:?}", wrong[0]);
            // A Coulomb friction the model lacks: a step in the speed's sign, which no
            // linear filter of the input shows but its level does.
            let friction: Vec<f64> = truth.iter().map(|v| v - 0.01 * v.signum()).collect();
            let y: Vec<f64> = friction.iter().zip(&noise).map(|(a, b)| a + b).collect();
            let lacks = residual_links(
                &dataset(u.clone(), y, dt),
                std::slice::from_ref(&truth),
                None,
            );
            assert!(lacks[0].says_model_wrong(), "{:?}", lacks[0]);
        }
    }
}
