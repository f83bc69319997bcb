//! Everything a run needs, derived once from a scene and immutable while the run goes
//! (the system half of Drake's system/context split; `Sim` holds the context).

use crate::firmware::pwm::PwmFilter;
use crate::firmware::pwm::COUNTS_PER_PCT;
use crate::firmware::swing_away::SwingAwayParams;
use crate::firmware::FirmwareParams;
use crate::model::battery::BatteryParams;
use crate::model::chassis::{ChassisParams, NoSlipParams, NormalLoads, Pose};
use crate::model::dcmc::{DcmcParams, DcmcRamp, DcmcResponse};
use crate::model::drivetrain::DrivetrainParams;
use crate::model::gearbox::GearboxParams;
use crate::model::motor::MotorParams;
use crate::model::tyre::TyreParams;
use crate::model::GRAVITY_M_S2;
use crate::scene::presets::{self, Compound, Surface};
use crate::scene::SensorLaw;
use crate::scene::{ControllerKind, Fidelity, Scene, TyreSpec};
use crate::sensing::bumper::{Bumper, Obstacle};
use crate::sensing::coil::{CoilLaw, CoilParams};
use crate::sensing::response::ResponseCurve;
use crate::sensing::wire::Wire;
use crate::world::engine::CastorParams;
use crate::world::Floor;

use super::SimError;

/// Which parts of the model a fidelity level switches on. One simulator; the levels only
/// differ in these switches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Features {
    /// Feedback is the linearised sensor difference of the true lateral offset.
    pub ideal_feedback: bool,
    /// The firmware samples on its timer period with a computation delay.
    pub sample_and_hold: bool,
    /// 8-bit ADC rounding and integer arithmetic in the P-D law.
    pub quantisation: bool,
    /// Gear backlash (otherwise the play is zero and only the tooth spring remains).
    pub backlash: bool,
    /// PWM outputs through the 100 Hz filter.
    pub pwm_filter: bool,
    /// Rapier chassis with tyres (slip) and castor bodies; otherwise the no-slip chassis.
    pub tyres_and_castors: bool,
    /// The DCMC's faults (enable delay, combined demand, low battery), which the thesis's
    /// Simulink levels did not model.
    pub dcmc_faults: bool,
}

impl Features {
    pub fn of(f: Fidelity) -> Features {
        match f {
            Fidelity::Linear => Features {
                ideal_feedback: true,
                sample_and_hold: false,
                quantisation: false,
                backlash: false,
                pwm_filter: false,
                tyres_and_castors: false,
                dcmc_faults: false,
            },
            Fidelity::Nonlinear => Features {
                ideal_feedback: false,
                sample_and_hold: true,
                quantisation: false,
                backlash: false,
                pwm_filter: true,
                tyres_and_castors: false,
                dcmc_faults: false,
            },
            Fidelity::Complex => Features {
                ideal_feedback: false,
                sample_and_hold: true,
                quantisation: true,
                backlash: true,
                pwm_filter: true,
                tyres_and_castors: false,
                dcmc_faults: false,
            },
            Fidelity::Full => Features {
                ideal_feedback: false,
                sample_and_hold: true,
                quantisation: true,
                backlash: true,
                pwm_filter: true,
                tyres_and_castors: true,
                dcmc_faults: true,
            },
        }
    }
}

/// Castor tyre: the compound's friction, but the lateral compliance of a small castor
/// wheel in its fork and swivel bearing, well below the tread's own stiffness.
const CASTOR_LAT_STIFFNESS_PER_N: f64 = 6.0;
const CASTOR_RELAXATION_M: f64 = 0.03;

/// The motor block's parameters from a scene's `[motor]` section.
pub fn motor_params(m: &crate::scene::MotorSpec) -> MotorParams {
    MotorParams {
        resistance_ohm: m.resistance_ohm,
        inductance_h: m.inductance_H,
        torque_constant_nm_a: m.torque_constant_Nm_A,
        rotor_inertia_kg_m2: m.rotor_inertia_kg_m2,
        viscous_nm_s_rad: m.viscous_Nm_s_rad,
        viscous_ratio: m.viscous_ratio,
        coulomb_nm: m.coulomb_Nm,
        offset_nm: m.offset_Nm,
    }
}

