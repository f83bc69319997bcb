#![warn(missing_docs)]
//! # agvsim
//!
//! Simulates a wire-guided differential-drive AGV (the UOC AGV Mk II of a 1996 thesis)
//! with real physics, so that wheel slip and backlash-induced loss of traction emerge.
//!
//! The crate reads like the thesis's block diagram:
//!
//! - [`scene`]: the TOML scene schema, presets (tyre compounds, floors), validation.
//! - [`model`]: the physical blocks, free of rapier and I/O: battery, DCMC, motor,
//!   gearbox (backlash), drivetrain, tyre, chassis (loads, no-slip chassis).
//! - [`sensing`]: guide wire (parry2d), pick-up coils and ADC, bumper.
//! - [`firmware`]: the 80C552's fixed-point P-D law, sample and hold, PWM, Open Day.
//! - [`world`]: floor surfaces and the rapier engine (chassis and castor bodies).
//! - [`sim`]: `Sim::step` in a fixed order, fidelity levels, snapshots, metrics, and the
//!   plant's linearisation (controllability, observability).
//! - [`record`]: the exchange format for recordings; [`import`]: other formats into it;
//!   [`sysid`]: WPILib SysId's feedforward regression (kS, kV, kA, kG).
//! - [`viz`]: the Rerun recorder (an observer of snapshots).
//! - [`run`]: running a scene with its observers, as the CLI does; [`live`]: a scene's
//!   simulation held in memory and stepped from outside (Python's `agvsim.Sim`).
//! - [`experiment`], [`rig`], [`ident`], [`diagnose`]: the thesis's lab experiments,
//!   rig files, grey-box identification and the diagnosis of missing physics.
//! - [`sweep`], [`study`]: parallel parameter sweeps (shards, merge) and the shipped
//!   studies built on them.

pub mod batch;
pub mod calibrate;
pub mod commands;
pub mod diagnose;
pub mod experiment;
pub mod firmware;
pub mod html;
pub mod ident;
pub mod import;
pub mod jobs;
pub mod live;
pub mod matfile;
pub mod model;
pub mod numtext;
pub mod output;
pub mod param;
pub mod plot;
pub mod record;
pub mod replay;
pub mod rig;
pub mod run;
pub mod scene;
pub mod sensing;
pub mod shard;
pub mod sim;
pub mod study;
pub mod sweep;
pub mod sysid;
pub mod viz;
pub mod world;
