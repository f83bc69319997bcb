//! How a block declares its parameters: once, beside its law. Each parameter has its key
//! (the scene's name for it, unit in the name), its unit, what values it allows, its
//! default and a one-line meaning. [`declare_params!`](crate::declare_params) writes from
//! that one declaration the block's struct (which the scene deserialises), its documented
//! `Default`, and its table of keys ([`Block::PARAMS`]).
//!
//! Everything that names a parameter reads the tables: the scene is the composition of
//! the blocks ([`crate::scene::keys`]), and its validation, `--set`, `--vary`,
//! `agvsim keys`, the rig's keys and the fits' parameter vectors go through them, so a
//! new parameter is declared in its block's file and nowhere else.

mod allowed;

pub use allowed::{
    closed, closed_open, open, open_closed, plain_number, true_or_false, Allowed, Takes,
};

/// Most points a wire or floor outline may have.
pub const MAX_FLOOR_POINTS: usize = 100_000;

/// A list of floor points, each exactly `[x, y]` (m): a third coordinate is an error, not
/// silently dropped. For `#[serde(deserialize_with = ...)]`.
pub fn points_2d<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
    use serde::Deserialize;
    let raw: Vec<Vec<f64>> = Vec::deserialize(d)?;
    if raw.len() > MAX_FLOOR_POINTS {
        return Err(serde::de::Error::custom(format!(
            "{} points, more than the {MAX_FLOOR_POINTS} a wire or outline may have (a kilometre at centimetre spacing): resample it",
            raw.len()
        )));
    }
    raw.iter()
        .enumerate()
        .map(|(i, p)| match p.as_slice() {
            [x, y] => Ok([*x, *y]),
            _ => Err(serde::de::Error::custom(format!(
                "point {i} has {} coordinates ({p:?}): expected two, [x, y] in metres on the floor",
                p.len()
            ))),
        })
        .collect()
}

/// One parameter of block `B`, as the block declares it.
pub struct Param<B: 'static> {
    /// The key inside the block's section (`resistance_ohm`).
    pub key: &'static str,
    /// The unit (`ohm`, `N m/A`); empty for a ratio, a count or a choice.
    pub unit: &'static str,
    /// What it takes.
    pub takes: Takes,
    /// What it is: the doc comment of its field.
    pub meaning: &'static str,
    /// What an optional parameter left out means (`""` for one that always has a value).
    pub unset: &'static str,
    /// Its value as a number (`None`: an optional one left out, or not a number).
    pub get: fn(&B) -> Option<f64>,
    /// Sets it from a number (whole numbers for integer keys; nothing for keys that are
    /// not numbers).
    pub set: fn(&mut B, f64),
}

/// A block's declared parameters: its struct is the block's section of a scene.
pub trait Block: Default + 'static {
    /// Every parameter in declaration order.
    const PARAMS: &'static [Param<Self>];
}

/// A block that sits in one section wherever it is composed (`motor`); a block composed
/// once per side has none and does not implement this. Its parameters have handles.
pub trait Sectioned: Block {
    /// The section.
    const SECTION: &'static str;
}

/// A typed handle on one declared parameter: its dotted key (`motor.resistance_ohm`) and
/// unit. [`declare_params!`](crate::declare_params) writes one per parameter of a block
/// with a section, as an associated constant named after the field
/// (`MotorParams::resistance_ohm`), so code names a parameter by its declaration and a
/// misspelt key does not compile. The dotted text is for files, messages and the CLI.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParamKey {
    key: &'static str,
    unit: &'static str,
}

impl ParamKey {
    /// A handle on `key` (dotted), in `unit`. Only the declarations and the contract's
    /// renames of scene keys (`supply.voltage_V`) make one.
    pub const fn new(key: &'static str, unit: &'static str) -> Self {
        ParamKey { key, unit }
    }

    /// The dotted key (`motor.resistance_ohm`).
    pub const fn key(self) -> &'static str {
        self.key
    }

    /// The unit, as declared (`ohm`); empty for a ratio, a count or a choice.
    pub const fn unit(self) -> &'static str {
        self.unit
    }
}

impl std::fmt::Display for ParamKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.key)
    }
}

/// How a field's value reads and takes a number, for the key tables.
pub trait Value {
    /// The value as a number, if it is one.
    fn number(&self) -> Option<f64> {
        None
    }
    /// Sets the value from a number (no-op for values that are not numbers).
    fn set_number(&mut self, _v: f64) {}
}

