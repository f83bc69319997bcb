//! What a calibration gives: each fitted key, each effect tried with its verdict, the
//! switches and removals, the wheel geometry and its `diff_drive_controller` multipliers.

use crate::model::chassis::ChassisParams;
use crate::model::wheel::WheelParams;

use crate::ident::effects::Effect;
use crate::replay::Replay;
use crate::scene::Scene;

use super::{effects, terms};

/// One fitted key.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyFit {
    /// The dotted scene key.
    pub key: String,
    /// The scene's value (for an effect's key the scene did not set, the value its physics
    /// had: a tyre compound's friction).
    pub before: f64,
    /// The value the calibrated scene holds: the fitted one where it is an estimate
    /// ([`KeyFit::calibrated`]), else the scene's.
    pub after: f64,
    /// Where the fit ended, estimate or not.
    pub fitted: f64,
    /// Standard deviation of the fitted value; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The bound the search ended on, if it did: then `after` is no estimate, and the
    /// scene keeps its value (the belief or the model's structure is wrong).
    pub at_bound: Option<f64>,
    /// Held by its stated belief (`[uncertainty_pct]`): the recording determines it less
    /// well than the belief does, so `after` is more belief than data.
    pub held: bool,
    /// The recording cannot tell it apart from the other keys (a combination of them is
    /// all it shows): held at the scene's value while the others were fitted.
    pub confounded: bool,
    /// The other fitted keys it trades off against: each with the correlation of the two
    /// estimates, where its size reaches [`TRADE_OFF_CORRELATION`] (the recording shows
    /// their combination far better than either).
    pub trades_with: Vec<(String, f64)>,
    /// How the estimate moves with each key held because the recording could not tell it
    /// apart ([`KeyFit::confounded`]): the held key's name and the change of this key's
    /// fitted value (its unit) when the held key is 10 % above the scene's value and the
    /// others are refitted. The interval is the recording's given the held value; where
    /// the shift is larger than the standard deviation ([`KeyFit::conditional`]), it holds
    /// only as far as the held value is right.
    pub moves_with_held: Vec<(String, f64)>,
}

/// The correlation of two fitted keys from which the report says they trade off: at
/// 0.99 the combination along the pair's long axis is determined seven times better than
/// either key alone (`1 / sqrt(1 - r^2)`), and a model that lacks something moves them
/// together along it.
pub const TRADE_OFF_CORRELATION: f64 = 0.99;

/// The standard deviation, as a share of its value, above which an estimate is said to be
/// loosely determined: its 95 % interval (two standard deviations) then reaches further
/// than a tenth of the value either side, so the recording does not tell the key to 10 %
/// (on the project's example bag, the yaw inertia 2.61 ± 0.35 kg m^2 of a robot's 3.035).
pub const LOOSE_RELATIVE_STD: f64 = 0.05;

impl KeyFit {
    /// Whether the fit is an estimate the calibrated scene takes: not at a bound of its
    /// search, determined by the recording, and its standard deviation smaller than its
    /// value (a mass of 235 +- 294 kg says the recording cannot tell it from nothing).
    pub fn calibrated(&self) -> bool {
        self.at_bound.is_none() && self.std.is_some_and(|s| s < self.fitted.abs())
    }

    /// Whether the estimate's interval is the recording's only given a held key's value:
    /// 10 % of a key the recording could not tell apart moves it by more than its standard
    /// deviation ([`KeyFit::moves_with_held`]).
    pub fn conditional(&self) -> bool {
        self.std.is_some_and(|s| {
            self.moves_with_held
                .iter()
                .any(|(_, shift)| shift.abs() > s)
        })
    }

    /// For an estimate the recording determines only loosely ([`LOOSE_RELATIVE_STD`]):
    /// the half-width of its 95 % interval as a share of its value; `None` for a tighter
    /// estimate or no estimate.
    pub fn loose_share(&self) -> Option<f64> {
        let std = self.std.filter(|_| self.calibrated())?;
        let share = std / self.after.abs();
        (share > LOOSE_RELATIVE_STD).then_some(2.0 * share)
    }
}

/// The share of the residual, %, below which an effect's trial or race shows no sign of
/// it: a tenth of what acceptance asks ([`crate::diagnose::MIN_RSS_REDUCTION`]).
pub const NO_SIGN_PCT: f64 = 10.0 * crate::diagnose::MIN_RSS_REDUCTION;

/// An effect the scene had and the recording does not support, taken out.
#[derive(Debug, Clone, PartialEq)]
pub struct Removal {
    /// The effect.
    pub effect: Effect,
    /// The key that held its strength.
    pub key: String,
    /// The scene's value before.
    pub was: f64,
    /// The value that takes the physics out (written into the scene).
    pub off: f64,
}

