//! The sweep grid: varied keys and their values, runs in grid order, shards.

use super::SweepError;

/// Largest grid a sweep accepts: beyond this a typing slip (`0..1:100000`) is more likely
/// than a study, and the runs would not finish on one machine anyway (use shards).
pub const MAX_RUNS: usize = 1_000_000;

/// Default `--max-runs`: a grid larger than this is refused unless the user raises the
/// limit, since at a few runs per second it would take days (a slip such as `:100000`
/// for `:10` is the likelier cause).
pub const DEFAULT_MAX_RUNS: usize = 100_000;

/// Refuses a grid of more than `max_runs` runs (value counts multiplied, times `repeat`),
/// naming the count and how to allow it, before any run starts.
pub fn check_size(varies: &[Vary], repeat: usize, max_runs: usize) -> Result<(), SweepError> {
    let total = varies
        .iter()
        .try_fold(repeat.max(1), |acc, v| acc.checked_mul(v.values.len()));
    match total {
        Some(t) if t <= max_runs => Ok(()),
        _ => {
            let counts: Vec<String> = varies
                .iter()
                .map(|v| format!("{} values of {}", v.values.len(), v.key))
                .collect();
            let shown = total.map_or_else(|| "too many to count".to_string(), |t| t.to_string());
            Err(SweepError::Argument {
                arg: "--vary".into(),
                message: format!(
                    "the grid has {shown} runs ({} x {repeat} repeat(s)), more than --max-runs {max_runs}; \
                     check the ranges, or pass --max-runs N to allow it",
                    counts.join(" x ")
                ),
            })
        }
    }
}

/// One varied scene key and its values, as TOML value text (`hard_polyurethane`, `2.5`).
#[derive(Debug, Clone, PartialEq)]
pub struct Vary {
    /// The dotted scene key.
    pub key: String,
    /// Its values as `--set` text.
    pub values: Vec<String>,
}

/// Parses `KEY=VALUES`. VALUES is a list (`hard,soft`), a linear range `LO..HI:N` (N values,
/// both ends included) or a log range `log:LO..HI:N` (N values in geometric progression).
pub fn parse_vary(arg: &str) -> Result<Vary, SweepError> {
    let err = |message: String| SweepError::Argument {
        arg: format!("--vary {arg}"),
        message,
    };
    let (key, values) = arg.split_once('=').ok_or_else(|| {
        err("expected KEY=VALUES, e.g. controller.gain_scale=0.5..4:8 or tyre.compound=hard_polyurethane,soft_rubber".into())
    })?;
    let key = key.trim();
    if key.is_empty() || key.split('.').any(|p| p.is_empty()) {
        return Err(err(
            "expected a dotted scene key before `=`, e.g. controller.gain_scale".into(),
        ));
    }
    let values = values.trim();
    let (log, body) = match values.strip_prefix("log:") {
        Some(rest) => (true, rest),
        None => (false, values),
    };
    let out = if let Some((lo, rest)) = body.split_once("..") {
        let (hi, n) = rest.split_once(':').ok_or_else(|| {
            err(format!(
                "`{values}`: a range needs a count, LO..HI:N, e.g. 0.1..6:25"
            ))
        })?;
        let num = |s: &str, what: &str| -> Result<f64, SweepError> {
            match s.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(err(format!("`{s}`: the range's {what} is not a number"))),
            }
        };
        let (lo, hi) = (num(lo, "start")?, num(hi, "end")?);
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| err(format!("`{n}`: the range's count is not a whole number")))?;
        if !(1..=MAX_RUNS).contains(&n) {
            return Err(err(format!(
                "`{n}`: the range's count must be 1 to {MAX_RUNS}"
            )));
        }
        if n == 1 && lo != hi {
            return Err(err("a range of one value must have LO equal to HI".into()));
        }
        if log && !(lo > 0.0 && hi > 0.0) {
            return Err(err(format!(
                "`{values}`: a log range needs LO and HI above zero"
            )));
        }
        (0..n)
            .map(|i| {
                let f = if n == 1 {
                    0.0
                } else {
                    i as f64 / (n - 1) as f64
                };
                // The ends are the values the user typed, kept exactly: a tidied end
                // could fall outside the range asked for.
                if i == 0 {
                    return format!("{lo}");
                }
                if i == n - 1 {
                    return format!("{hi}");
                }
                let v = if log {
                    lo * (hi / lo).powf(f)
                } else {
                    lo + f * (hi - lo)
                };
                tidy_number(v)
            })
            .collect()
    } else {
        if log {
            return Err(err(format!("`{values}`: log: needs a range, log:LO..HI:N")));
        }
        let list: Vec<String> = values.split(',').map(|s| s.trim().to_string()).collect();
        if list.iter().any(|s| s.is_empty()) {
            return Err(err(format!(
                "`{values}`: an empty value in the list; expected VALUE,VALUE,... or LO..HI:N"
            )));
        }
        list
    };
    Ok(Vary {
        key: key.to_string(),
        values: out,
    })
}

/// A grid value as short text: twelve significant digits, so that 0.1 + 2 x 0.3 prints as
/// 0.7 rather than 0.7000000000000001.
fn tidy_number(v: f64) -> String {
    let rounded: f64 = format!("{v:.11e}").parse().unwrap_or(v);
    format!("{rounded}")
}

pub use crate::shard::Shard;

