//! Everything a run needs, derived once from a scene and immutable while the run goes
//! (the system half of Drake's system/context split; `Sim` holds the context).

use crate::firmware::pwm::PwmFilter;
use crate::firmware::pwm::COUNTS_PER_PCT;
use crate::firmware::swing_away::SwingAwayParams;
use crate::firmware::{ControllerKind, Firmware};
use crate::model::base_controller::{BaseGeometry, BaseParams};
use crate::model::battery::BatteryParams;
use crate::model::castor::CastorParams;
use crate::model::chassis::{ChassisParams, LoadedChassis, NoSlipParams, NormalLoads, Pose};
use crate::model::dcmc::Dcmc;
use crate::model::drivetrain::DrivetrainParams;
use crate::model::gearbox::GearboxParams;
use crate::model::tyre::{TyreChoice, TyreParams};
use crate::model::tyre_presets::{self as presets, Compound, Surface};
use crate::model::GRAVITY_M_S2;
use crate::scene::{Features, Scene, SimSettings};
use crate::sensing::bumper::{Bumper, Obstacle};
use crate::sensing::coil::{CoilParams, SensorParams};
use crate::sensing::wire::Wire;
use crate::world::Floor;

use super::SimError;

/// Castor tyre: the compound's friction, but the lateral compliance of a small castor
/// wheel in its fork and swivel bearing, well below the tread's own stiffness.
const CASTOR_LAT_STIFFNESS_PER_N: f64 = 6.0;
const CASTOR_RELAXATION_M: f64 = 0.03;

/// Immutable run parameters: the scene's blocks as the fidelity level runs them, and what
/// is worked out from them once.
#[derive(Clone)]
pub struct SimParams {
    /// How the run is simulated and recorded.
    pub sim: SimSettings,
    /// What the fidelity level switches on.
    pub features: Features,
    /// The chassis with its payload, and where the castors stand.
    pub chassis: LoadedChassis,
    /// The static normal loads on the wheels and castors.
    pub loads: NormalLoads,
    /// The bare chassis as declared (its outline: front, rear, width).
    pub body: ChassisParams,
    /// Each side's motor, gear train (its play zero where the level has no backlash) and
    /// wheel.
    pub drivetrain: DrivetrainParams,
    /// The no-slip levels' chassis.
    pub noslip: NoSlipParams,
    /// The castor idlers.
    pub castors: CastorParams,
    /// The castors' tyre compound.
    pub castor_compound: &'static Compound,
    /// The drive tyres' compound.
    pub drive_compound: &'static Compound,
    /// The drive tyres: compound and overrides.
    pub tyre: TyreChoice,
    /// The floor's surfaces.
    pub floor: Floor,
    /// The battery and the bridges' limits.
    pub battery: BatteryParams,
    /// The DCMC wired to the motors.
    pub dcmc: Dcmc,
    /// A velocity-commanded base's controller and drivers (used by
    /// [`super::Actuation::Velocity`]).
    pub base: BaseParams,
    /// The geometry its kinematics use.
    pub base_geometry: BaseGeometry,
    /// The radius the wheels' encoders are read with, m: the configured one (what a
    /// robot's odometry and joint speeds in m/s assume).
    pub odometry_radius_m: f64,
    /// The drive wheels' effective rolling radii on the floor (left, right), m.
    pub rolling_radii_m: [f64; 2],
    /// The firmware as the level runs it.
    pub firmware: Firmware,
    /// The PWM filter between firmware and DCMC.
    pub pwm: PwmFilter,
    /// The pick-up coils and their ADC.
    pub sensors: SensorParams,
    /// The coils' sensing law.
    pub coil: CoilParams,
    /// Slope of the linearised sensor difference, counts per m (the linear level's
    /// feedback).
    pub ideal_slope_counts_per_m: f64,
    /// The guide wire.
    pub wire: Wire,
    /// Fixed obstacles.
    pub obstacles: Vec<Obstacle>,
    /// The bumper strip along the body's front edge.
    pub bumper: Bumper,
    /// Initial pose of the drive-axle midpoint.
    pub start: Pose,
    /// Drivetrain sub-steps per physics step.
    pub substeps: usize,
}

