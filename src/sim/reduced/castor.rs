//! A castor of the reduced base: a massless trailing wheel on its tyre's bristles.
//!
//! Trailing, the castor turns so that its patch, `t` behind its swivel, slides neither way,
//! `dphi/dt = (v_s . n) / t - r` (`v_s` its swivel's velocity, `n` its wheel's left, `r`
//! the chassis's yaw rate), and the floor turns it against its swivel friction `T_s` with
//! a side force `T_s / t` (within the castor tyre's grip; smoothed through rest).
//!
//! Held by its swivel friction, the castor turns with the chassis and its patch creeps
//! sideways at `v_p = v_s . n - t r`; the tyre's bristles take that up as a deflection `d`
//! (m) with the simulator's bristle law, `dd/dt = v_p - |v_a| d / L` (`v_a` the speed along
//! the wheel, `L` the tyre's relaxation length), integrated implicitly over a sub-step `h`
//! (`d (1 + h |v_a| / L) = d_0 + h v_p`), and push the chassis with `-k d` (`k = C N / L`,
//! N/m: the castor tyre's cornering stiffness per newton `C` at its load `N`). Once that
//! push reaches the trailing law's side force the castor breaks away and trails; it trails
//! until it is in line (its swivel rate under [`IN_LINE_RAD_S`]), where the swivel holds
//! it again with its bristles unloaded. Along its wheel it drags with its
//! rolling resistance ([`rolling_drag_n`]).
//!
//! Why the bristles: the simulator's castors are bodies on the same tyres, and on a light
//! robot (OptiOdom's 1 kg, 1.3 N on a castor, `k` = 260 N/m) their side force takes about
//! 0.2 s to build as the patch creeps at a few mm/s. A castor that pushed the full `T_s / t`
//! at once turned the reduced base late at every corner of a square run (its heading fell
//! 0.05 rad behind the simulator's per corner).

use crate::model::castor::rolling_drag_n;

/// Speed over which a castor's rolling drag is smoothed through rest, m/s (the
/// simulator's castors use the same).
const DRAG_SMOOTHING_M_S: f64 = 0.005;

/// Swivel rate over which a castor's swivel friction is smoothed through rest, rad/s.
const SWIVEL_SMOOTHING_RAD_S: f64 = 0.05;

/// Swivel rate under which a trailing castor is in line and its swivel holds it, rad/s.
/// Well under the friction's smoothing: the swivel takes hold only of a castor that has
/// all but stopped turning.
pub const IN_LINE_RAD_S: f64 = 1e-3;

/// What a castor is, worked out once from the scene.
#[derive(Clone, Copy, Debug)]
pub struct CastorLaw {
    /// Rolling drag along the wheel, N.
    pub drag_n: f64,
    /// Side force that turns it against its swivel friction, `T_s / t` within its tyre's
    /// grip, N.
    pub side_n: f64,
    /// Trail of the patch behind the swivel, m.
    pub trail_m: f64,
    /// Lateral stiffness of its tyre's bristles at its load, `C N / L`, N/m.
    pub bristle_n_m: f64,
    /// Its tyre's relaxation length, m.
    pub relaxation_m: f64,
}

/// A castor's state.
#[derive(Clone, Copy, Debug)]
pub struct CastorState {
    /// The wheel's heading against the chassis, as its cosine and sine (1, 0: trailing
    /// straight).
    pub heading: [f64; 2],
    /// The bristles' lateral deflection, m (to the wheel's left).
    pub bristle_m: f64,
    /// Whether the castor trails (turns on its swivel) rather than being held by it.
    pub trailing: bool,
}

impl CastorState {
    /// A castor at rest, held, at `angle_rad` against the chassis.
    pub fn at_rest(angle_rad: f64) -> CastorState {
        let (s, c) = angle_rad.sin_cos();
        CastorState {
            heading: [c, s],
            bristle_m: 0.0,
            trailing: false,
        }
    }
}