/// An effect tried: its key fitted through the simulator with the scene's keys, and the
/// evidence the recording gives for it (the diagnosis's rule: an AIC gain above
/// [`crate::diagnose::MIN_DELTA_AIC`] with the effective sample count, at least
/// [`crate::diagnose::MIN_RSS_REDUCTION`] of
/// the residual removed, and the key not at a bound of its search).
#[derive(Debug, Clone, PartialEq)]
pub struct EffectTrial {
    /// The effect.
    pub effect: Effect,
    /// The scene key holding its strength.
    pub key: String,
    /// Its fitted value (the key's unit).
    pub value: f64,
    /// Its standard deviation; `None` where the record does not determine it.
    pub std: Option<f64>,
    /// The bound its search ended on, if it did: then the value is no estimate.
    pub at_bound: Option<f64>,
    /// Likelihood gain over its AIC penalty, with the effective sample count.
    pub delta_aic: f64,
    /// Share of the weighted residual removed, %.
    pub rss_reduction_pct: f64,
    /// Whether the evidence rule accepted it (written into the scene).
    pub accepted: bool,
    /// An effect the scene had that the recording does not support: taken out (its key
    /// at its off value).
    pub removed: bool,
    /// Only raced (its key scanned, then fitted with the others for a few iterations), not
    /// fitted to convergence: the round's full trials went to effects whose races gained
    /// more.
    pub raced_only: bool,
    /// Supported by the recording's fit but not confirmed (so not added): the simulator
    /// replays the recording no better with it (found on the reduced base), or the
    /// validation recordings replay no better with it.
    pub unconfirmed: Option<Unconfirmed>,
    /// An effect the scene has, supported by the recording at the scene's strength (weighed
    /// against its absence) without being refined.
    pub kept: bool,
    /// The AIC gain of the model with the effect over the model without it, where the
    /// backward pass weighed its absence.
    pub against_absence: Option<f64>,
    /// Its place among the accepted effects (1: the first accepted), where it was.
    pub accepted_as: Option<usize>,
    /// The key's value in the scene where the scene already had the effect on (then an
    /// accepted trial refines it); `None` where the effect is new to the scene.
    pub scene_value: Option<f64>,
}

impl EffectTrial {
    /// Whether it removed next to nothing of the residual, or added to it ([`NO_SIGN_PCT`]):
    /// the recording shows no sign of the effect.
    pub fn shows_no_sign(&self) -> bool {
        self.rss_reduction_pct < NO_SIGN_PCT
    }

    /// The trial of `home`'s effect with its strength key at `value`, weighed by
    /// `gain`; not (yet) accepted, removed, raced only, kept or weighed against absence.
    pub(super) fn of(
        home: &effects::Home,
        value: f64,
        std: Option<f64>,
        at_bound: Option<f64>,
        gain: &crate::diagnose::evidence::Gain,
    ) -> EffectTrial {
        EffectTrial {
            effect: home.effect,
            key: home.key.to_string(),
            value,
            std,
            at_bound,
            delta_aic: gain.delta_aic,
            rss_reduction_pct: 100.0 * gain.reduction,
            accepted: false,
            removed: false,
            raced_only: false,
            unconfirmed: None,
            kept: false,
            against_absence: None,
            accepted_as: None,
            scene_value: home.in_scene.then_some(home.start),
        }
    }
}

/// What did not confirm an effect the recording's fit supported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unconfirmed {
    /// Found on the reduced base, the simulator replays the recording no better with it.
    Simulator,
    /// The validation recordings replay no better with it.
    Validation,
}

/// A key set (not fitted) to switch an accepted effect's physics on.
#[derive(Debug, Clone, PartialEq)]
pub struct Switch {
    /// The effect switched on.
    pub effect: Effect,
    /// The dotted scene key set.
    pub key: String,
    /// The value as TOML text (`"pi"`, `2.4e1`).
    pub value: String,
}

/// A calibration's result.
#[derive(Debug, Clone)]
pub struct Calibration {
    /// The fitted keys: the free ones, then the accepted effects'.
    pub keys: Vec<KeyFit>,
    /// Each effect tried, as last fitted (an accepted one as it was accepted).
    pub effects: Vec<EffectTrial>,
    /// The search for a term outside the vocabulary, where one ran (every effect offered,
    /// a lifted drive on the simulator: [`terms::searched`]).
    pub terms: Option<terms::TermSearch>,
    /// Keys set to switch the accepted effects on.
    pub switches: Vec<Switch>,
    /// Effects the scene had that the recording does not support, taken out.
    pub removed: Vec<Removal>,
    /// The outputs fitted (the contract's outputs the recording has and excites).
    pub outputs: Vec<String>,
    /// Outputs the recording has but does not excite, left out of the fit, with why.
    pub left_out: Vec<crate::ident::LeftOut>,
    /// The recording replayed on the original and on the calibrated scene.
    pub before: Replay,
    /// The recording replayed on the calibrated scene.
    pub after: Replay,
    /// The calibrated scene (the original with the fitted keys changed).
    pub scene: Scene,
    /// The scene with its free keys fitted and no effect tried yet: the nominal model
    /// fitted, which `diagnose` calls the baseline.
    pub baseline: Scene,
    /// Solver iterations in all (the keys' fit, the effects' races and fits, the
    /// settling).
    pub iterations: usize,
    /// The length of the residual's blocks whose scores' spread gave the standard
    /// deviations, s: the block length, doubled from one sample up to a twentieth of the
    /// recording, that gave the widest intervals ([`crate::ident::fit`]'s block sandwich;
    /// one sample interval where the white residual's were widest).
    pub residual_correlation_s: f64,
    /// [`Calibration::residual_correlation_s`] in rows (1: the white residual's intervals were widest).
    pub residual_correlation_rows: usize,
    /// Each fitted output's strongest link between its residual and a signal the model
    /// knows, strongest first ([`super::adequacy`]): where one says the model is wrong, the intervals,
    /// which assume a right model, are not to be trusted.
    pub residual_links: Vec<super::adequacy::ResidualLink>,
}

