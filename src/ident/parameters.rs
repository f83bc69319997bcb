//! A fitted model's parameters: each declared with its key, belief, bounds and search
//! step ([`ParamSpec`], as every fitting model, the diagnosis and calibrate declare it),
//! and a vector of them bound to the model's blocks by key ([`Binding`]).

use crate::param::KeyTable;

/// One model parameter: a key of the model's blocks with its bounds and search step.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Rig key or vocabulary name, e.g. `motor.resistance_ohm`: how reports name it.
    pub name: String,
    /// The key of the model's blocks its value sets (the name, unless it is the
    /// vocabulary's name of an effect's strength: `backlash_rad` sets
    /// `gearbox.backlash_rad`).
    pub key: String,
    /// Starting (nominal) value.
    pub nominal: f64,
    /// Physical bounds.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Finite-difference step of the Jacobian in the search coordinate. Parameters whose
    /// effect switches at events (a backlash play decides when teeth meet) make the cost
    /// rough on the scale of an integration step; a wider difference sees the trend.
    pub fd_step: f64,
    /// How far the belief (`nominal`) may be off, one standard deviation as a fraction of
    /// it: the prior that holds the parameter near its belief where a record cannot
    /// determine it (log-normal for a positive quantity, normal otherwise). `None`: no
    /// belief worth holding to (an effect's strength, a block's nuisance parameter), the
    /// record alone decides.
    pub belief_sd_rel: Option<f64>,
    /// The cost is rough on the scale of the Jacobian's step in this parameter (a
    /// simulator stepping gear play and friction as events on its time grid): the
    /// covariance's derivative is taken over the smallest step at which it no longer
    /// changes with the step ([`crate::ident::fit`]), so that it measures the trend, not
    /// the roughness.
    pub rough: bool,
}

/// One standard deviation of a rig's belief, as a fraction of it, where the rig does not
/// state its own (`[uncertainty_pct]`): the contract's beliefs are "typically within some
/// tens of percent of the truth".
pub const DEFAULT_BELIEF_SD_REL: f64 = 0.3;

impl ParamSpec {
    /// A parameter `name` starting at `nominal` within `[lo, hi]`, setting the key of the same name.
    pub fn new(name: &str, nominal: f64, lo: f64, hi: f64) -> ParamSpec {
        ParamSpec {
            name: name.to_string(),
            key: name.to_string(),
            nominal,
            lo,
            hi,
            fd_step: 1e-6,
            belief_sd_rel: None,
            rough: false,
        }
    }

    /// The same parameter with a belief `sd_rel` (one standard deviation, a fraction of the
    /// nominal value) holding it: see [`ParamSpec::belief_sd_rel`]. A belief of zero is no
    /// belief to hold to (a friction thought absent): it stays without a prior.
    pub fn believed(mut self, sd_rel: f64) -> ParamSpec {
        self.belief_sd_rel = (self.nominal != 0.0 && sd_rel > 0.0).then_some(sd_rel);
        self
    }

    /// The same parameter believed at its nominal value within `sd_rel` (one standard
    /// deviation, a fraction of it: a belief someone stated), a positive one's search
    /// widened to reach [`crate::ident::BELIEF_SPAN_SD`] of those deviations either side
    /// (log scale): a guess stated at 100 % may be several times off, beyond the factor a
    /// tens-of-percent belief is searched in.
    pub fn stated_belief(self, sd_rel: f64) -> ParamSpec {
        let mut spec = self.believed(sd_rel);
        if spec.lo > 0.0 && spec.nominal > 0.0 {
            let span = (crate::ident::BELIEF_SPAN_SD * sd_rel.ln_1p()).exp();
            spec.lo = spec.lo.min(spec.nominal / span);
            spec.hi = spec.hi.max(spec.nominal * span);
        }
        spec
    }

    /// The same parameter, setting the model's key `key` (a name that is not a key of the
    /// model's blocks: an effect's strength under its vocabulary name).
    pub fn setting(mut self, key: &str) -> ParamSpec {
        self.key = key.to_string();
        self
    }

    /// The same parameter with a wider finite-difference step.
    pub fn with_fd_step(mut self, step: f64) -> ParamSpec {
        self.fd_step = step;
        self
    }

    /// A strictly positive physical quantity, searched on a log scale within a factor of 10
    /// of the rig's belief (beliefs are tens of percent off, not orders of magnitude; the
    /// bound also keeps the search out of absurdly stiff corners).
    /// It carries the default belief ([`DEFAULT_BELIEF_SD_REL`]).
    pub fn positive(name: &str, nominal: f64) -> ParamSpec {
        ParamSpec::new(name, nominal, nominal.abs() * 0.1, nominal.abs() * 10.0)
            .believed(DEFAULT_BELIEF_SD_REL)
    }

    /// A friction coefficient: as [`ParamSpec::positive`] around a positive belief; a
    /// belief of zero (no such friction believed) is searched on a linear scale from zero
    /// up to `scale`, a physical ceiling the caller names.
    pub fn friction(name: &str, nominal: f64, scale: f64) -> ParamSpec {
        if nominal > 0.0 {
            ParamSpec::positive(name, nominal)
        } else {
            ParamSpec::new(name, 0.0, 0.0, scale)
        }
    }
}

/// A parameter vector bound to a model's blocks by key: each parameter's value is written
/// into the blocks through the key table the blocks declare, so a model reads its
/// parameters as named fields and no position in the vector carries a meaning.
#[derive(Clone)]
pub struct Binding<T: 'static> {
    table: &'static KeyTable<T>,
    /// For each parameter, the place of its key in the table (`None`: a key the table
    /// does not have, which [`Binding::unbound`] lists).
    keys: Vec<Option<usize>>,
}

impl<T: 'static> std::fmt::Debug for Binding<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list()
            .entries(
                self.keys
                    .iter()
                    .map(|k| k.map(|i| self.table.keys()[i].key.as_str())),
            )
            .finish()
    }
}

impl<T: Clone + 'static> Binding<T> {
    /// Binds each parameter's key in `table`.
    pub fn new(table: &'static KeyTable<T>, specs: &[ParamSpec]) -> Binding<T> {
        let keys = specs
            .iter()
            .map(|s| table.keys().iter().position(|k| k.key == s.key))
            .collect();
        Binding { table, keys }
    }

    /// `base` with each parameter's value of `p` set by its key.
    #[inline]
    pub fn apply(&self, base: &T, p: &[f64]) -> T {
        let mut t = base.clone();
        for (value, key) in p.iter().zip(&self.keys) {
            if let Some(k) = key {
                self.table.keys()[*k].set(&mut t, *value);
            }
        }
        t
    }

    /// Parameters whose key the blocks do not have (a model's bug; tests check none).
    pub fn unbound<'a>(&self, specs: &'a [ParamSpec]) -> Vec<&'a str> {
        specs
            .iter()
            .zip(&self.keys)
            .filter(|(_, k)| k.is_none())
            .map(|(s, _)| s.key.as_str())
            .collect()
    }
}