impl Value for f64 {
    fn number(&self) -> Option<f64> {
        Some(*self)
    }
    fn set_number(&mut self, v: f64) {
        *self = v;
    }
}

impl Value for Option<f64> {
    fn number(&self) -> Option<f64> {
        *self
    }
    fn set_number(&mut self, v: f64) {
        *self = Some(v);
    }
}

impl Value for i32 {
    fn number(&self) -> Option<f64> {
        Some(f64::from(*self))
    }
    fn set_number(&mut self, v: f64) {
        *self = v as i32;
    }
}

impl Value for u64 {
    fn number(&self) -> Option<f64> {
        Some(*self as f64)
    }
    fn set_number(&mut self, v: f64) {
        *self = v as u64;
    }
}

impl Value for bool {}
impl Value for String {}
impl<T> Value for Vec<T> {}

/// Declares a block's parameters once: the struct (serde, unknown keys refused, every
/// field defaulted), its `Default`, and its [`Block::PARAMS`] table. Each field:
///
/// ```text
/// /// Meaning (the field's doc and the key's meaning).
/// field as "key_Unit": type = default, "unit", takes [, unset "what leaving it out means"];
/// ```
///
/// `as "key"` is needed where the key is not the field's name (mixed-case units);
/// `takes` is an [`Allowed`] rule for numbers, or `other(fn)` with a function describing
/// what the key takes. A field may carry `#[serde(...)]` attributes after its doc.
///
/// A block that always sits in one section says so after its name
/// (`pub struct MotorParams in "motor"`); each of its parameters then has a typed handle,
/// [`ParamKey`], named after its field (`MotorParams::resistance_ohm`).
#[macro_export]
macro_rules! declare_params {
    (
        $(#[doc = $sdoc:literal])*
        #[derive($($derive:path),*)]
        pub struct $name:ident $(in $section:literal)? {
            $(
                $(#[doc = $doc:literal])+
                $(#[serde($($serde:tt)*)])*
                $field:ident $(as $key:literal)? : $ty:ty = $default:expr,
                    $unit:literal, $kind:ident $(($($rule:tt)*))? $(, unset $unset:literal)?;
            )*
        }
    ) => {
        $(#[doc = $sdoc])*
        #[derive($($derive),*, serde::Deserialize, serde::Serialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct $name {
            $(
                $(#[doc = $doc])+
                #[doc = ""]
                #[doc = concat!(
                    "Key `", $crate::declare_params!(@key $field $(, $key)?), "`",
                    $crate::declare_params!(@unit $unit),
                    ", default `", stringify!($default), "`."
                )]
                $(#[serde(rename = $key)])?
                $(#[serde($($serde)*)])*
                pub $field: $ty,
            )*
        }

        impl Default for $name {
            fn default() -> Self {
                $name { $($field: $default),* }
            }
        }

        impl $crate::param::Block for $name {
            const PARAMS: &'static [$crate::param::Param<Self>] = &[
                $(
                    $crate::param::Param {
                        key: $crate::declare_params!(@key $field $(, $key)?),
                        unit: $unit,
                        takes: $crate::declare_params!(@takes $kind $(($($rule)*))?),
                        meaning: concat!($($doc),+),
                        unset: $crate::declare_params!(@unset $($unset)?),
                        get: |b: &$name| $crate::param::Value::number(&b.$field),
                        set: |b: &mut $name, v: f64| $crate::param::Value::set_number(&mut b.$field, v),
                    },
                )*
            ];
        }

        $crate::declare_params!(@handles $name [$($section)?] $( ($field $(, $key)?) $unit; )*);
    };
    (@handles $name:ident [] $($rest:tt)*) => {};
    (@handles $name:ident [$section:literal] $( ($field:ident $(, $key:literal)?) $unit:literal; )*) => {
        impl $crate::param::Sectioned for $name {
            const SECTION: &'static str = $section;
        }

        /// Typed handles on the block's parameters ([`ParamKey`](crate::param::ParamKey)).
        #[allow(non_upper_case_globals)]
        impl $name {
            $(
                #[doc = concat!("Handle on `", $section, ".", $crate::declare_params!(@key $field $(, $key)?), "`.")]
                pub const $field: $crate::param::ParamKey = $crate::param::ParamKey::new(
                    concat!($section, ".", $crate::declare_params!(@key $field $(, $key)?)),
                    $unit,
                );
            )*
        }
    };
    (@key $field:ident) => { stringify!($field) };
    (@key $field:ident, $key:literal) => { $key };
    (@unit "") => { "" };
    (@unit $unit:literal) => { concat!(", ", $unit) };
    (@unset) => { "" };
    (@unset $unset:literal) => { $unset };
    (@takes other($describe:expr)) => { $crate::param::Takes::Other($describe) };
    (@takes closed($lo:expr, $hi:expr)) => { $crate::param::Takes::Number($crate::param::closed($lo, $hi)) };
    (@takes open_closed($lo:expr, $hi:expr)) => { $crate::param::Takes::Number($crate::param::open_closed($lo, $hi)) };
    (@takes closed_open($lo:expr, $hi:expr)) => { $crate::param::Takes::Number($crate::param::closed_open($lo, $hi)) };
    (@takes open($lo:expr, $hi:expr)) => { $crate::param::Takes::Number($crate::param::open($lo, $hi)) };
    (@takes $rule:ident) => { $crate::param::Takes::Number($crate::param::Allowed::$rule) };
}

/// One key of a composition of blocks (a scene, a fitting model's blocks): the block's
/// declaration with the section it sits in.
pub struct Key<T> {
    /// The dotted key (`motor.resistance_ohm`).
    pub key: String,
    /// The unit, as declared.
    pub unit: &'static str,
    /// What it takes, as declared.
    pub takes: Takes,
    /// What it is, as declared (whitespace as in the doc comment).
    pub meaning: &'static str,
    /// What an optional key left out means.
    pub unset: &'static str,
    get: Getter<T>,
    set: Setter<T>,
}

/// Reads a key's number from a composition.
type Getter<T> = Box<dyn Fn(&T) -> Option<f64> + Send + Sync>;
/// Sets a key's number in a composition.
type Setter<T> = Box<dyn Fn(&mut T, f64) + Send + Sync>;

impl<T> Key<T> {
    /// The key's value in `t` as a number (`None`: an optional key left out, or not a
    /// number).
    pub fn get(&self, t: &T) -> Option<f64> {
        (self.get)(t)
    }

    /// Sets the key's value in `t` (whole numbers for integer keys).
    pub fn set(&self, t: &mut T, v: f64) {
        (self.set)(t, v)
    }

    /// The numeric rule, if the key is a number.
    pub fn allowed(&self) -> Option<Allowed> {
        self.takes.allowed()
    }

    /// The meaning on one line, as the reference prints it.
    pub fn meaning_line(&self) -> String {
        self.meaning
            .split_whitespace()
            .collect::<Vec<_>>()
            .join(" ")
    }
}

impl<T> std::fmt::Debug for Key<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Key({} {:?})", self.key, self.takes)
    }
}

/// The keys of a composition of blocks, section by section, in the order they were
/// added.
pub struct KeyTable<T> {
    keys: Vec<Key<T>>,
}

impl<T> Default for KeyTable<T> {
    fn default() -> Self {
        KeyTable { keys: Vec::new() }
    }
}

impl<T: 'static> KeyTable<T> {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a block's keys under `prefix` (`motor`), the block reached through `get` and
    /// `get_mut`.
    pub fn section<B: Block>(
        mut self,
        prefix: &str,
        get: fn(&T) -> &B,
        get_mut: fn(&mut T) -> &mut B,
    ) -> Self {
        for p in B::PARAMS {
            let (read, write) = (p.get, p.set);
            self.keys.push(Key {
                key: format!("{prefix}.{}", p.key),
                unit: p.unit,
                takes: p.takes,
                meaning: p.meaning,
                unset: p.unset,
                get: Box::new(move |t| read(get(t))),
                set: Box::new(move |t, v| write(get_mut(t), v)),
            });
        }
        self
    }

    /// Adds a block's keys under the section it declares ([`Sectioned`]), so its handles
    /// name them.
    pub fn block<B: Sectioned>(self, get: fn(&T) -> &B, get_mut: fn(&mut T) -> &mut B) -> Self {
        self.section(B::SECTION, get, get_mut)
    }

    /// Adds a key that is not a block's parameter (a scene's description, a list of
    /// tables), described.
    pub fn other(mut self, key: &str, takes: fn() -> String, meaning: &'static str) -> Self {
        self.keys.push(Key {
            key: key.to_string(),
            unit: "",
            takes: Takes::Other(takes),
            meaning,
            unset: "",
            get: Box::new(|_| None),
            set: Box::new(|_, _| {}),
        });
        self
    }

    /// Every key in order.
    pub fn keys(&self) -> &[Key<T>] {
        &self.keys
    }

    /// A key by its dotted name.
    pub fn find(&self, key: &str) -> Option<&Key<T>> {
        self.keys.iter().find(|k| k.key == key)
    }

    /// Every numeric key.
    pub fn numbers(&self) -> impl Iterator<Item = (&Key<T>, Allowed)> {
        self.keys.iter().filter_map(|k| k.allowed().map(|a| (k, a)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    crate::declare_params! {
        /// A block for the test.
        #[derive(Debug, Clone, PartialEq)]
        pub struct Thing in "thing" {
            /// Its mass.
            mass_kg: f64 = 2.0, "kg", Positive;
            /// Its stiffness.
            stiffness as "stiffness_N_m": f64 = 10.0, "N/m", closed(0.0, 100.0);
            /// A count.
            teeth: i32 = 12, "", Integer;
            /// An optional value.
            bias as "bias_N": Option<f64> = None, "N", Finite, unset "no bias";
            /// A name.
            colour: String = "red".into(), "", other(|| "a colour".into());
        }
    }

    #[test]
    fn a_declaration_gives_the_struct_its_default_and_its_table() {
        let t = Thing::default();
        assert_eq!(t.mass_kg, 2.0);
        assert_eq!(t.colour, "red");
        let keys: Vec<&str> = Thing::PARAMS.iter().map(|p| p.key).collect();
        assert_eq!(
            keys,
            ["mass_kg", "stiffness_N_m", "teeth", "bias_N", "colour"]
        );
        let back: Thing = toml::from_str("stiffness_N_m = 5.0\nbias_N = -1.0\n").unwrap();
        assert_eq!(back.stiffness, 5.0);
        assert_eq!(back.bias, Some(-1.0));
        assert!(toml::from_str::<Thing>("stiffness = 5.0\n").is_err());
        let mut t = t;
        (Thing::PARAMS[2].set)(&mut t, 15.0);
        assert_eq!(t.teeth, 15);
        assert_eq!((Thing::PARAMS[3].get)(&t), None);
        assert_eq!((Thing::PARAMS[4].get)(&t), None);
        assert_eq!(Thing::PARAMS[1].meaning.trim(), "Its stiffness.");
        assert!(!Thing::PARAMS[1].takes.allowed().unwrap().admits(101.0));
    }

    #[test]
    fn a_block_with_a_section_has_a_handle_per_parameter_naming_its_key_in_a_table() {
        assert_eq!(Thing::SECTION, "thing");
        assert_eq!(Thing::stiffness.key(), "thing.stiffness_N_m");
        assert_eq!(Thing::stiffness.unit(), "N/m");
        assert_eq!(Thing::bias.to_string(), "thing.bias_N");
        let table = KeyTable::<Thing>::new().block(|t| t, |t| t);
        let mut t = Thing::default();
        table
            .find(Thing::stiffness.key())
            .unwrap()
            .set(&mut t, 42.0);
        assert_eq!(t.stiffness, 42.0);
        // Every parameter's handle is a key of the table the block composes.
        let keys: Vec<&str> = table.keys().iter().map(|k| k.key.as_str()).collect();
        for h in [
            Thing::mass_kg,
            Thing::stiffness,
            Thing::teeth,
            Thing::bias,
            Thing::colour,
        ] {
            assert!(keys.contains(&h.key()), "{h}");
        }
    }

    #[test]
    fn a_table_addresses_a_blocks_keys_under_its_section() {
        #[derive(Default)]
        struct Two {
            a: Thing,
            b: Thing,
        }
        let table = KeyTable::<Two>::new()
            .section("a", |t| &t.a, |t| &mut t.a)
            .section("b", |t| &t.b, |t| &mut t.b);
        let mut two = Two::default();
        table.find("b.mass_kg").unwrap().set(&mut two, 7.0);
        assert_eq!((two.a.mass_kg, two.b.mass_kg), (2.0, 7.0));
        assert_eq!(table.find("b.mass_kg").unwrap().get(&two), Some(7.0));
        assert_eq!(table.numbers().count(), 8);
        assert!(table.find("c.mass_kg").is_none());
    }
}