impl SimParams {
    /// The run parameters of a (validated) scene.
    pub fn from_scene(scene: &Scene) -> Result<SimParams, SimError> {
        let features = Features::of(scene.sim.fidelity);
        let chassis = loaded_chassis(scene);
        let loads = chassis.normal_loads();
        let drivetrain = drivetrain_of(scene, features);
        let noslip = NoSlipParams {
            chassis,
            wheel_radii_m: scene.wheel.rolling_radii_m(),
            wheel_inertia_kg_m2: scene.wheel.inertia_kg_m2,
            linear_drag_n_s_m: scene.castors.lumped_linear_drag_n_s_m,
            angular_drag_nm_s_rad: scene.castors.lumped_angular_drag_nm_s_rad,
        };
        let (drive_compound, castor_compound) = compounds(scene)?;
        let dcmc = Dcmc {
            params: scene.dcmc,
            armature_resistance_ohm: scene.motor.resistance_ohm,
            back_emf_v_s_rad: scene.motor.torque_constant_nm_a,
            faults: features.dcmc_faults,
        };
        let coil = scene.sensors.coil();
        let firmware = firmware_of(scene, features, &dcmc, coil);
        let mut params = SimParams {
            sim: scene.sim.clone(),
            features,
            chassis,
            loads,
            body: scene.chassis,
            drivetrain,
            noslip,
            castors: scene.castors.clone(),
            castor_compound,
            drive_compound,
            tyre: scene.tyre.clone(),
            floor: Floor::from_params(&scene.floor),
            battery: scene.battery,
            dcmc,
            base: scene.base,
            base_geometry: BaseGeometry {
                track_width_m: scene
                    .base
                    .wheel_separation_m
                    .unwrap_or(scene.chassis.track_width_m),
                wheel_radius_m: scene.base.wheel_radius_m.unwrap_or(scene.wheel.radius_m),
                gear_ratio: scene.gearbox.ratio,
            },
            odometry_radius_m: scene.base.wheel_radius_m.unwrap_or(scene.wheel.radius_m),
            rolling_radii_m: scene.wheel.rolling_radii_m(),
            firmware,
            pwm: PwmFilter {
                corner_hz: scene.controller.pwm_filter_hz,
            },
            sensors: scene.sensors,
            coil,
            ideal_slope_counts_per_m: coil
                .difference_slope_counts_per_m(scene.sensors.half_spacing_m),
            wire: Wire::new(scene.wire.points_m.clone(), scene.wire.closed),
            obstacles: scene.obstacles.iter().map(Obstacle::from_params).collect(),
            bumper: Bumper {
                x_m: scene.chassis.front_m + 0.01,
                half_width_m: 0.5 * scene.chassis.width_m,
                half_depth_m: 0.01,
            },
            start: scene.start,
            substeps: 1,
        };
        params.substeps = params.choose_substeps();
        params.check_substeps()?;
        params.check_castor_step()?;
        params.check_start_clear()?;
        Ok(params)
    }

    /// Coil positions, body frame (left, right), m.
    pub fn coils_m(&self) -> [[f64; 2]; 2] {
        let s = &self.sensors;
        [[s.x_m, s.half_spacing_m], [s.x_m, -s.half_spacing_m]]
    }

    /// The rear coil pair, body frame (left, right), m, if fitted.
    pub fn rear_coils_m(&self) -> Option<[[f64; 2]; 2]> {
        let s = &self.sensors;
        s.rear_x_m
            .map(|x| [[x, s.half_spacing_m], [x, -s.half_spacing_m]])
    }

    /// Body outline (front, rear, width), m.
    pub fn outline_m(&self) -> (f64, f64, f64) {
        (self.body.front_m, self.body.rear_m, self.body.width_m)
    }

