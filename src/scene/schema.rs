//! The scene file schema: every key a scene may set, its unit and its default.
//!
//! Defaults are the thesis's machine (see `shared/spec/seed-digest.md`); values the
//! thesis does not give are marked *assumed* in the doc comment of the key.
//! Unknown keys are rejected so that a typo never silently falls back to a default.

use serde::{Deserialize, Serialize};

use super::{ControllerSpec, ExpectSpec};

/// A whole scene: vehicle, floor, wire, obstacles and run settings.
#[derive(Debug, Clone, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Scene {
    /// Free text shown in summaries.
    pub description: String,
    pub sim: SimSettings,
    pub chassis: ChassisSpec,
    pub payload: PayloadSpec,
    pub castors: CastorSpec,
    pub motor: MotorSpec,
    pub gearbox: GearboxSpec,
    pub wheel: WheelSpec,
    pub tyre: TyreSpec,
    pub floor: FloorSpec,
    pub battery: BatterySpec,
    pub dcmc: DcmcSpec,
    pub sensors: SensorSpec,
    pub controller: ControllerSpec,
    pub wire: WireSpec,
    pub start: StartSpec,
    pub obstacles: Vec<ObstacleSpec>,
    /// What a run of the scene as written shows (checked by `agvsim run` and the tests).
    #[serde(skip_serializing_if = "ExpectSpec::is_empty")]
    pub expect: ExpectSpec,
}

/// Which parts of the model are switched on (the thesis's three levels plus ours).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Fidelity {
    /// Thesis level 1: ideal (linearised) position feedback, continuous controller, no slip.
    Linear,
    /// Thesis level 2: real sensor law, sample and hold, computation delay, PWM filter, no slip.
    Nonlinear,
    /// Thesis level 3: level 2 plus ADC quantisation, integer arithmetic and gear backlash.
    Complex,
    /// Level 3 on the rapier chassis with tyres (slip) and castors.
    #[default]
    Full,
}

impl Fidelity {
    pub const ALL: [Fidelity; 4] = [
        Fidelity::Linear,
        Fidelity::Nonlinear,
        Fidelity::Complex,
        Fidelity::Full,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Fidelity::Linear => "linear",
            Fidelity::Nonlinear => "nonlinear",
            Fidelity::Complex => "complex",
            Fidelity::Full => "full",
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimSettings {
    pub fidelity: Fidelity,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Physics (rapier) step, s. The drivetrain sub-steps inside it as its stiffness needs.
    pub dt_s: f64,
    /// Seed of the sensor-noise generator.
    pub seed: u64,
    /// Interval between rows of the recording CSV, s.
    pub record_interval_s: f64,
    /// Wheels lifted off the floor (lab identification rig): the chassis stays put.
    pub wheels_lifted: bool,
    /// Most physics steps (`duration_s / dt_s`) a run may take: a guard against a typo
    /// that asks for days of simulated time; raise it for a run that needs more.
    pub max_steps: u64,
}

/// Default of `sim.max_steps`: 10^7 physics steps, 2.8 hours simulated at the 1 ms step,
/// a minute or two of work.
pub const DEFAULT_MAX_STEPS: u64 = 10_000_000;

impl Default for SimSettings {
    fn default() -> Self {
        SimSettings {
            fidelity: Fidelity::Full,
            duration_s: 10.0,
            dt_s: 0.001,
            seed: 1,
            record_interval_s: 0.01,
            wheels_lifted: false,
            max_steps: DEFAULT_MAX_STEPS,
        }
    }
}

/// The bare vehicle with batteries. The body frame has its origin at the midpoint of the
/// drive axle, x forward, y to the left.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ChassisSpec {
    /// Mass with batteries, kg ("a 120 kg Logo turtle").
    pub mass_kg: f64,
    /// Yaw inertia about the centre of gravity, kg m^2 (*assumed*: from CAD, not given).
    pub yaw_inertia_kg_m2: f64,
    /// Distance between the drive wheels, m (*assumed*).
    pub track_width_m: f64,
    /// Centre of gravity ahead of the drive axle, m (*assumed*).
    pub cg_x_m: f64,
    /// Centre of gravity left of the centre line, m.
    pub cg_y_m: f64,
    /// Share of the weight on the two drive wheels (the hinged chassis keeps them loaded).
    pub drive_load_fraction: f64,
    /// Front edge of the body ahead of the drive axle, m (outline, bumper), *assumed*.
    pub front_m: f64,
    /// Rear edge of the body behind the drive axle, m (*assumed*).
    pub rear_m: f64,
    /// Body width, m (*assumed*).
    pub width_m: f64,
}

impl Default for ChassisSpec {
    fn default() -> Self {
        ChassisSpec {
            mass_kg: 120.0,
            yaw_inertia_kg_m2: 14.0,
            track_width_m: 0.50,
            cg_x_m: 0.05,
            cg_y_m: 0.0,
            drive_load_fraction: 0.6,
            front_m: 0.55,
            rear_m: 0.45,
            width_m: 0.62,
        }
    }
}

/// Load on the scissor-lift platform; adds mass and inertia and may shift the CG.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PayloadSpec {
    /// Payload mass, kg (design payload 200 kg).
    pub mass_kg: f64,
    /// Payload CG ahead of the drive axle, m.
    pub cg_x_m: f64,
    /// Payload CG left of the centre line, m.
    pub cg_y_m: f64,
    /// Payload yaw inertia about its own CG, kg m^2.
    pub yaw_inertia_kg_m2: f64,
}

