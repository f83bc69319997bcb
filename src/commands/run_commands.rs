//! A commands file's run (`manoeuvre.kind = "commands"`): how long it lasts and what is
//! said of it. The file's times are the run's (from 0 s); each row's command is held to the
//! next and the last for `manoeuvre.rest_s`. A scene's `sim.duration_s` is written for the
//! square (`agvsim new`), so a commands run lasts its file's span plus the rest unless
//! `--duration` (or `--set sim.duration_s=`) gives a length; then what that length holds
//! or cuts is said. Commands above the base's top speed are said too: the wheels saturate.

use std::fmt::Write as _;
use std::path::Path;

use super::CommandError;
use crate::param::plain_number;
use crate::scene::Scene;

/// One command row: time, s; forward speed, m/s; yaw rate, rad/s.
pub type CommandRow = (f64, f64, f64);

/// Sets the run's length to the commands' (unless `length_given`) and returns the lines to
/// say before the run; an error naming `file` where no run can follow them.
pub fn fit_run_to_commands(
    scene: &mut Scene,
    rows: &[CommandRow],
    file: &Path,
    length_given: bool,
) -> Result<String, CommandError> {
    let refuse = |message: String| CommandError::Option {
        option: "manoeuvre.commands".into(),
        value: format!("= {}", file.display()),
        message,
    };
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return Err(refuse(
            "no row gives both cmd_linear_m_s and cmd_angular_rad_s".into(),
        ));
    };
    let sim = &mut scene.sim;
    let mut said = String::new();
    let n = rows.len();
    let name = file.display();
    if !length_given {
        let end_s = last.0 + scene.manoeuvre.rest_s;
        let steps = end_s / sim.dt_s;
        if steps > sim.max_steps as f64 {
            return Err(refuse(format!(
                "its commands run from {} s to {} s: a run to them would take {steps:.3e} physics steps, more than sim.max_steps = {}; a commands file's times are the run's, from 0 s (subtract the first row's time), or raise sim.max_steps if the length is meant",
                plain_number(first.0),
                plain_number(last.0),
                sim.max_steps
            )));
        }
        let _ = writeln!(
            said,
            "commands   {n} rows from {name}, {} to {} s: the run lasts to {} s, the last command held for manoeuvre.rest_s (sim.duration_s = {} s is not used; --duration sets a length)",
            plain_number(first.0),
            plain_number(last.0),
            plain_number(end_s),
            plain_number(sim.duration_s)
        );
        sim.duration_s = end_s;
    } else {
        let end_s = sim.duration_s;
        if first.0 >= end_s {
            return Err(refuse(format!(
                "its first command is at {} s, at or after the run's end ({} s, sim.duration_s): nothing would be commanded; a commands file's times are the run's, from 0 s",
                plain_number(first.0),
                plain_number(end_s)
            )));
        }
        let cut = rows.iter().filter(|r| r.0 >= end_s).count();
        let _ = if cut > 0 {
            writeln!(
                said,
                "commands   {n} rows from {name}: the last {cut} (from {} s on) are not run, the run ends at {} s (sim.duration_s)",
                plain_number(rows[n - cut].0),
                plain_number(end_s)
            )
        } else {
            writeln!(
                said,
                "commands   {n} rows from {name}: the last ({} m/s, {} rad/s at {} s) is held to the run's end at {} s (sim.duration_s)",
                plain_number(last.1),
                plain_number(last.2),
                plain_number(last.0),
                plain_number(end_s)
            )
        };
    }
    if first.0 > 0.0 {
        let _ = writeln!(
            said,
            "commands   the base rests until the first command at {} s",
            plain_number(first.0)
        );
    }
    said.push_str(&saturation_note(scene, rows));
    Ok(said)
}

/// A warning when a row asks a wheel for more than the base's top speed (the faster
/// wheel's speed is the forward speed plus the yaw rate times half the track): the wheels
/// saturate at what the motors give, so the base does not follow that row.
fn saturation_note(scene: &Scene, rows: &[CommandRow]) -> String {
    let top_m_s = scene.top_speed_m_s(scene.battery.drive_limit_v);
    let half_track_m = 0.5 * scene.chassis.track_width_m;
    let wheel_m_s = |r: &CommandRow| r.1.abs() + r.2.abs() * half_track_m;
    let Some(worst) = rows
        .iter()
        .max_by(|a, b| wheel_m_s(a).total_cmp(&wheel_m_s(b)))
    else {
        return String::new();
    };
    let over = rows.iter().filter(|r| wheel_m_s(r) > top_m_s).count();
    if over == 0 {
        return String::new();
    }
    format!(
        "warning: {over} of {} command rows ask a wheel for more than the base's top speed {} m/s (at most {} m/s: {} m/s and {} rad/s at {} s); the wheels saturate there and the base does not follow them\n",
        rows.len(),
        crate::numtext::sig(top_m_s, 3),
        crate::numtext::sig(wheel_m_s(worst), 4),
        plain_number(worst.1),
        plain_number(worst.2),
        plain_number(worst.0)
    )
}

/// Refuses a square or circle the base cannot drive: a straight, a turn on the spot or the
/// circle's outer wheel faster than the base's top speed (the motors' no-load speed at the
/// drive limit). Such a shape would not be driven as asked, and a speed past any motor's
/// (1e300 m/s) drives nothing at all.
pub fn check_shape_speeds(scene: &Scene) -> Result<(), CommandError> {
    use crate::model::manoeuvre::ManoeuvreParams as M;
    let m = &scene.manoeuvre;
    if m.kind == "commands" {
        return Ok(());
    }
    let top_m_s = scene.top_speed_m_s(scene.battery.drive_limit_v);
    let half_track_m = 0.5 * scene.chassis.track_width_m;
    let straight = (
        M::speed_m_s.key(),
        m.speed_m_s,
        m.speed_m_s,
        "m/s",
        "the straights' speed",
    );
    // The square's other limit is a turn on the spot, the circle's its outer wheel.
    let other = if m.kind == "circle" {
        (
            M::speed_m_s.key(),
            m.speed_m_s,
            m.speed_m_s * (1.0 + half_track_m / m.radius_m),
            "m/s",
            "the outer wheel's speed on the circle",
        )
    } else {
        (
            M::turn_rate_rad_s.key(),
            m.turn_rate_rad_s,
            m.turn_rate_rad_s * half_track_m,
            "rad/s",
            "each wheel's speed turning on the spot",
        )
    };
    for (key, value, wheel_m_s, unit, what) in [straight, other] {
        if !(wheel_m_s <= top_m_s) {
            return Err(CommandError::Option {
                option: key.to_string(),
                value: format!("= {} {unit}", plain_number(value)),
                message: format!(
                    "{what} would be {} m/s, above the base's top speed {} m/s (the motors' no-load speed at the drive limit {} V): the base cannot drive this {}; lower it",
                    crate::numtext::sig(wheel_m_s, 4),
                    crate::numtext::sig(top_m_s, 3),
                    scene.battery.drive_limit_v,
                    m.kind
                ),
            });
        }
    }
    Ok(())
}
