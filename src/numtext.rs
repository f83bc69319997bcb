//! Numbers as the text reports print them: significant figures in plain decimals, with
//! their unit, and an estimate with its standard deviation to the digits that deviation
//! supports. JSON and written scenes keep full precision; this is for people reading.

/// Magnitudes printed in plain decimals; beyond them (a 1e-9 H inductance, a 1e12 count)
/// plain decimals would be a row of zeros, and e-notation is the readable form.
const PLAIN: (f64, f64) = (1e-6, 1e9);

/// `v` to `digits` significant figures, trailing zeros after the point dropped: `0.35`,
/// `23.5`, `0.000249`; a whole part longer than `digits` is kept whole (`2732`, not
/// `2730`: zeros that look measured).
pub fn sig(v: f64, digits: usize) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = digits.max(1);
    if v.abs() < PLAIN.0 || v.abs() >= PLAIN.1 {
        return format!("{v:.*e}", digits - 1);
    }
    // Round first: 9.996 to 3 figures is 10.0, whose exponent is one more.
    let rounded: f64 = format!("{v:.*e}", digits - 1).parse().unwrap_or(v);
    let exponent = rounded.abs().log10().floor() as i32;
    let decimals = (digits as i32 - 1 - exponent).max(0) as usize;
    trim(format!("{v:.decimals$}"))
}

/// Drops trailing zeros after a decimal point, and the point if nothing follows it.
fn trim(s: String) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// `v` to `digits` significant figures followed by its unit (`0.35 ohm`); a quantity
/// without a unit (a ratio, a count) prints the number alone.
pub fn quantity(v: f64, digits: usize, unit: &str) -> String {
    with_unit(sig(v, digits), unit)
}

fn with_unit(number: String, unit: &str) -> String {
    if unit.is_empty() {
        number
    } else {
        format!("{number} {unit}")
    }
}

/// An estimate and one standard deviation, `2.732 ± 0.040 N m`: the deviation to two
/// significant figures and the value to the same decimal place, since digits below the
/// deviation's carry no information. A deviation under a millionth of the value (a fit of
/// noise-free data) prints as such rather than as a row of zeros; `None` says the record
/// does not determine it.
pub fn estimate(v: f64, std: Option<f64>, unit: &str) -> String {
    let Some(s) = std.filter(|s| s.is_finite() && *s > 0.0) else {
        let why = match std {
            Some(0.0) => "(std 0)",
            Some(_) => "(std not finite)",
            None => "(std not determined)",
        };
        return format!("{} {why}", quantity(v, 6, unit));
    };
    if v != 0.0 && s < 1e-6 * v.abs() {
        return format!("{} (± < 0.0001 %)", quantity(v, 6, unit));
    }
    match decimals_of(v, s) {
        Some(d) => with_unit(format!("{v:.d$} ± {s:.d$}"), unit),
        None => format!("{} ± {}", sig(v, 6), quantity(s, 2, unit)),
    }
}

/// The decimal places a deviation `s` supports (its two significant figures), where
/// `v` and `s` print in plain decimals; `None` where they do not.
fn decimals_of(v: f64, s: f64) -> Option<usize> {
    let decimals = 1 - s.log10().floor() as i32;
    ((0..=9).contains(&decimals) && (PLAIN.0..PLAIN.1).contains(&v.abs().max(s)))
        .then_some(decimals as usize)
}

/// The value of [`estimate`] alone, to the decimal place its standard deviation `std`
/// supports (6 figures where the deviation is under a millionth of it): what a table of
/// values beside a table of estimates prints, so both show the same number.
pub fn estimate_value(v: f64, std: f64, unit: &str) -> String {
    match decimals_of(v, std).filter(|_| v == 0.0 || std >= 1e-6 * v.abs()) {
        Some(d) => with_unit(format!("{v:.d$}"), unit),
        None => quantity(v, 6, unit),
    }
}

/// A share in percent to one decimal, with its sign when it is a change (`-81.2 %`).
pub fn change_pct(v: f64) -> String {
    format!("{v:+.1} %")
}