/// Immutable run parameters.
#[derive(Clone)]
pub struct SimParams {
    pub fidelity: Fidelity,
    pub features: Features,
    pub dt_s: f64,
    pub duration_s: f64,
    pub seed: u64,
    pub record_interval_s: f64,
    pub wheels_lifted: bool,
    pub chassis: ChassisParams,
    pub loads: NormalLoads,
    /// Body outline (front, rear, width), m.
    pub outline_m: (f64, f64, f64),
    pub drivetrain: DrivetrainParams,
    pub noslip: NoSlipParams,
    pub castor: CastorParams,
    pub castor_rolling_resistance: f64,
    pub castor_compound: &'static Compound,
    pub drive_compound: &'static Compound,
    pub tyre_overrides: TyreSpec,
    pub floor: Floor,
    pub battery: BatteryParams,
    /// Dead time between an external command and the drive, s (0: none).
    pub command_delay_s: f64,
    pub dcmc: DcmcParams,
    pub firmware: FirmwareParams,
    pub pwm: PwmFilter,
    pub coil: CoilParams,
    /// Coil positions, body frame (left, right).
    pub coils_m: [[f64; 2]; 2],
    /// Rear coil pair, body frame (left, right), if fitted.
    pub rear_coils_m: Option<[[f64; 2]; 2]>,
    pub noise_adc: f64,
    pub ideal_slope_counts_per_m: f64,
    pub wire: Wire,
    pub obstacles: Vec<Obstacle>,
    pub bumper: Bumper,
    pub start: Pose,
    /// Drivetrain sub-steps per physics step.
    pub substeps: usize,
}

