//! `Sim::step`: one physics step, in a fixed order.

use rand_distr::{Distribution, StandardNormal};

use super::{Actuation, Body, Sim, SimError, SimParams};
use crate::firmware::pwm::duty_to_pct;
use crate::firmware::FirmwareInput;
use crate::model::base_controller::BaseInput;
use crate::model::castor::rolling_drag_n;
use crate::model::chassis::PoseFrame;
use crate::model::dcmc::DcmcInput;
use crate::model::motor::Terminal;
use crate::model::tyre::{slip_measures, ContactKinematics, TyreOutput, TyreState};
use crate::sensing::coil::{adc_counts, adc_unquantised};
use crate::world::engine::CastorMotion;

/// Speeds beyond this are not physical for this machine: a diverging run, rad/s.
const MAX_SPEED_RAD_S: f64 = 1.0e4;
/// Voltages beyond this are no vehicle's supply: a scene value far out of range, V.
const MAX_VOLTAGE_V: f64 = 1.0e5;

impl Sim {
    /// Advances the simulation by one physics step `dt`. The order is fixed:
    ///
    /// 0. **Command dead time**: external commands whose dead time has passed act (one
    ///    arriving within the step is blended in for the part of the step it acts).
    /// 1. **Sensors**: coil readings at the current pose (field, noise, ADC), bumper contact.
    /// 2. **Controller**: the firmware runs its interrupt if one is due (sample and hold),
    ///    and writes PWM values whose computation delay has elapsed.
    /// 3. **PWM filter and DCMC**: duty to demand, demand to motor voltage, with the
    ///    battery's available voltage from the last step's current draw; or, driven by a
    ///    velocity command, the base controller and its drivers' speed loops.
    /// 4. **Drivetrain and tyres**: `substeps` sub-steps of motor, gear mesh and wheel;
    ///    on the floor each wheel's tyre sub-steps with it against the chassis velocity of
    ///    the step's start; on the no-slip levels the chassis sub-steps with the wheels.
    /// 5. **Forces into rapier**: mean tyre forces at the wheel contacts, castor tyre and
    ///    rolling-resistance forces at the castor patches (forces reset first).
    /// 6. **Rapier step**.
    /// 7. **Finiteness check**: any non-finite or unphysical state stops the run with
    ///    [`SimError::Diverged`].
    pub fn step(&mut self) -> Result<(), SimError> {
        let dt = self.params.sim.dt_s;
        if let Some(d) = &mut self.command_delay {
            self.actuation = d.acting(self.t_s, dt);
        }
        // 1. Sensors.
        let sensed = self.sense();
        // 2. Controller.
        let duty = self.controller_duty(&sensed);
        // 3. PWM filter and DCMC (or the base's drivers, or the given voltages).
        let drive = self.motor_terminals(duty, dt);
        // 4-6. Drivetrain and tyres, forces into rapier, rapier step.
        let tyre = self.advance_drivetrains_and_body(drive.terminals, dt);
        self.keep_last(&sensed, drive, tyre);
        self.t_s = (self.steps + 1) as f64 * dt;
        self.steps += 1;
        // 7. Finiteness check.
        self.check_finite()
    }

    /// Step 1: the coil pairs (with their noise, in this order: front, then rear), the
    /// bumper, the pair the controller steers on and the ideal feedback's difference.
    fn sense(&mut self) -> Sensed {
        let body_pose = self.pose();
        let pose = body_pose.frame();
        let (sensors, rear) = if self.coils_read {
            (
                self.read_coils(&pose, self.params.coils_m()),
                self.params
                    .rear_coils_m()
                    .map(|c| self.read_coils(&pose, c)),
            )
        } else {
            ([0.0; 2], None)
        };
        let bumper = self
            .params
            .bumper
            .touches(&body_pose, &self.params.obstacles);
        let steer_on = match (self.params.firmware.controller.reverse, rear) {
            (true, Some(r)) => r,
            _ => sensors,
        };
        let ideal = self.params.features.ideal_feedback.then(|| {
            let coils = match (
                self.params.firmware.controller.reverse,
                self.params.rear_coils_m(),
            ) {
                (true, Some(r)) => r,
                _ => self.params.coils_m(),
            };
            let mid = [
                0.5 * (coils[0][0] + coils[1][0]),
                0.5 * (coils[0][1] + coils[1][1]),
            ];
            self.params.ideal_slope_counts_per_m
                * self.params.wire.offset(pose.to_world(mid)).lateral_m
        });
        Sensed {
            sensors,
            rear,
            bumper,
            steer_on,
            ideal,
        }
    }