impl Default for PayloadSpec {
    fn default() -> Self {
        PayloadSpec {
            mass_kg: 0.0,
            cg_x_m: 0.05,
            cg_y_m: 0.0,
            yaw_inertia_kg_m2: 0.0,
        }
    }
}

/// The four castor idlers at the corners.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct CastorSpec {
    /// Swivel axes of the front castors ahead of the drive axle, m (*assumed*).
    pub front_x_m: f64,
    /// Swivel axes of the rear castors (negative: behind the axle), m (*assumed*).
    pub rear_x_m: f64,
    /// Swivel axes left/right of the centre line, m (*assumed*).
    pub half_spacing_m: f64,
    /// Trail: contact patch behind the swivel axis, m (*assumed*).
    pub trail_m: f64,
    /// Mass of one castor fork and wheel, kg (*assumed*).
    pub mass_kg: f64,
    /// Swivel (Coulomb) friction torque, N m (*assumed*).
    pub swivel_friction_Nm: f64,
    /// Rolling resistance coefficient of a castor wheel (force / normal load).
    pub rolling_resistance: f64,
    /// Tyre compound of the castor wheels (lateral stiffness and friction).
    pub compound: String,
    /// Castor initial swivel angle relative to the body, rad (0 = trailing straight ahead).
    pub initial_angle_rad: f64,
    /// Lumped castor drag for the no-slip levels (Johnson & Aylor): linear, N s/m.
    pub lumped_linear_drag_N_s_m: f64,
    /// Lumped castor drag for the no-slip levels: angular, N m s/rad.
    pub lumped_angular_drag_Nm_s_rad: f64,
}

impl Default for CastorSpec {
    fn default() -> Self {
        CastorSpec {
            front_x_m: 0.40,
            rear_x_m: -0.35,
            half_spacing_m: 0.24,
            trail_m: 0.04,
            mass_kg: 1.2,
            swivel_friction_Nm: 0.3,
            rolling_resistance: 0.02,
            compound: "hard_polyurethane".into(),
            initial_angle_rad: 0.0,
            lumped_linear_drag_N_s_m: 10.0,
            lumped_angular_drag_Nm_s_rad: 2.0,
        }
    }
}

/// Permanent-magnet DC motor (one per side).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotorSpec {
    /// Armature resistance, ohm (*assumed* 0.35).
    pub resistance_ohm: f64,
    /// Armature inductance, H (*assumed* 0.8 mH).
    pub inductance_H: f64,
    /// Torque constant, N m/A; equals the back-EMF constant in V s/rad (measured 0.063).
    pub torque_constant_Nm_A: f64,
    /// Rotor inertia including the worm, kg m^2 (*assumed*).
    pub rotor_inertia_kg_m2: f64,
    /// Viscous friction at the motor shaft, N m s/rad (*assumed*).
    pub viscous_Nm_s_rad: f64,
    /// Coulomb friction at the motor shaft (brushes, bearings), N m (*assumed*).
    pub coulomb_Nm: f64,
    /// Forward over reverse viscous friction (1: the same both ways; `viscous_Nm_s_rad`
    /// is their mean). The contract's `friction_asymmetry`.
    pub viscous_ratio: f64,
    /// Constant torque on the motor shaft, driving forward rotation when positive: a
    /// slope's gravity, a cable's pull, a bias, N m (default 0). The contract's `offset`.
    pub offset_Nm: f64,
}

impl Default for MotorSpec {
    fn default() -> Self {
        MotorSpec {
            resistance_ohm: 0.35,
            inductance_H: 0.0008,
            torque_constant_Nm_A: 0.063,
            rotor_inertia_kg_m2: 2.0e-4,
            viscous_Nm_s_rad: 1.0e-4,
            coulomb_Nm: 0.02,
            viscous_ratio: 1.0,
            offset_Nm: 0.0,
        }
    }
}

