//! The proof's cases: each kind's clean machine, the effects its recordings can show, and
//! each effect concealed in it at a size built from the machine's physics (a share of its
//! stall torque, of the voltages the excitation asks).

use super::recording::excitation_rows;
use super::*;

/// The clean machine of each kind: its scene (no play, no Coulomb friction; the
/// velocity-commanded base from `agvsim new`'s numbers for a 40 kg robot).
pub fn clean_machine(kind: Kind) -> Result<Scene, CalibrateError> {
    let key = |e: String| CalibrateError::Key(e);
    let lab = |extra: &[&str]| {
        let mut sets = vec![
            "gearbox.backlash_rad=0".to_string(),
            "motor.coulomb_Nm=0".to_string(),
        ];
        sets.extend(extra.iter().map(|s| s.to_string()));
        Scene::from_toml(
            include_str!("../../../scenes/lab_offset_120mm.toml"),
            Path::new("scenes/lab_offset_120mm.toml"),
            &sets,
        )
        .map_err(|e| key(e.to_string()))
    };
    match kind {
        Kind::BaseVelocity => {
            use crate::scene::robot::{new_scene, Guidance, MotorDatasheet, RobotSpec};
            let spec = RobotSpec {
                mass_kg: Some(40.0),
                track_m: Some(0.4),
                wheel_radius_m: Some(0.08),
                battery_v: Some(24.0),
                motor: Some(MotorDatasheet {
                    rated_v: 24.0,
                    no_load_rpm: 3000.0,
                    stall_current_a: Some(40.0),
                    stall_torque_nm: None,
                }),
                gear_ratio: Some(20.0),
                backlash_rad: Some(0.0),
                guidance: Some(Guidance::None),
                ..RobotSpec::default()
            };
            let made = new_scene(&spec, None, "agvsim new").map_err(|e| key(e.to_string()))?;
            let text = made.text;
            Scene::from_toml(
                &text,
                Path::new("base.toml"),
                &["motor.coulomb_Nm=0".into()],
            )
            .map_err(|e| key(e.to_string()))
        }
        // The base's rig read back: what a rig cannot state (the gear mesh, the
        // battery's resistance) is what `diagnose --rig` makes of it.
        Kind::BaseRig => {
            let base = clean_machine(Kind::BaseVelocity)?;
            through_rig(&base)
        }
        _ => lab(&[]),
    }
}

/// The scene `agvsim diagnose --rig` makes of the `base` rig describing `scene`'s robot:
/// the rig written as a file's text, read back, and made a scene.
pub(super) fn through_rig(scene: &Scene) -> Result<Scene, CalibrateError> {
    use crate::rig::Rig;
    let path = Path::new("base.rig.toml");
    let text = Rig::of_base_scene(scene).to_toml();
    let rig = Rig::parse(&text, path).map_err(|e| CalibrateError::Key(e.to_string()))?;
    rig.base_scene(path)
        .map_err(|e| CalibrateError::Key(e.to_string()))
}

/// The motor's stall torque at the drive limit, N m.
pub(super) fn stall_nm(s: &Scene) -> f64 {
    s.motor.stall_torque_nm(s.battery.drive_limit_v)
}

/// Largest terminal voltage the excitation (its seed-1 rows) puts on a motor of `s`, V:
/// the clean machine run on it (a DCMC shapes and limits its demands, so the demand alone
/// does not tell); the drive limit for a velocity-commanded base (its loops ask what
/// they need).
pub(super) fn peak_command_v(
    kind: Kind,
    excitation: Excitation,
    s: &Scene,
) -> Result<f64, CalibrateError> {
    use crate::sim::{Actuation, Sim};
    let (_, dt, rows) = excitation_rows(kind, excitation, &mut Pcg64::seed_from_u64(1));
    if kind.is_base() {
        return Ok(s.battery.drive_limit_v);
    }
    let mut scene = s.clone();
    scene.sim.wheels_lifted = !matches!(kind, Kind::VehicleVoltage);
    let mut sim = Sim::new(&scene).map_err(|e| CalibrateError::Data(e.to_string()))?;
    let per = (dt / sim.params().sim.dt_s).round().max(1.0) as usize;
    let mut peak = 0.0_f64;
    for u in &rows {
        sim.set_actuation(match kind {
            Kind::AxisVoltage => Actuation::Voltage([u[0], 0.0]),
            Kind::VehicleVoltage => Actuation::Voltage([u[0], u[1]]),
            Kind::AxisDemand => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: 0.0,
            },
            _ => Actuation::Demand {
                forward_pct: u[0],
                turn_pct: u[1],
            },
        });
        for _ in 0..per {
            sim.step()
                .map_err(|e| CalibrateError::Data(e.to_string()))?;
            let snap = sim.snapshot();
            peak = peak.max(
                snap.sides[0]
                    .voltage_v
                    .abs()
                    .max(snap.sides[1].voltage_v.abs()),
            );
        }
    }
    Ok(peak)
}

