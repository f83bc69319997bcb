//! What `agvsim new` derives from the builder's numbers: each key the thesis machine's
//! proportions give, with how, kept in the machine's ratios (its shipped values).

use super::*;

/// `v` to 4 significant figures.
pub(super) fn round4(v: f64) -> f64 {
    if v == 0.0 || !v.is_finite() {
        return v;
    }
    let scale = 10f64.powi(3 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

/// A derived number for a `how` text: four figures, in exponent form past 1e7 (a mass of
/// 1e308 given would otherwise print 300 digits).
fn r4(v: f64) -> String {
    crate::param::plain_number(round4(v))
}

pub(super) fn d(
    key: ParamKey,
    value: f64,
    from: &'static [Input],
    how: impl Into<String>,
) -> Derived {
    Derived {
        key,
        value: round4(value),
        how: how.into(),
        from,
    }
}

/// The thesis machine's reflected drivetrain inertia at the wheel, kg m^2.
pub(super) fn thesis_reflected_kg_m2() -> f64 {
    thesis::WHEEL_INERTIA_KG_M2 + thesis::ROTOR_KG_M2 * thesis::RATIO * thesis::RATIO
}

/// Every derived value, from the numbers.
pub(super) fn derive(n: &Numbers) -> Vec<Derived> {
    let mut out = given_values(n);
    out.extend(body(n));
    out.extend(castors(n));
    out.extend(motor(n));
    out.extend(drivetrain(n));
    out.extend(supply_and_drive(n));
    out
}

pub(super) fn given_values(n: &Numbers) -> Vec<Derived> {
    use Input::*;
    let mass = if n.mass_given {
        d(ChassisParams::mass_kg, n.mass_kg, &[Mass], "given")
    } else {
        let [l0, w0] = n.base_outline_m;
        d(
            ChassisParams::mass_kg,
            n.mass_kg,
            &[Footprint],
            format!(
                "not given: sized from the body's {} x {} m outline as the starting machine's {} kg on {} x {} m (mass in proportion to the outline's area to the power 1.5); weigh the robot",
                r4(n.length_m),
                r4(n.width_m),
                r4(n.base_mass_kg),
                r4(l0),
                r4(w0)
            ),
        )
    };
    vec![
        mass,
        d(ChassisParams::track_width_m, n.track_m, &[Track], "given"),
        d(WheelParams::radius_m, n.wheel_radius_m, &[Wheel], "given"),
        d(GearboxParams::ratio, n.ratio, &[Ratio], ratio_how(n)),
        d(
            GearboxParams::backlash_rad,
            n.backlash_rad,
            &[Backlash, Ratio],
            if n.backlash_rad > 0.0 {
                "given".to_string()
            } else {
                "not given, so none: `calibrate --effects backlash` finds a play a recording shows"
                    .into()
            },
        ),
        d(
            BatteryParams::open_circuit_v,
            n.battery_v,
            &[Battery],
            "given",
        ),
    ]
}

pub(super) fn body(n: &Numbers) -> Vec<Derived> {
    use Input::*;
    let (l, w) = (n.length_m, n.width_m);
    vec![
        d(ChassisParams::front_m, thesis::FRONT_SHARE * l, &[Footprint],
          format!("{:.0} % of the body length {} m ahead of the axle, as the thesis machine", 100.0 * thesis::FRONT_SHARE, r4(l))),
        d(ChassisParams::rear_m, (1.0 - thesis::FRONT_SHARE) * l, &[Footprint], "the rest of the body length behind the axle"),
        d(ChassisParams::width_m, w, &[Footprint, Track], format!("body width (given, or the track plus {} m as the thesis machine)", thesis::WIDTH_OVER_TRACK_M)),
        d(ChassisParams::yaw_inertia_kg_m2, slab_yaw_inertia_kg_m2(n.mass_kg, l, w), &[Mass, Footprint],
          format!("a uniform slab of the footprint: mass (L^2 + W^2) / 12 with L = {}, W = {} m; measure or calibrate it for a real body", r4(l), r4(w))),
        d(ChassisParams::cg_x_m, if n.castors { thesis::CG_X_SHARE * l } else { 0.0 }, &[Footprint, Castors],
          if n.castors { "5 % of the length ahead of the axle, as the thesis machine" } else { "over the drive axle: no castors carry any load" }),
        d(ChassisParams::drive_load_fraction, if n.castors { 0.6 } else { 1.0 }, &[Castors],
          if n.castors { "60 % on the drive wheels, as the thesis machine" } else { "every load on the drive wheels: no castors" }),
        d(SensorParams::x_m, (thesis::FRONT_SHARE - thesis::SENSOR_BEHIND_FRONT_SHARE) * l, &[Footprint],
          "the coil pair 10 % of the body length inside its front edge, as the thesis machine"),
    ]
}

pub(super) fn castors(n: &Numbers) -> Vec<Derived> {
    use Input::*;
    let (l, w, m) = (n.length_m, n.width_m, n.mass_kg);
    let scaled = "scaled from the thesis machine's";
    vec![
        d(
            CastorParams::front_x_m,
            thesis::CASTOR_FRONT_SHARE * l,
            &[Footprint],
            "40 % of the body length ahead of the axle, as the thesis machine",
        ),
        d(
            CastorParams::rear_x_m,
            thesis::CASTOR_REAR_SHARE * l,
            &[Footprint],
            "35 % of the body length behind the axle, as the thesis machine",
        ),
        d(
            CastorParams::half_spacing_m,
            thesis::CASTOR_HALF_SPACING_SHARE * w,
            &[Footprint, Track],
            "39 % of the body width each side, as the thesis machine",
        ),
        d(
            CastorParams::trail_m,
            thesis::TRAIL_SHARE * l,
            &[Footprint],
            "4 % of the body length, as the thesis machine",
        ),
        d(
            CastorParams::mass_kg,
            thesis::CASTOR_MASS_SHARE * m,
            &[Mass],
            "1 % of the vehicle's mass, as the thesis machine",
        ),
        d(
            CastorParams::swivel_friction_nm,
            thesis::SWIVEL_NM_PER_KG_M * m * l,
            &[Mass, Footprint],
            format!("{scaled} 0.3 N m with load and size"),
        ),
        d(
            CastorParams::lumped_linear_drag_n_s_m,
            thesis::LINEAR_DRAG_PER_KG * m,
            &[Mass],
            format!("{scaled} 10 N s/m with mass"),
        ),
        d(
            CastorParams::lumped_angular_drag_nm_s_rad,
            thesis::ANGULAR_DRAG_PER_KG_M2 * m * l * l,
            &[Mass, Footprint],
            format!("{scaled} 2 N m s/rad with mass and length squared"),
        ),
    ]
}

/// How the gear ratio was found: given, or sized for the starting machine's top speed.
fn ratio_how(n: &Numbers) -> String {
    match n.drive_sized {
        Some(p) if !n.ratio_given => format!(
            "not given: sized for the starting machine's top speed {} m/s (the motors' no-load speed at the wheel) on this wheel; give --gear-ratio",
            r4(p.top_speed_m_s)
        ),
        _ => "given".into(),
    }
}

/// How the motor's torque constant and resistance were found: from the datasheet given,
/// or sized for the robot as the starting machine's drive is for it.
fn motor_how(n: &Numbers) -> [String; 2] {
    match n.drive_sized {
        Some(p) if !n.motor_given => [
            format!(
                "not given: sized for the starting machine's top speed {} m/s at the wheel through this gear on {} V; give the motor's datasheet",
                r4(p.top_speed_m_s),
                r4(n.rated_v)
            ),
            format!(
                "not given: sized so that both motors at stall push {} times the robot's weight, as the starting machine's; give the motor's datasheet",
                r4(p.stall_push_per_weight)
            ),
        ],
        _ => [
            format!(
                "rated {} V over the no-load speed in rad/s (the back-EMF constant; no-load current neglected)",
                n.rated_v
            ),
            "rated voltage over stall current".into(),
        ],
    }
}

pub(super) fn motor(n: &Numbers) -> Vec<Derived> {
    use Input::*;
    let (k, r) = (n.torque_constant_nm_a, n.resistance_ohm);
    let [k_how, r_how] = motor_how(n);
    let datasheet = MotorParams {
        torque_constant_nm_a: k,
        resistance_ohm: r,
        ..MotorParams::default()
    };
    let stall_nm = datasheet.stall_torque_nm(n.rated_v);
    let emf_damping = datasheet.electrical_damping_nm_s_rad();
    vec![
        d(MotorParams::torque_constant_nm_a, k, &[Motor], k_how),
        d(MotorParams::resistance_ohm, r, &[Motor], r_how),
        d(
            MotorParams::inductance_h,
            r * thesis::ELECTRICAL_TAU_S,
            &[Motor],
            format!(
                "assumed: an electrical time constant L/R of {:.2} ms, the thesis machine's",
                1e3 * thesis::ELECTRICAL_TAU_S
            ),
        ),
        d(
            MotorParams::rotor_inertia_kg_m2,
            thesis::MECHANICAL_TAU_S * emf_damping,
            &[Motor],
            format!(
                "assumed: a mechanical time constant J R / K^2 of {:.1} ms, the thesis machine's",
                1e3 * thesis::MECHANICAL_TAU_S
            ),
        ),
        d(
            MotorParams::coulomb_nm,
            thesis::COULOMB_SHARE_OF_STALL * stall_nm,
            &[Motor],
            format!(
                "assumed: {:.2} % of the stall torque ({} N m), the thesis machine's share",
                100.0 * thesis::COULOMB_SHARE_OF_STALL,
                r4(stall_nm)
            ),
        ),
        d(
            MotorParams::viscous_nm_s_rad,
            thesis::VISCOUS_SHARE_OF_EMF_DAMPING * emf_damping,
            &[Motor],
            format!(
                "assumed: {:.2} % of the back-EMF damping K^2/R, the thesis machine's share",
                100.0 * thesis::VISCOUS_SHARE_OF_EMF_DAMPING
            ),
        ),
    ]
}

pub(super) fn drivetrain(n: &Numbers) -> Vec<Derived> {
    use Input::*;
    let wheel_kg_m2 = thesis::WHEEL_INERTIA_KG_M2
        * (n.mass_kg / thesis::MASS_KG)
        * (n.wheel_radius_m / thesis::WHEEL_RADIUS_M).powi(2);
    // The rotor inertia `motor` derives, as the scene is written (rounded).
    let rotor_kg_m2 = round4(
        thesis::MECHANICAL_TAU_S
            * electrical_damping_nm_s_rad(n.torque_constant_nm_a, n.resistance_ohm),
    );
    let reflected = round4(wheel_kg_m2) + rotor_kg_m2 * n.ratio * n.ratio;
    // The thesis's tooth spring and damper against its reflected inertia: keeping the mesh's
    // resonance and damping ratio keeps the drivetrain as stiff, relative to its inertia,
    // as the tested machine (and the simulator's sub-steps as few).
    let omega2 = thesis::TOOTH_STIFFNESS / thesis_reflected_kg_m2();
    let zeta =
        thesis::TOOTH_DAMPING / (2.0 * (thesis::TOOTH_STIFFNESS * thesis_reflected_kg_m2()).sqrt());
    let k_mesh = reflected * omega2;
    vec![
        d(WheelParams::inertia_kg_m2, wheel_kg_m2, &[Mass, Wheel], "scaled from the thesis machine's 0.02 kg m^2 with mass and radius squared"),
        d(GearboxParams::tooth_stiffness_nm_rad, k_mesh, &[Mass, Wheel, Motor, Ratio],
          format!("the thesis machine's mesh resonance ({:.1} Hz) against the reflected inertia wheel + rotor x ratio^2 = {} kg m^2", omega2.sqrt() / std::f64::consts::TAU, r4(reflected))),
        d(GearboxParams::tooth_damping_nm_s_rad, 2.0 * zeta * (k_mesh * reflected).sqrt(), &[Mass, Wheel, Motor, Ratio],
          format!("the thesis machine's mesh damping ratio {zeta:.3}")),
    ]
}

pub(super) fn supply_and_drive(n: &Numbers) -> Vec<Derived> {
    use Input::*;
    let k = n.torque_constant_nm_a;
    let drive_v = round4(thesis::DRIVE_SHARE * n.battery_v);
    let stall_a = n.rated_v / n.resistance_ohm;
    let limit_a = round4(thesis::CURRENT_LIMIT_SHARE * stall_a);
    let forward = round4(drive_v / 100.0);
    vec![
        d(BatteryParams::drive_limit_v, drive_v, &[Battery], "the bridges deliver 23.5 of 24 V on the thesis machine (97.9 %)"),
        d(BatteryParams::low_voltage_fault_v, thesis::FAULT_SHARE * n.battery_v, &[Battery], "faults at 22 of 24 V on the thesis machine (91.7 %)"),
        d(BatteryParams::internal_resistance_ohm, thesis::SAG_SHARE * n.battery_v / (2.0 * limit_a), &[Battery, Motor],
          format!("assumed: both motors at the current limit sag the battery by {:.1} % (the thesis machine's share), above the fault threshold", 100.0 * thesis::SAG_SHARE)),
        d(DcmcParams::current_limit_a, limit_a, &[Motor], format!("{:.0} % of the stall current {} A, the thesis machine's share", 100.0 * thesis::CURRENT_LIMIT_SHARE, r4(stall_a))),
        d(DcmcParams::forward_gain_v_pct, forward, &[Battery], "full forward demand (100 %) asks the drive limit"),
        d(DcmcParams::turn_gain_v_pct, thesis::TURN_OVER_FORWARD * forward, &[Battery], "the thesis unit's identified turn/forward ratio 0.628"),
        d(DcmcParams::speed_per_pct_rad_s, thesis::SPEED_SHARE_OF_NO_LOAD * drive_v / k / 100.0, &[Battery, Motor],
          format!("speed loops (dcmc.kind p, pi): full demand asks {:.1} % of the no-load speed at the drive limit, as the thesis machine", 100.0 * thesis::SPEED_SHARE_OF_NO_LOAD)),
        d(DcmcParams::kp_v_s_rad, thesis::KP_PER_K * k, &[Motor], "speed loops: the thesis machine's gain in proportion to the torque constant"),
        d(DcmcParams::ki_v_rad, thesis::KI_PER_K * k, &[Motor], "speed loops: the thesis machine's gain in proportion to the torque constant"),
        d(DcmcParams::brake_gain_v_s_rad, thesis::BRAKE_PER_K * k, &[Motor], "the thesis machine's braking gain in proportion to the torque constant"),
        d(BaseParams::speed_kp_v_s_rad, thesis::KP_PER_K * k, &[Motor], "velocity-commanded drivers' speed loops: the thesis unit's gain in proportion to the torque constant"),
        d(BaseParams::speed_ki_v_rad, thesis::KI_PER_K * k, &[Motor], "velocity-commanded drivers' speed loops: the thesis unit's gain in proportion to the torque constant"),
    ]
}
