//! Where each effect of the contract's vocabulary lives in the scene: the key that sets its
//! strength in the simulator, the keys that switch its physics on, and where a calibration
//! starts it. Calibration fits an effect by fitting that key through the simulator, so what
//! it finds is the physics the user's scene runs.

use super::{keys, CalibrateError};
pub use crate::ident::effects::Choice;
use crate::ident::effects::{Effect, Off};
use crate::model::battery::BatteryParams;
use crate::model::dcmc::DcmcParams;
use crate::model::wheel::WheelParams;
use crate::replay::Drive;
use crate::scene::Scene;
use crate::sim::SimParams;

/// An effect's home in the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Home {
    /// The effect.
    pub effect: Effect,
    /// The scene key holding the effect's strength, fitted by the calibration.
    pub key: &'static str,
    /// Other keys set to switch the physics on, with their values.
    pub switches: Vec<SwitchOn>,
    /// Where the fit starts the key.
    pub start: f64,
    /// Whether the scene already had the effect's physics on (the start is the scene's
    /// own value): accepted, it is refined, not added.
    pub in_scene: bool,
    /// For a key of either sign (a bias torque), the half-width of its linear search
    /// around zero; `None` for a strictly positive key, searched on a log scale.
    pub signed_range: Option<f64>,
    /// The key's value at which the effect's physics is absent (no play, no delay, no
    /// clipping, no sag): where a calibration sets it to remove an effect the scene has
    /// and the recording does not support. `None` where the physics cannot be taken out
    /// (a tyre always has a friction limit).
    pub off: Option<f64>,
    /// Keys fitted with the strength key, each with its start and off value (the wheel
    /// geometry's two rolling radii beside its track).
    pub also: Vec<Companion>,
    /// Whether a race scans the key over its range before fitting (a play or a limit
    /// moves the outputs in steps the gradient cannot see across); `false` where the
    /// outputs follow the key smoothly from its start (the wheel geometry, a few
    /// percent from the configured).
    pub scanned: bool,
}

/// A scene key an effect sets to switch its physics on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchOn {
    /// The dotted scene key.
    pub key: &'static str,
    /// Its value.
    pub value: Setting,
}

/// A switch's value, typed as the scene holds it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Setting {
    /// A number (a bridge rating, V).
    Number(f64),
    /// The DCMC's loop structure.
    DcmcKind(crate::model::dcmc::DcmcKind),
}

impl SwitchOn {
    /// Sets the key on a scene (not validated: [`switched_on`] validates the whole).
    fn apply(&self, scene: &mut Scene) -> Result<(), CalibrateError> {
        match self.value {
            Setting::Number(v) => keys::set_number(scene, self.key, v),
            Setting::DcmcKind(k) => {
                scene.dcmc.kind = k;
                Ok(())
            }
        }
    }

    /// The value as TOML text, as the report and a written scene show it (`"pi"`,
    /// `2.4e1`).
    pub fn value_text(&self) -> String {
        match self.value {
            Setting::Number(v) => format!("{v:e}"),
            Setting::DcmcKind(k) => format!("\"{}\"", k.name()),
        }
    }
}

/// A key fitted with an effect's strength key.
#[derive(Debug, Clone, PartialEq)]
pub struct Companion {
    /// The scene key.
    pub key: &'static str,
    /// Where the fit starts it.
    pub start: f64,
    /// Its value where the effect's physics is absent.
    pub off: f64,
}

impl Home {
    /// Every key the effect's fit adds to the free ones, in the order they are added (the
    /// strength key last).
    pub fn keys(&self) -> Vec<&'static str> {
        let mut k: Vec<&'static str> = self.also.iter().map(|c| c.key).collect();
        k.push(self.key);
        k
    }

    /// Each key at its off value, where the physics can be taken out.
    pub fn off_values(&self) -> Option<Vec<(String, f64)>> {
        let off = self.off?;
        let mut pairs: Vec<(String, f64)> = self
            .also
            .iter()
            .map(|c| (c.key.to_string(), c.off))
            .collect();
        pairs.push((self.key.to_string(), off));
        Some(pairs)
    }
}

/// Why an effect has no home for this recording, or none yet.
fn homeless(effect: Effect, why: &str) -> CalibrateError {
    CalibrateError::Key(format!("--effects {}: {why}", effect.name()))
}

