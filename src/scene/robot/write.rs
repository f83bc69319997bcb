//! Writing the scene `agvsim new` (and an import) makes: the derived values set on the
//! starting scene, the guidance, each key's note on where its number came from, the
//! commented TOML, and the check that it loads back as the same scene.

use super::*;

/// A velocity-commanded base: no firmware, its manoeuvre UMBmark's square at half its top
/// speed (0.1 to 0.5 m/s), the run as long as the manoeuvre.
pub(super) fn velocity_base(scene: &mut Scene, top_speed_m_s: f64) {
    scene.controller.kind = ControllerKind::Velocity;
    let speed = (0.5 * top_speed_m_s).clamp(0.1, 0.5);
    scene.manoeuvre = crate::model::manoeuvre::ManoeuvreParams {
        speed_m_s: round4(speed),
        ..Default::default()
    };
    scene.sim.duration_s = round4(scene.manoeuvre.duration_s());
}

/// Writes a new robot's scene: `base` (the thesis machine when `from` is `None`) with
/// the spec's numbers and every value derived from them, commented.
pub fn new_scene(
    spec: &RobotSpec,
    from: Option<(&Path, &Scene)>,
    command: &str,
) -> Result<NewScene, RobotError> {
    spec.check(from.is_some())?;
    let default = Scene::default();
    let base = from.map_or(&default, |(_, s)| s);
    let given = spec.given(from.is_some());
    let (n, notes) = spec.numbers(base);
    let derived: Vec<Derived> = derive(&n)
        .into_iter()
        .filter(|d| d.from.iter().any(|i| given.contains(i)))
        .collect();
    let mut scene = base.clone();
    for dv in &derived {
        keys::set_number(&mut scene, dv.key.key(), dv.value);
    }
    if let Some(t) = &spec.tyre {
        scene.tyre.compound = t.clone();
    }
    guide(&mut scene, spec.guidance, from.is_none());
    if spec.configured_geometry {
        scene.base.wheel_radius_m = Some(scene.wheel.radius_m);
        scene.base.wheel_separation_m = Some(scene.chassis.track_width_m);
    }
    scene.expect = Default::default();
    scene.description = spec.description.clone().unwrap_or_else(|| {
        format!(
            "A {} kg robot on a {} m track, {} m wheels, {} V, written by agvsim new",
            round4(n.mass_kg),
            round4(n.track_m),
            round4(n.wheel_radius_m),
            round4(n.battery_v)
        )
    });
    let notes_by_key = notes_by_key(spec, &scene, from.is_none());
    let text = render(
        &scene,
        &derived,
        &notes_by_key,
        from.map(|(p, _)| p),
        command,
    );
    let scene = checked(spec, &text, &derived)?;
    let top_speed_m_s = scene.top_speed_m_s(scene.battery.drive_limit_v);
    Ok(NewScene {
        text,
        scene,
        derived,
        top_speed_m_s,
        notes,
    })
}

/// Sets the scene's guidance: the wire's P-D firmware, open-loop demands, or a
/// velocity-commanded base (also where a new scene says none).
pub(super) fn guide(scene: &mut Scene, guidance: Option<Guidance>, new: bool) {
    let top_speed_m_s = scene.top_speed_m_s(scene.battery.drive_limit_v);
    match guidance {
        Some(Guidance::Wire) => scene.controller.kind = ControllerKind::Pd,
        Some(Guidance::OpenLoop) => {
            scene.controller.kind = ControllerKind::OpenLoop;
            scene.controller.open_loop_forward_pct = thesis::OPEN_LOOP_DEMAND_PCT;
        }
        Some(Guidance::None) => velocity_base(scene, top_speed_m_s),
        None if new => velocity_base(scene, top_speed_m_s),
        None => {}
    }
}