    /// Refuses a drivetrain whose sub-step rule asks for more than [`MAX_SUBSTEPS`] sub-steps
    /// per physics step: such a run would take hours per simulated second. Names the
    /// keys behind the fastest mode.
    fn check_substeps(&self) -> Result<(), SimError> {
        if self.substeps <= MAX_SUBSTEPS {
            return Ok(());
        }
        let mesh_alone = self.drivetrain.substeps(self.sim.dt_s, 0.0, 0.0);
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
                self.sim.dt_s
            ),
        })
    }

    /// Refuses an obstacle that overlaps the body at the start pose: the contact solver
    /// would throw the vehicle clear at its first step.
    fn check_start_clear(&self) -> Result<(), SimError> {
        use parry2d_f64::math::{Pose as ShapePose, Vector};
        use parry2d_f64::query;
        use parry2d_f64::shape::Cuboid;
        if self.sim.wheels_lifted {
            return Ok(());
        }
        let (front, rear, width) = self.outline_m();
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
                        o.params.center_m, self.start.x_m, self.start.y_m, self.start.heading_rad
                    ),
                });
            }
        }
        Ok(())
    }

    /// Drive tyre parameters on a surface (compound preset, then any scene override).
    pub fn drive_tyre(&self, surface: &Surface) -> TyreParams {
        self.tyre.law(self.drive_compound, surface)
    }

    /// Castor tyre parameters on a surface.
    pub fn castor_tyre(&self, surface: &Surface) -> TyreParams {
        let mut t = TyreParams::of(self.castor_compound, surface);
        t.lat_stiffness_per_N = CASTOR_LAT_STIFFNESS_PER_N;
        t.long_stiffness_per_N = CASTOR_LAT_STIFFNESS_PER_N;
        t.relaxation_length_m = CASTOR_RELAXATION_M;
        t.damping_ratio = 0.0;
        t
    }

    /// Sub-steps per physics step: enough for the stiffest of the tooth mesh and the drive
    /// tyre on the stiffest surface (see `DrivetrainParams::substeps`).
    fn choose_substeps(&self) -> usize {
        let mut n = self.drivetrain.substeps(self.sim.dt_s, 0.0, 0.0);
        if self.features.tyres_and_castors && !self.sim.wheels_lifted {
            let load = self.loads.drive_n[0].max(self.loads.drive_n[1]);
            let mut surfaces: Vec<&Surface> = vec![self.floor.default];
            surfaces.extend(self.floor.regions.iter().map(|r| r.1));
            for s in surfaces {
                let t = self.drive_tyre(s);
                let k = t.bristle_stiffness_n_m(load)[0];
                let c = t.bristle_damping_n_s_m(load)[0];
                n = n.max(self.drivetrain.substeps(self.sim.dt_s, k, c));
            }
        }
        n
    }

    /// The castor forces are applied explicitly over a whole physics step; the swivel
    /// mode (lateral tyre stiffness at the trail against the castor's swivel inertia)
    /// must be slow enough for that: w dt <= 0.5.
    fn check_castor_step(&self) -> Result<(), SimError> {
        if !self.features.tyres_and_castors || self.sim.wheels_lifted {
            return Ok(());
        }
        let load = self.loads.castor_n.iter().cloned().fold(0.0, f64::max);
        let t = self.castor_tyre(self.floor.default);
        let k = t.bristle_stiffness_n_m(load)[1];
        let tr = self.castors.trail_m;
        let m = self.castors.mass_kg;
        let inertia = m * (2.0 * tr).powi(2) / 12.0 + m * (0.5 * tr).powi(2);
        let w = (k * tr * tr / inertia).sqrt();
        if w * self.sim.dt_s > 0.5 {
            return Err(SimError::Setup {
                message: format!(
                    "the castor swivel mode ({w:.3e} rad/s) is too fast for sim.dt_s = {} s: it comes from the castors' load ({load:.3e} N per castor, from chassis.mass_kg, payload.mass_kg and chassis.drive_load_fraction), their tyre, castors.trail_m ({tr} m) and castors.mass_kg ({m} kg); check those keys, or use sim.dt_s <= {:.3e}",
                    self.sim.dt_s,
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

/// The swing-away strategy as it knows the vehicle: the coils, the track, and the yaw
/// rate of one count of turn (pct, then the unit's motor-speed difference, through the
/// gears to the rims, over the track).
fn swing_away(scene: &Scene, dcmc: &Dcmc, coil: CoilParams) -> SwingAwayParams {
    let rim_difference_m_s = dcmc
        .params
        .motor_speed_difference_per_turn_pct(scene.motor.torque_constant_nm_a)
        / COUNTS_PER_PCT
        / scene.gearbox.ratio
        * scene.wheel.radius_m;
    SwingAwayParams {
        coil,
        half_spacing_m: scene.sensors.half_spacing_m,
        sensor_ahead_m: scene.sensors.x_m,
        track_width_m: scene.chassis.track_width_m,
        yaw_rate_per_turn_count: rim_difference_m_s / scene.chassis.track_width_m,
        design: scene.controller.swing_away,
    }
}

/// The chassis with its payload.
fn loaded_chassis(scene: &Scene) -> LoadedChassis {
    let (cg, mass, inertia) = LoadedChassis::with_payload(
        scene.chassis.mass_kg,
        scene.chassis.yaw_inertia_kg_m2,
        [scene.chassis.cg_x_m, scene.chassis.cg_y_m],
        scene.payload.mass_kg,
        scene.payload.yaw_inertia_kg_m2,
        [scene.payload.cg_x_m, scene.payload.cg_y_m],
    );
    LoadedChassis {
        mass_kg: mass,
        yaw_inertia_kg_m2: inertia,
        cg_m: cg,
        track_width_m: scene.chassis.track_width_m,
        drive_load_fraction: scene.chassis.drive_load_fraction,
        castor_front_x_m: scene.castors.front_x_m,
        castor_rear_x_m: scene.castors.rear_x_m,
        castor_half_spacing_m: scene.castors.half_spacing_m,
    }
}

/// Each side's motor, gear (its play only where the level has backlash) and wheel.
fn drivetrain_of(scene: &Scene, features: Features) -> DrivetrainParams {
    DrivetrainParams {
        motor: scene.motor,
        gearbox: GearboxParams {
            backlash_rad: if features.backlash {
                scene.gearbox.backlash_rad
            } else {
                0.0
            },
            ..scene.gearbox
        },
        wheel: scene.wheel,
        term: scene.term.any().then_some(scene.term),
    }
}

/// The drive tyres' and the castors' compounds (an unknown one is refused).
fn compounds(scene: &Scene) -> Result<(&'static Compound, &'static Compound), SimError> {
    let drive_compound =
        presets::compound(&scene.tyre.compound).ok_or_else(|| SimError::Setup {
            message: format!("unknown tyre compound {:?}", scene.tyre.compound),
        })?;
    let castor_compound =
        presets::compound(&scene.castors.compound).ok_or_else(|| SimError::Setup {
            message: format!("unknown castor compound {:?}", scene.castors.compound),
        })?;
    Ok((drive_compound, castor_compound))
}

/// The firmware as the level runs it (sampled, delayed and quantised where it says).
fn firmware_of(scene: &Scene, features: Features, dcmc: &Dcmc, coil: CoilParams) -> Firmware {
    Firmware {
        controller: scene.controller,
        period_s: features
            .sample_and_hold
            .then_some(scene.controller.period_s),
        compute_delay_s: if features.sample_and_hold {
            scene.controller.compute_delay_s
        } else {
            0.0
        },
        integer_math: features.quantisation,
        lost_threshold_adc: scene.sensors.lost_threshold_adc,
        swing_away: (scene.controller.kind == ControllerKind::SwingAway)
            .then(|| swing_away(scene, dcmc, coil)),
    }
}