/// An `I/N` argument, or `auto` from the scheduler's array variables (see
/// [`crate::shard`]), with where it came from.
pub fn parse_shard(arg: &str) -> Result<crate::shard::Resolved, SweepError> {
    crate::shard::parse_env(arg).map_err(|e| SweepError::Argument {
        arg: format!("--shard {}", e.arg),
        message: e.message,
    })
}

/// One run of the grid.
#[derive(Debug, Clone, PartialEq)]
pub struct RunPoint {
    /// Position in grid order, from 0.
    pub index: usize,
    /// One value per varied key, in `--vary` order.
    pub values: Vec<String>,
    /// Repeat number, from 0.
    pub repeat: usize,
    /// Noise seed of this run: the scene's seed plus the repeat number.
    pub seed: u64,
}

impl RunPoint {
    /// The scene overrides of this run (`key=value`, then the seed).
    pub fn overrides(&self, varies: &[Vary]) -> Vec<String> {
        let mut o: Vec<String> = varies
            .iter()
            .zip(&self.values)
            .map(|(v, x)| format!("{}={x}", v.key))
            .collect();
        o.push(format!("sim.seed={}", self.seed));
        o
    }
}

/// The full grid of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// The varied keys, the first slowest in run order.
    pub varies: Vec<Vary>,
    /// Runs per grid point.
    pub repeat: usize,
    /// Noise seed of a point's first repeat.
    pub base_seed: u64,
}

impl Grid {
    /// A grid, refusing an empty one or one with repeated keys.
    pub fn new(varies: Vec<Vary>, repeat: usize, base_seed: u64) -> Result<Grid, SweepError> {
        if varies.is_empty() {
            return Err(SweepError::Argument {
                arg: "--vary".into(),
                message: "a sweep needs at least one --vary KEY=VALUES".into(),
            });
        }
        for (i, v) in varies.iter().enumerate() {
            if varies[..i].iter().any(|w| w.key == v.key) {
                return Err(SweepError::Argument {
                    arg: format!("--vary {}", v.key),
                    message: "this key is varied twice; give all its values in one --vary".into(),
                });
            }
        }
        if repeat < 1 {
            return Err(SweepError::Argument {
                arg: "--repeat".into(),
                message: "expected at least 1".into(),
            });
        }
        let g = Grid {
            varies,
            repeat,
            base_seed,
        };
        let total = g
            .varies
            .iter()
            .try_fold(repeat, |acc, v| acc.checked_mul(v.values.len()))
            .filter(|t| *t <= MAX_RUNS);
        if total.is_none() {
            return Err(SweepError::Argument {
                arg: "--vary".into(),
                message: format!(
                    "the grid has more than {MAX_RUNS} runs; split the study into several sweeps"
                ),
            });
        }
        Ok(g)
    }

    /// Runs in all.
    pub fn total(&self) -> usize {
        self.varies
            .iter()
            .map(|v| v.values.len())
            .product::<usize>()
            * self.repeat
    }

    /// Run number `index` in grid order.
    pub fn point(&self, index: usize) -> RunPoint {
        let repeat = index % self.repeat;
        let mut rest = index / self.repeat;
        let mut values = vec![String::new(); self.varies.len()];
        for (slot, v) in values.iter_mut().zip(&self.varies).rev() {
            let n = v.values.len();
            *slot = v.values[rest % n].clone();
            rest /= n;
        }
        RunPoint {
            index,
            values,
            repeat,
            seed: self.base_seed.wrapping_add(repeat as u64),
        }
    }

    /// The runs of a slice, in run order.
    pub fn points(&self, shard: Shard) -> Vec<RunPoint> {
        shard.range(self.total()).map(|i| self.point(i)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_parse_as_lists_linear_and_log_ranges() {
        assert_eq!(
            parse_vary("tyre.compound=hard,soft").unwrap().values,
            ["hard", "soft"]
        );
        let lin = parse_vary("controller.gain_scale=0.1..6:60")
            .unwrap()
            .values;
        assert_eq!(lin.len(), 60);
        assert_eq!(lin[0], "0.1");
        assert_eq!(lin[59], "6");
        assert_eq!(lin[6], "0.7");
        let log = parse_vary("k=log:0.01..1:3").unwrap().values;
        assert_eq!(log, ["0.01", "0.1", "1"]);
        for bad in [
            "k",
            "=1,2",
            "k=1..2",
            "k=a..2:3",
            "k=1..2:0",
            "k=1..2:1",
            "k=log:0..1:3",
            "k=1,,2",
            "k=log:1,2",
        ] {
            assert!(parse_vary(bad).is_err(), "{bad} accepted");
        }
    }

    #[test]
    fn grid_order_has_the_first_key_slowest_and_shards_partition_it() {
        let g = Grid::new(
            vec![parse_vary("a=1,2").unwrap(), parse_vary("b=x,y,z").unwrap()],
            2,
            7,
        )
        .unwrap();
        assert_eq!(g.total(), 12);
        let p = g.point(5);
        assert_eq!(p.values, ["1", "z"]);
        assert_eq!((p.repeat, p.seed), (1, 8));
        assert_eq!(g.point(6).values, ["2", "x"]);
        for n in 1..=13 {
            let mut seen = vec![];
            for i in 1..=n {
                seen.extend(Shard { index: i, count: n }.range(12));
            }
            assert_eq!(seen, (0..12).collect::<Vec<_>>(), "{n} shards");
        }
        assert!(parse_shard("0/3").is_err() && parse_shard("4/3").is_err());
        assert_eq!(
            parse_shard("2/3").unwrap().shard,
            Shard { index: 2, count: 3 }
        );
    }
}