impl CastorLaw {
    /// The castor's force on the chassis at its swivel (body frame, N) over a sub-step `h`
    /// (s), with its swivel moving at `pivot_m_s` (body frame) and the chassis yawing at
    /// `yaw_rate_rad_s`; returns the castor's swivel rate against the chassis too (rad/s),
    /// by which its heading turns over the sub-step.
    pub fn force(
        &self,
        state: &mut CastorState,
        pivot_m_s: [f64; 2],
        yaw_rate_rad_s: f64,
        h: f64,
    ) -> ([f64; 2], f64) {
        let [c, s] = state.heading;
        let along = pivot_m_s[0] * c + pivot_m_s[1] * s;
        let across = -pivot_m_s[0] * s + pivot_m_s[1] * c;
        // The swivel rate at which the patch slides neither way.
        let trailing_rate = across / self.trail_m - yaw_rate_rad_s;
        let [roll] = rolling_drag_n(self.drag_n, [along], DRAG_SMOOTHING_M_S);
        let [friction] = rolling_drag_n(self.side_n, [trailing_rate], SWIVEL_SMOOTHING_RAD_S);
        let (side, swivel_rate) = if state.trailing {
            state.trailing = trailing_rate.abs() >= IN_LINE_RAD_S;
            // In line, the swivel takes the castor back with its bristles unloaded: the
            // simulator's castors, their forks undamped on their tyres, shake the load off
            // as they settle. Held with its bristles at the edge of its friction band, a
            // castor would push that side force on into the straights.
            state.bristle_m = if state.trailing {
                -friction / self.bristle_n_m
            } else {
                0.0
            };
            (friction, trailing_rate)
        } else {
            let creep_m_s = self.trail_m * trailing_rate;
            let relax = 1.0 + h * along.abs() / self.relaxation_m;
            let d = (state.bristle_m + h * creep_m_s) / relax;
            let push = -self.bristle_n_m * d;
            if push.abs() >= friction.abs() && push * friction > 0.0 {
                state.trailing = true;
                state.bristle_m = -friction / self.bristle_n_m;
                (friction, trailing_rate)
            } else {
                state.bristle_m = d;
                (push, 0.0)
            }
        };
        state.heading = super::body::turned([c, s], h * swivel_rate);
        ([roll * c - side * s, roll * s + side * c], swivel_rate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// OptiOdom's castor: 1.3 N on it, `T_s / t` 0.25 N, 1 cm trail, the castor tyre's
    /// `C` = 6 per newton over `L` = 0.03 m.
    fn light() -> CastorLaw {
        CastorLaw {
            drag_n: 0.02,
            side_n: 0.25,
            trail_m: 0.01,
            bristle_n_m: 6.0 * 1.3 / 0.03,
            relaxation_m: 0.03,
        }
    }

    /// Rolling straight on at `v_a` with the swivel moving sideways at `v_p` from the
    /// start, a held castor breaks away when its bristles' push reaches the side force:
    /// `d(t) = v_p L / |v_a| (1 - exp(-|v_a| t / L))` reaches `F / k` at
    /// `t = -L / |v_a| ln(1 - F |v_a| / (k v_p L))`, within a step and a half.
    #[test]
    fn a_held_castor_breaks_away_when_its_bristles_carry_the_friction() {
        let law = light();
        let (v_a, v_p, h) = (0.1, 0.004, 1e-3);
        let mut state = CastorState::at_rest(0.0);
        let mut t = 0.0;
        let mut last_push = 0.0;
        while !state.trailing {
            let (f, rate) = law.force(&mut state, [v_a, v_p], 0.0, h);
            if !state.trailing {
                assert_eq!(rate, 0.0);
                last_push = f[1];
            }
            t += h;
            assert!(t < 2.0, "never broke away");
        }
        // The side force at breakaway: the friction at the trailing rate v_p / t.
        let rate = v_p / law.trail_m;
        let friction = law.side_n * rate / (rate * rate + 0.05f64.powi(2)).sqrt();
        let k = law.bristle_n_m;
        let expected =
            -law.relaxation_m / v_a * (1.0 - friction * v_a / (k * v_p * law.relaxation_m)).ln();
        assert!((t - expected).abs() < 1.5 * h, "{t} s against {expected} s");
        assert!(last_push < 0.0 && last_push.abs() < friction, "{last_push}");
    }

    /// A castor a radian out of line, trailing on a chassis rolling straight, turns into
    /// line; in line, its swivel holds it and it pushes next to no side force.
    #[test]
    fn a_castor_out_of_line_trails_into_line_and_rests_there() {
        let law = light();
        let mut state = CastorState::at_rest(1.0);
        state.trailing = true;
        let h = 1e-3;
        let (mut side, mut rate) = (f64::NAN, f64::NAN);
        for _ in 0..5000 {
            let (f, r) = law.force(&mut state, [0.1, 0.0], 0.0, h);
            side = f[1];
            rate = r;
        }
        assert!(!state.trailing && rate == 0.0, "{rate} rad/s");
        assert!(state.heading[1].abs() < 1e-3, "{:?}", state.heading);
        // Held, it rolls on at the slip angle it had when the swivel took it, under
        // `IN_LINE_RAD_S t / v_a`: its tyre's side force at that angle, `C N` times it.
        let slip_rad = IN_LINE_RAD_S * law.trail_m / 0.1;
        let cornering_n = law.bristle_n_m * law.relaxation_m;
        assert!(side.abs() <= cornering_n * slip_rad, "{side} N");
        assert!(side.abs() < 0.01 * law.side_n, "{side} N");
    }
}
