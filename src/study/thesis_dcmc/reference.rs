//! The thesis's case-1 DCMC result (section 5.2.1) and a reference recording made from
//! it: what agvsim's machine is matched against. Units and signs: see the parent module.

use crate::record::channels as chan;
use std::fmt::Write as _;

use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_pcg::Pcg64;

/// The thesis's case-1 result, in its own sign convention.
#[derive(Debug, Clone, Copy)]
pub struct ThesisCase1 {
    /// Diagonal of A, 1/s.
    pub a_1_s: [f64; 2],
    /// Their standard deviations, 1/s.
    pub a_std_1_s: [f64; 2],
    /// B, rad/s^2 per pct, rows (left, right), columns (forward, turn).
    pub b: [[f64; 2]; 2],
    /// Their standard deviations.
    pub b_std: [[f64; 2]; 2],
    /// Determinant of the residual covariance, (rad/s)^4.
    pub loss: f64,
    /// Akaike's final prediction error.
    pub fpe: f64,
    /// Sample interval, s.
    pub sample_s: f64,
}

/// Section 5.2.1, case 1.
pub const CASE1: ThesisCase1 = ThesisCase1 {
    a_1_s: [-1.5447, -1.7278],
    a_std_1_s: [0.0533, 0.0315],
    b: [[-4.3438, -3.1130], [-3.9616, 2.8626]],
    b_std: [[0.1248, 0.1074], [0.0641, 0.0498]],
    loss: 4.45e5,
    fpe: 4.54e5,
    sample_s: 0.025,
};

impl ThesisCase1 {
    /// B in agvsim's convention (speeds and turn demand negated, see the module notes).
    pub fn b_agvsim(&self) -> [[f64; 2]; 2] {
        let b = self.b;
        [[-b[0][0], b[0][1]], [-b[1][0], b[1][1]]]
    }

    /// Time constants (left, right), s.
    pub fn time_constants_s(&self) -> [f64; 2] {
        self.a_1_s.map(|a| -1.0 / a)
    }

    /// Turn column over forward column, per side (magnitudes).
    pub fn column_ratios(&self) -> [f64; 2] {
        column_ratios(&self.b)
    }

    /// RMS of equal white noise on both outputs that gives the loss, rad/s.
    pub fn noise_rms_rad_s(&self) -> f64 {
        self.loss.powf(0.25)
    }
}

/// |B_turn / B_forward| per side.
pub fn column_ratios(b: &[[f64; 2]; 2]) -> [f64; 2] {
    [(b[0][1] / b[0][0]).abs(), (b[1][1] / b[1][0]).abs()]
}

/// Peak forward demand of the thesis-like lifted-wheel runs, pct (the reference's).
pub const THESIS_LIKE_PEAK_PCT: f64 = 90.0;
/// Hold range of their demand levels, samples of 25 ms (the reference's).
pub const THESIS_LIKE_HOLD: (usize, usize) = (20, 60);

/// How the reference recording is made.
#[derive(Debug, Clone, Copy)]
pub struct ReferenceSpec {
    /// Length, s.
    pub duration_s: f64,
    /// Peak forward demand, pct; turn demand peaks at half of it.
    pub peak_demand_pct: f64,
    /// Each demand level is held for a random whole number of samples in this range.
    pub hold_samples: (usize, usize),
    /// Zero demand at the start (the DCMC faults on a demand within 0.5 s of enabling).
    pub quiet_s: f64,
    /// Seed of the demands and noise.
    pub seed: u64,
}

impl Default for ReferenceSpec {
    fn default() -> Self {
        ReferenceSpec {
            // The thesis's runs lasted 2-15 s; the longest gives the best-determined fit.
            duration_s: 15.0,
            // Joystick-like levels of up to 90 % held 0.5-1.5 s: at the thesis's noise these
            // determine A and B to 2-4 % (one standard deviation), as the thesis's record
            // did (1.6-3.5 %), and stay below the bridges' 23.5 V with the fitted gains,
            // where the thesis's model is linear.
            peak_demand_pct: THESIS_LIKE_PEAK_PCT,
            hold_samples: THESIS_LIKE_HOLD,
            quiet_s: 0.6,
            seed: 1997,
        }
    }
}