/// How a recording drives the simulator: what decides where an effect can live.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Driven {
    /// Which inputs the recording gives.
    pub drive: Drive,
    /// The machine stands on the floor (a vehicle), not on blocks.
    pub on_floor: bool,
    /// The largest voltage the recording asks of the motors, V: its voltage commands, or
    /// what a DCMC or a base's loops applied in the scene's replay (never above the
    /// scene's drive limit: at it, the scene clips them).
    pub max_command_v: Option<f64>,
    /// The recording has a pose from a tracker or a map (independent of the wheels).
    pub tracked_pose: bool,
}

/// The effect's home in `scene` for a recording driven as `driven` says. The key starts at the scene's
/// value where that already switches the effect on, otherwise at a small strength that
/// the recording's gradient can grow from (a key at its null value has none):
///
/// | effect | key | start when off |
/// |---|---|---|
/// | `backlash` | `gearbox.backlash_rad` | 0.03 rad (1.7 deg) |
/// | `coulomb_friction` | `motor.coulomb_Nm` | 1 % of the motor's stall torque at the drive limit |
/// | `voltage_saturation` | `battery.drive_limit_V` | 90 % of the largest voltage command |
/// | `battery_sag` | `battery.internal_resistance_ohm` (bridges set their duty against `battery.bridge_rated_V`, the open-circuit voltage) | 0.05 ohm |
/// | `speed_feedback` | `dcmc.ki_V_rad` (with `dcmc.kind = "gain_pi"`, or `"pi"` from `"p"`) | the motor's constant per second |
/// | `wheel_slip` | `tyre.peak_mu` | the compound's friction on the floor |
/// | `castor_drag` | `castors.rolling_resistance` | 0.02 |
/// | `transport_delay` | `dcmc.command_delay_s` | 10 ms |
/// | `friction_asymmetry` | `motor.viscous_ratio` | the scene's ratio (1: symmetric) |
/// | `offset` | `motor.offset_Nm`, either sign within 5 % of the stall torque | the scene's bias |
/// | `wheel_geometry` | `chassis.track_width_m`, with `wheel.left_rolling_radius_m` and `wheel.right_rolling_radius_m` | the scene's (off: the configured `base.wheel_separation_m` and `base.wheel_radius_m`) |
pub fn home(effect: Effect, scene: &Scene, driven: Driven) -> Result<Home, CalibrateError> {
    let Driven {
        drive,
        on_floor,
        max_command_v,
        ..
    } = driven;
    let current = |key: &str| keys::get(scene, key).unwrap_or(0.0);
    let key = effect.scene_key().key();
    // The scene's value where it switches the effect on, else a start of `off`.
    let home_or = |on: bool, scene_value: f64, start_off: f64| Home {
        effect,
        key,
        switches: vec![],
        start: if on { scene_value } else { start_off },
        in_scene: on,
        signed_range: None,
        off: off_value(effect, driven),
        also: vec![],
        scanned: true,
    };
    let home = |start: f64| home_or(false, start, start);
    let stall_nm = scene.motor.stall_torque_nm(scene.battery.drive_limit_v);
    Ok(match effect {
        Effect::Backlash => {
            let b = current(key);
            home_or(b >= 1e-3, b, 0.03)
        }
        Effect::CoulombFriction => {
            let tc = scene.motor.coulomb_nm;
            home_or(tc > 1e-4 * stall_nm, tc, 0.01 * stall_nm)
        }
        Effect::VoltageSaturation => {
            let limit = scene.battery.drive_limit_v;
            // The scene's limit is this recording's saturation where it clips its
            // commands (a loop's reach the limit); one above them all is not.
            match max_command_v {
                Some(v) if v > 0.0 => home_or(limit <= v * (1.0 + 1e-9), limit, 0.9 * v),
                _ => home(0.9 * limit),
            }
        }
        Effect::BatterySag => battery_sag_home(scene, drive, home_or)?,
        Effect::SpeedFeedback => {
            if !matches!(drive, Drive::Demands | Drive::AxisDemand) {
                return Err(homeless(
                    effect,
                    "the DCMC's speed loop acts on demands, and the recording commands motor voltages, which bypass the DCMC",
                ));
            }
            speed_loop_home(scene, home(0.0))
        }
        Effect::WheelSlip | Effect::CastorDrag if !on_floor => {
            return Err(homeless(
                effect,
                "a lifted drive has no floor contact: fit it to a vehicle recording",
            ))
        }
        Effect::WheelSlip => {
            let params = SimParams::from_scene(scene)
                .map_err(|e| CalibrateError::Key(format!("the scene does not set up: {e}")))?;
            // A scene's tyre slips at its grip limit unless it is the idealised no-slip
            // one (`high_grip`, its grip left as the preset's).
            let no_slip = scene.tyre.compound == "high_grip" && scene.tyre.peak_mu.is_none();
            let mu = params.drive_tyre(params.floor.default).peak_mu;
            home_or(!no_slip, mu, mu)
        }
        Effect::CastorDrag => {
            let rr = scene.castors.rolling_resistance;
            home_or(rr > 1e-4, rr, 0.02)
        }
        Effect::TransportDelay => {
            let d = scene.dcmc.command_delay_s;
            home_or(d >= 1e-4, d, 0.01)
        }
        Effect::FrictionAsymmetry => {
            let r = scene.motor.viscous_ratio;
            home_or(r != 1.0, r, r)
        }
        Effect::Offset => Home {
            signed_range: Some(0.05 * stall_nm),
            ..home_or(scene.motor.offset_nm != 0.0, scene.motor.offset_nm, 0.0)
        },
        Effect::WheelGeometry => geometry_home(scene, driven)?,
        Effect::BaseLimits => limits_home(scene, driven)?,
    })
}