    /// Step 2: the firmware's PWM duties from what it senses and the wheels' odometry.
    fn controller_duty(&mut self, sensed: &Sensed) -> [i32; 2] {
        let odometry = self.rim_speeds_m_s();
        self.params.firmware.step(
            &mut self.firmware,
            &FirmwareInput {
                t_s: self.t_s,
                sensors_adc: sensed.steer_on,
                ideal_difference: sensed.ideal,
                bumper: sensed.bumper,
                wheel_speed_m_s: odometry,
            },
        )
    }

    /// Step 3: the duties through the PWM filter into demands, the DCMC's voltages from
    /// them (or the recording's demands), and the motor terminals by the actuation: the
    /// DCMC's, the base controller's, given voltages through the bridges, or open.
    fn motor_terminals(&mut self, duty: [i32; 2], dt: f64) -> Drive {
        for (f, d) in self.pwm_filtered.iter_mut().zip(duty) {
            *f = if self.params.features.pwm_filter {
                self.params.pwm.step(*f, d as f64, dt)
            } else {
                d as f64
            };
        }
        let firmware_demand = [
            duty_to_pct(self.pwm_filtered[0]),
            duty_to_pct(self.pwm_filtered[1]),
        ];
        let battery = self.params.battery;
        let battery_v = battery.terminal_voltage_v(self.last.battery_current_a);
        let available_v = battery.available_drive_v(battery_v);
        let speeds = [
            self.drive[0].motor.speed_rad_s,
            self.drive[1].motor.speed_rad_s,
        ];
        let (demand, enabled) = match self.actuation {
            Actuation::Demand {
                forward_pct,
                turn_pct,
            } => ([forward_pct, turn_pct], true),
            // The base's own drivers act; the DCMC stands by.
            Actuation::Velocity { .. } => ([0.0; 2], false),
            _ => (firmware_demand, self.firmware.drive_enabled),
        };
        let dcmc = self.params.dcmc.step(
            &mut self.dcmc,
            &DcmcInput {
                t_s: self.t_s,
                enabled,
                forward_pct: demand[0],
                turn_pct: demand[1],
                motor_speed_rad_s: speeds,
                back_emf_v: speeds.map(|w| self.params.drivetrain.motor.back_emf_v(w)),
                low_battery: battery.below_fault(battery_v),
                available_v,
            },
            dt,
        );
        let terminals = match self.actuation {
            Actuation::Firmware | Actuation::Demand { .. } => dcmc.voltage_v.map(Terminal::Voltage),
            Actuation::Velocity {
                linear_m_s,
                angular_rad_s,
            } => {
                let out = self.params.base.step(
                    &self.params.base_geometry,
                    &mut self.base,
                    &BaseInput {
                        linear_m_s,
                        angular_rad_s,
                        motor_speed_rad_s: speeds,
                        available_v,
                    },
                    dt,
                );
                out.voltage_v.map(Terminal::Voltage)
            }
            Actuation::Voltage(v) => {
                v.map(|x| Terminal::Voltage(battery.bridge_output_v(x, battery_v)))
            }
            Actuation::Open => [Terminal::Open; 2],
        };
        Drive {
            demand,
            dcmc,
            terminals,
            battery_v,
        }
    }

