//! The chassis as a rigid body: mass properties with payload, static normal loads on the
//! wheels and castors, and the thesis's no-slip chassis (wheels rolling without slip,
//! castor drag lumped into linear and angular viscous damping as Johnson & Aylor did).
//! The rapier version of the chassis lives in `world`.

use super::GRAVITY_M_S2;

crate::declare_params! {
    /// The bare vehicle with its batteries (scene section `[chassis]`). The body frame
    /// has its origin at the midpoint of the drive axle, x forward, y to the left.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct ChassisParams in "chassis" {
        /// Mass with batteries ("a 120 kg Logo turtle").
        mass_kg: f64 = 120.0, "kg", Positive;
        /// Yaw inertia about the centre of gravity (*assumed*: from CAD, not given).
        yaw_inertia_kg_m2: f64 = 14.0, "kg m^2", Positive;
        /// Distance between the drive wheels (*assumed*).
        track_width_m: f64 = 0.50, "m", Positive;
        /// Centre of gravity ahead of the drive axle (*assumed*).
        cg_x_m: f64 = 0.05, "m", Finite;
        /// Centre of gravity left of the centre line.
        cg_y_m: f64 = 0.0, "m", Finite;
        /// Share of the weight on the two drive wheels (the hinged chassis keeps them
        /// loaded); 1: every load on them (a tank or a drop-centre six-wheel drive, the
        /// castors idle), the centre of gravity over the drive axle.
        drive_load_fraction: f64 = 0.6, "", open_closed(0.0, 1.0);
        /// Front edge of the body ahead of the drive axle: outline and bumper (*assumed*).
        front_m: f64 = 0.55, "m", Positive;
        /// Rear edge of the body behind the drive axle (*assumed*).
        rear_m: f64 = 0.45, "m", Positive;
        /// Body width (*assumed*).
        width_m: f64 = 0.62, "m", Positive;
    }
}

crate::declare_params! {
    /// Load on the scissor-lift platform (scene section `[payload]`): adds mass and
    /// inertia and may shift the centre of gravity.
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct PayloadParams in "payload" {
        /// Payload mass (design payload 200 kg).
        mass_kg: f64 = 0.0, "kg", NonNegative;
        /// Payload centre of gravity ahead of the drive axle.
        cg_x_m: f64 = 0.05, "m", Finite;
        /// Payload centre of gravity left of the centre line.
        cg_y_m: f64 = 0.0, "m", Finite;
        /// Payload yaw inertia about its own centre of gravity.
        yaw_inertia_kg_m2: f64 = 0.0, "kg m^2", NonNegative;
    }
}

/// The vehicle as it runs: chassis and payload combined (mass, yaw inertia and centre of
/// gravity), the track and where the castors stand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadedChassis {
    /// Mass with payload, kg.
    pub mass_kg: f64,
    /// Yaw inertia about the centre of gravity, kg m^2.
    pub yaw_inertia_kg_m2: f64,
    /// Centre of gravity in the body frame (origin at the drive-axle midpoint), m.
    pub cg_m: [f64; 2],
    /// Distance between the drive wheels, m.
    pub track_width_m: f64,
    /// Share of the weight on the drive wheels.
    pub drive_load_fraction: f64,
    /// Castor swivel axes: x of the front and rear pairs and their half spacing, m.
    pub castor_front_x_m: f64,
    /// x of the rear castors' swivel axes, m (negative: behind the axle).
    pub castor_rear_x_m: f64,
    /// Half the spacing of each castor pair, m.
    pub castor_half_spacing_m: f64,
}

/// Normal loads, N: drive wheels (left, right) and castors (front-left, front-right,
/// rear-left, rear-right).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalLoads {
    /// Drive wheels (left, right), N.
    pub drive_n: [f64; 2],
    /// Castors (front-left, front-right, rear-left, rear-right), N.
    pub castor_n: [f64; 4],
}

impl LoadedChassis {
    /// Combines the bare vehicle and a payload (parallel-axis theorem for the yaw inertia).
    pub fn with_payload(
        mass_kg: f64,
        yaw_inertia_kg_m2: f64,
        cg_m: [f64; 2],
        payload_kg: f64,
        payload_inertia_kg_m2: f64,
        payload_cg_m: [f64; 2],
    ) -> ([f64; 2], f64, f64) {
        let m = mass_kg + payload_kg;
        let cg = [
            (mass_kg * cg_m[0] + payload_kg * payload_cg_m[0]) / m,
            (mass_kg * cg_m[1] + payload_kg * payload_cg_m[1]) / m,
        ];
        let d2 = |p: [f64; 2]| (p[0] - cg[0]).powi(2) + (p[1] - cg[1]).powi(2);
        let inertia = yaw_inertia_kg_m2
            + mass_kg * d2(cg_m)
            + payload_inertia_kg_m2
            + payload_kg * d2(payload_cg_m);
        (cg, m, inertia)
    }