impl SimParams {
    pub fn from_scene(scene: &Scene) -> Result<SimParams, SimError> {
        let features = Features::of(scene.sim.fidelity);
        let (cg, mass, inertia) = ChassisParams::with_payload(
            scene.chassis.mass_kg,
            scene.chassis.yaw_inertia_kg_m2,
            [scene.chassis.cg_x_m, scene.chassis.cg_y_m],
            scene.payload.mass_kg,
            scene.payload.yaw_inertia_kg_m2,
            [scene.payload.cg_x_m, scene.payload.cg_y_m],
        );
        let chassis = ChassisParams {
            mass_kg: mass,
            yaw_inertia_kg_m2: inertia,
            cg_m: cg,
            track_width_m: scene.chassis.track_width_m,
            drive_load_fraction: scene.chassis.drive_load_fraction,
            castor_front_x_m: scene.castors.front_x_m,
            castor_rear_x_m: scene.castors.rear_x_m,
            castor_half_spacing_m: scene.castors.half_spacing_m,
        };
        let loads = chassis.normal_loads();
        let motor = motor_params(&scene.motor);
        let g = &scene.gearbox;
        let gearbox = GearboxParams {
            ratio: g.ratio,
            backlash_rad: if features.backlash {
                g.backlash_rad
            } else {
                0.0
            },
            tooth_stiffness_nm_rad: g.tooth_stiffness_Nm_rad,
            tooth_damping_nm_s_rad: g.tooth_damping_Nm_s_rad,
        };
        let drivetrain = DrivetrainParams {
            motor,
            gearbox,
            wheel_inertia_kg_m2: scene.wheel.inertia_kg_m2,
            wheel_radius_m: scene.wheel.radius_m,
            wheel_viscous_nm_s_rad: scene.wheel.viscous_Nm_s_rad,
        };
        let noslip = NoSlipParams {
            chassis,
            wheel_radius_m: scene.wheel.radius_m,
            wheel_inertia_kg_m2: scene.wheel.inertia_kg_m2,
            linear_drag_n_s_m: scene.castors.lumped_linear_drag_N_s_m,
            angular_drag_nm_s_rad: scene.castors.lumped_angular_drag_Nm_s_rad,
        };
        let drive_compound =
            presets::compound(&scene.tyre.compound).ok_or_else(|| SimError::Setup {
                message: format!("unknown tyre compound {:?}", scene.tyre.compound),
            })?;
        let castor_compound =
            presets::compound(&scene.castors.compound).ok_or_else(|| SimError::Setup {
                message: format!("unknown castor compound {:?}", scene.castors.compound),
            })?;
        let floor = Floor::from_spec(&scene.floor);
        let b = &scene.battery;
        let battery = BatteryParams {
            open_circuit_v: b.open_circuit_V,
            internal_resistance_ohm: b.internal_resistance_ohm,
            drive_limit_v: b.drive_limit_V,
            low_voltage_fault_v: b.low_voltage_fault_V,
            bridge_rated_v: b.bridge_rated_V,
        };
        let d = &scene.dcmc;
        let dcmc = DcmcParams {
            kind: d.kind,
            forward_gain_v_pct: d.forward_gain_V_pct,
            turn_gain_v_pct: d.turn_gain_V_pct,
            speed_per_pct_rad_s: d.speed_per_pct_rad_s,
            kp_v_s_rad: d.kp_V_s_rad,
            ki_v_rad: d.ki_V_rad,
            back_emf_v_s_rad: motor.torque_constant_nm_a,
            enable_delay_s: d.enable_delay_s,
            combined_fault_pct: d.combined_fault_pct,
            turn_priority: d.turn_priority,
            brake_gain_v_s_rad: d.brake_gain_V_s_rad,
            current_limit_a: d.current_limit_A,
            faults: features.dcmc_faults,
            armature_resistance_ohm: motor.resistance_ohm,
            ramp: (d.ramp_left_pct_s > 0.0 || d.ramp_right_pct_s > 0.0).then_some(DcmcRamp {
                left_pct_s: positive_or_unlimited(d.ramp_left_pct_s),
                right_pct_s: positive_or_unlimited(d.ramp_right_pct_s),
            }),
            turn_ramp_pct_s: (d.turn_ramp_pct_s > 0.0).then_some(d.turn_ramp_pct_s),
            response: (d.response_time_left_s > 0.0
                || d.response_time_right_s > 0.0
                || d.turn_response_time_s > 0.0)
                .then_some(DcmcResponse {
                    left_time_constant_s: d.response_time_left_s,
                    right_time_constant_s: d.response_time_right_s,
                    turn_time_constant_s: d.turn_response_time_s,
                }),
        };
        let c = &scene.controller;
        let s = &scene.sensors;
        let coil = CoilParams {
            height_m: s.height_m,
            full_scale_adc: s.full_scale_adc,
            law: match s.law {
                SensorLaw::Physical => CoilLaw::Physical,
                SensorLaw::Measured => CoilLaw::Measured(ResponseCurve::thesis()),
            },
        };
        let swing_away = (c.kind == ControllerKind::SwingAway).then(|| {
            let sw = &c.swing_away;
            // One count of turn: pct, then the unit's motor-speed difference, through the
            // gears to the rims, over the track.
            let rim_difference_m_s = dcmc
                .motor_speed_difference_per_turn_pct(drivetrain.motor.torque_constant_nm_a)
                / COUNTS_PER_PCT
                / g.ratio
                * scene.wheel.radius_m;
            SwingAwayParams {
                coil,
                half_spacing_m: s.half_spacing_m,
                sensor_ahead_m: s.x_m,
                track_width_m: scene.chassis.track_width_m,
                yaw_rate_per_turn_count: rim_difference_m_s / scene.chassis.track_width_m,
                axle_gain_per_s: sw.axle_gain_per_s,
                heading_gain_per_s: sw.heading_gain_per_s,
                max_heading_rad: sw.max_heading_rad,
                correction: sw.correction,
                straight_start_s: sw.straight_start_s,
            }
        });
        let firmware = FirmwareParams {
            kind: c.kind,
            kp_num: c.kp_num,
            kp_den: c.kp_den,
            kd_num: c.kd_num,
            kd_den: c.kd_den,
            gain_scale: c.gain_scale,
            period_s: features.sample_and_hold.then_some(c.period_s),
            compute_delay_s: if features.sample_and_hold {
                c.compute_delay_s
            } else {
                0.0
            },
            integer_math: features.quantisation,
            pwm_dither: c.pwm_dither,
            forward_counts: c.forward_counts,
            reverse: c.reverse,
            reference_counts: c.reference_counts,
            duty_min: c.duty_min,
            duty_max: c.duty_max,
            start_delay_s: c.start_delay_s,
            open_loop_forward_pct: c.open_loop_forward_pct,
            open_loop_turn_pct: c.open_loop_turn_pct,
            crawl_counts: c.crawl_counts,
            spin_counts: c.spin_counts,
            found_adc: c.found_adc,
            centred_counts: c.centred_counts,
            centring_kp_den: c.centring_kp_den,
            lost_threshold_adc: scene.sensors.lost_threshold_adc,
            bumper: c.bumper,
            swing_away,
        };
        let coils_m = [[s.x_m, s.half_spacing_m], [s.x_m, -s.half_spacing_m]];
        let rear_coils_m = s
            .rear_x_m
            .map(|x| [[x, s.half_spacing_m], [x, -s.half_spacing_m]]);
        let castor = CastorParams {
            trail_m: scene.castors.trail_m,
            mass_kg: scene.castors.mass_kg,
            swivel_friction_nm: scene.castors.swivel_friction_Nm,
            initial_angle_rad: scene.castors.initial_angle_rad,
        };
        let mut params = SimParams {
            fidelity: scene.sim.fidelity,
            features,
            dt_s: scene.sim.dt_s,
            duration_s: scene.sim.duration_s,
            seed: scene.sim.seed,
            record_interval_s: scene.sim.record_interval_s,
            wheels_lifted: scene.sim.wheels_lifted,
            chassis,
            loads,
            outline_m: (
                scene.chassis.front_m,
                scene.chassis.rear_m,
                scene.chassis.width_m,
            ),
            drivetrain,
            noslip,
            castor,
            castor_rolling_resistance: scene.castors.rolling_resistance,
            castor_compound,
            drive_compound,
            tyre_overrides: scene.tyre.clone(),
            floor,
            battery,
            command_delay_s: scene.dcmc.command_delay_s,
            dcmc,
            firmware,
            pwm: PwmFilter {
                corner_hz: c.pwm_filter_hz,
            },
            coil,
            coils_m,
            rear_coils_m,
            noise_adc: s.noise_adc,
            ideal_slope_counts_per_m: coil.difference_slope_counts_per_m(s.half_spacing_m),
            wire: Wire::new(scene.wire.points_m.clone(), scene.wire.closed),
            obstacles: scene.obstacles.iter().map(Obstacle::from_spec).collect(),
            bumper: Bumper {
                x_m: scene.chassis.front_m + 0.01,
                half_width_m: 0.5 * scene.chassis.width_m,
                half_depth_m: 0.01,
            },
            start: Pose {
                x_m: scene.start.x_m,
                y_m: scene.start.y_m,
                heading_rad: scene.start.heading_rad,
            },
            substeps: 1,
        };
        params.substeps = params.choose_substeps();
        params.check_substeps()?;
        params.check_castor_step()?;
        params.check_start_clear()?;
        Ok(params)
    }

