//! The importers (`agvsim import ros2`, `agvsim import wpilib`) as the library runs them:
//! the command's own request builder from the arguments, each number checked and named
//! as Python passes it.

use std::path::PathBuf;

use pyo3::prelude::*;

use agvsim::commands;

use crate::{bad_argument, drive_of, failed, job, positive};

/// `agvsim import ros2 BAG --out OUT ...`.
#[pyfunction]
#[pyo3(signature = (bag, out, command, map=None, wheel_radius_m=None, track_m=None, mass_kg=None,
    controller_yaml=None, battery_v=None, motor_rated_v=None, motor_no_load_rpm=None,
    motor_stall_current_a=None, motor_stall_torque_nm=None, gear_ratio=None, backlash_rad=None))]
#[allow(clippy::too_many_arguments)]
pub fn import_ros2(
    py: Python<'_>,
    bag: PathBuf,
    out: PathBuf,
    command: String,
    map: Option<PathBuf>,
    wheel_radius_m: Option<f64>,
    track_m: Option<f64>,
    mass_kg: Option<f64>,
    controller_yaml: Option<PathBuf>,
    battery_v: Option<f64>,
    motor_rated_v: Option<f64>,
    motor_no_load_rpm: Option<f64>,
    motor_stall_current_a: Option<f64>,
    motor_stall_torque_nm: Option<f64>,
    gear_ratio: Option<f64>,
    backlash_rad: Option<f64>,
) -> PyResult<String> {
    let args = commands::import::Ros2Args {
        bag,
        map,
        out: Some(out),
        wheel_radius_m: positive("wheel_radius_m", wheel_radius_m)?,
        track_m: positive("track_m", track_m)?,
        mass_kg: positive("mass_kg", mass_kg)?,
        controller_yaml,
        drive: drive_of(
            battery_v,
            motor_rated_v,
            motor_no_load_rpm,
            motor_stall_current_a,
            motor_stall_torque_nm,
            gear_ratio,
            backlash_rad,
        )?,
    };
    let request = args.request(command).map_err(failed)?;
    job(py, false, move |say| commands::import::ros2(&request, say))
}

/// `agvsim import wpilib FILE --out OUT ...`.
#[pyfunction]
#[pyo3(signature = (file, out, routine=None, motors=vec![], mechanism=None, wheel_radius_m=None,
    resistance_ohm=None, track_width_m=None, supply_v=None))]
#[allow(clippy::too_many_arguments)]
pub fn import_wpilib(
    py: Python<'_>,
    file: PathBuf,
    out: PathBuf,
    routine: Option<String>,
    motors: Vec<String>,
    mechanism: Option<String>,
    wheel_radius_m: Option<f64>,
    resistance_ohm: Option<f64>,
    track_width_m: Option<f64>,
    supply_v: Option<f64>,
) -> PyResult<String> {
    let mechanism = mechanism
        .map(|m| {
            m.parse::<agvsim::import::wpilib::Mechanism>()
                .map_err(|e| bad_argument("mechanism", &m, &e))
        })
        .transpose()?;
    let request = commands::import::WpilibArgs {
        file,
        out: Some(out),
        routine,
        motors,
        mechanism,
        wheel_radius_m: positive("wheel_radius_m", wheel_radius_m)?,
        resistance_ohm: positive("resistance_ohm", resistance_ohm)?,
        track_width_m: positive("track_width_m", track_width_m)?,
        supply_v: positive("supply_v", supply_v)?,
    }
    .request();
    job(py, false, move |say| {
        commands::import::wpilib(&request, say)
    })
}