    /// Static normal loads from the CG position. The hinged chassis puts a set share of
    /// the weight on the drive wheels (split left/right by the lever rule); the castors
    /// carry the rest, shared bilinearly so that the moments about both axes balance.
    /// A static distribution: load transfer under acceleration is not modelled.
    pub fn normal_loads(&self) -> NormalLoads {
        let w = self.mass_kg * GRAVITY_M_S2;
        let f = self.drive_load_fraction;
        let t = self.track_width_m;
        let left_share = 0.5 + self.cg_m[1] / t;
        let drive = [f * w * left_share, f * w * (1.0 - left_share)];
        // Where the castors' share must act for the moments to balance.
        let rest = (1.0 - f) * w;
        // With every load on the drive wheels the castors carry none (and the CG is over
        // the axle, which the scene checks).
        let cx = if rest > 0.0 {
            self.cg_m[0] / (1.0 - f)
        } else {
            0.0
        };
        // The drive pair already splits its share about the CG's y, so the castors'
        // share must be centred on it too; along x the drive axle sits at x = 0.
        let cy = self.cg_m[1];
        let (xf, xr, hy) = (
            self.castor_front_x_m,
            self.castor_rear_x_m,
            self.castor_half_spacing_m,
        );
        let front = (cx - xr) / (xf - xr);
        let left = 0.5 + cy / (2.0 * hy);
        let castor = [
            rest * front * left,
            rest * front * (1.0 - left),
            rest * (1.0 - front) * left,
            rest * (1.0 - front) * (1.0 - left),
        ];
        NormalLoads {
            drive_n: drive,
            castor_n: castor,
        }
    }

    /// Castor swivel points in the body frame, in the order of [`NormalLoads::castor_n`].
    pub fn castor_points_m(&self) -> [[f64; 2]; 4] {
        let (xf, xr, hy) = (
            self.castor_front_x_m,
            self.castor_rear_x_m,
            self.castor_half_spacing_m,
        );
        [[xf, hy], [xf, -hy], [xr, hy], [xr, -hy]]
    }

    /// Drive-wheel contact points in the body frame (left, right).
    pub fn wheel_points_m(&self) -> [[f64; 2]; 2] {
        let h = 0.5 * self.track_width_m;
        [[0.0, h], [0.0, -h]]
    }
}

crate::declare_params! {
    /// Pose of the drive-axle midpoint, world frame (a scene's start is one: section
    /// `[start]`).
    #[derive(Debug, Clone, Copy, PartialEq)]
    pub struct Pose in "start" {
        /// Position along the world's x axis.
        x_m: f64 = 0.0, "m", Finite;
        /// Position along the world's y axis.
        y_m: f64 = 0.0, "m", Finite;
        /// Heading from the x axis, counter-clockwise, unwrapped.
        heading_rad: f64 = 0.0, "rad", Finite;
    }
}

/// A pose with its heading's sine and cosine worked out once, for mapping several points
/// or directions from the body frame to the world.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFrame {
    /// Position, world x, m.
    pub x_m: f64,
    /// Position, world y, m.
    pub y_m: f64,
    /// Sine of the heading.
    pub sin: f64,
    /// Cosine of the heading.
    pub cos: f64,
}

impl PoseFrame {
    /// A body-frame point in the world frame.
    pub fn to_world(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = (self.sin, self.cos);
        [
            self.x_m + c * p[0] - s * p[1],
            self.y_m + s * p[0] + c * p[1],
        ]
    }

    /// A body-frame direction in the world frame.
    pub fn rotate(&self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = (self.sin, self.cos);
        [c * v[0] - s * v[1], s * v[0] + c * v[1]]
    }
}

impl Pose {
    /// This pose's frame (one sine and cosine for many mappings).
    pub fn frame(&self) -> PoseFrame {
        let (sin, cos) = self.heading_rad.sin_cos();
        PoseFrame {
            x_m: self.x_m,
            y_m: self.y_m,
            sin,
            cos,
        }
    }

    /// A body-frame point in the world frame.
    pub fn to_world(&self, p: [f64; 2]) -> [f64; 2] {
        self.frame().to_world(p)
    }

    /// A body-frame direction in the world frame.
    pub fn rotate(&self, v: [f64; 2]) -> [f64; 2] {
        self.frame().rotate(v)
    }

    /// A world-frame direction in the body frame.
    pub fn unrotate(&self, v: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.heading_rad.sin_cos();
        [c * v[0] + s * v[1], -s * v[0] + c * v[1]]
    }
}