/// Gear train between motor and wheel, with backlash as a dead band between the gear
/// output and the wheel, the teeth a damped spring once the play is taken up.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct GearboxSpec {
    /// Motor turns per wheel turn.
    pub ratio: f64,
    /// Total play at the wheel, rad (about 10 degrees on the thesis AGV).
    pub backlash_rad: f64,
    /// Tooth (mesh) stiffness referred to the wheel, N m/rad (*assumed*; the thesis
    /// softened its tooth springs to keep a 5 ms step).
    pub tooth_stiffness_Nm_rad: f64,
    /// Tooth damping referred to the wheel, N m s/rad (*assumed*).
    pub tooth_damping_Nm_s_rad: f64,
}

impl Default for GearboxSpec {
    fn default() -> Self {
        GearboxSpec {
            ratio: 23.41,
            backlash_rad: 10.0_f64.to_radians(),
            tooth_stiffness_Nm_rad: 3000.0,
            tooth_damping_Nm_s_rad: 4.0,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct WheelSpec {
    /// Drive wheel radius, m (*assumed* 0.075).
    pub radius_m: f64,
    /// Wheel plus output gear inertia about the axle, kg m^2 (*assumed*).
    pub inertia_kg_m2: f64,
    /// Viscous friction of the wheel's bearings and the gear's output stage, at the
    /// wheel's axle, N m s/rad (default 0: all viscous friction lumped at the motor,
    /// `motor.viscous_Nm_s_rad`). It acts on the wheel's side of the gear play, so it
    /// matters apart from the motor's only with backlash; through rigid gears it adds
    /// `this / ratio^2` to the motor's.
    pub viscous_Nm_s_rad: f64,
}

impl Default for WheelSpec {
    fn default() -> Self {
        WheelSpec {
            radius_m: 0.075,
            inertia_kg_m2: 0.02,
            viscous_Nm_s_rad: 0.0,
        }
    }
}

/// Drive tyre: a named compound; any explicit value here overrides the compound x floor
/// preset (see `scene::presets`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct TyreSpec {
    /// `hard_polyurethane`, `soft_rubber` or `high_grip` (see `agvsim presets`).
    pub compound: String,
    /// Peak (static) friction coefficient; overrides the preset.
    pub peak_mu: Option<f64>,
    /// Sliding friction as a fraction of the peak; overrides the preset.
    pub sliding_ratio: Option<f64>,
    /// Longitudinal slip stiffness per newton of load (N per unit slip per N); overrides.
    pub long_stiffness_per_N: Option<f64>,
    /// Cornering stiffness per newton of load (N per rad per N); overrides.
    pub lat_stiffness_per_N: Option<f64>,
    /// Relaxation length, m; overrides.
    pub relaxation_length_m: Option<f64>,
}

impl Default for TyreSpec {
    fn default() -> Self {
        TyreSpec {
            compound: "hard_polyurethane".into(),
            peak_mu: None,
            sliding_ratio: None,
            long_stiffness_per_N: None,
            lat_stiffness_per_N: None,
            relaxation_length_m: None,
        }
    }
}

/// The floor: a default surface and optional regions of other surfaces.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct FloorSpec {
    /// `painted_concrete`, `bare_concrete` or `epoxy_wet` (see `agvsim presets`).
    pub surface: String,
    pub regions: Vec<FloorRegionSpec>,
}

impl Default for FloorSpec {
    fn default() -> Self {
        FloorSpec {
            surface: "painted_concrete".into(),
            regions: Vec::new(),
        }
    }
}

/// A convex polygon of another surface; later regions win where they overlap.
#[derive(Debug, Clone, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields)]
pub struct FloorRegionSpec {
    pub surface: String,
    /// Corners of a convex polygon, world frame, m.
    #[serde(deserialize_with = "points_2d")]
    pub polygon_m: Vec<[f64; 2]>,
}

/// Two 12 V lead-acid batteries in series.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct BatterySpec {
    /// Open-circuit voltage, V.
    pub open_circuit_V: f64,
    /// Internal resistance, ohm (*assumed*).
    pub internal_resistance_ohm: f64,
    /// Highest voltage the H-bridges deliver to a motor under load, V (23.5 V measured).
    pub drive_limit_V: f64,
    /// The DCMC faults when the battery terminal voltage falls below this, V.
    pub low_voltage_fault_V: f64,
    /// For motor-voltage commands (a recording's `voltage_V`): the supply voltage the
    /// bridges assume when they set their PWM duty, V. 0 (default): compensated bridges,
    /// which deliver the command while the battery can. Above 0: duty = command / this
    /// (clipped to 1), times the battery's terminal voltage, so its sag under current
    /// scales every command (the contract's `battery_sag`).
    pub bridge_rated_V: f64,
}