/// The battery sag's home: the scene's internal resistance where it is felt, else a
/// start; only a recording driven by voltages shows it (the DCMC regulates against the
/// battery), and a scene without a bridge rating gets one at its open-circuit voltage.
fn battery_sag_home(
    scene: &Scene,
    drive: Drive,
    home_or: impl Fn(bool, f64, f64) -> Home,
) -> Result<Home, CalibrateError> {
    let b = &scene.battery;
    let r = b.internal_resistance_ohm;
    let mut h = home_or(r >= 0.01, r, 0.05);
    // Without a bridge rating the scene's sag never reached the drive.
    h.in_scene &= b.bridge_rated_v > 0.0;
    if !matches!(drive, Drive::Voltages | Drive::AxisVoltage) {
        return Err(homeless(
            Effect::BatterySag,
            "the recording drives the DCMC by demand; the simulator's DCMC regulates its voltage against the battery, so its sag shows only as saturation (use voltage_saturation)",
        ));
    }
    if b.bridge_rated_v <= 0.0 {
        h.switches.push(SwitchOn {
            key: BatteryParams::bridge_rated_v.key(),
            value: Setting::Number(b.open_circuit_v),
        });
    }
    Ok(h)
}

/// The wheel geometry's home: the track (the strength key) and the two wheels' rolling
/// radii, fitted together from the scene's, each off where it equals what the odometry
/// and the base controller are configured with. Only a pose measured apart from the
/// wheels (a tracker's, a map's) shows it: the wheels' own odometry is read with the
/// configured geometry whatever the floor's.
fn geometry_home(scene: &Scene, driven: Driven) -> Result<Home, CalibrateError> {
    let effect = Effect::WheelGeometry;
    if !driven.on_floor {
        return Err(homeless(
            effect,
            "a lifted drive does not roll: fit it to a vehicle recording",
        ));
    }
    if !driven.tracked_pose {
        return Err(homeless(
            effect,
            "the recording has no pose measured apart from the wheels (x_m, y_m, heading_rad from a tracker or a map): the wheels' odometry alone cannot show their own geometry",
        ));
    }
    let configured_radius = scene.base.wheel_radius_m.unwrap_or(scene.wheel.radius_m);
    let configured_track = scene
        .base
        .wheel_separation_m
        .unwrap_or(scene.chassis.track_width_m);
    let [left, right] = scene.wheel.rolling_radii_m();
    let track = scene.chassis.track_width_m;
    let differs = |a: f64, b: f64| (a / b - 1.0).abs() > 1e-9;
    let in_scene = differs(left, configured_radius)
        || differs(right, configured_radius)
        || differs(track, configured_track);
    Ok(Home {
        effect,
        key: effect.scene_key().key(),
        switches: vec![],
        start: track,
        in_scene,
        signed_range: None,
        off: Some(configured_track),
        also: vec![
            Companion {
                key: WheelParams::left_rolling_radius_m.key(),
                start: left,
                off: configured_radius,
            },
            Companion {
                key: WheelParams::right_rolling_radius_m.key(),
                start: right,
                off: configured_radius,
            },
        ],
        scanned: false,
    })
}