/// The unit a column's or parameter's name ends in (`speed_m_s` -> `m/s`,
/// `coulomb_torque_Nm` -> `N m`); `""` when its suffix names none.
pub fn unit_of_name(name: &str) -> &'static str {
    // Longest suffixes first: `_rad_s` before `_s`, `_m_s` before `_s`; the thesis's
    // state-space names (`a_left_1_s`, `b_left_fwd_rad_s2_pct`) before their tails.
    const UNITS: [(&str, &str); 19] = [
        ("_rad_s2_pct", "rad/s^2 per pct"),
        ("_rad_s_pct", "rad/s per pct"),
        ("_1_s2", "1/s^2"),
        ("_1_s", "1/s"),
        ("_per_N", "1/N"),
        ("_kg_m2", "kg m^2"),
        ("_rad_s", "rad/s"),
        ("_m_s", "m/s"),
        ("_V_pct", "V/pct"),
        ("_rad", "rad"),
        ("_Nm", "N m"),
        ("_pct", "pct"),
        ("_ohm", "ohm"),
        ("_m", "m"),
        ("_N", "N"),
        ("_A", "A"),
        ("_V", "V"),
        ("_adc", "counts"),
        ("_s", "s"),
    ];
    UNITS
        .iter()
        .find(|(s, _)| name.ends_with(s))
        .map_or("", |u| u.1)
}