/// The effects a kind's recording can show (what `--effects all` offers it).
pub fn effects_of(kind: Kind) -> Vec<Effect> {
    use Effect::*;
    match kind {
        Kind::AxisVoltage => vec![
            Backlash,
            CoulombFriction,
            FrictionAsymmetry,
            Offset,
            VoltageSaturation,
            BatterySag,
            TransportDelay,
        ],
        Kind::AxisDemand => vec![
            Backlash,
            CoulombFriction,
            FrictionAsymmetry,
            Offset,
            VoltageSaturation,
            TransportDelay,
            SpeedFeedback,
        ],
        // Not the viscous friction's asymmetry: with no current measured, the speeds show
        // two combinations of the resistance, torque constant, inertia and viscous loss,
        // and an asymmetry of a loss whose level they cannot tell trades with the others
        // (the lifted axis on demands, its current measured, shows it).
        Kind::PairDemand => vec![
            Backlash,
            CoulombFriction,
            Offset,
            VoltageSaturation,
            TransportDelay,
            SpeedFeedback,
        ],
        Kind::VehicleVoltage => vec![
            WheelSlip,
            CastorDrag,
            Backlash,
            CoulombFriction,
            VoltageSaturation,
            BatterySag,
            TransportDelay,
        ],
        // Not Coulomb friction: the drivers' speed loops integrate a constant friction
        // away, and what a transient shows of it their gains absorb.
        Kind::BaseVelocity => vec![
            WheelSlip,
            CastorDrag,
            Backlash,
            TransportDelay,
            WheelGeometry,
        ],
        // What a ROS robot's log most often shows (the rig path's own cases; the other
        // effects' physics is the base's above).
        Kind::BaseRig => vec![WheelSlip, TransportDelay, WheelGeometry],
    }
}

