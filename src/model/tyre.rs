#![allow(non_snake_case)]
//! Tyre force law: a bristle (brush) model with relaxation length, so that it is
//! well-behaved at zero and crawling speed.
//!
//! The contact patch carries a deflection `d` (m, wheel frame: x along the rolling
//! direction, y to the left). It grows with the patch's sliding velocity `s` and relaxes
//! over the relaxation length `sigma` as the wheel rolls:
//! `dd/dt = s - |V| d / sigma`, with `|V| = max(|v_x|, |w r|)`.
//! The ground pushes the wheel with `F = -(k d + c dd/dt)`, `k = C / sigma` where C is the
//! slip stiffness (proportional to the normal load). In steady rolling this gives
//! `F = C * slip` (slip ratio and slip angle); at standstill the bristles are a damped
//! spring, so a parked wheel holds instead of chattering between signs. The force is
//! limited to a friction circle `mu(|s|) Fz`, where mu falls from its peak to the sliding
//! value as the sliding speed grows (the Stribeck drop that makes a spinning wheel keep
//! spinning: "the spinning wheels have less tractive effort").

use super::tyre_presets::{self, Compound, Surface};

/// What `tyre.compound` takes.
fn compound_choice() -> String {
    format!("one of {}", tyre_presets::compound_names())
}

crate::declare_params! {
    /// The drive tyres (scene section `[tyre]`): a named compound, whose values on each
    /// floor surface come from the presets (`agvsim presets`), and any value overriding
    /// the preset.
    #[derive(Debug, Clone, PartialEq)]
    pub struct TyreChoice in "tyre" {
        /// The tread compound: `hard_polyurethane`, `soft_rubber` or `high_grip` (an
        /// idealised no-slip tyre); see `agvsim presets`.
        compound: String = "hard_polyurethane".into(), "", other(compound_choice);
        /// Peak (static) friction coefficient; overrides the preset (the sliding
        /// friction keeps the preset's ratio to it).
        peak_mu: Option<f64> = None, "", Positive, unset "the compound's on the floor";
        /// Sliding friction as a fraction of the peak; overrides the preset.
        sliding_ratio: Option<f64> = None, "", open_closed(0.0, 1.0), unset "the compound's";
        /// Longitudinal slip stiffness per newton of load (N per unit slip ratio per N);
        /// overrides the preset.
        long_stiffness_per_n as "long_stiffness_per_N": Option<f64> = None, "1/N per unit slip", Positive, unset "the compound's";
        /// Cornering stiffness per newton of load (N per rad of slip angle per N);
        /// overrides the preset.
        lat_stiffness_per_n as "lat_stiffness_per_N": Option<f64> = None, "1/rad", Positive, unset "the compound's";
        /// Relaxation length; overrides the preset.
        relaxation_length_m: Option<f64> = None, "m", Positive, unset "the compound's";
    }
}

impl TyreChoice {
    /// The tyre's law on a surface: the compound's preset there, then each override.
    /// `None` for a compound that is not a preset.
    pub fn on(&self, surface: &Surface) -> Option<TyreParams> {
        Some(self.law(tyre_presets::compound(&self.compound)?, surface))
    }

    /// The tyre's law for a compound (this choice's, looked up once) on a surface: the
    /// preset, then each override.
    pub fn law(&self, compound: &Compound, surface: &Surface) -> TyreParams {
        let mut t = TyreParams::of(compound, surface);
        if let Some(mu) = self.peak_mu {
            let ratio = t.sliding_mu / t.peak_mu;
            t.peak_mu = mu;
            t.sliding_mu = mu * ratio;
        }
        if let Some(r) = self.sliding_ratio {
            t.sliding_mu = t.peak_mu * r;
        }
        if let Some(v) = self.long_stiffness_per_n {
            t.long_stiffness_per_N = v;
        }
        if let Some(v) = self.lat_stiffness_per_n {
            t.lat_stiffness_per_N = v;
        }
        if let Some(v) = self.relaxation_length_m {
            t.relaxation_length_m = v;
        }
        t
    }
}