    /// What the step leaves for the snapshot and the next step: the readings, demands,
    /// voltages, tyre outputs, and the battery current of the power the motors drew
    /// (ideal bridges), for the next step's terminal voltage.
    fn keep_last(&mut self, sensed: &Sensed, drive: Drive, tyre: [TyreOutput; 2]) {
        let power: f64 = (0..2)
            .map(|i| match drive.terminals[i] {
                Terminal::Voltage(v) => v * self.drive[i].motor.current_a,
                Terminal::Open => 0.0,
            })
            .sum();
        let current = self.params.battery.current_for_power_a(power);
        self.last.sensors_adc = sensed.sensors;
        self.last.rear_sensors_adc = sensed.rear.unwrap_or([0.0; 2]);
        self.last.demand_pct = drive.demand;
        self.last.dcmc = drive.dcmc;
        self.last.motor_v = drive.terminals.map(|t| match t {
            Terminal::Voltage(v) => v,
            Terminal::Open => 0.0,
        });
        self.last.battery_v = drive.battery_v;
        self.last.battery_current_a = current;
        self.last.tyre = tyre;
        self.last.bumper = sensed.bumper;
    }

    /// Readings of a coil pair (left, right) at a pose: field, noise, ADC.
    fn read_coils(&mut self, pose: &PoseFrame, coils: [[f64; 2]; 2]) -> [f64; 2] {
        let axis = pose.rotate([0.0, 1.0]);
        let mut out = [0.0; 2];
        for (i, c) in coils.iter().enumerate() {
            let field = self
                .params
                .wire
                .horizontal_field(pose.to_world(*c), self.params.coil.height_m);
            let mut s = self.params.coil.reading(field, axis);
            if self.params.sensors.noise_adc > 0.0 {
                let n: f64 = StandardNormal.sample(&mut self.rng);
                s += self.params.sensors.noise_adc * n;
            }
            out[i] = if self.params.features.quantisation {
                adc_counts(s)
            } else {
                adc_unquantised(s)
            };
        }
        out
    }

    /// Sub-steps the drivetrains together with whatever carries the wheels, then (on the
    /// floor) applies the forces and steps rapier. Returns the drive tyres' mean output.
    pub(super) fn advance_drivetrains_and_body(
        &mut self,
        terminals: [Terminal; 2],
        dt: f64,
    ) -> [TyreOutput; 2] {
        let p = &self.params;
        let dtp = p.drivetrain;
        let n = p.substeps;
        let h = dt / n as f64;
        let mut mean = [TyreOutput::default(); 2];
        match &mut self.body {
            Body::Lifted(_) => {
                for _ in 0..n {
                    for i in 0..2 {
                        let t = dtp.tooth_torque_nm(&self.drive[i]);
                        dtp.motor_substep(&mut self.drive[i], terminals[i], t, h);
                        dtp.wheel_substep(&mut self.drive[i], t, 0.0, h);
                    }
                }
            }
            Body::NoSlip(state) => {
                for _ in 0..n {
                    let mut torque = [0.0; 2];
                    for i in 0..2 {
                        let tooth = dtp.tooth_torque_nm(&self.drive[i]);
                        dtp.motor_substep(&mut self.drive[i], terminals[i], tooth, h);
                        torque[i] = tooth
                            - dtp.wheel_bearing_torque_nm(self.drive[i].wheel_speed_rad_s)
                            + dtp.wheel_term_torque_nm(&self.drive[i]);
                    }
                    p.noslip.step(state, torque, h);
                    let w = p.noslip.wheel_speeds_rad_s(state);
                    for i in 0..2 {
                        self.drive[i].wheel_speed_rad_s = w[i];
                        self.drive[i].wheel_angle_rad += h * w[i];
                    }
                }
            }
            Body::Rapier(engine) => {
                let pose = engine.pose();
                let wheels = p.chassis.wheel_points_m();
                // Each wheel rolls on its effective radius.
                let r = p.rolling_radii_m;
                let mut kin = [ContactKinematics::default(); 2];
                let mut tyre_params = [p.drive_tyre(p.floor.default); 2];
                for i in 0..2 {
                    let v = engine.point_velocity_body(wheels[i]);
                    kin[i] = ContactKinematics {
                        forward_m_s: v[0],
                        lateral_m_s: v[1],
                        rim_m_s: 0.0,
                    };
                    tyre_params[i] = p.drive_tyre(p.floor.surface_at(pose.to_world(wheels[i])));
                }
                let mut force_sum = [[0.0; 2]; 2];
                let inv_n = 1.0 / n as f64;
                for _ in 0..n {
                    for i in 0..2 {
                        let t = dtp.tooth_torque_nm(&self.drive[i]);
                        dtp.motor_substep(&mut self.drive[i], terminals[i], t, h);
                        kin[i].rim_m_s = self.drive[i].wheel_speed_rad_s * r[i];
                        let out = tyre_params[i].step_force(
                            &mut self.tyres[i],
                            kin[i],
                            p.loads.drive_n[i],
                            h,
                        );
                        dtp.wheel_substep(&mut self.drive[i], t, -r[i] * out.force_n[0], h);
                        force_sum[i][0] += out.force_n[0];
                        force_sum[i][1] += out.force_n[1];
                        // The last sub-step's sliding state (its slip measures follow the
                        // loop) and the mean of the forces.
                        mean[i] = TyreOutput {
                            force_n: [0.0; 2],
                            ..out
                        };
                    }
                }
                for i in 0..2 {
                    mean[i].force_n = [force_sum[i][0] * inv_n, force_sum[i][1] * inv_n];
                    if p.loads.drive_n[i] > 0.0 {
                        (mean[i].slip_ratio, mean[i].slip_angle_rad) = slip_measures(kin[i]);
                    }
                }
                let wheel_forces = [
                    (wheels[0], pose.rotate(mean[0].force_n)),
                    (wheels[1], pose.rotate(mean[1].force_n)),
                ];
                let motion = engine.castor_motion();
                let castor_forces = castor_forces_n(p, &motion, &mut self.castor_tyres, dt);
                self.last.castor_force_n = castor_forces;
                engine.step(&wheel_forces, &castor_forces, &motion);
            }
        }
        mean
    }