/// The drive wheels' geometry as calibrated, beside what the odometry is configured with.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelGeometry {
    /// Effective rolling radii (left, right), m, each with its standard deviation.
    pub radii_m: [(f64, Option<f64>); 2],
    /// Effective track, m, with its standard deviation.
    pub track_m: (f64, Option<f64>),
    /// The radius and the wheel separation the odometry and the base controller use, m.
    pub configured_m: (f64, f64),
}

impl WheelGeometry {
    /// UMBmark's `Ed`: the right wheel's effective diameter over the left's.
    pub fn ed(&self) -> f64 {
        self.radii_m[1].0 / self.radii_m[0].0
    }

    /// UMBmark's `Eb`: the effective track over the configured wheel separation.
    pub fn eb(&self) -> f64 {
        self.track_m.0 / self.configured_m.1
    }

    /// The geometry as `diff_drive_controller`'s multipliers of the configured values
    /// (ros2_control's `wheel_separation_multiplier`, `left_wheel_radius_multiplier`,
    /// `right_wheel_radius_multiplier`): the controller and its odometry then work with
    /// the effective track and radii. Where its file already has multipliers, the new ones
    /// are these times the old.
    pub fn controller_multipliers(&self) -> ControllerMultipliers {
        ControllerMultipliers {
            wheel_separation: self.eb(),
            left_wheel_radius: self.radii_m[0].0 / self.configured_m.0,
            right_wheel_radius: self.radii_m[1].0 / self.configured_m.0,
        }
    }
}

/// `diff_drive_controller`'s geometry multipliers (dimensionless), named as its
/// parameters without the `_multiplier` suffix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerMultipliers {
    /// `wheel_separation_multiplier`: effective track over the configured separation.
    pub wheel_separation: f64,
    /// `left_wheel_radius_multiplier`: the left wheel's effective radius over the
    /// configured radius.
    pub left_wheel_radius: f64,
    /// `right_wheel_radius_multiplier`: the right wheel's, likewise.
    pub right_wheel_radius: f64,
}

impl Calibration {
    /// The model check's verdict: whether the strongest residual link (the first of
    /// [`Calibration::residual_links`]) says the model is wrong, so the intervals are not
    /// to be trusted.
    pub fn model_check_fails(&self) -> bool {
        self.residual_links
            .first()
            .is_some_and(|l| l.says_model_wrong())
    }

    /// The wheel geometry, where the calibration fitted it (the `wheel_geometry` effect,
    /// or its keys freed).
    pub fn wheel_geometry(&self) -> Option<WheelGeometry> {
        let fit = |key: &str| self.keys.iter().find(|k| k.key == key && k.calibrated());
        let (l, r, t) = (
            fit(WheelParams::left_rolling_radius_m.key())?,
            fit(WheelParams::right_rolling_radius_m.key())?,
            fit(ChassisParams::track_width_m.key())?,
        );
        let s = &self.scene;
        Some(WheelGeometry {
            radii_m: [(l.after, l.std), (r.after, r.std)],
            track_m: (t.after, t.std),
            configured_m: (
                s.base.wheel_radius_m.unwrap_or(s.wheel.radius_m),
                s.base.wheel_separation_m.unwrap_or(t.before),
            ),
        })
    }

    /// The effects accepted, in the order they were, each with its key's final value.
    pub fn accepted_in_order(&self) -> Vec<(Effect, f64)> {
        let mut accepted: Vec<&EffectTrial> = self.effects.iter().filter(|t| t.accepted).collect();
        accepted.sort_by_key(|t| t.accepted_as.unwrap_or(usize::MAX));
        accepted.iter().map(|t| (t.effect, t.value)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_controllers_multipliers_are_the_effective_geometry_over_the_configured() {
        // A 0.4 m, 0.08 m drawing; the right wheel rolls on 1 % less, the track is 2 %
        // wider: ros2_control scales the drawing's values by these to match.
        let g = WheelGeometry {
            radii_m: [(0.08, None), (0.0792, None)],
            track_m: (0.408, None),
            configured_m: (0.08, 0.4),
        };
        let m = g.controller_multipliers();
        assert!((m.wheel_separation - 1.02).abs() < 1e-12, "{m:?}");
        assert!((m.left_wheel_radius - 1.0).abs() < 1e-12, "{m:?}");
        assert!((m.right_wheel_radius - 0.99).abs() < 1e-12, "{m:?}");
    }
}