/// Tyre parameters on a given floor (compound x surface, see `tyre_presets`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TyreParams {
    /// Peak (static) friction coefficient.
    pub peak_mu: f64,
    /// Friction coefficient at full sliding.
    pub sliding_mu: f64,
    /// Sliding speed over which friction falls from peak to sliding, m/s.
    pub stribeck_speed_m_s: f64,
    /// Longitudinal slip stiffness per newton of normal load (per unit slip ratio).
    pub long_stiffness_per_N: f64,
    /// Cornering stiffness per newton of normal load (per rad of slip angle).
    pub lat_stiffness_per_N: f64,
    /// Relaxation length, m.
    pub relaxation_length_m: f64,
    /// Damping ratio of the bristle spring against the mass it carries.
    pub damping_ratio: f64,
}

/// What is integrated: the contact-patch deflection, m (wheel frame).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TyreState {
    /// Deflection along the rolling direction and to the left, m.
    pub deflection_m: [f64; 2],
}

/// Motion of the wheel centre over the ground, in the wheel frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactKinematics {
    /// Wheel-centre velocity along the wheel's rolling direction, m/s.
    pub forward_m_s: f64,
    /// Wheel-centre velocity to the wheel's left, m/s.
    pub lateral_m_s: f64,
    /// Rim speed `w r`, m/s (zero for a wheel that is not driven... or free-rolling: pass forward_m_s).
    pub rim_m_s: f64,
}

/// Force and slip measures of one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TyreOutput {
    /// Force of the ground on the wheel, wheel frame, N.
    pub force_n: [f64; 2],
    /// Slip ratio `(w r - v_x) / max(|w r|, |v_x|)`, 0 at standstill.
    pub slip_ratio: f64,
    /// Slip angle, rad (positive when the wheel centre moves to the left of its heading).
    pub slip_angle_rad: f64,
    /// The friction limit is active.
    pub sliding: bool,
}

/// A tyre's bristles at one normal load: stiffness and damping (x, y), N/m and N s/m
/// ([`TyreParams::bristle_stiffness_n_m`], [`TyreParams::bristle_damping_n_s_m`]), worked
/// out once where the load stays (the reduced base's wheels) instead of at every sub-step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bristles {
    /// Stiffness (x, y), N/m.
    pub stiffness_n_m: [f64; 2],
    /// Damping (x, y), N s/m.
    pub damping_n_s_m: [f64; 2],
}

/// Below this speed, slip measures are reported as zero (m/s).
const SLIP_REPORT_FLOOR_M_S: f64 = 1e-3;

impl TyreParams {
    /// A compound on a surface: the compound's friction scaled by the surface's, its
    /// stiffnesses per newton of load (the law scales them with the normal load) and
    /// relaxation length.
    pub fn of(c: &Compound, s: &Surface) -> TyreParams {
        TyreParams {
            peak_mu: c.peak_mu_on_bare_concrete * s.friction_factor,
            sliding_mu: c.peak_mu_on_bare_concrete * s.friction_factor * c.sliding_ratio,
            stribeck_speed_m_s: 0.05,
            long_stiffness_per_N: c.long_stiffness_per_N,
            lat_stiffness_per_N: c.lat_stiffness_per_N,
            relaxation_length_m: c.relaxation_length_m,
            damping_ratio: 0.3,
        }
    }

    /// Friction coefficient at a sliding speed.
    pub fn mu_at(&self, sliding_speed_m_s: f64) -> f64 {
        let r = sliding_speed_m_s / self.stribeck_speed_m_s;
        self.sliding_mu + (self.peak_mu - self.sliding_mu) * (-r * r).exp()
    }

    /// Bristle stiffness (x, y) at a normal load, N/m.
    pub fn bristle_stiffness_n_m(&self, normal_load_n: f64) -> [f64; 2] {
        [
            self.long_stiffness_per_N * normal_load_n / self.relaxation_length_m,
            self.lat_stiffness_per_N * normal_load_n / self.relaxation_length_m,
        ]
    }