/// Where each key that is no derived number came from, for the scene's comments.
pub(super) fn notes_by_key(
    spec: &RobotSpec,
    scene: &Scene,
    new: bool,
) -> Vec<(&'static str, String)> {
    let mut notes_by_key: Vec<(&'static str, String)> = vec![(
        "description",
        if spec.description.is_some() {
            "given"
        } else {
            "from the numbers given"
        }
        .into(),
    )];
    if spec.tyre.is_some() {
        notes_by_key.push((
            TyreChoice::compound.key(),
            "given (`agvsim presets` lists its friction on each floor)".into(),
        ));
    } else if new {
        notes_by_key.push((
            TyreChoice::compound.key(),
            "not given: the thesis machine's (`agvsim presets`)".into(),
        ));
    }
    if spec.configured_geometry {
        let how = "the odometry's and the base controller's configured value: the drawing's; the wheels roll on their effective radii and track (`calibrate --effects wheel_geometry` finds them)";
        notes_by_key.push((BaseParams::wheel_radius_m.key(), how.into()));
        notes_by_key.push((BaseParams::wheel_separation_m.key(), how.into()));
    }
    if spec.guidance.is_some() || new {
        let how = match scene.controller.kind {
            ControllerKind::Pd => "guidance: the guide wire, the thesis's P-D firmware and gains",
            ControllerKind::Velocity => "guidance: none, a velocity-commanded base: its base controller and speed loops ([base]) drive the manoeuvre ([manoeuvre]) in `run`, a recording's cmd_vel in `replay`",
            _ => "guidance: open loop, so constant demands (replay drives it with a recording's commands instead)",
        };
        notes_by_key.push((ControllerParams::kind.key(), how.into()));
        if scene.controller.kind == ControllerKind::Velocity {
            notes_by_key.push((
                ManoeuvreParams::speed_m_s.key(),
                "half the top speed (at most 0.5 m/s): UMBmark's square of 1 m sides, a quarter turn on the spot at each corner".into(),
            ));
            notes_by_key.push((
                SimSettings::duration_s.key(),
                "the manoeuvre's length with a second's rest either side".into(),
            ));
            for (key, how) in [
                (
                    ManoeuvreParams::kind.key(),
                    "UMBmark's square (`circle`, or `commands` with a commands CSV)",
                ),
                (
                    ManoeuvreParams::turn_rate_rad_s.key(),
                    "a quarter turn on the spot at each corner at this rate",
                ),
                (ManoeuvreParams::side_m.key(), "the square's side"),
                (ManoeuvreParams::radius_m.key(), "a circle's radius"),
                (ManoeuvreParams::laps.key(), "once round"),
                (ManoeuvreParams::clockwise.key(), "counter-clockwise"),
                (ManoeuvreParams::rest_s.key(), "at rest before and after"),
                (
                    ManoeuvreParams::commands.key(),
                    "the commands CSV of `kind = \"commands\"`",
                ),
            ] {
                notes_by_key.push((key, how.into()));
            }
        }
        if scene.controller.kind == ControllerKind::OpenLoop {
            notes_by_key.push((
                ControllerParams::open_loop_forward_pct.key(),
                "half of full demand, straight ahead".into(),
            ));
        }
    }
    notes_by_key
}

/// The written text loaded back as a scene; a value that breaks its key's rule is named
/// with the options it was derived from.
pub(super) fn checked(
    spec: &RobotSpec,
    text: &str,
    derived: &[Derived],
) -> Result<Scene, RobotError> {
    let path = Path::new("(new scene)");
    Scene::from_toml(text, path, &[]).map_err(|e| match &e {
        SceneError::Invalid {
            key,
            value,
            expected,
            ..
        } => match derived.iter().find(|d| d.key.key() == key) {
            Some(d) => RobotError::Derived {
                options: spec.options_behind(d.from).join(" "),
                key: key.clone(),
                value: value.clone(),
                expected: expected.clone(),
                how: d.how.clone(),
            },
            None => match spec.options_setting(key) {
                Some(options) => RobotError::Derived {
                    options,
                    key: key.clone(),
                    value: value.clone(),
                    expected: expected.clone(),
                    how: "as given".into(),
                },
                None => RobotError::Scene(e),
            },
        },
        _ => RobotError::Scene(e),
    })
}

