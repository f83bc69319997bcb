//! A snapshot: everything an observer (CSV writer, Rerun recorder, metrics) may want to see
//! of the simulation at one instant. Built on request, so observers that sample at a
//! lower rate cost nothing in between.

use super::{Body, Sim};
use crate::model::chassis::Pose;

/// One drive side.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SideSnapshot {
    /// Motor terminal voltage, V.
    pub voltage_v: f64,
    /// Armature current, A.
    pub current_a: f64,
    /// Motor speed, rad/s.
    pub motor_speed_rad_s: f64,
    /// Motor angle, rad.
    pub motor_angle_rad: f64,
    /// Wheel speed, rad/s.
    pub wheel_speed_rad_s: f64,
    /// Wheel angle, rad.
    pub wheel_angle_rad: f64,
    /// Wheel rim speed as the wheel's encoder gives it, m/s: its turning rate times the
    /// configured radius (`base.wheel_radius_m`, else the wheel's), as a robot's odometry
    /// reads it.
    pub wheel_rim_m_s: f64,
    /// Distance the wheel has turned through since the start as its encoder gives it, m:
    /// the angle times the configured radius.
    pub wheel_rim_distance_m: f64,
    /// Gear output angle minus wheel angle, rad (inside +/- half the play: teeth apart).
    pub backlash_gap_rad: f64,
    /// Torque through the gear teeth, N m at the wheel.
    pub tooth_torque_nm: f64,
    /// Tyre force on the wheel, wheel frame (forward, left), N.
    pub tyre_force_n: [f64; 2],
    /// Slip ratio of the drive tyre.
    pub slip_ratio: f64,
    /// Slip angle of the drive tyre, rad.
    pub slip_angle_rad: f64,
    /// The tyre's force is on its friction limit.
    pub sliding: bool,
    /// Wheel contact point, world frame, m.
    pub contact_m: [f64; 2],
}

/// One castor.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CastorSnapshot {
    /// Swivel axis, world frame, m.
    pub swivel_m: [f64; 2],
    /// Contact patch, world frame, m.
    pub patch_m: [f64; 2],
    /// Castor wheel heading, world frame, rad.
    pub heading_rad: f64,
    /// Swivel angle relative to the body, rad (0: trailing straight).
    pub swivel_rad: f64,
    /// Floor force on the castor, world frame, N.
    pub force_n: [f64; 2],
}

/// The state of the whole simulation at an instant.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Snapshot {
    /// Time, s.
    pub t_s: f64,
    /// Pose of the drive-axle midpoint.
    pub pose: Pose,
    /// Velocity of the axle midpoint, body frame (forward, left), m/s.
    pub velocity_m_s: [f64; 2],
    /// Yaw rate, rad/s.
    pub yaw_rate_rad_s: f64,
    /// (left, right).
    pub sides: [SideSnapshot; 2],
    /// Empty on the no-slip levels (castors are lumped there).
    pub castors: Vec<CastorSnapshot>,
    /// Castor drag: the castor forces resolved against the body's forward axis, N
    /// (positive when they hold the vehicle back; lumped drag on the no-slip levels).
    pub castor_drag_n: f64,
    /// Coil readings (left, right), counts.
    pub sensors_adc: [f64; 2],
    /// Rear coil readings (left, right), counts (0 without a rear pair).
    pub rear_sensors_adc: [f64; 2],
    /// Coil positions, world frame.
    pub coils_m: [[f64; 2]; 2],
    /// Sensor-pair midpoint offset from the wire, m (left of the wire positive).
    pub lateral_error_m: f64,
    /// Axle-midpoint offset from the wire, m.
    pub axle_offset_m: f64,
    /// Demand into the DCMC (forward, turn), pct.
    pub demand_pct: [f64; 2],
    /// PWM registers (forward, turn), counts.
    pub duty_counts: [f64; 2],
    /// Firmware demand before the duty limits (forward, turn), counts.
    pub command_counts: [f64; 2],
    /// Battery terminal voltage, V.
    pub battery_v: f64,
    /// Battery current, A.
    pub battery_current_a: f64,
    /// The DCMC is braking (disabled or faulted).
    pub dcmc_braking: bool,
    /// The DCMC's latched fault, by name.
    pub dcmc_fault: Option<&'static str>,
    /// The firmware's phase, by name.
    pub controller_phase: &'static str,
    /// The coils lost the wire at the last interrupt.
    pub lost_wire: bool,
    /// The axle midpoint is beyond the far end of an open wire.
    pub past_wire_end: bool,
    /// Wheels lifted off the floor (the chassis stays put; no tracking to speak of).
    pub wheels_lifted: bool,
    /// The bumper touches an obstacle.
    pub bumper: bool,
    /// The swing-away strategy's picture of the wire, once it has one: a 6 m stretch of
    /// the straight line it assumes, centred on the axle, world frame, m.
    pub assumed_wire_m: Option<[[f64; 2]; 2]>,
}

