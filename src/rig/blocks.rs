//! The parts of a rig's machine that the AGV's scene has no block for: a linear axis's
//! load, a current amplifier, the position loop that produced a closed-loop command, the
//! instruments, and the falling-weight fixture. Each declares its keys as the AGV's blocks
//! do; the rig's other keys are the scene's (`super::keys`).

/// What `feedback.kind` takes.
fn feedback_kinds() -> String {
    "`position_velocity_cascade`: command = kv (kp (reference - position) - speed)".into()
}

crate::declare_params! {
    /// A linear axis's load (rig section `[load]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct LinearLoad in "load" {
        /// Moving mass.
        mass_kg: f64 = 1.0, "kg", Positive;
        /// Viscous friction of the axis (0: none believed).
        viscous_n_s_m as "viscous_N_s_m": f64 = 0.0, "N s/m", NonNegative;
    }
}

crate::declare_params! {
    /// A current amplifier: force (or torque) = gain x command (rig section `[drive]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct CurrentAmplifier in "drive" {
        /// Force per volt of command, linear axis.
        force_per_volt_n_v as "force_per_volt_N_V": f64 = 1.0, "N/V", Positive;
        /// Motor torque per volt of command, rotary axis.
        torque_per_volt_nm_v as "torque_per_volt_Nm_V": f64 = 1.0, "N m/V", Positive;
        /// Command limit.
        limit_v as "limit_V": f64 = 10.0, "V", Positive;
    }
}

crate::declare_params! {
    /// The position loop that produced a closed-loop command (rig section `[feedback]`).
    #[derive(Debug, Clone, PartialEq)]
    pub struct PositionLoop in "feedback" {
        /// The loop's structure.
        kind: String = "position_velocity_cascade".into(), "", other(feedback_kinds);
        /// Position gain.
        kp_1_s: f64 = 1.0, "1/s", Positive;
        /// Velocity gain of a linear axis, V per m/s.
        kv_v_s_m as "kv_V_s_m": f64 = 1.0, "V s/m", Positive;
        /// Velocity gain of a rotary axis, V per rad/s of the wheel (an agvsim key beside
        /// the contract's linear one).
        kv_v_s_rad as "kv_V_s_rad": f64 = 1.0, "V s/rad", Positive;
    }
}

crate::declare_params! {
    /// The instruments a recording was made with (rig section `[sensors]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct Instruments in "sensors" {
        /// Motor encoder resolution: speeds are count differences over the sample
        /// interval.
        motor_encoder_counts_per_rev: f64 = 1024.0, "counts", Positive;
        /// RMS noise of `current_A`.
        current_noise_a as "current_noise_A": f64 = 0.0, "A", Positive;
        /// RMS position noise of the external pose tracker.
        tracker_position_noise_m: f64 = 0.002, "m", Positive;
        /// RMS heading noise of the external pose tracker.
        tracker_heading_noise_rad: f64 = 0.005, "rad", Positive;
        /// Sample rate of the external pose tracker.
        tracker_rate_hz: f64 = 50.0, "Hz", Positive;
    }
}

crate::declare_params! {
    /// The falling-weight test (rig section `[falling_weight]`, an agvsim section): the
    /// motor off the vehicle, a mass on a pulley on its shaft, dropping from rest until it
    /// lands.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct FallingWeight in "falling_weight" {
        /// The falling mass.
        mass_kg: f64 = 0.5, "kg", Positive;
        /// Radius of the pulley on the motor shaft.
        pulley_radius_m: f64 = 0.015, "m", Positive;
        /// Height the mass falls before it lands.
        drop_m: f64 = 1.0, "m", Positive;
    }
}