/// Names as a message lists them: each in backticks, joined by commas (`` `a`, `b` ``).
pub fn backticked(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A value from the user's input as a message quotes it: whole up to 40 characters, else
/// its first 40 and how long it was (a 2 MB number in a cell must not make a 2 MB message).
pub fn echoed(value: &str) -> String {
    const SHOWN: usize = 40;
    let n = value.chars().count();
    if n <= SHOWN {
        value.to_string()
    } else {
        format!(
            "{}... ({n} characters)",
            value.chars().take(SHOWN).collect::<String>()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_value_is_echoed_cut_with_its_length() {
        assert_eq!(echoed("0.25"), "0.25");
        let long = "1".repeat(2_000_000);
        let e = echoed(&long);
        assert!(e.len() < 80, "{e}");
        assert!(e.ends_with("... (2000000 characters)"), "{e}");
    }

    #[test]
    fn names_are_listed_in_backticks() {
        assert_eq!(backticked(&["wl".into(), "wr".into()]), "`wl`, `wr`");
        assert_eq!(backticked(&[]), "");
    }

    #[test]
    fn significant_figures_print_in_plain_decimals() {
        assert_eq!(sig(23.5, 4), "23.5");
        assert_eq!(sig(0.35, 6), "0.35");
        assert_eq!(sig(0.000249, 3), "0.000249");
        assert_eq!(sig(2732.43, 4), "2732");
        assert_eq!(sig(9.996, 3), "10");
        assert_eq!(sig(-0.04897, 3), "-0.049");
        assert_eq!(sig(138.0, 6), "138");
        assert_eq!(sig(4.94266e-5, 4), "0.00004943");
        assert_eq!(sig(3.0e-9, 2), "3.0e-9");
        assert_eq!(sig(0.0, 3), "0");
    }

    #[test]
    fn quantities_carry_their_unit() {
        assert_eq!(quantity(11.0, 4, "V"), "11 V");
        assert_eq!(quantity(1.817, 3, ""), "1.82");
    }

    #[test]
    fn an_estimates_value_alone_has_the_estimates_digits() {
        assert_eq!(estimate_value(0.04897, 0.0021, "N m"), "0.0490 N m");
        assert_eq!(estimate_value(2.73243, 0.03968, "N m"), "2.732 N m");
        assert_eq!(estimate_value(0.05, 1e-12, "N m"), "0.05 N m");
    }

    #[test]
    fn an_estimate_keeps_the_digits_its_deviation_supports() {
        assert_eq!(estimate(2.73243, Some(0.03968), "N m"), "2.732 ± 0.040 N m");
        assert_eq!(estimate(0.70264, Some(0.0126), "V"), "0.703 ± 0.013 V");
        assert_eq!(estimate(138.2, Some(4.1), "kg"), "138.2 ± 4.1 kg");
        assert_eq!(estimate(1520.0, Some(37.0), "N"), "1520 ± 37 N");
        assert_eq!(
            estimate(0.35, Some(1.3e-9), "ohm"),
            "0.35 ohm (± < 0.0001 %)"
        );
        assert_eq!(estimate(0.05, None, "N m"), "0.05 N m (std not determined)");
        assert!(!estimate(2.5e-4, Some(3e-6), "kg m^2").contains('e'));
    }

    #[test]
    fn names_end_in_their_unit() {
        assert_eq!(unit_of_name("left_wheel_speed_m_s"), "m/s");
        assert_eq!(unit_of_name("motor_speed_rad_s"), "rad/s");
        assert_eq!(unit_of_name("coulomb_torque_Nm"), "N m");
        assert_eq!(unit_of_name("delay_s"), "s");
        assert_eq!(unit_of_name("peak_mu"), "");
        assert_eq!(unit_of_name("a_left_1_s"), "1/s");
        assert_eq!(unit_of_name("b_left_fwd_rad_s2_pct"), "rad/s^2 per pct");
    }

    #[test]
    fn changes_carry_their_sign() {
        assert_eq!(change_pct(-81.24), "-81.2 %");
        assert_eq!(change_pct(2.1), "+2.1 %");
    }
}

/// TOML text with every float literal longer than 24 characters (a 1e300 written out in
/// 301 digits by the TOML writer) rewritten in e-notation (`1e300`, valid TOML); strings
/// and comments untouched.
pub fn toml_short_floats(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        // A string (basic or literal, one line or three quotes), copied as it is.
        if c == '"' || c == '\'' {
            let triple = chars.get(i + 1) == Some(&c) && chars.get(i + 2) == Some(&c);
            let quote_len = if triple { 3 } else { 1 };
            let mut j = i + quote_len;
            while j < chars.len() {
                if c == '"' && chars[j] == '\\' {
                    j += 2;
                    continue;
                }
                if chars[j] == c
                    && (!triple || (chars.get(j + 1) == Some(&c) && chars.get(j + 2) == Some(&c)))
                {
                    j += quote_len;
                    break;
                }
                j += 1;
            }
            let end = j.min(chars.len());
            out.extend(&chars[i..end]);
            i = end;
            continue;
        }
        if c == '#' {
            let end = chars[i..]
                .iter()
                .position(|&x| x == '\n')
                .map_or(chars.len(), |p| i + p);
            out.extend(&chars[i..end]);
            i = end;
            continue;
        }
        let starts_number = (c.is_ascii_digit() || c == '-' || c == '+')
            && (i == 0 || matches!(chars[i - 1], ' ' | '=' | '[' | ',' | '\n' | '\t'));
        if starts_number {
            let end = chars[i..]
                .iter()
                .position(|x| {
                    !(x.is_ascii_digit() || matches!(x, '.' | 'e' | 'E' | '+' | '-' | '_'))
                })
                .map_or(chars.len(), |p| i + p);
            let token: String = chars[i..end].iter().collect();
            match token.replace('_', "").parse::<f64>() {
                Ok(v) if token.len() > 24 && v.is_finite() => out.push_str(&format!("{v:e}")),
                _ => out.push_str(&token),
            }
            i = end;
            continue;
        }
        out.push(c);
        i += 1;
    }
    out
}

#[cfg(test)]
mod toml_float_tests {
    use super::toml_short_floats;

    #[test]
    fn long_float_literals_become_e_notation_and_strings_stay() {
        let big = format!("{}.0", 1e300);
        let text = format!("a = {big}\nb = [[{big}, -0.5]]\nc = \"{big}\" # {big}\nd = 1.5\n");
        let short = toml_short_floats(&text);
        assert_eq!(
            short,
            format!("a = 1e300\nb = [[1e300, -0.5]]\nc = \"{big}\" # {big}\nd = 1.5\n")
        );
        let v: toml::Table = toml::from_str(&short).unwrap();
        assert_eq!(v["a"].as_float(), Some(1e300));
        let tiny = format!("x = {}\n", 1e-30_f64);
        assert_eq!(toml_short_floats(&tiny), "x = 1e-30\n");
        assert_eq!(toml_short_floats("y = 0.1\n"), "y = 0.1\n");
    }
}
