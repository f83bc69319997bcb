//! `agvsim batch diagnose|calibrate|merge`: one diagnosis or calibration per recording of
//! a fleet, sharded across a cluster's array tasks if asked, and the merge of the shards'
//! results into one summary.

use std::path::PathBuf;

use super::flags::{no_progress, Effects, Jobs};
use super::{on_workers, CommandError, Say};
use crate::batch::{self, find_items, Job};
use crate::output::file_stem_or;
use crate::shard::Shard;

/// What `agvsim batch diagnose` or `calibrate` was asked: the flags both take (the rig or
/// scene is each subcommand's own flag).
#[derive(Debug, Clone, clap::Args)]
pub struct BatchRequest {
    /// A folder of recordings (every *.csv), or a list file (one `recording.csv
    /// [rig.toml]` per line, relative to the list; # comments).
    #[arg(value_name = "FOLDER|LIST")]
    pub recordings: PathBuf,
    /// Diagnose: one rig for every recording (else each one's `NAME.rig.toml`).
    #[arg(skip)]
    pub rig: Option<PathBuf>,
    /// Calibrate: the scene fitted to each recording (`None`: diagnose).
    #[arg(skip)]
    pub scene: Option<PathBuf>,
    /// The effects to try (`--effects`).
    #[command(flatten)]
    pub effects: Effects,
    /// Only the I-th of N contiguous slices of the recordings (1-based), or `auto`: from
    /// the scheduler's array variables (Slurm SLURM_ARRAY_TASK_ID/_MIN/_MAX/_COUNT,
    /// Kubernetes JOB_COMPLETION_INDEX, AWS Batch AWS_BATCH_JOB_ARRAY_INDEX/_SIZE, or
    /// AGVSIM_SHARD_INDEX from 0; the count from AGVSIM_SHARD_COUNT where the scheduler
    /// does not give it).
    #[arg(long, value_name = "I/N|auto")]
    pub shard: Option<String>,
    /// Output folder [default: runs/batch_NAME, with _shard_I_of_N when sharded].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (`--jobs`).
    #[command(flatten)]
    pub jobs: Jobs,
    /// Told as each recording's result is written (or kept from an earlier run).
    #[arg(skip = no_progress as fn(&str))]
    pub progress: fn(&str),
}

/// Runs the batch's shard and prints what it did and where the summary is.
pub fn run(req: &BatchRequest, say: Say) -> Result<(), CommandError> {
    let effects = req.effects.choice()?;
    let job = match &req.scene {
        Some(scene) => {
            // The scene once, up front: an error in it is one error, not one per recording.
            crate::scene::Scene::load(scene, &[])?;
            Job::Calibrate {
                scene: scene.clone(),
                effects,
                effect_words: req.effects.effects.clone(),
            }
        }
        None => Job::Diagnose {
            effects,
            effect_words: req.effects.effects.clone(),
        },
    };
    let (shard, source) = match &req.shard {
        Some(s) => {
            let r = crate::shard::parse_env(s).map_err(|e| CommandError::Option {
                option: "--shard".into(),
                value: e.arg,
                message: e.message,
            })?;
            (r.shard, Some(r.source))
        }
        None => (Shard::WHOLE, None),
    };
    // A rig given for every recording is read once, before any work: a CSV given as the
    // rig is one error, not one per recording.
    if let Some(rig) = &req.rig {
        crate::rig::Rig::load(rig)?;
    }
    let items = find_items(&req.recordings, req.rig.as_deref())?;
    let out = req.out.clone().unwrap_or_else(|| {
        let mut n = format!("batch_{}", file_stem_or(&req.recordings, "recordings"));
        if shard != Shard::WHOLE {
            n.push_str(&format!("_shard_{}_of_{}", shard.index, shard.count));
        }
        PathBuf::from("runs").join(n)
    });
    let _lock = super::lock_out("--out", &out)?;
    let range = shard.range(items.len());
    say(&format!(
        "batch      {} {} of {} recordings{} into {}\n",
        if req.scene.is_some() {
            "calibrate"
        } else {
            "diagnose"
        },
        range.len(),
        items.len(),
        source.map_or(String::new(), |s| format!(" (shard {shard}: {s})")),
        out.display()
    ));
    let progress = req.progress;
    let told = move |e: &batch::Entry, kept: bool| {
        progress(&format!(
            "{:<10} {}: {}",
            if kept { "kept" } else { "done" },
            e.name,
            if e.status == "ok" {
                format!("{} effect(s)", e.effects.len())
            } else {
                e.error.clone().unwrap_or_default()
            }
        ))
    };
    let outcome = on_workers(req.jobs.count(), || {
        Ok(batch::run(&job, &items, shard, &out, &told)?)
    })?;
    say(&format!(
        "results    {} computed, {} kept from an earlier run, {} failed\n",
        outcome.computed, outcome.kept, outcome.failed
    ));
    say(&format!(
        "summary    {}\nfleet      {}\n",
        out.join("summary.csv").display(),
        out.join("fleet.md").display()
    ));
    if outcome.failed > 0 && outcome.failed == outcome.in_shard {
        // A batch with no result is a failed job, whatever the summary holds.
        return Err(batch::BatchError::AllFailed {
            failed: outcome.failed,
            summary: out.join("summary.csv"),
        }
        .into());
    }
    Ok(())
}

/// Merges shard folders into `out` and prints where the summary is.
pub fn merge(shards: &[PathBuf], out: &std::path::Path, say: Say) -> Result<(), CommandError> {
    let _lock = super::lock_out("--out", out)?;
    let n = batch::summary::merge(shards, out)?;
    say(&format!(
        "merged     {n} results from {} shard folders\nsummary    {}\nfleet      {}\n",
        shards.len(),
        out.join("summary.csv").display(),
        out.join("fleet.md").display()
    ));
    Ok(())
}
