//! Whether a vehicle record shows turning: the commands' imbalance and the heading's
//! excursion, which decide whether the yaw it measures can steer a fit.

use crate::ident::data::Dataset;
use crate::record::channels as chan;

/// Largest RMS of the left and right commands' difference, as a share of the RMS of their
/// mean, at which a record commands no turn. Two sides' drivers never deliver exactly the
/// same voltage (a competition robot's straight SysId tests differ by 0.3 % to 2 %, a
/// single sample of 3.5 V at a step among them); a record that means to turn commands
/// several percent or more.
pub const NO_TURN_COMMAND_SHARE: f64 = 0.05;

/// Largest heading excursion within a test, rad, at which a record shows no turn (about
/// one degree: a gyro's drift and noise over a straight test of tens of seconds).
pub const NO_TURN_HEADING_RAD: f64 = 0.02;

/// What a record shows of turning: how much turn it commands, and how far the heading
/// moved where a gyro or a tracker measures it.
#[derive(Debug, Clone, Copy)]
pub struct Turning {
    /// RMS of the commands' difference over the RMS of their mean.
    pub command_share: f64,
    /// Largest heading excursion within a test (measured, or the gyro's rate integrated),
    /// rad; `None` where neither is measured.
    pub heading_excursion_rad: Option<f64>,
}

impl Turning {
    /// What `data` (inputs: left and right voltage) shows.
    pub fn of(data: &Dataset) -> Turning {
        let (l, r) = (&data.inputs[0], &data.inputs[1]);
        let n = l.len().max(1) as f64;
        let diff = (l.iter().zip(r).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / n).sqrt();
        let mean = (l
            .iter()
            .zip(r)
            .map(|(a, b)| (0.5 * (a + b)).powi(2))
            .sum::<f64>()
            / n)
            .sqrt();
        let command_share = if mean > 0.0 {
            diff / mean
        } else if diff > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        Turning {
            command_share,
            heading_excursion_rad: heading_excursion(data),
        }
    }

    /// Whether the record shows a turn: a commanded one, or a heading that moved.
    pub fn shown(&self) -> bool {
        self.command_share > NO_TURN_COMMAND_SHARE
            || self
                .heading_excursion_rad
                .is_some_and(|h| h > NO_TURN_HEADING_RAD)
    }

    /// The yaw outputs a record without a turn leaves out, each with why; none when it turns.
    pub fn yaw_left_out(&self) -> Vec<(String, String)> {
        if self.shown() {
            return Vec::new();
        }
        let why = self.why_none();
        [chan::YAW_RATE_RAD_S, chan::HEADING_RAD]
            .into_iter()
            .map(|o| (o.to_string(), why.clone()))
            .collect()
    }

    /// Why a record without a turn leaves the yaw outputs out, in words.
    fn why_none(&self) -> String {
        let heading = match self.heading_excursion_rad {
            Some(h) => format!(", and the heading moves {h:.4} rad at most within a test"),
            None => String::new(),
        };
        format!(
            "no turn: the left and right voltages differ by {:.1} % (RMS, of their mean){heading}; the yaw measured is the sensor's noise and the model's a response to the commands' imbalance, so it would steer the fit without showing anything",
            100.0 * self.command_share
        )
    }
}

/// Largest heading excursion within a test, rad: from `heading_rad` where measured, else
/// the integral of `yaw_rate_rad_s`; `None` with neither.
fn heading_excursion(data: &Dataset) -> Option<f64> {
    let excursion = |values: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
        if hi >= lo {
            hi - lo
        } else {
            0.0
        }
    };
    let segments = data.segments();
    if let Some(j) = data.output_index(chan::HEADING_RAD) {
        let col = &data.outputs[j];
        return Some(
            segments
                .iter()
                .map(|s| excursion(&mut col[s.clone()].iter().flatten().copied()))
                .fold(0.0, f64::max),
        );
    }
    let j = data.output_index(chan::YAW_RATE_RAD_S)?;
    let col = &data.outputs[j];
    Some(
        segments
            .iter()
            .map(|s| {
                let mut heading = 0.0;
                let mut last: Option<(f64, f64)> = None;
                let mut values = Vec::new();
                for k in s.clone() {
                    if let Some(w) = col[k] {
                        if let Some((t0, w0)) = last {
                            heading += 0.5 * (w + w0) * (data.t_s[k] - t0);
                        }
                        last = Some((data.t_s[k], w));
                        values.push(heading);
                    }
                }
                excursion(&mut values.into_iter())
            })
            .fold(0.0, f64::max),
    )
}
