//! What a key takes: a number within a rule ([`Allowed`]: positive, a fraction, an
//! interval with open or closed ends, an integer) or something else described in words
//! ([`Takes`]), and how the reference and the messages print it.

/// What a numeric key allows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Allowed {
    /// Finite and above zero.
    Positive,
    /// Finite, zero or more.
    NonNegative,
    /// Finite and below zero.
    Negative,
    /// Any finite number.
    Finite,
    /// Strictly between 0 and 1.
    OpenFraction,
    /// Within `[lo, hi]`, each end open or closed.
    Interval {
        /// Lower end.
        lo: f64,
        /// Whether the lower end is excluded.
        lo_open: bool,
        /// Upper end.
        hi: f64,
        /// Whether the upper end is excluded.
        hi_open: bool,
    },
    /// Any integer (the type is checked when the file is read).
    Integer,
    /// An integer other than zero (a denominator).
    NonZeroInteger,
}

/// `[lo, hi]`.
pub const fn closed(lo: f64, hi: f64) -> Allowed {
    Allowed::Interval {
        lo,
        lo_open: false,
        hi,
        hi_open: false,
    }
}

/// `(lo, hi]`.
pub const fn open_closed(lo: f64, hi: f64) -> Allowed {
    Allowed::Interval {
        lo,
        lo_open: true,
        hi,
        hi_open: false,
    }
}

/// `[lo, hi)`.
pub const fn closed_open(lo: f64, hi: f64) -> Allowed {
    Allowed::Interval {
        lo,
        lo_open: false,
        hi,
        hi_open: true,
    }
}

/// `(lo, hi)`.
pub const fn open(lo: f64, hi: f64) -> Allowed {
    Allowed::Interval {
        lo,
        lo_open: true,
        hi,
        hi_open: true,
    }
}

impl Allowed {
    /// The rule as the reference prints it.
    pub fn text(&self) -> String {
        match *self {
            Allowed::Positive => "> 0".into(),
            Allowed::Negative => "< 0".into(),
            Allowed::NonNegative => ">= 0".into(),
            Allowed::Finite => "finite".into(),
            Allowed::OpenFraction => "(0, 1)".into(),
            Allowed::Interval {
                lo,
                lo_open,
                hi,
                hi_open,
            } => format!(
                "{}{}, {}{}",
                if lo_open { "(" } else { "[" },
                bound(lo),
                bound(hi),
                if hi_open { ")" } else { "]" }
            ),
            Allowed::Integer => "integer".into(),
            Allowed::NonZeroInteger => "integer, not 0".into(),
        }
    }

    /// What an error message says was expected.
    pub fn expected(&self) -> String {
        match self {
            Allowed::Positive => "a finite number greater than zero".into(),
            Allowed::Negative => "a finite number below zero".into(),
            Allowed::NonNegative => "a finite number, zero or more".into(),
            Allowed::Finite => "a finite number".into(),
            Allowed::OpenFraction => "a fraction strictly between 0 and 1".into(),
            Allowed::Interval { .. } => format!("a number in {}", self.text()),
            Allowed::Integer => "an integer".into(),
            Allowed::NonZeroInteger => "a non-zero integer".into(),
        }
    }

    /// Whether `v` satisfies the rule.
    pub fn admits(&self, v: f64) -> bool {
        v.is_finite()
            && match *self {
                Allowed::Positive => v > 0.0,
                Allowed::Negative => v < 0.0,
                Allowed::NonNegative => v >= 0.0,
                Allowed::Finite | Allowed::Integer => true,
                Allowed::OpenFraction => v > 0.0 && v < 1.0,
                Allowed::Interval {
                    lo,
                    lo_open,
                    hi,
                    hi_open,
                } => {
                    (if lo_open { v > lo } else { v >= lo })
                        && (if hi_open { v < hi } else { v <= hi })
                }
                Allowed::NonZeroInteger => v != 0.0,
            }
    }

    /// Whether the rule is about whole numbers.
    pub fn is_integer(&self) -> bool {
        matches!(self, Allowed::Integer | Allowed::NonZeroInteger)
    }
}

/// A number as messages print it: plain for everyday magnitudes, in e-notation for the
/// very large and very small (so that 1e308 does not print 309 digits).
pub fn plain_number(v: f64) -> String {
    if v.is_finite() && v != 0.0 && (v.abs() >= 1e7 || v.abs() < 1e-5) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// An interval's end as the reference prints it.
fn bound(v: f64) -> String {
    if v == std::f64::consts::FRAC_PI_2 {
        "pi/2".into()
    } else {
        format!("{v}")
    }
}

/// What a key takes.
#[derive(Clone, Copy)]
pub enum Takes {
    /// A number within a rule.
    Number(Allowed),
    /// Something else (a name from a list, true or false, text, a table), described.
    Other(fn() -> String),
}

impl std::fmt::Debug for Takes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Takes::Number(a) => write!(f, "Number({})", a.text()),
            Takes::Other(t) => write!(f, "Other({})", t()),
        }
    }
}

impl Takes {
    /// The numeric rule, if the key is a number.
    pub fn allowed(&self) -> Option<Allowed> {
        match self {
            Takes::Number(a) => Some(*a),
            Takes::Other(_) => None,
        }
    }

    /// What the reference prints in its "allowed" column.
    pub fn text(&self) -> String {
        match self {
            Takes::Number(a) => a.text(),
            Takes::Other(t) => t(),
        }
    }
}

/// `true` or `false`.
pub fn true_or_false() -> String {
    "true, false".into()
}