    fn check_finite(&self) -> Result<(), SimError> {
        let bad = |what: &str, value: f64| SimError::Diverged {
            t_s: self.t_s,
            what: what.to_string(),
            value,
            suspects: "try a smaller sim.dt_s or check the scene's stiffness and gains".into(),
        };
        for (i, d) in self.drive.iter().enumerate() {
            let side = if i == 0 { "left" } else { "right" };
            for (name, v, limit) in [
                ("motor speed (rad/s)", d.motor.speed_rad_s, MAX_SPEED_RAD_S),
                ("wheel speed (rad/s)", d.wheel_speed_rad_s, MAX_SPEED_RAD_S),
                ("armature current (A)", d.motor.current_a, 1.0e4),
                ("motor angle (rad)", d.motor.angle_rad, f64::MAX),
                ("wheel angle (rad)", d.wheel_angle_rad, f64::MAX),
            ] {
                if !v.is_finite() || v.abs() > limit {
                    return Err(bad(&format!("{side} {name}"), v));
                }
            }
        }
        // What the blocks around the drive output: a supply or a gain far beyond any
        // machine's (1e308 V, a gain scale of 1e308) shows here before it reaches a cell.
        let l = &self.last;
        let outputs = [
            ("left motor voltage (V)", l.motor_v[0], MAX_VOLTAGE_V),
            ("right motor voltage (V)", l.motor_v[1], MAX_VOLTAGE_V),
            ("battery voltage (V)", l.battery_v, MAX_VOLTAGE_V),
            ("battery current (A)", l.battery_current_a, 1.0e4),
            ("left demand (%)", l.demand_pct[0], f64::MAX),
            ("right demand (%)", l.demand_pct[1], f64::MAX),
            (
                "left command (counts)",
                self.firmware.command_counts[0],
                f64::MAX,
            ),
            (
                "right command (counts)",
                self.firmware.command_counts[1],
                f64::MAX,
            ),
            ("left tyre force (N)", l.tyre[0].force_n[0], f64::MAX),
            ("right tyre force (N)", l.tyre[1].force_n[0], f64::MAX),
        ];
        for (name, v, limit) in outputs {
            if !v.is_finite() || v.abs() > limit {
                return Err(bad(name, v));
            }
        }
        for f in l.castor_force_n.iter().flatten() {
            if !f.is_finite() {
                return Err(bad("castor force (N)", *f));
            }
        }
        let pose = self.pose();
        for (name, v) in [
            ("x (m)", pose.x_m),
            ("y (m)", pose.y_m),
            ("heading (rad)", pose.heading_rad),
        ] {
            if !v.is_finite() {
                return Err(bad(name, v));
            }
        }
        if let Body::Rapier(e) = &self.body {
            let v = e.body_velocity();
            let speed = v.axle_m_s[0].hypot(v.axle_m_s[1]);
            let bound = self.speed_bound_m_s();
            if !speed.is_finite() || speed > bound.min(100.0) {
                return Err(bad("chassis speed (m/s)", speed));
            }
            let yaw_bound = 2.0 * bound / self.params.chassis.track_width_m;
            if !v.yaw_rate_rad_s.is_finite() || v.yaw_rate_rad_s.abs() > yaw_bound {
                return Err(bad("yaw rate (rad/s)", v.yaw_rate_rad_s));
            }
        }
        Ok(())
    }