/// The concealed effect's key, its true value and the keys that switch it on, built from
/// the clean machine's physics.
pub(super) fn concealed(
    effect: Effect,
    peak_v: f64,
    clean: &Scene,
) -> (&'static str, f64, Vec<String>, Vec<String>) {
    let key = effect.scene_key().key();
    let stall = stall_nm(clean);
    let mut common = vec![];
    let (value, mut extra) = match effect {
        // A yaw rate limit at a third of the largest the excitation commands.
        Effect::BaseLimits => (0.33, vec![]),
        // A few degrees of play at the wheel.
        Effect::Backlash => (0.06, vec![]),
        // 1.2 % of the stall torque: the thesis motor's brushes and bearings.
        Effect::CoulombFriction => (0.012 * stall, vec![]),
        // Viscous friction two and a half times as strong forward, the viscous loss
        // raised to a fifth of the back-EMF damping so that it shows.
        Effect::FrictionAsymmetry => {
            let damping = 0.2 * clean.motor.electrical_damping_nm_s_rad();
            // The scene knows the loss, not its asymmetry.
            common.push(format!("motor.viscous_Nm_s_rad={damping}"));
            (2.5, vec![])
        }
        // A bias against forward rotation, 0.7 % of the stall torque.
        Effect::Offset => (-0.007 * stall, vec![]),
        // The bridges clip at three quarters of the largest voltage the excitation asks.
        Effect::VoltageSaturation => (0.75 * peak_v, vec![]),
        // Bridges setting duty against the battery, which sags a tenth of its voltage at
        // the stall current's quarter.
        Effect::BatterySag => {
            let b = clean.battery.open_circuit_v;
            let i = 0.25 * b / clean.motor.resistance_ohm;
            (0.1 * b / i, vec![format!("battery.bridge_rated_V={b}")])
        }
        // Four milliseconds of firmware per 5 ms sample: a dead time of 20 ms.
        Effect::TransportDelay => (0.02, vec![]),
        // Integral action correcting a speed error in about a fifth of a second.
        // (an error held for t raises the voltage by ki t times it, which moves the speed
        // by ki t / K times it: all of it at ki = K / t).
        Effect::SpeedFeedback => (
            clean.motor.torque_constant_nm_a / 0.2,
            vec!["dcmc.kind=\"gain_pi\"".into()],
        ),
        // Tyres that grip to 0.6 of the compound's friction.
        Effect::WheelSlip => {
            let p = crate::sim::SimParams::from_scene(clean).expect("the clean machine sets up");
            (0.6 * p.drive_tyre(p.floor.default).peak_mu, vec![])
        }
        // Castors rolling with 8 % of their load.
        Effect::CastorDrag => (0.08, vec![]),
        // The right wheel rolling on 1 % less than its radius, the wheels 2 % further
        // apart than drawn; the odometry and the base controller configured with the
        // drawing's (UMBmark's two systematic errors, at the sizes it finds).
        Effect::WheelGeometry => {
            let (r, b) = (clean.wheel.radius_m, clean.chassis.track_width_m);
            common.push(format!("base.wheel_radius_m={r}"));
            common.push(format!("base.wheel_separation_m={b}"));
            (
                1.02 * b,
                vec![format!("wheel.right_rolling_radius_m={}", 0.99 * r)],
            )
        }
    };
    extra.push(format!("{key}={value}"));
    (key, value, extra, common)
}

/// Every case of the proof for `kinds`: each effect its recording can show, and a clean one,
/// on each excitation people use for it.
pub fn cases(kinds: &[Kind]) -> Result<Vec<Case>, CalibrateError> {
    let mut out = vec![];
    for &kind in kinds {
        let clean = clean_machine(kind)?;
        let excitations: &[Excitation] = match kind {
            Kind::AxisVoltage => &[Excitation::Multisine, Excitation::SysId],
            Kind::AxisDemand => &[Excitation::Multisine],
            Kind::PairDemand => &[Excitation::RandomDemand],
            Kind::VehicleVoltage => &[Excitation::Multisine],
            Kind::BaseVelocity | Kind::BaseRig => &[Excitation::CmdVelSteps],
        };
        for &excitation in excitations {
            let name = |e: &str| format!("{}/{}/{e}", kind.name(), excitation.name());
            out.push(Case {
                name: name("clean"),
                kind,
                excitation,
                effect: None,
                truth: None,
                machine: vec![],
                common: vec![],
                noise: SensorNoise::White,
                left_out: false,
            });
            let peak_v = peak_command_v(kind, excitation, &clean)?;
            for effect in effects_of(kind) {
                let (key, value, machine, common) = concealed(effect, peak_v, &clean);
                out.push(Case {
                    name: name(effect.name()),
                    kind,
                    excitation,
                    effect: Some(effect),
                    truth: Some((key, value)),
                    machine,
                    common,
                    noise: SensorNoise::White,
                    left_out: false,
                });
            }
            if kind == Kind::BaseRig {
                out.push(payload_case(kind, excitation, &clean, &name("payload")));
            }
        }
    }
    Ok(out)
}

/// A payload the rig does not know: the machine carries a quarter more mass than the
/// rig states, which is physics of no effect (nothing may be accepted) but must show in
/// the fitted mass.
pub(super) fn payload_case(kind: Kind, excitation: Excitation, clean: &Scene, name: &str) -> Case {
    let key = crate::model::chassis::ChassisParams::mass_kg.key();
    let mass = 1.25 * clean.chassis.mass_kg;
    Case {
        name: name.to_string(),
        kind,
        excitation,
        effect: None,
        truth: Some((key, mass)),
        machine: vec![format!("{key}={mass}")],
        common: vec![],
        noise: SensorNoise::White,
        left_out: false,
    }
}