impl Default for BatterySpec {
    fn default() -> Self {
        BatterySpec {
            open_circuit_V: 24.0,
            internal_resistance_ohm: 0.02,
            drive_limit_V: 23.5,
            low_voltage_fault_V: 22.0,
            bridge_rated_V: 0.0,
        }
    }
}

/// How the DCMC turns demand into motor voltage (the thesis's identification cases).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum DcmcKind {
    /// Case 1: a gain matrix from (forward, turn) to (left, right) voltage.
    #[default]
    Gain,
    /// Case 2-I: proportional speed loop.
    P,
    /// Case 2-II: proportional-integral speed loop.
    Pi,
    /// The gain structure's voltage plus integral action on the speed error, the set-point
    /// being the speed that voltage gives the unloaded motor (a unit calibrated to its
    /// motor: forward gain over the back-EMF constant per percent); no proportional term.
    /// The contract's `speed_feedback`, its integral gain `ki_V_rad`.
    #[serde(rename = "gain_pi")]
    GainPi,
}

/// The wheelchair motor controller (Dynamic Controls DCMC).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct DcmcSpec {
    pub kind: DcmcKind,
    /// `gain`: volts per percent of forward demand. Default matched to the thesis's
    /// case-1 identification (see `response_time_left_s`).
    pub forward_gain_V_pct: f64,
    /// `gain`: volts per percent of turn demand (added right, subtracted left). Default
    /// matched likewise: the identified turn/forward column ratio is the thesis's 0.72.
    pub turn_gain_V_pct: f64,
    /// `p`/`pi`: motor speed set-point per percent of demand, rad/s per pct.
    pub speed_per_pct_rad_s: f64,
    /// `p`/`pi`: proportional gain, V s/rad.
    pub kp_V_s_rad: f64,
    /// `pi`, `gain_pi`: integral gain, V/rad.
    pub ki_V_rad: f64,
    /// A non-zero demand within this time of enabling faults the DCMC, s.
    pub enable_delay_s: f64,
    /// |forward| + |turn| demand above this faults the DCMC, pct.
    pub combined_fault_pct: f64,
    /// When a side would saturate, keep the turn and slow the common speed.
    pub turn_priority: bool,
    /// Active braking gain when disabled or faulted, V s/rad (drives the speed to zero).
    pub brake_gain_V_s_rad: f64,
    /// Armature current limit per motor, A (*assumed*: wheelchair controllers limit at
    /// 40-70 A).
    pub current_limit_A: f64,
    /// The unit's acceleration setting: the left side's demand may change by at most
    /// this, percent of full demand per second (0: no limit). Default fitted to the
    /// thesis's case-1 identification (section 5.2.1) through the lifted-wheel simulator;
    /// see `agvsim study thesis-dcmc`.
    pub ramp_left_pct_s: f64,
    /// The same for the right side, pct/s.
    pub ramp_right_pct_s: f64,
    /// The unit's turn acceleration setting: the turn demand may change by at most this,
    /// percent of full turn demand per second (0: no limit).
    pub turn_ramp_pct_s: f64,
    /// Time constant of the unit's first-order lag on the left side's forward demand, s
    /// (0: none). Default matched, with the two gains, so that the machine's lifted-wheel
    /// runs identified with the thesis's case-1 structure give the thesis's A and B
    /// (section 5.2.1): `agvsim study thesis-dcmc`. Equal on both sides: a 12 % side
    /// difference (the thesis's A11 and A22) would yaw the vehicle 0.1 rad at every start
    /// and lose the wire from the floor runs' start at gains up to 1, which the thesis's
    /// vehicle did not.
    pub response_time_left_s: f64,
    /// The same for the right side, s.
    pub response_time_right_s: f64,
    /// Time constant of the lag on the turn demand, s (0: none). *Assumed* 0: the
    /// thesis's case-1 structure cannot tell a turn lag from a forward one, and the floor
    /// runs bound it: with the forward lags on the turn demand too, the firmware's P-D
    /// loop at the thesis's gains is unstable (`agvsim linearize`) and loses the wire,
    /// where the real vehicle followed it (`agvsim study thesis-dcmc` sweeps it).
    pub turn_response_time_s: f64,
    /// Dead time between an external command (a recording's `voltage_V`/`demand_pct` or
    /// left/right voltages and demands, as `replay` applies them) and the drive acting on
    /// it, s (default 0). The contract's `transport_delay`. The firmware's own delay is
    /// `controller.compute_delay_s`.
    pub command_delay_s: f64,
}

