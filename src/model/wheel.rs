//! The drive wheel with its output gear: its size, its inertia and its bearings' friction.

crate::declare_params! {
    /// The drive wheel, one per side (scene section `[wheel]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct WheelParams in "wheel" {
        /// Drive wheel radius (*assumed* 0.075 m).
        radius_m: f64 = 0.075, "m", Positive;
        /// Wheel plus output gear inertia about the axle (*assumed*).
        inertia_kg_m2: f64 = 0.02, "kg m^2", Positive;
        /// Viscous friction of the wheel's bearings and the gear's output stage, at the
        /// wheel's axle (default 0: all viscous friction lumped at the motor). It acts on
        /// the wheel's side of the gear play, so it matters apart from the motor's only
        /// with backlash; through rigid gears it adds this over the ratio squared to the
        /// motor's.
        viscous_nm_s_rad as "viscous_Nm_s_rad": f64 = 0.0, "N m s/rad", NonNegative;
        /// Effective rolling radius of the left drive wheel on the floor: the distance it
        /// rolls per radian of its turn (a worn or soft tyre, a wheel a little smaller than
        /// drawn). The contract's `wheel_geometry` (with the right one and the track). The
        /// odometry and the base controller keep working with the configured radius
        /// (`base.wheel_radius_m`).
        left_rolling_radius_m: Option<f64> = None, "m", Positive, unset "wheel.radius_m";
        /// Effective rolling radius of the right drive wheel on the floor (see the left's).
        right_rolling_radius_m: Option<f64> = None, "m", Positive, unset "wheel.radius_m";
    }
}

impl WheelParams {
    /// The effective rolling radii on the floor (left, right), m: each side's where set,
    /// else the wheel's radius.
    pub fn rolling_radii_m(&self) -> [f64; 2] {
        [
            self.left_rolling_radius_m.unwrap_or(self.radius_m),
            self.right_rolling_radius_m.unwrap_or(self.radius_m),
        ]
    }
}

impl WheelParams {
    /// The bearings' friction torque at a wheel speed, N m (opposing it).
    #[inline]
    pub fn bearing_torque_nm(&self, wheel_speed_rad_s: f64) -> f64 {
        self.viscous_nm_s_rad * wheel_speed_rad_s
    }
}