    /// Bristle damping (x, y) at a normal load, N s/m: the damping ratio against the mass
    /// the wheel carries.
    pub fn bristle_damping_n_s_m(&self, normal_load_n: f64) -> [f64; 2] {
        let m = normal_load_n / crate::model::GRAVITY_M_S2;
        let k = self.bristle_stiffness_n_m(normal_load_n);
        [
            2.0 * self.damping_ratio * (k[0] * m).sqrt(),
            2.0 * self.damping_ratio * (k[1] * m).sqrt(),
        ]
    }

    /// Slip ratio at which the linear range meets the peak friction (the tyre's peak slip).
    pub fn peak_slip_ratio(&self) -> f64 {
        self.peak_mu / self.long_stiffness_per_N
    }

    /// Advances the patch deflection by `h` and returns the force on the wheel with the
    /// slip measures of `kin`.
    pub fn step(
        &self,
        s: &mut TyreState,
        kin: ContactKinematics,
        normal_load_n: f64,
        h: f64,
    ) -> TyreOutput {
        let out = self.step_force(s, kin, normal_load_n, h);
        if normal_load_n <= 0.0 {
            return out;
        }
        let (slip_ratio, slip_angle_rad) = slip_measures(kin);
        TyreOutput {
            slip_ratio,
            slip_angle_rad,
            ..out
        }
    }

    /// [`Self::step`] without the slip measures (left zero): for sub-steps whose slip is
    /// reported only once, after the last of them (the slip angle costs an `atan2`).
    pub fn step_force(
        &self,
        s: &mut TyreState,
        kin: ContactKinematics,
        normal_load_n: f64,
        h: f64,
    ) -> TyreOutput {
        self.step_force_with(s, kin, normal_load_n, self.bristles(normal_load_n), h)
    }

    /// The bristles at a normal load, N.
    pub fn bristles(&self, normal_load_n: f64) -> Bristles {
        Bristles {
            stiffness_n_m: self.bristle_stiffness_n_m(normal_load_n),
            damping_n_s_m: self.bristle_damping_n_s_m(normal_load_n),
        }
    }

    /// [`Self::step_force`] with the bristles at `normal_load_n` given
    /// ([`Self::bristles`]).
    pub fn step_force_with(
        &self,
        s: &mut TyreState,
        kin: ContactKinematics,
        normal_load_n: f64,
        bristles: Bristles,
        h: f64,
    ) -> TyreOutput {
        if normal_load_n <= 0.0 {
            s.deflection_m = [0.0, 0.0];
            return TyreOutput::default();
        }
        let slide = [kin.forward_m_s - kin.rim_m_s, kin.lateral_m_s];
        let speed = kin.forward_m_s.abs().max(kin.rim_m_s.abs());
        let (k, c) = (bristles.stiffness_n_m, bristles.damping_n_s_m);
        // Implicit in the relaxation term: stable however fast the wheel rolls.
        let relax = 1.0 + h * speed / self.relaxation_length_m;
        let mut d = [0.0; 2];
        let mut f = [0.0; 2];
        for i in 0..2 {
            d[i] = (s.deflection_m[i] + h * slide[i]) / relax;
            let rate = (d[i] - s.deflection_m[i]) / h;
            f[i] = -(k[i] * d[i] + c[i] * rate);
        }
        // The friction coefficient lies between the peak and the sliding one at any
        // speed: below the lower of the two the bristles hold, and neither the sliding
        // speed nor the Stribeck curve's exponential need be worked out (most sub-steps of
        // a rolling wheel; compared squared, so that no root is taken either).
        let mag_sq = f[0] * f[0] + f[1] * f[1];
        let hold_n = self.peak_mu.min(self.sliding_mu) * normal_load_n;
        let mut sliding = false;
        if mag_sq > hold_n * hold_n {
            let sliding_speed = (slide[0] * slide[0] + slide[1] * slide[1]).sqrt();
            let limit = self.mu_at(sliding_speed) * normal_load_n;
            let mag = mag_sq.sqrt();
            sliding = mag > limit;
            if sliding {
                // On the friction circle the bristles carry exactly the friction force.
                let scale = limit / mag;
                for i in 0..2 {
                    f[i] *= scale;
                    d[i] = -f[i] / k[i];
                }
            }
        }
        s.deflection_m = d;
        TyreOutput {
            force_n: f,
            slip_ratio: 0.0,
            slip_angle_rad: 0.0,
            sliding,
        }
    }
}

