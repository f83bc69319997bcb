//! Shards: the I-th of N contiguous slices of a job's work (a sweep's runs, a batch's
//! recordings), given as `I/N` (1-based) or read by `--shard auto` from the variables the
//! batch schedulers people already run set for each array task:
//!
//! | scheduler | index | count |
//! | --- | --- | --- |
//! | Slurm array | `SLURM_ARRAY_TASK_ID` (from `_MIN`, step `_STEP`) | `SLURM_ARRAY_TASK_COUNT` (or from `_MIN`, `_MAX`) |
//! | Kubernetes Indexed Job | `JOB_COMPLETION_INDEX` (from 0) | `AGVSIM_SHARD_COUNT` (the Job's `completions`) |
//! | AWS Batch array job | `AWS_BATCH_JOB_ARRAY_INDEX` (from 0) | `AWS_BATCH_JOB_ARRAY_SIZE` or `AGVSIM_SHARD_COUNT` |
//! | HTCondor, or any other | `AGVSIM_SHARD_INDEX` (from 0; HTCondor: `$(Process)`) | `AGVSIM_SHARD_COUNT` |
//!
//! Several schedulers' variables may be present (a Kubernetes pod inside a Slurm
//! allocation); they must then name the same shard, or the run is refused.

/// `I/N`: the I-th (1-based) of N contiguous slices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This slice, from 1.
    pub index: usize,
    /// Number of slices.
    pub count: usize,
}

impl Shard {
    /// The whole job as one slice.
    pub const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// The item numbers `[start, end)` of this shard among `total` (in 128-bit arithmetic:
    /// a count near the integer limit times the items overflowed).
    pub fn range(self, total: usize) -> std::ops::Range<usize> {
        let at = |k: usize| (total as u128 * k as u128 / self.count.max(1) as u128) as usize;
        at(self.index - 1)..at(self.index)
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A shard that could not be worked out; the message says what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("--shard {arg}: {message}")]
pub struct ShardError {
    /// What was given.
    pub arg: String,
    /// What is wrong and what was expected.
    pub message: String,
}

/// A shard and where it came from (`I/N` as typed, or the scheduler's variables).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Resolved {
    /// The shard.
    pub shard: Shard,
    /// Where it came from, for the report (`SLURM_ARRAY_TASK_ID=4 of _MIN=1.._MAX=8`).
    pub source: String,
}

/// `I/N`, or `auto` read from `var` (the environment, or a test's table).
pub fn parse(arg: &str, var: &dyn Fn(&str) -> Option<String>) -> Result<Resolved, ShardError> {
    if arg.trim() == "auto" {
        return from_scheduler(var).map_err(|e| ShardError {
            arg: arg.into(),
            message: e.to_string(),
        });
    }
    let err = || {
        ShardError {
        arg: arg.into(),
        message: "expected I/N with 1 <= I <= N, e.g. 3/8 (the third of eight slices), or auto (from the scheduler's array variables)".into(),
    }
    };
    let (i, n) = arg.split_once('/').ok_or_else(err)?;
    let index: usize = i.trim().parse().map_err(|_| err())?;
    let count: usize = n.trim().parse().map_err(|_| err())?;
    if index < 1 || index > count {
        return Err(err());
    }
    Ok(Resolved {
        shard: Shard { index, count },
        source: format!("--shard {arg}"),
    })
}

/// `I/N` or `auto` from the process's environment.
pub fn parse_env(arg: &str) -> Result<Resolved, ShardError> {
    parse(arg, &|name| std::env::var(name).ok())
}

/// Why the scheduler's array variables name no shard.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SchedulerError {
    /// A variable that is not a whole number (its name and value).
    #[error("{0}={1:?} is not a whole number")]
    NotWhole(String, String),
    /// An index outside its count.
    #[error("{names}: index {index} of {count} is outside 0..{count} (0-based)")]
    Outside {
        /// The variables.
        names: String,
        /// The 0-based index.
        index: i64,
        /// The count.
        count: i64,
    },
    /// Slurm's task id without the array's first id.
    #[error("SLURM_ARRAY_TASK_ID is set without SLURM_ARRAY_TASK_MIN: is this an array task?")]
    SlurmNoMin,
    /// A Slurm task id off the array's steps.
    #[error(
        "SLURM_ARRAY_TASK_ID={id} is not on the array's steps from _MIN={min} by _STEP={step}"
    )]
    SlurmOffStep {
        /// The task id.
        id: i64,
        /// The first id.
        min: i64,
        /// The step.
        step: i64,
    },
    /// A Slurm array whose count disagrees with its range.
    #[error("SLURM_ARRAY_TASK_COUNT={count} but _MIN={min}.._MAX={max} by {step} holds {range} tasks: an array with gaps (1,3,7) or a %-limit cannot be sliced; use an array of consecutive indices")]
    SlurmGaps {
        /// The stated count.
        count: i64,
        /// The first id.
        min: i64,
        /// The last id.
        max: i64,
        /// The step.
        step: i64,
        /// The tasks the range holds.
        range: i64,
    },
    /// A Slurm task id without the array's size.
    #[error("SLURM_ARRAY_TASK_ID is set without SLURM_ARRAY_TASK_COUNT or _MAX")]
    SlurmNoCount,
    /// An index without the number of shards.
    #[error("{index_name}={index} is set but not the number of shards: set {count_names} (the {scheduler} job's task count)")]
    NoCount {
        /// The index variable.
        index_name: String,
        /// Its value.
        index: i64,
        /// The variables that could give the count.
        count_names: String,
        /// The scheduler.
        scheduler: String,
    },
    /// Two count variables that disagree.
    #[error("{0}={1} but {2}={3}")]
    CountsDisagree(String, i64, String, i64),
    /// No scheduler's variables at all.
    #[error("no scheduler's array variables are set (SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX, AWS_BATCH_JOB_ARRAY_INDEX, or AGVSIM_SHARD_INDEX with AGVSIM_SHARD_COUNT); give I/N instead")]
    None,
    /// Two schedulers naming different shards.
    #[error("the schedulers' variables disagree: {first} gives shard {first_shard}, {other} gives {other_shard}")]
    Disagree {
        /// Where the first came from.
        first: String,
        /// Its shard.
        first_shard: Shard,
        /// Where the other came from.
        other: String,
        /// Its shard.
        other_shard: Shard,
    },
}