    /// Refuses a drivetrain whose sub-step rule asks for more than [`MAX_SUBSTEPS`] sub-steps
    /// per physics step: such a run would take hours per simulated second. Names the
    /// keys behind the fastest mode.
    fn check_substeps(&self) -> Result<(), SimError> {
        if self.substeps <= MAX_SUBSTEPS {
            return Ok(());
        }
        let mesh_alone = self.drivetrain.substeps(self.dt_s, 0.0, 0.0);
        let keys = if mesh_alone > MAX_SUBSTEPS {
            "the gear mesh: gearbox.tooth_stiffness_Nm_rad, gearbox.tooth_damping_Nm_s_rad, motor.rotor_inertia_kg_m2, gearbox.ratio, wheel.inertia_kg_m2"
        } else {
            "the drive tyre's bristles on the wheel: tyre.relaxation_length_m, tyre.long_stiffness_per_N, wheel.radius_m, wheel.inertia_kg_m2, the load on the wheel (chassis.mass_kg, payload.mass_kg, chassis.drive_load_fraction)"
        };
        // A count that saturated its integer type is no count: say "more than".
        let needed = if self.substeps >= 1_000_000_000_000 {
            "more than 1e12".to_string()
        } else {
            self.substeps.to_string()
        };
        Err(SimError::Setup {
            message: format!(
                "the drivetrain needs {needed} sub-steps per {} s step (at most {MAX_SUBSTEPS} are run): its fastest mode is {keys}; check those values",
                self.dt_s
            ),
        })
    }

    /// Refuses an obstacle that overlaps the body at the start pose: the contact solver
    /// would throw the vehicle clear at its first step.
    fn check_start_clear(&self) -> Result<(), SimError> {
        use parry2d_f64::math::{Pose as ShapePose, Vector};
        use parry2d_f64::query;
        use parry2d_f64::shape::Cuboid;
        if self.wheels_lifted {
            return Ok(());
        }
        let (front, rear, width) = self.outline_m;
        let centre = self.start.to_world([0.5 * (front - rear), 0.0]);
        let body_pose = ShapePose::new(Vector::new(centre[0], centre[1]), self.start.heading_rad);
        let body = Cuboid::new(Vector::new(0.5 * (front + rear), 0.5 * width));
        for (i, o) in self.obstacles.iter().enumerate() {
            let overlaps = query::intersection_test(&body_pose, &body, &o.pose, o.shape.as_ref())
                .map(|r| r.intersecting)
                .unwrap_or(false);
            if overlaps {
                return Err(SimError::Setup {
                    message: format!(
                        "obstacles[{i}] (centre {:?} m) overlaps the vehicle's body at its start pose (start.x_m = {}, start.y_m = {}, start.heading_rad = {}); move the obstacle or the start",
                        o.spec.center_m, self.start.x_m, self.start.y_m, self.start.heading_rad
                    ),
                });
            }
        }
        Ok(())
    }