/// Slip ratio `(w r - v_x) / max(|w r|, |v_x|)` and slip angle (rad) of a wheel's motion;
/// both zero below 1 mm/s, where they mean nothing.
pub fn slip_measures(kin: ContactKinematics) -> (f64, f64) {
    let speed = kin.forward_m_s.abs().max(kin.rim_m_s.abs());
    if speed < SLIP_REPORT_FLOOR_M_S {
        (0.0, 0.0)
    } else {
        (
            (kin.rim_m_s - kin.forward_m_s) / speed,
            kin.lateral_m_s
                .atan2(kin.forward_m_s.abs().max(SLIP_REPORT_FLOOR_M_S)),
        )
    }
}

/// Steady-state (relaxation-free) tyre force of the whole-vehicle identification model, N,
/// wheel frame: `F_lin = C N slip` per direction, with slip measured against
/// `sqrt(v_x^2 + v_floor^2)` so that it stays finite at standstill, and, when a friction
/// limit is given, the combined demand `q = |F_lin| / (mu N)` mapped through the smooth
/// saturation `sin(c atan(q / c)) / q` (a magic-formula shape: linear at small demand,
/// exactly `mu N` at the peak, falling beyond it). Smooth, so a fit can differentiate it;
/// the bristle model above is the simulator's transient version of the same law.
pub fn steady_slip_force(
    kin: ContactKinematics,
    normal_load_n: f64,
    stiffness_per_n: [f64; 2],
    speed_floor_m_s: f64,
    peak_mu: Option<f64>,
) -> [f64; 2] {
    // sqrt rather than hypot: the arguments are speeds, far from overflow, and this sits
    // in the innermost loop of identification.
    let denom = (kin.forward_m_s * kin.forward_m_s + speed_floor_m_s * speed_floor_m_s).sqrt();
    let slip = [
        (kin.rim_m_s - kin.forward_m_s) / denom,
        -kin.lateral_m_s / denom,
    ];
    let f = [
        stiffness_per_n[0] * normal_load_n * slip[0],
        stiffness_per_n[1] * normal_load_n * slip[1],
    ];
    match peak_mu {
        None => f,
        Some(mu) => {
            let q = (f[0] * f[0] + f[1] * f[1]).sqrt() / (mu * normal_load_n).max(1e-12);
            [f[0] * friction_saturation(q), f[1] * friction_saturation(q)]
        }
    }
}

/// Shape factor of the saturation (between Pacejka's typical longitudinal 1.65 and lateral
/// 1.3): the force beyond the peak falls to `sin(c pi / 2)` of it.
pub const SATURATION_SHAPE: f64 = 1.5;

