//! Scene keys by their dotted names (`motor.resistance_ohm`): read one, or set several
//! through the same path as `--set`, so a fitted value is validated like a user's.

use super::CalibrateError;
use crate::scene::Scene;

/// The number a dotted key holds in the scene.
pub fn get(scene: &Scene, key: &str) -> Result<f64, CalibrateError> {
    let table = crate::scene::keys::table();
    match table.find(key) {
        None => Err(CalibrateError::Key(format!("`{key}`: no such scene key"))),
        Some(k) if k.allowed().is_none() => Err(CalibrateError::Key(format!(
            "`{key}`: not a number ({}), so it cannot be fitted",
            k.takes.text()
        ))),
        Some(k) => k
            .get(scene)
            .or_else(|| {
                // An optional key that stands for another while unset (a wheel's rolling
                // radius is the wheel's radius) starts from that one's value.
                table.find(k.unset).and_then(|other| other.get(scene))
            })
            .ok_or_else(|| {
                CalibrateError::Key(format!(
                    "`{key}` is not set in the scene ({}): give it a value to fit",
                    k.unset
                ))
            }),
    }
}

/// The scene with each `(key, value)` set on the typed scene and validated as a `--set`
/// would be (every key against its rule, then the rules that tie keys together). No text
/// round trip: a fit sets keys on every evaluation.
pub fn set(scene: &Scene, pairs: &[(String, f64)]) -> Result<Scene, CalibrateError> {
    let mut out = scene.clone();
    for (k, v) in pairs {
        set_number(&mut out, k, *v)?;
    }
    out.validate().map_err(|bad| {
        CalibrateError::Key(format!(
            "{} = {}: expected {}",
            bad.key, bad.value, bad.expected
        ))
    })?;
    Ok(out)
}

/// Sets one numeric key on the typed scene, not yet validated ([`set`] validates).
pub fn set_number(scene: &mut Scene, key: &str, value: f64) -> Result<(), CalibrateError> {
    if crate::scene::keys::set_number(scene, key, value) {
        return Ok(());
    }
    // Not a numeric key: `get` names why.
    get(scene, key)?;
    Err(CalibrateError::Key(format!(
        "`{key}`: not a numeric scene key"
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_read_and_set_by_name_and_bad_ones_are_named() {
        let s = Scene::default();
        let r = get(&s, "motor.resistance_ohm").unwrap();
        let t = set(&s, &[("motor.resistance_ohm".into(), 2.0 * r)]).unwrap();
        assert_eq!(get(&t, "motor.resistance_ohm").unwrap(), 2.0 * r);
        let e = get(&s, "motor.resistence_ohm").unwrap_err().to_string();
        assert!(e.contains("motor.resistence_ohm"), "{e}");
        let e = set(&s, &[("motor.resistance_ohm".into(), -1.0)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("motor.resistance_ohm"), "{e}");
    }
}