/// The base controller's limits as the scene has them: the limits it sets (a speed or an
/// acceleration limit of the forward speed or the yaw rate), the yaw rate's first; all off
/// at 0 (no limit, as in ROS). Only velocity commands pass the base controller. Where the
/// scene sets none, the home names the yaw rate's limit at 0: the limits are not raced
/// from a start but read off the recording first ([`super::base_limits`]).
fn limits_home(scene: &Scene, driven: Driven) -> Result<Home, CalibrateError> {
    use crate::model::base_controller::BaseParams;
    let effect = Effect::BaseLimits;
    if driven.drive != Drive::Velocity {
        return Err(homeless(
            effect,
            "the base controller's limits act on velocity commands (cmd_linear_m_s, cmd_angular_rad_s), and the recording drives the motors otherwise",
        ));
    }
    let b = &scene.base;
    let all = [
        (BaseParams::max_angular_rad_s, b.max_angular_rad_s),
        (BaseParams::max_linear_m_s, b.max_linear_m_s),
        (
            BaseParams::max_angular_accel_rad_s2,
            b.max_angular_accel_rad_s2,
        ),
        (BaseParams::max_linear_accel_m_s2, b.max_linear_accel_m_s2),
    ];
    let set: Vec<(&'static str, f64)> = all
        .iter()
        .filter(|(_, v)| *v > 0.0)
        .map(|(k, v)| (k.key(), *v))
        .collect();
    let (key, start) = set.first().copied().unwrap_or((all[0].0.key(), 0.0));
    Ok(Home {
        effect,
        key,
        switches: vec![],
        start,
        in_scene: !set.is_empty(),
        signed_range: None,
        off: Some(0.0),
        also: set
            .iter()
            .skip(1)
            .map(|&(key, start)| Companion {
                key,
                start,
                off: 0.0,
            })
            .collect(),
        scanned: false,
    })
}

/// The value of `effect`'s key at which its physics is absent (see [`Home::off`]) for a
/// recording driven as `driven` says: no play, no friction, no bias, no dead time, no
/// castor drag, no sag, no integral action, the same viscous friction both ways, and a
/// drive limit at the largest voltage command (it clips none of them). A drive limit
/// under a DCMC's or a base's loops is the hardware's: nothing to take out.
pub fn off_value(effect: Effect, driven: Driven) -> Option<f64> {
    match effect.def().off {
        Off::Never => None,
        Off::At(v) => Some(v),
        Off::LargestVoltageCommand => match driven.drive {
            Drive::Voltages | Drive::AxisVoltage => driven.max_command_v,
            _ => None,
        },
    }
}

/// Time in which a speed loop switched on by a calibration starts out correcting a speed
/// error, s: a wheelchair unit's loop is slow beside the motor.
const SPEED_LOOP_START_CORRECTION_S: f64 = 1.0;

/// The DCMC's speed loop switched on as the vocabulary's `speed_feedback` describes it: a
/// scene whose DCMC is a plain gain becomes `gain_pi` (the same voltage fed forward, its
/// speed set-point calibrated to the motor, and integral action on the speed error: the
/// law the fitting models run, [`crate::model::speed_loop::SpeedLoopGains`]); one that already
/// closes a speed loop (`p`) gains the integral (`pi`). The integral gain starts where
/// the loop corrects a speed error in [`SPEED_LOOP_START_CORRECTION_S`].
fn speed_loop_home(scene: &Scene, mut h: Home) -> Home {
    use crate::model::dcmc::DcmcKind;
    let d = &scene.dcmc;
    h.in_scene = d.ki_v_rad > 0.0 && matches!(d.kind, DcmcKind::GainPi | DcmcKind::Pi);
    h.start = if d.ki_v_rad > 0.0 && d.kind != DcmcKind::Gain {
        d.ki_v_rad
    } else {
        // An error held for the time raises the voltage by ki t times it, which moves the
        // speed by ki t / K times it: all of it at ki = K / t.
        scene.motor.torque_constant_nm_a / SPEED_LOOP_START_CORRECTION_S
    };
    let kind = match d.kind {
        DcmcKind::Gain | DcmcKind::GainPi => DcmcKind::GainPi,
        DcmcKind::P | DcmcKind::Pi => DcmcKind::Pi,
    };
    h.switches.push(SwitchOn {
        key: DcmcParams::kind.key(),
        value: Setting::DcmcKind(kind),
    });
    h
}

/// The scene with the effect switched on at its start: set on the typed scene, then
/// validated as a `--set` would be (no text round trip).
pub fn switched_on(scene: &Scene, home: &Home) -> Result<Scene, CalibrateError> {
    let mut on = scene.clone();
    for s in &home.switches {
        s.apply(&mut on)?;
    }
    let mut starts: Vec<(String, f64)> = home
        .also
        .iter()
        .map(|c| (c.key.to_string(), c.start))
        .collect();
    starts.push((home.key.to_string(), home.start));
    keys::set(&on, &starts)
}

/// The effects a choice names for this recording: named ones must have a home (the first
/// that has none is the error); `all` keeps those that have one.
pub fn chosen(
    choice: &Choice,
    scene: &Scene,
    driven: Driven,
) -> Result<Vec<Effect>, CalibrateError> {
    match choice {
        Choice::None => Ok(vec![]),
        Choice::Named(list) => {
            for &e in list {
                home(e, scene, driven)?;
            }
            Ok(list.clone())
        }
        Choice::All => Ok(Effect::ALL
            .into_iter()
            .filter(|&e| home(e, scene, driven).is_ok())
            .collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_effect_is_switched_on_in_the_scene_or_refused_with_its_reason() {
        let scene = Scene::default();
        let axis = Driven {
            drive: Drive::AxisVoltage,
            on_floor: false,
            max_command_v: Some(14.0),
            tracked_pose: false,
        };
        let volts = |e| home(e, &scene, axis);
        let h = volts(Effect::VoltageSaturation).unwrap();
        assert_eq!(h.key, "battery.drive_limit_V");
        assert!((h.start - 12.6).abs() < 1e-12);
        let sag = volts(Effect::BatterySag).unwrap();
        let on = switched_on(&scene, &sag).unwrap();
        assert_eq!(on.battery.bridge_rated_v, scene.battery.open_circuit_v);
        // The scene's own 0.02 ohm already sags: the fit starts there.
        assert_eq!(on.battery.internal_resistance_ohm, 0.02);
        let e = volts(Effect::SpeedFeedback).unwrap_err().to_string();
        assert!(e.contains("speed_feedback") && e.contains("bypass"), "{e}");
        let pi = home(
            Effect::SpeedFeedback,
            &scene,
            Driven {
                drive: Drive::AxisDemand,
                max_command_v: None,
                ..axis
            },
        )
        .unwrap();
        let on = switched_on(&scene, &pi).unwrap();
        assert_eq!(on.dcmc.kind, crate::model::dcmc::DcmcKind::GainPi);
        let e = volts(Effect::WheelSlip).unwrap_err().to_string();
        assert!(e.contains("lifted"), "{e}");
        let slip = home(
            Effect::WheelSlip,
            &scene,
            Driven {
                drive: Drive::Voltages,
                on_floor: true,
                ..axis
            },
        )
        .unwrap();
        assert!(slip.start > 0.1 && slip.start < 2.0, "{}", slip.start);
        assert_eq!(
            switched_on(&scene, &slip).unwrap().tyre.peak_mu,
            Some(slip.start)
        );
        let bias = volts(Effect::Offset).unwrap();
        assert_eq!(bias.key, "motor.offset_Nm");
        assert!(bias.signed_range.unwrap() > 0.0);
        // Every effect of the vocabulary has a home on some recording.
        let floor = Driven {
            drive: Drive::Voltages,
            on_floor: true,
            tracked_pose: true,
            ..axis
        };
        // The wheel geometry only with a pose apart from the wheels.
        let e = home(
            Effect::WheelGeometry,
            &scene,
            Driven {
                tracked_pose: false,
                ..floor
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("no pose measured apart from the wheels"), "{e}");
        let g = home(Effect::WheelGeometry, &scene, floor).unwrap();
        assert_eq!(g.keys().len(), 3);
        assert!(!g.in_scene, "the default scene rolls as configured");
        let demand = Driven {
            drive: Drive::AxisDemand,
            ..axis
        };
        // The base's limits only on a velocity-commanded base.
        let velocity = Driven {
            drive: Drive::Velocity,
            ..floor
        };
        assert!(home(Effect::BaseLimits, &scene, floor).is_err());
        for e in Effect::ALL {
            assert!(
                [axis, floor, demand, velocity]
                    .iter()
                    .any(|d| home(e, &scene, *d).is_ok()),
                "{e:?}"
            );
        }
        assert_eq!(Choice::parse(&["all".into()]).unwrap(), Choice::All);
        assert_eq!(Choice::parse(&["none".into()]).unwrap(), Choice::None);
        assert!(Choice::parse(&["none".into(), "backlash".into()]).is_err());
        let all = chosen(&Choice::All, &scene, axis).unwrap();
        assert!(all.contains(&Effect::BatterySag) && !all.contains(&Effect::WheelSlip));
        assert!(
            !all.contains(&Effect::SpeedFeedback),
            "voltages bypass the DCMC"
        );
        let m = Choice::parse(&["backlash".into(), "slip".into()])
            .unwrap_err()
            .to_string();
        assert!(m.contains("slip") && m.contains("wheel_slip"), "{m}");
    }
}