/// Parameters of the no-slip chassis (thesis levels 1-3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoSlipParams {
    /// The chassis with its payload.
    pub chassis: LoadedChassis,
    /// Drive wheels' effective rolling radii (left, right), m.
    pub wheel_radii_m: [f64; 2],
    /// Inertia turning with each drive wheel, kg m^2.
    pub wheel_inertia_kg_m2: f64,
    /// Lumped castor drag on the forward speed, N s/m.
    pub linear_drag_n_s_m: f64,
    /// Lumped castor drag on the yaw rate, N m s/rad.
    pub angular_drag_nm_s_rad: f64,
}

/// What is integrated: pose, forward speed of the axle midpoint and yaw rate.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NoSlipState {
    /// Pose of the drive-axle midpoint.
    pub pose: Pose,
    /// Forward speed of the axle midpoint, m/s.
    pub speed_m_s: f64,
    /// Yaw rate, rad/s.
    pub yaw_rate_rad_s: f64,
}

impl NoSlipParams {
    /// Wheel angular speeds (left, right) that roll without slip at this motion, rad/s.
    pub fn wheel_speeds_rad_s(&self, s: &NoSlipState) -> [f64; 2] {
        let h = 0.5 * self.chassis.track_width_m;
        let r = self.wheel_radii_m;
        [
            (s.speed_m_s - h * s.yaw_rate_rad_s) / r[0],
            (s.speed_m_s + h * s.yaw_rate_rad_s) / r[1],
        ]
    }

    /// One sub-step under the wheel torques (N m, left and right, from the gear teeth).
    /// Differential-drive dynamics with the CG a distance `a` ahead of the axle:
    /// `m_eff dv/dt = F + m a w^2`, `I_eff dw/dt = M - m a v w`, the wheel inertias folded
    /// into the effective mass and inertia since the wheels cannot slip.
    pub fn step(&self, s: &mut NoSlipState, wheel_torque_nm: [f64; 2], h: f64) {
        let c = &self.chassis;
        let body = self.body();
        let a = c.cg_m[0];
        let (m_eff, i_eff) = body.effective_inertias();
        let [force, moment] = body.wheel_force_and_moment(wheel_torque_nm);
        let (v, w) = (s.speed_m_s, s.yaw_rate_rad_s);
        // Drag implicit, so a large lumped drag cannot destabilise the step.
        let v_new = (v + h * (force + c.mass_kg * a * w * w) / m_eff)
            / (1.0 + h * self.linear_drag_n_s_m / m_eff);
        let w_new = (w + h * (moment - c.mass_kg * a * v * w) / i_eff)
            / (1.0 + h * self.angular_drag_nm_s_rad / i_eff);
        s.speed_m_s = v_new;
        s.yaw_rate_rad_s = w_new;
        // Midpoint heading for the position update keeps arcs on their circle.
        let mid = s.pose.heading_rad + 0.5 * h * w_new;
        s.pose.x_m += h * v_new * mid.cos();
        s.pose.y_m += h * v_new * mid.sin();
        s.pose.heading_rad += h * w_new;
    }
}

impl NoSlipParams {
    /// The rolling body these parameters describe.
    pub fn body(&self) -> NoSlipBody {
        let c = &self.chassis;
        NoSlipBody {
            mass_kg: c.mass_kg,
            yaw_inertia_kg_m2: c.yaw_inertia_kg_m2,
            cg_ahead_m: c.cg_m[0],
            track_width_m: c.track_width_m,
            wheel_radii_m: self.wheel_radii_m,
            wheel_inertia_kg_m2: self.wheel_inertia_kg_m2,
        }
    }
}

/// A differential-drive body whose wheels roll without slipping: the chassis and
/// everything that turns with each drive wheel, seen from the wheels' axles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoSlipBody {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Yaw inertia about the centre of gravity, kg m^2.
    pub yaw_inertia_kg_m2: f64,
    /// Centre of gravity ahead of the drive-axle midpoint, m.
    pub cg_ahead_m: f64,
    /// Distance between the drive wheels, m.
    pub track_width_m: f64,
    /// Drive wheels' effective rolling radii (left, right), m.
    pub wheel_radii_m: [f64; 2],
    /// Inertia turning with one drive wheel, referred to its axle, kg m^2 (the wheel, and
    /// through a rigid gear train the rotor times the ratio squared).
    pub wheel_inertia_kg_m2: f64,
}

