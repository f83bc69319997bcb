//! The physical blocks of the AGV, free of rapier, files and the CLI. Each has its
//! parameters (immutable during a run), its state (what is integrated) and a step or a
//! force law that can be tested alone. Block diagram order:
//! battery -> DCMC -> motor -> gearbox (backlash) -> wheel/tyre -> chassis.

pub mod battery;
pub mod castor;
pub mod chassis;
pub mod dcmc;
pub mod drivetrain;
pub mod gearbox;
pub mod motor;
pub mod speed_loop;
pub mod tyre;
pub mod tyre_presets;
pub mod wheel;

/// Standard gravity, m/s^2.
pub const GRAVITY_M_S2: f64 = 9.81;
