//! The recording channels agvsim reads and writes, each declared once: its column name
//! (ending in its unit, as the contract's names do), its unit, its role and its meaning.
//! Code names a channel by its constant (`chan::X_M`, a `&str`, so it serves in a `match`
//! as well as in a lookup); [`ALL`] is the table, [`find`] looks a name up. The contract's
//! channels (`recording-format.md`, "Channels by rig") come first, then agvsim's own
//! additions, which readers of the contract keep and ignore.

/// What a channel is to a model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The time column.
    Time,
    /// An input the contract defines: what drove the machine.
    Input,
    /// An output the contract defines: what was measured.
    Output,
    /// An input of agvsim's own (a velocity command a base controller follows).
    ExtraInput,
    /// A column of agvsim's own: measured, or the simulator's insight (slip, gear gap).
    Extra,
}

/// One channel, declared.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Channel {
    /// The column name, ending in its unit.
    pub name: &'static str,
    /// Its unit as printed (`rad/s`); empty for a count or a reading.
    pub unit: &'static str,
    /// Its role.
    pub role: Role,
    /// What it is.
    pub meaning: &'static str,
}

/// Declares each channel's constant and the table of them all, in order.
macro_rules! declare_channels {
    ($( $konst:ident = $name:literal, $unit:literal, $role:ident, $meaning:literal; )*) => {
        $(
            #[doc = concat!("`", $name, "`: ", $meaning, ".")]
            pub const $konst: &str = $name;
        )*
        /// Every channel declared, the contract's first.
        pub const ALL: &[Channel] = &[
            $( Channel { name: $name, unit: $unit, role: Role::$role, meaning: $meaning }, )*
        ];
    };
}

declare_channels! {
    T_S = "t_s", "s", Time, "time of the sample";
    // drive_axis
    VOLTAGE_V = "voltage_V", "V", Input, "motor terminal voltage command";
    DEMAND_PCT = "demand_pct", "%", Input, "speed demand into the motor controller, -100..100";
    MOTOR_SPEED_RAD_S = "motor_speed_rad_s", "rad/s", Output, "motor shaft speed (encoder derived)";
    MOTOR_ANGLE_RAD = "motor_angle_rad", "rad", Output, "motor shaft angle (encoder)";
    WHEEL_ANGLE_RAD = "wheel_angle_rad", "rad", Output, "wheel angle (encoder on the wheel side)";
    CURRENT_A = "current_A", "A", Output, "armature current";
    // drive_axis through a current amplifier, measured by position, in closed loop
    COMMAND_V = "command_V", "V", Input, "command into a current amplifier (force or torque = gain x command)";
    TORQUE_NM = "torque_Nm", "N m", Input, "commanded motor torque (rotary)";
    FORCE_N = "force_N", "N", Input, "commanded motor force (linear)";
    DISTURBANCE_FORCE_N = "disturbance_force_N", "N", Input, "known external force applied to the load";
    REFERENCE_RAD = "reference_rad", "rad", Input, "set-point of the position loop that produced the command (rotary)";
    REFERENCE_M = "reference_m", "m", Input, "set-point of the position loop that produced the command (linear)";
    POSITION_M = "position_m", "m", Output, "linear axis position, load side";
    SPEED_M_S = "speed_m_s", "m/s", Output, "linear axis speed, load side";
    // vehicle
    LEFT_VOLTAGE_V = "left_voltage_V", "V", Input, "left motor terminal voltage command";
    RIGHT_VOLTAGE_V = "right_voltage_V", "V", Input, "right motor terminal voltage command";
    DEMAND_FWD_PCT = "demand_fwd_pct", "%", Input, "forward demand into the motor controller";
    DEMAND_TURN_PCT = "demand_turn_pct", "%", Input, "turn demand into the motor controller";
    X_M = "x_m", "m", Output, "chassis x from an external tracker, world frame, at the drive-axle midpoint";
    Y_M = "y_m", "m", Output, "chassis y from an external tracker, world frame, at the drive-axle midpoint";
    HEADING_RAD = "heading_rad", "rad", Output, "chassis heading from an external tracker, world frame";
    LEFT_MOTOR_SPEED_RAD_S = "left_motor_speed_rad_s", "rad/s", Output, "left motor shaft speed";
    RIGHT_MOTOR_SPEED_RAD_S = "right_motor_speed_rad_s", "rad/s", Output, "right motor shaft speed";
    SENSOR_LEFT_ADC = "sensor_left_adc", "", Output, "left guide-wire pick-up reading, 0..255";
    SENSOR_RIGHT_ADC = "sensor_right_adc", "", Output, "right guide-wire pick-up reading, 0..255";
    LEFT_WHEEL_SPEED_M_S = "left_wheel_speed_m_s", "m/s", Output, "left wheel rim speed from its encoder";
    RIGHT_WHEEL_SPEED_M_S = "right_wheel_speed_m_s", "m/s", Output, "right wheel rim speed from its encoder";
    YAW_RATE_RAD_S = "yaw_rate_rad_s", "rad/s", Output, "chassis yaw rate from a gyro";
    // agvsim's own
    CMD_LINEAR_M_S = "cmd_linear_m_s", "m/s", ExtraInput, "a velocity-commanded base's linear speed command";
    CMD_ANGULAR_RAD_S = "cmd_angular_rad_s", "rad/s", ExtraInput, "a velocity-commanded base's yaw rate command";
    LEFT_CURRENT_A = "left_current_A", "A", Extra, "left motor armature current";
    RIGHT_CURRENT_A = "right_current_A", "A", Extra, "right motor armature current";
    LEFT_WHEEL_ANGLE_RAD = "left_wheel_angle_rad", "rad", Extra, "left wheel angle from its encoder";
    RIGHT_WHEEL_ANGLE_RAD = "right_wheel_angle_rad", "rad", Extra, "right wheel angle from its encoder";
    ODOM_X_M = "odom_x_m", "m", Extra, "x the robot's own odometry integrates (not ground truth)";
    ODOM_Y_M = "odom_y_m", "m", Extra, "y the robot's own odometry integrates (not ground truth)";
    ODOM_HEADING_RAD = "odom_heading_rad", "rad", Extra, "heading the robot's own odometry integrates";
    ODOM_LINEAR_M_S = "odom_linear_m_s", "m/s", Extra, "linear speed the robot's own odometry reports";
    ODOM_ANGULAR_RAD_S = "odom_angular_rad_s", "rad/s", Extra, "yaw rate the robot's own odometry reports";
    BATTERY_V = "battery_V", "V", Extra, "battery terminal voltage";
}