    /// The fastest the chassis can move, m/s: the motors' no-load speed at the supply,
    /// through the gear to the larger rolling radius, three times over, plus 1 m/s (for
    /// transients and collisions). Every joule of a floor run comes from the motors, so a
    /// body faster than this has gained energy from an integration gone unstable (a yaw
    /// inertia far below the body's, a stiffness too high for `sim.dt_s`).
    fn speed_bound_m_s(&self) -> f64 {
        let p = &self.params;
        let d = &p.drivetrain;
        let no_load_m_s = d.motor.no_load_speed_rad_s(p.battery.open_circuit_v.abs())
            / d.gearbox.ratio
            * p.rolling_radii_m[0].max(p.rolling_radii_m[1]);
        3.0 * no_load_m_s + 1.0
    }
}

/// What step 1 sensed.
struct Sensed {
    /// The front coil pair, ADC counts (zeros where the coils are not read).
    sensors: [f64; 2],
    /// The rear pair, if the vehicle has one.
    rear: Option<[f64; 2]>,
    /// Whether the bumper touches an obstacle.
    bumper: bool,
    /// The pair the controller steers on (the rear when reversing with one).
    steer_on: [f64; 2],
    /// The ideal feedback's difference, counts (the linear level's).
    ideal: Option<f64>,
}

/// What step 3 drives the motors with.
struct Drive {
    /// The demands the DCMC was given, pct.
    demand: [f64; 2],
    /// The DCMC's output.
    dcmc: crate::model::dcmc::DcmcOutput,
    /// The motors' terminals.
    terminals: [Terminal; 2],
    /// The battery's terminal voltage this step, V.
    battery_v: f64,
}

/// The castors' forces on the chassis, world frame, N: each castor wheel rolls freely
/// (its rim speed its forward speed, so it slips only sideways) on the floor under its
/// patch, over the whole step `dt` (s), against its rolling resistance.
fn castor_forces_n(
    p: &SimParams,
    motion: &[CastorMotion; 4],
    tyres: &mut [TyreState; 4],
    dt: f64,
) -> [[f64; 2]; 4] {
    let mut castor_forces = [[0.0; 2]; 4];
    for (k, m) in motion.iter().enumerate() {
        let load = p.loads.castor_n[k];
        let tp = p.castor_tyre(p.floor.surface_at(m.patch_m));
        let roll = m.velocity_m_s[0];
        // A free-rolling wheel: rim speed equals forward speed, only lateral slip.
        let out = tp.step_force(
            &mut tyres[k],
            ContactKinematics {
                forward_m_s: roll,
                lateral_m_s: m.velocity_m_s[1],
                rim_m_s: roll,
            },
            load,
            dt,
        );
        // Rolling resistance, smoothed through zero speed over 5 mm/s.
        let [rr] = rolling_drag_n(p.castors.rolling_resistance * load, [roll], 0.005);
        let local = [rr, out.force_n[1]];
        let (s, c) = m.heading_rad.sin_cos();
        castor_forces[k] = [c * local[0] - s * local[1], s * local[0] + c * local[1]];
    }
    castor_forces
}