/// Half the length of the swing-away strategy's assumed wire shown, m.
const ASSUMED_WIRE_HALF_LENGTH_M: f64 = 3.0;

impl Sim {
    /// What the simulation looks like now.
    pub fn snapshot(&self) -> Snapshot {
        let p = &self.params;
        let pose = self.pose();
        let (velocity_m_s, yaw_rate_rad_s) = match &self.body {
            Body::Lifted(_) => ([0.0, 0.0], 0.0),
            Body::NoSlip(s) => ([s.speed_m_s, 0.0], s.yaw_rate_rad_s),
            Body::Rapier(e) => {
                let v = e.body_velocity();
                (v.axle_m_s, v.yaw_rate_rad_s)
            }
        };
        let wheels = p.chassis.wheel_points_m();
        let rims = self.rim_speeds_m_s();
        let mut sides = [SideSnapshot::default(); 2];
        for i in 0..2 {
            let d = &self.drive[i];
            let (gap, _) = p.drivetrain.twist(d);
            let t = &self.last.tyre[i];
            sides[i] = SideSnapshot {
                voltage_v: self.last.motor_v[i],
                current_a: d.motor.current_a,
                motor_speed_rad_s: d.motor.speed_rad_s,
                motor_angle_rad: d.motor.angle_rad,
                wheel_speed_rad_s: d.wheel_speed_rad_s,
                wheel_angle_rad: d.wheel_angle_rad,
                wheel_rim_m_s: rims[i],
                wheel_rim_distance_m: d.wheel_angle_rad * p.odometry_radius_m,
                backlash_gap_rad: gap,
                tooth_torque_nm: p.drivetrain.tooth_torque_nm(d),
                tyre_force_n: t.force_n,
                slip_ratio: t.slip_ratio,
                slip_angle_rad: t.slip_angle_rad,
                sliding: t.sliding,
                contact_m: pose.to_world(wheels[i]),
            };
        }
        let castors = match &self.body {
            Body::Rapier(e) => {
                let points = p.chassis.castor_points_m();
                e.castor_motion()
                    .iter()
                    .enumerate()
                    .map(|(k, m)| CastorSnapshot {
                        swivel_m: pose.to_world(points[k]),
                        patch_m: m.patch_m,
                        heading_rad: m.heading_rad,
                        swivel_rad: m.swivel_rad,
                        force_n: self.last.castor_force_n[k],
                    })
                    .collect()
            }
            _ => Vec::new(),
        };
        let castor_drag_n = if castors.is_empty() {
            p.noslip.linear_drag_n_s_m * velocity_m_s[0]
        } else {
            -castors
                .iter()
                .map(|c| pose.unrotate(c.force_n)[0])
                .sum::<f64>()
        };
        let coils_m = [pose.to_world(p.coils_m()[0]), pose.to_world(p.coils_m()[1])];
        let mid = [
            0.5 * (coils_m[0][0] + coils_m[1][0]),
            0.5 * (coils_m[0][1] + coils_m[1][1]),
        ];
        Snapshot {
            t_s: self.t_s,
            pose,
            velocity_m_s,
            yaw_rate_rad_s,
            sides,
            castors,
            castor_drag_n,
            sensors_adc: self.last.sensors_adc,
            rear_sensors_adc: self.last.rear_sensors_adc,
            coils_m,
            lateral_error_m: p.wire.offset(mid).lateral_m,
            axle_offset_m: p.wire.offset([pose.x_m, pose.y_m]).lateral_m,
            demand_pct: self.last.demand_pct,
            duty_counts: [self.firmware.duty[0] as f64, self.firmware.duty[1] as f64],
            command_counts: self.firmware.command_counts,
            battery_v: self.last.battery_v,
            battery_current_a: self.last.battery_current_a,
            dcmc_braking: self.last.dcmc.braking,
            dcmc_fault: self.dcmc.fault.map(|f| f.name()),
            controller_phase: self.firmware.phase.name(),
            lost_wire: self.firmware.lost_wire,
            past_wire_end: p.wire.past_end([pose.x_m, pose.y_m]),
            wheels_lifted: matches!(self.body, Body::Lifted(_)),
            bumper: self.last.bumper,
            assumed_wire_m: self
                .firmware
                .swing_away
                .estimate
                .map(|e| e.assumed_wire_m(pose, ASSUMED_WIRE_HALF_LENGTH_M)),
        }
    }
}