/// `sin(c atan(q / c)) / q`: 1 at small demand, `1 / q` at the peak.
pub fn friction_saturation(q: f64) -> f64 {
    if q < 1e-6 {
        1.0
    } else {
        (SATURATION_SHAPE * (q / SATURATION_SHAPE).atan()).sin() / q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tyre() -> TyreParams {
        TyreParams {
            peak_mu: 0.5,
            sliding_mu: 0.35,
            stribeck_speed_m_s: 0.05,
            long_stiffness_per_N: 20.0,
            lat_stiffness_per_N: 15.0,
            relaxation_length_m: 0.01,
            damping_ratio: 0.0,
        }
    }

    fn settle(t: &TyreParams, kin: ContactKinematics, fz: f64) -> TyreOutput {
        let mut s = TyreState::default();
        let mut out = TyreOutput::default();
        for _ in 0..20000 {
            out = t.step(&mut s, kin, fz, 1e-4);
        }
        out
    }

    #[test]
    fn steady_small_slip_gives_slip_stiffness_times_slip() {
        let t = tyre();
        // 1 % traction slip at 0.5 m/s: F = C kappa = 20 * 300 * 0.01 = 60 N.
        let out = settle(
            &t,
            ContactKinematics {
                forward_m_s: 0.5,
                lateral_m_s: 0.0,
                rim_m_s: 0.5 / 0.99,
            },
            300.0,
        );
        let kappa = 1.0 - 0.99;
        assert!((out.slip_ratio - kappa).abs() < 1e-9);
        assert!(
            (out.force_n[0] - 20.0 * 300.0 * kappa).abs() < 0.5,
            "{:?}",
            out
        );
        assert!(!out.sliding);
    }

    #[test]
    fn spinning_wheel_is_limited_to_sliding_friction() {
        let t = tyre();
        let out = settle(
            &t,
            ContactKinematics {
                forward_m_s: 0.0,
                lateral_m_s: 0.0,
                rim_m_s: 1.0,
            },
            300.0,
        );
        assert!(out.sliding);
        assert!((out.force_n[0] - 0.35 * 300.0).abs() < 1e-6);
        assert!((out.slip_ratio - 1.0).abs() < 1e-12);
    }

    #[test]
    fn standstill_is_a_spring_not_a_singularity() {
        let t = tyre();
        let mut s = TyreState {
            deflection_m: [-1e-5, 0.0],
        };
        let out = t.step(&mut s, ContactKinematics::default(), 300.0, 1e-3);
        assert!(out.force_n[0].is_finite() && out.force_n[0] > 0.0);
        assert_eq!(out.slip_ratio, 0.0);
    }

    #[test]
    fn steady_force_is_linear_at_small_slip_and_peaks_at_mu_n() {
        let kin = |rim: f64| ContactKinematics {
            forward_m_s: 1.0,
            lateral_m_s: 0.0,
            rim_m_s: rim,
        };
        let floor = 0.2;
        let denom = 1.0f64.hypot(floor);
        // 0.1 % slip: linear, C N slip.
        let f = steady_slip_force(kin(1.001), 500.0, [30.0, 25.0], floor, Some(0.6));
        let lin = 30.0 * 500.0 * 0.001 / denom;
        assert!((f[0] - lin).abs() < 1e-3 * lin, "{f:?} vs {lin}");
        // Over all slips the force never exceeds mu N, and reaches it.
        let peak = (0..4000)
            .map(|i| {
                steady_slip_force(
                    kin(1.0 + i as f64 * 1e-3),
                    500.0,
                    [30.0, 25.0],
                    floor,
                    Some(0.6),
                )[0]
            })
            .fold(0.0, f64::max);
        assert!(
            peak <= 0.6 * 500.0 + 1e-9 && peak > 0.6 * 500.0 * 0.999,
            "{peak}"
        );
        // Without a limit the law stays linear.
        let f = steady_slip_force(kin(2.0), 500.0, [30.0, 25.0], floor, None);
        assert!((f[0] - 30.0 * 500.0 / denom).abs() < 1e-9);
    }

    #[test]
    fn combined_slip_stays_inside_the_friction_circle() {
        let t = tyre();
        let out = settle(
            &t,
            ContactKinematics {
                forward_m_s: 0.5,
                lateral_m_s: 0.3,
                rim_m_s: 1.5,
            },
            300.0,
        );
        let mag = out.force_n[0].hypot(out.force_n[1]);
        assert!(mag <= t.peak_mu * 300.0 + 1e-9);
        assert!(out.force_n[1] < 0.0, "lateral force opposes lateral motion");
    }
}