impl Default for DcmcSpec {
    fn default() -> Self {
        DcmcSpec {
            kind: DcmcKind::Gain,
            forward_gain_V_pct: 0.1623,
            turn_gain_V_pct: 0.1020,
            speed_per_pct_rad_s: 3.5,
            kp_V_s_rad: 0.5,
            ki_V_rad: 4.0,
            enable_delay_s: 0.5,
            combined_fault_pct: 185.0,
            turn_priority: true,
            brake_gain_V_s_rad: 0.3,
            current_limit_A: 40.0,
            ramp_left_pct_s: 0.0,
            ramp_right_pct_s: 0.0,
            turn_ramp_pct_s: 0.0,
            response_time_left_s: 0.699,
            response_time_right_s: 0.699,
            turn_response_time_s: 0.0,
            command_delay_s: 0.0,
        }
    }
}

/// The two guide-wire pick-up coils, body frame.
/// Which law turns the field at a coil into its reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum SensorLaw {
    /// The thesis's coils as measured: the calibration table (`AGVPOS.C`) as one coil's
    /// response against distance, interpolated monotonically, zero beyond 164 mm.
    #[default]
    Measured,
    /// Reading proportional to the Biot-Savart field component along the coil's axis
    /// (`full_scale_adc h^2 / (h^2 + y^2)` off a straight wire): for other machines.
    Physical,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// Coil pair ahead of the drive axle, m (*assumed*).
    pub x_m: f64,
    /// Half the spacing between the coils, m (37 mm: where the thesis's calibration table
    /// puts them, see `sensing::response`).
    pub half_spacing_m: f64,
    /// Height of the coils above the wire, m (about 38 mm).
    pub height_m: f64,
    /// `measured` (the thesis's calibration table) or `physical`.
    pub law: SensorLaw,
    /// Reading directly over a straight wire, ADC counts (the `physical` law's scale).
    pub full_scale_adc: f64,
    /// RMS noise added before quantisation, ADC counts.
    pub noise_adc: f64,
    /// The wire counts as lost when both readings are below this, ADC counts.
    pub lost_threshold_adc: f64,
    /// A second, rear coil pair for reversing (body frame x, m); none when absent.
    pub rear_x_m: Option<f64>,
}

impl Default for SensorSpec {
    fn default() -> Self {
        SensorSpec {
            x_m: 0.45,
            half_spacing_m: 0.037,
            height_m: 0.038,
            law: SensorLaw::Measured,
            full_scale_adc: 250.0,
            noise_adc: 0.0,
            lost_threshold_adc: 4.0,
            rear_x_m: None,
        }
    }
}

/// The buried guide wire: a polyline or a closed loop, world frame.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct WireSpec {
    /// Vertices, m.
    #[serde(deserialize_with = "points_2d")]
    pub points_m: Vec<[f64; 2]>,
    /// Joins the last point to the first.
    pub closed: bool,
}

impl Default for WireSpec {
    fn default() -> Self {
        WireSpec {
            points_m: vec![[-2.0, 0.0], [40.0, 0.0]],
            closed: false,
        }
    }
}

/// Initial pose of the drive-axle midpoint, world frame.
#[derive(Debug, Clone, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct StartSpec {
    pub x_m: f64,
    pub y_m: f64,
    pub heading_rad: f64,
}

/// A fixed obstacle on the floor; the bumper stops the vehicle on contact.
#[derive(Debug, Clone, Deserialize, Serialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct ObstacleSpec {
    /// Centre, world frame, m.
    pub center_m: [f64; 2],
    /// Rectangle half extents, m (give this or `radius_m`).
    pub half_extents_m: Option<[f64; 2]>,
    /// Circle radius, m.
    pub radius_m: Option<f64>,
    /// Rotation of a rectangle, rad.
    pub angle_rad: f64,
}

/// A list of floor points, each exactly `[x, y]`: a third coordinate is an error, not
/// silently dropped.
fn points_2d<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
    let raw: Vec<Vec<f64>> = Vec::deserialize(d)?;
    raw.iter()
        .enumerate()
        .map(|(i, p)| match p.as_slice() {
            [x, y] => Ok([*x, *y]),
            _ => Err(serde::de::Error::custom(format!(
                "point {i} has {} coordinates ({p:?}): expected two, [x, y] in metres on the floor",
                p.len()
            ))),
        })
        .collect()
}