    /// Drive tyre parameters on a surface (compound preset, then any scene override).
    pub fn drive_tyre(&self, surface: &Surface) -> TyreParams {
        let mut t = presets::combine(self.drive_compound, surface);
        let o = &self.tyre_overrides;
        if let Some(mu) = o.peak_mu {
            let ratio = t.sliding_mu / t.peak_mu;
            t.peak_mu = mu;
            t.sliding_mu = mu * ratio;
        }
        if let Some(r) = o.sliding_ratio {
            t.sliding_mu = t.peak_mu * r;
        }
        if let Some(v) = o.long_stiffness_per_N {
            t.long_stiffness_per_N = v;
        }
        if let Some(v) = o.lat_stiffness_per_N {
            t.lat_stiffness_per_N = v;
        }
        if let Some(v) = o.relaxation_length_m {
            t.relaxation_length_m = v;
        }
        t
    }

    /// Castor tyre parameters on a surface.
    pub fn castor_tyre(&self, surface: &Surface) -> TyreParams {
        let mut t = presets::combine(self.castor_compound, surface);
        t.lat_stiffness_per_N = CASTOR_LAT_STIFFNESS_PER_N;
        t.long_stiffness_per_N = CASTOR_LAT_STIFFNESS_PER_N;
        t.relaxation_length_m = CASTOR_RELAXATION_M;
        t.damping_ratio = 0.0;
        t
    }

    /// Sub-steps per physics step: enough for the stiffest of the tooth mesh and the drive
    /// tyre on the stiffest surface (see `DrivetrainParams::substeps`).
    fn choose_substeps(&self) -> usize {
        let mut n = self.drivetrain.substeps(self.dt_s, 0.0, 0.0);
        if self.features.tyres_and_castors && !self.wheels_lifted {
            let load = self.loads.drive_n[0].max(self.loads.drive_n[1]);
            let mut surfaces: Vec<&Surface> = vec![self.floor.default];
            surfaces.extend(self.floor.regions.iter().map(|r| r.1));
            for s in surfaces {
                let t = self.drive_tyre(s);
                let k = t.bristle_stiffness_n_m(load)[0];
                let c = t.bristle_damping_n_s_m(load)[0];
                n = n.max(self.drivetrain.substeps(self.dt_s, k, c));
            }
        }
        n
    }

    /// The castor forces are applied explicitly over a whole physics step; the swivel
    /// mode (lateral tyre stiffness at the trail against the castor's swivel inertia)
    /// must be slow enough for that: w dt <= 0.5.
    fn check_castor_step(&self) -> Result<(), SimError> {
        if !self.features.tyres_and_castors || self.wheels_lifted {
            return Ok(());
        }
        let load = self.loads.castor_n.iter().cloned().fold(0.0, f64::max);
        let t = self.castor_tyre(self.floor.default);
        let k = t.bristle_stiffness_n_m(load)[1];
        let tr = self.castor.trail_m;
        let m = self.castor.mass_kg;
        let inertia = m * (2.0 * tr).powi(2) / 12.0 + m * (0.5 * tr).powi(2);
        let w = (k * tr * tr / inertia).sqrt();
        if w * self.dt_s > 0.5 {
            return Err(SimError::Setup {
                message: format!(
                    "the castor swivel mode ({w:.3e} rad/s) is too fast for sim.dt_s = {} s: it comes from the castors' load ({load:.3e} N per castor, from chassis.mass_kg, payload.mass_kg and chassis.drive_load_fraction), their tyre, castors.trail_m ({tr} m) and castors.mass_kg ({m} kg); check those keys, or use sim.dt_s <= {:.3e}",
                    self.dt_s,
                    0.5 / w
                ),
            });
        }
        Ok(())
    }

    /// Weight of the whole vehicle, N.
    pub fn weight_n(&self) -> f64 {
        self.chassis.mass_kg * GRAVITY_M_S2
    }
}

/// Most drivetrain sub-steps per physics step a run may take (the shipped scenes need a
/// few tens): beyond it a run takes hours per simulated second.
pub const MAX_SUBSTEPS: usize = 1000;

/// A rate limit of 0 in the scene means "no limit".
fn positive_or_unlimited(rate: f64) -> f64 {
    if rate > 0.0 {
        rate
    } else {
        f64::INFINITY
    }
}