/// A variable as a whole number, naming it when it is not one.
fn whole(var: &dyn Fn(&str) -> Option<String>, name: &str) -> Result<Option<i64>, SchedulerError> {
    match var(name) {
        None => Ok(None),
        Some(v) if v.trim().is_empty() => Ok(None),
        Some(v) => v
            .trim()
            .parse::<i64>()
            .map(Some)
            .map_err(|_| SchedulerError::NotWhole(name.to_string(), v)),
    }
}

/// A 0-based index and a count as a shard, naming the variables when they do not fit.
fn zero_based(index: i64, count: i64, names: &str) -> Result<Shard, SchedulerError> {
    if count < 1 || index < 0 || index >= count {
        return Err(SchedulerError::Outside {
            names: names.to_string(),
            index,
            count,
        });
    }
    Ok(Shard {
        index: index as usize + 1,
        count: count as usize,
    })
}

fn slurm(var: &dyn Fn(&str) -> Option<String>) -> Result<Option<Resolved>, SchedulerError> {
    let Some(id) = whole(var, "SLURM_ARRAY_TASK_ID")? else {
        return Ok(None);
    };
    let min = whole(var, "SLURM_ARRAY_TASK_MIN")?;
    let max = whole(var, "SLURM_ARRAY_TASK_MAX")?;
    let step = whole(var, "SLURM_ARRAY_TASK_STEP")?.unwrap_or(1);
    let count = whole(var, "SLURM_ARRAY_TASK_COUNT")?;
    let Some(min) = min else {
        return Err(SchedulerError::SlurmNoMin);
    };
    if step < 1 || (id - min) % step != 0 {
        return Err(SchedulerError::SlurmOffStep { id, min, step });
    }
    let from_range = max.map(|max| (max - min) / step + 1);
    let count = match (count, from_range) {
        (Some(c), Some(r)) if c != r => {
            return Err(SchedulerError::SlurmGaps {
                count: c,
                min,
                max: max.unwrap_or_default(),
                step,
                range: r,
            })
        }
        (Some(c), _) => c,
        (None, Some(r)) => r,
        (None, None) => return Err(SchedulerError::SlurmNoCount),
    };
    let shard = zero_based((id - min) / step, count, "SLURM_ARRAY_TASK_ID")?;
    Ok(Some(Resolved {
        shard,
        source: format!("Slurm: SLURM_ARRAY_TASK_ID={id} of _MIN={min}, {count} tasks"),
    }))
}

fn indexed(
    var: &dyn Fn(&str) -> Option<String>,
    scheduler: &str,
    index_name: &str,
    count_names: &[&str],
) -> Result<Option<Resolved>, SchedulerError> {
    let Some(index) = whole(var, index_name)? else {
        return Ok(None);
    };
    let mut counts = Vec::new();
    for name in count_names {
        if let Some(c) = whole(var, name)? {
            counts.push((*name, c));
        }
    }
    let Some(&(count_name, count)) = counts.first() else {
        return Err(SchedulerError::NoCount {
            index_name: index_name.to_string(),
            index,
            count_names: count_names.join(" or "),
            scheduler: scheduler.to_string(),
        });
    };
    if let Some((other, c)) = counts.iter().find(|(_, c)| *c != count) {
        return Err(SchedulerError::CountsDisagree(
            count_name.to_string(),
            count,
            other.to_string(),
            *c,
        ));
    }
    let shard = zero_based(index, count, index_name)?;
    Ok(Some(Resolved {
        shard,
        source: format!("{scheduler}: {index_name}={index} of {count_name}={count}"),
    }))
}