/// The reference recording: the thesis's case-1 model (agvsim's signs) driven by random
/// demand levels held for random times ([`ReferenceSpec`]), sampled every 25 ms, exact zero-order-hold discretisation, white noise of
/// RMS `loss^(1/4)` on each speed. The speeds are what the thesis's encoders gave: the
/// mean over the 25 ms before each sample. Rig `drive_pair`, in the exchange format.
pub fn reference_recording(spec: &ReferenceSpec) -> String {
    let m = CASE1;
    let b = m.b_agvsim();
    let t = m.sample_s;
    let n = (spec.duration_s / t).round() as usize;
    let quiet = (spec.quiet_s / t).ceil() as usize;
    let noise = m.noise_rms_rad_s();
    let mut rng = Pcg64::seed_from_u64(spec.seed);
    let mut csv = crate::record::header(
        crate::rig::RigKind::DrivePair,
        &[
            (
                "description",
                format!(
                    "the thesis's case-1 DCMC model (section 5.2.1, PEM 2/22 1997 17:17) driven by random demand levels (peak {} pct forward, {} pct turn, held {}-{} samples), motor speeds with white noise of {noise:.2} rad/s RMS (the thesis's loss {:.3e})",
                    spec.peak_demand_pct,
                    0.5 * spec.peak_demand_pct,
                    spec.hold_samples.0,
                    spec.hold_samples.1,
                    m.loss
                ),
            ),
            ("sample_time_s", format!("{t}")),
            (
                "source",
                "agvsim study thesis-dcmc (reference generator)".into(),
            ),
            ("experiment", "lifted-random-demand".into()),
            ("seed", format!("{}", spec.seed)),
        ],
        &[
            chan::T_S,
            chan::DEMAND_FWD_PCT,
            chan::DEMAND_TURN_PCT,
            chan::LEFT_MOTOR_SPEED_RAD_S,
            chan::RIGHT_MOTOR_SPEED_RAD_S,
        ],
    );
    let phi = m.a_1_s.map(|a| (a * t).exp());
    let (mut y, mut demand, mut hold) = ([0.0f64; 2], [0.0f64; 2], 0usize);
    // Encoder speeds: the mean over the interval ending at the sample (row 0: at rest).
    let mut mean = [0.0f64; 2];
    let peak = spec.peak_demand_pct;
    for k in 0..=n {
        let measured = [0, 1].map(|i| {
            let e: f64 = StandardNormal.sample(&mut rng);
            mean[i] + noise * e
        });
        demand = demand_after(k, quiet, demand, &mut hold, peak, spec, &mut rng);
        let _ = writeln!(
            csv,
            "{:.3},{:.4},{:.4},{:.4},{:.4}",
            k as f64 * t,
            demand[0],
            demand[1],
            measured[0],
            measured[1]
        );
        for i in 0..2 {
            // Exact for a held demand: y(t) = y_ss + (y_k - y_ss) exp(a t).
            let a = m.a_1_s[i];
            let y_ss = -(b[i][0] * demand[0] + b[i][1] * demand[1]) / a;
            mean[i] = y_ss + (y[i] - y_ss) * (phi[i] - 1.0) / (a * t);
            y[i] = y_ss + (y[i] - y_ss) * phi[i];
        }
    }
    csv
}

/// The demand held from row `k` on: zero for the quiet start, then random levels held for
/// random numbers of samples.
fn demand_after(
    k: usize,
    quiet: usize,
    demand: [f64; 2],
    hold: &mut usize,
    peak: f64,
    spec: &ReferenceSpec,
    rng: &mut Pcg64,
) -> [f64; 2] {
    if k < quiet {
        return demand;
    }
    let mut demand = demand;
    if *hold == 0 {
        demand = [
            rng.random_range(-peak..=peak),
            rng.random_range(-0.5 * peak..=0.5 * peak),
        ];
        *hold = rng.random_range(spec.hold_samples.0..=spec.hold_samples.1);
    }
    *hold -= 1;
    demand
}