impl NoSlipBody {
    /// Mass and yaw inertia about the axle midpoint with the wheels' inertia folded in
    /// (they cannot slip, so they turn with the body): kg and kg m^2.
    #[inline]
    pub fn effective_inertias(&self) -> (f64, f64) {
        let (r, half, a) = (
            self.wheel_radii_m,
            0.5 * self.track_width_m,
            self.cg_ahead_m,
        );
        let jw = self.wheel_inertia_kg_m2;
        let per_r2 = 1.0 / (r[0] * r[0]) + 1.0 / (r[1] * r[1]);
        let m_eff = self.mass_kg + jw * per_r2;
        let i_axle = self.yaw_inertia_kg_m2 + self.mass_kg * a * a;
        (m_eff, i_axle + jw * half * half * per_r2)
    }

    /// Forward force (N) and yaw moment (N m) of the wheel torques at the axles (left,
    /// right) on the body.
    #[inline]
    pub fn wheel_force_and_moment(&self, wheel_torque_nm: [f64; 2]) -> [f64; 2] {
        let r = self.wheel_radii_m;
        let f = [wheel_torque_nm[0] / r[0], wheel_torque_nm[1] / r[1]];
        [f[0] + f[1], (f[1] - f[0]) * 0.5 * self.track_width_m]
    }

    /// Forward acceleration of the axle midpoint (m/s^2) and yaw acceleration (rad/s^2) at
    /// forward speed `speed_m_s` and yaw rate `yaw_rate_rad_s`, under the wheel torques
    /// (left, right, N m at the axles) and an external forward force and yaw moment (drag:
    /// N, N m): `m_eff dv/dt = F + m a w^2`, `I_eff dw/dt = M - m a v w`.
    #[inline]
    pub fn accelerations(
        &self,
        speed_m_s: f64,
        yaw_rate_rad_s: f64,
        wheel_torque_nm: [f64; 2],
        external: [f64; 2],
    ) -> [f64; 2] {
        let (m_eff, i_eff) = self.effective_inertias();
        let [force, moment] = self.wheel_force_and_moment(wheel_torque_nm);
        let (v, w, ma) = (speed_m_s, yaw_rate_rad_s, self.mass_kg * self.cg_ahead_m);
        [
            (force + external[0] + ma * w * w) / m_eff,
            (moment + external[1] - ma * v * w) / i_eff,
        ]
    }

    /// Rim speeds of the left and right wheels at this motion, m/s (the no-slip constraint).
    #[inline]
    pub fn rim_speeds_m_s(&self, speed_m_s: f64, yaw_rate_rad_s: f64) -> [f64; 2] {
        let half = 0.5 * self.track_width_m;
        [
            speed_m_s - half * yaw_rate_rad_s,
            speed_m_s + half * yaw_rate_rad_s,
        ]
    }
}

/// The rolling law of a differential drive that does not slip: the distances its left and
/// right wheels roll, `rims` (m, each its turn times its effective rolling radius), move
/// the drive-axle midpoint `(l + r) / 2` forward and turn it `(r - l) / track` (rad). The
/// inverse of [`NoSlipBody::rim_speeds_m_s`]; what wheel odometry integrates.
#[inline]
pub fn rolling_motion(rims: [f64; 2], track_m: f64) -> (f64, f64) {
    (0.5 * (rims[0] + rims[1]), (rims[1] - rims[0]) / track_m)
}

/// An angle in (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut w = a % two_pi;
    if w > std::f64::consts::PI {
        w -= two_pi;
    } else if w <= -std::f64::consts::PI {
        w += two_pi;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(cg: [f64; 2]) -> LoadedChassis {
        LoadedChassis {
            mass_kg: 120.0,
            yaw_inertia_kg_m2: 14.0,
            cg_m: cg,
            track_width_m: 0.5,
            drive_load_fraction: 0.6,
            castor_front_x_m: 0.4,
            castor_rear_x_m: -0.35,
            castor_half_spacing_m: 0.24,
        }
    }

    #[test]
    fn static_loads_carry_the_weight_and_balance_the_moments() {
        let c = params([0.07, 0.03]);
        let l = c.normal_loads();
        let w = 120.0 * GRAVITY_M_S2;
        let total: f64 = l.drive_n.iter().chain(l.castor_n.iter()).sum();
        assert!((total - w).abs() < 1e-9);
        let mut mx = 0.0;
        let mut my = 0.0;
        for (p, f) in c.wheel_points_m().iter().zip(l.drive_n) {
            mx += p[0] * f;
            my += p[1] * f;
        }
        for (p, f) in c.castor_points_m().iter().zip(l.castor_n) {
            mx += p[0] * f;
            my += p[1] * f;
        }
        assert!((mx - w * 0.07).abs() < 1e-9 && (my - w * 0.03).abs() < 1e-9);
        assert!(l.castor_n.iter().all(|&f| f > 0.0));
    }
}