/// The shard the scheduler's variables name; an error where none is set or they
/// disagree.
pub fn from_scheduler(var: &dyn Fn(&str) -> Option<String>) -> Result<Resolved, SchedulerError> {
    let found: Vec<Resolved> = [
        slurm(var)?,
        indexed(
            var,
            "Kubernetes",
            "JOB_COMPLETION_INDEX",
            &["AGVSIM_SHARD_COUNT"],
        )?,
        indexed(
            var,
            "AWS Batch",
            "AWS_BATCH_JOB_ARRAY_INDEX",
            &["AWS_BATCH_JOB_ARRAY_SIZE", "AGVSIM_SHARD_COUNT"],
        )?,
        indexed(var, "AGVSIM", "AGVSIM_SHARD_INDEX", &["AGVSIM_SHARD_COUNT"])?,
    ]
    .into_iter()
    .flatten()
    .collect();
    match found.as_slice() {
        [] => Err(SchedulerError::None),
        [one] => Ok(one.clone()),
        [first, rest @ ..] => match rest.iter().find(|r| r.shard != first.shard) {
            Some(other) => Err(SchedulerError::Disagree {
                first: first.source.clone(),
                first_shard: first.shard,
                other: other.source.clone(),
                other_shard: other.shard,
            }),
            None => Ok(first.clone()),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<String> {
        let pairs: Vec<(String, String)> = pairs
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect();
        move |name| {
            pairs
                .iter()
                .find(|(a, _)| a == name)
                .map(|(_, b)| b.clone())
        }
    }

    fn auto(pairs: &[(&str, &str)]) -> Result<Shard, String> {
        parse("auto", &env(pairs))
            .map(|r| r.shard)
            .map_err(|e| e.message)
    }

    #[test]
    fn each_scheduler_counts_its_own_way() {
        let s = |index, count| Ok(Shard { index, count });
        // Slurm --array=1-8, task 3; --array=0-7, task 2; --array=10-24:2, task 14.
        let slurm = |id: &str, min: &str, max: &str, count: &str| {
            auto(&[
                ("SLURM_ARRAY_TASK_ID", id),
                ("SLURM_ARRAY_TASK_MIN", min),
                ("SLURM_ARRAY_TASK_MAX", max),
                ("SLURM_ARRAY_TASK_COUNT", count),
            ])
        };
        assert_eq!(slurm("3", "1", "8", "8"), s(3, 8));
        assert_eq!(slurm("2", "0", "7", "8"), s(3, 8));
        assert_eq!(
            auto(&[
                ("SLURM_ARRAY_TASK_ID", "14"),
                ("SLURM_ARRAY_TASK_MIN", "10"),
                ("SLURM_ARRAY_TASK_MAX", "24"),
                ("SLURM_ARRAY_TASK_STEP", "2"),
                ("SLURM_ARRAY_TASK_COUNT", "8"),
            ]),
            s(3, 8)
        );
        assert_eq!(
            auto(&[("JOB_COMPLETION_INDEX", "0"), ("AGVSIM_SHARD_COUNT", "3")]),
            s(1, 3)
        );
        assert_eq!(
            auto(&[
                ("AWS_BATCH_JOB_ARRAY_INDEX", "2"),
                ("AWS_BATCH_JOB_ARRAY_SIZE", "3")
            ]),
            s(3, 3)
        );
        assert_eq!(
            auto(&[("AGVSIM_SHARD_INDEX", "1"), ("AGVSIM_SHARD_COUNT", "2")]),
            s(2, 2)
        );
    }

    #[test]
    fn a_contradictory_or_incomplete_set_is_refused_by_name() {
        let e = auto(&[
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
            ("JOB_COMPLETION_INDEX", "3"),
            ("AGVSIM_SHARD_COUNT", "4"),
        ])
        .unwrap_err();
        assert!(e.contains("disagree") && e.contains("Kubernetes"), "{e}");
        let e = auto(&[("JOB_COMPLETION_INDEX", "0")]).unwrap_err();
        assert!(e.contains("AGVSIM_SHARD_COUNT"), "{e}");
        let e = auto(&[
            ("AWS_BATCH_JOB_ARRAY_INDEX", "3"),
            ("AWS_BATCH_JOB_ARRAY_SIZE", "3"),
        ])
        .unwrap_err();
        assert!(e.contains("outside 0..3"), "{e}");
        let e = auto(&[
            ("SLURM_ARRAY_TASK_ID", "7"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "7"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ])
        .unwrap_err();
        assert!(e.contains("gaps"), "{e}");
        assert!(auto(&[]).unwrap_err().contains("give I/N"));
        assert!(auto(&[("SLURM_ARRAY_TASK_ID", "x")])
            .unwrap_err()
            .contains("not a whole number"));
    }

    #[test]
    fn slices_cover_every_item_once() {
        for count in 1..6 {
            let mut seen = vec![];
            for index in 1..=count {
                seen.extend(Shard { index, count }.range(20));
            }
            assert_eq!(seen, (0..20).collect::<Vec<_>>());
        }
    }
}