/// The declared channel of a column name.
pub fn find(name: &str) -> Option<&'static Channel> {
    ALL.iter().find(|c| c.name == name)
}

/// Whether a column is one of the contract's inputs (what drove the machine).
pub fn is_contract_input(name: &str) -> bool {
    find(name).is_some_and(|c| c.role == Role::Input)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every name is declared once and ends in a unit the reader knows (a reading, `_adc`,
    /// and the time included).
    #[test]
    fn each_channel_is_declared_once_and_ends_in_a_known_unit() {
        let mut seen = std::collections::BTreeSet::new();
        for c in ALL {
            assert!(seen.insert(c.name), "{} twice", c.name);
            assert!(
                super::super::KNOWN_UNITS
                    .iter()
                    .any(|u| c.name.ends_with(&format!("_{u}")) || c.name == "t_s"),
                "{} ends in no known unit",
                c.name
            );
        }
        assert_eq!(find(X_M).map(|c| c.role), Some(Role::Output));
        // The contract's inputs, for any rig ("Channels by rig"): twelve.
        let inputs: Vec<&str> = ALL
            .iter()
            .filter(|c| c.role == Role::Input)
            .map(|c| c.name)
            .collect();
        assert_eq!(
            inputs,
            [
                "voltage_V",
                "demand_pct",
                "command_V",
                "torque_Nm",
                "force_N",
                "disturbance_force_N",
                "reference_rad",
                "reference_m",
                "left_voltage_V",
                "right_voltage_V",
                "demand_fwd_pct",
                "demand_turn_pct"
            ]
        );
        assert!(is_contract_input(LEFT_VOLTAGE_V) && !is_contract_input(CMD_LINEAR_M_S));
    }
}