/// The scene as commented TOML: every key of the table, section by section, with how it
/// was derived or where it came from.
pub(super) fn render(
    scene: &Scene,
    derived: &[Derived],
    notes_by_key: &[(&str, String)],
    from: Option<&Path>,
    command: &str,
) -> String {
    let tree = toml::Value::try_from(scene).unwrap_or(toml::Value::Table(Default::default()));
    let origin = match from {
        Some(p) => format!("from {}", p.display()),
        None => "the thesis machine's".to_string(),
    };
    // A comment ends at a line break: one inside an argument (`--description "a\nb"`)
    // would leave the rest of the command as a line of TOML.
    let command = command.replace('\r', "\\r").replace('\n', "\\n");
    let origin = origin.replace('\r', "\\r").replace('\n', "\\n");
    let mut out = format!(
        "# Written by: {command}\n\
         # Values derived from the numbers given say how; the others are {origin} \
         (`agvsim keys` explains each key).\n\
         # Check it: agvsim check FILE. Run it: agvsim run FILE.\n\
         # No [expect] claims: a run of this scene has not been checked against any.\n\n"
    );
    let mut section = String::new();
    for k in keys::table().keys() {
        // Tables, which a written scene leaves to the user.
        let tables = [
            FloorParams::regions.key(),
            "obstacles",
            "expect",
            ControllerParams::swing_away.key(),
        ];
        if tables.contains(&k.key.as_str()) {
            continue;
        }
        let (sec, leaf) = k.key.rsplit_once('.').unwrap_or(("", k.key.as_str()));
        if sec != section {
            out.push_str(&format!("\n[{sec}]\n"));
            section = sec.to_string();
        }
        let value = k.key.split('.').try_fold(&tree, |v, part| v.get(part));
        let comment = derived
            .iter()
            .find(|d| d.key.key() == k.key)
            .map(|d| d.how.clone())
            .or_else(|| {
                notes_by_key
                    .iter()
                    .find(|(key, _)| *key == k.key)
                    .map(|(_, n)| n.clone())
            })
            .unwrap_or_else(|| {
                let assumed = if k.meaning.contains("*assumed*") {
                    ", assumed"
                } else {
                    ""
                };
                format!("{origin}{assumed}")
            });
        let unit = if k.unit.is_empty() {
            String::new()
        } else {
            format!("{}; ", k.unit)
        };
        match value {
            Some(v) => out.push_str(&format!("{leaf} = {v}  # {unit}{comment}\n")),
            None => out.push_str(&format!("# {leaf} =  ({unit}unset: {})\n", k.unset)),
        }
    }
    out.push_str(&tables_after(scene));
    crate::numtext::toml_short_floats(&out)
}

/// The array-of-tables keys (floor regions, obstacles) and stated uncertainties, as TOML.
pub(super) fn tables_after(scene: &Scene) -> String {
    let mut t = toml::Table::new();
    if !scene.floor.regions.is_empty() {
        if let Ok(v) = toml::Value::try_from(&scene.floor.regions) {
            let mut floor = toml::Table::new();
            floor.insert("regions".into(), v);
            t.insert("floor".into(), toml::Value::Table(floor));
        }
    }
    if !scene.obstacles.is_empty() {
        if let Ok(v) = toml::Value::try_from(&scene.obstacles) {
            t.insert("obstacles".into(), v);
        }
    }
    if !scene.uncertainty_pct.is_empty() {
        if let Ok(v) = toml::Value::try_from(&scene.uncertainty_pct) {
            t.insert("uncertainty_pct".into(), v);
        }
    }
    if t.is_empty() {
        String::new()
    } else {
        format!("\n{}", toml::to_string(&t).unwrap_or_default())
    }
}
