//! `agvsim sweep` and `agvsim sweep merge`: a scene run over a grid of values, in
//! parallel, into one results table; shard folders joined back into it.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

use super::{CommandError, Say};
use crate::scene::Scene;
use crate::sweep::{self, Shard, SweepOptions};

/// `agvsim sweep`'s command line (without `sweep merge`).
#[derive(Debug, Clone, clap::Args)]
pub struct SweepFlags {
    /// Scene file (TOML), e.g. scenes/high_gain_slip.toml.
    #[arg(required = true)]
    pub scene: Option<PathBuf>,
    /// A scene key and its values: a list (tyre.compound=hard_polyurethane,soft_rubber), a
    /// linear range LO..HI:N (controller.gain_scale=0.1..6:25) or a log range
    /// log:LO..HI:N. Repeat for a full grid; the first is the slowest in run order.
    #[arg(long = "vary", value_name = "KEY=VALUES", required = true)]
    pub vary: Vec<String>,
    /// Runs per grid point, with noise seeds sim.seed, sim.seed+1, ...
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10000))]
    pub repeat: u32,
    /// Worker threads (`--jobs`).
    #[command(flatten)]
    pub jobs: super::flags::Jobs,
    /// Run only the I-th of N contiguous slices of the runs (e.g. a cluster job array);
    /// join the slices' folders with `agvsim sweep merge`.
    /// `auto`: from the scheduler's array variables (see `agvsim batch diagnose --help`).
    #[arg(long, value_name = "I/N|auto")]
    pub shard: Option<String>,
    /// Output folder [default: runs/sweep_SCENE_NAME, with _shard_I_of_N when sharded].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Scene overrides, for every run.
    #[command(flatten)]
    pub set: super::flags::Overrides,
    /// Simulated time of each run, s (overrides sim.duration_s).
    #[arg(long = "duration", value_name = "DURATION", value_parser = super::flags::positive_seconds)]
    pub duration_s: Option<f64>,
    /// Also write every run's path and lateral error (traces/run_NNNNN.csv).
    #[arg(long)]
    pub traces: bool,
    /// Refuse grids of more runs than this (a guard against a typo that asks for a
    /// million runs).
    #[arg(long, default_value_t = crate::sweep::DEFAULT_MAX_RUNS)]
    pub max_runs: usize,
    /// Continue an interrupted sweep in its --out folder (same arguments): its finished
    /// runs are kept and only the rest are run.
    #[arg(long)]
    pub resume: bool,
}

/// What `agvsim sweep` was asked: the command line, and where progress and a stop come
/// from.
pub struct SweepRequest<'a> {
    /// The command line.
    pub flags: SweepFlags,
    /// Told as runs finish (runs done, runs in all).
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Set when the sweep should stop (a signal): the runs in progress finish and are kept.
    pub stop: Option<&'static AtomicBool>,
}

/// The sweep's options from the request: grid, shard, overrides and output folder.
fn options(request: &SweepRequest) -> Result<SweepOptions, CommandError> {
    let req = &request.flags;
    let scene = req.scene.clone().unwrap_or_default();
    let varies = req
        .vary
        .iter()
        .map(|v| sweep::parse_vary(v))
        .collect::<Result<Vec<_>, _>>()?;
    sweep::check_size(&varies, req.repeat as usize, req.max_runs)?;
    let (shard, shard_source) = match &req.shard {
        Some(s) => {
            let r = sweep::parse_shard(s)?;
            (r.shard, Some(r.source))
        }
        None => (Shard::WHOLE, None),
    };
    let set = super::overrides(&req.set, req.duration_s, None);
    let out = req.out.clone().unwrap_or_else(|| {
        let mut n = format!("sweep_{}", crate::output::file_stem_or(&scene, "scene"));
        if shard != Shard::WHOLE {
            n.push_str(&format!("_shard_{}_of_{}", shard.index, shard.count));
        }
        PathBuf::from("runs").join(n)
    });
    let mut opts = SweepOptions::new(
        &scene,
        set,
        varies,
        req.repeat as usize,
        shard,
        req.jobs.count(),
        req.traces,
        out,
    )?;
    opts.resume = req.resume;
    opts.stop = request.stop;
    opts.shard_source = shard_source;
    Ok(opts)
}

/// Runs the sweep, telling what it replaces or resumes and what it did.
pub fn run(req: &SweepRequest, say: Say) -> Result<(), CommandError> {
    let opts = options(req)?;
    let _lock = super::lock_out("--out", &opts.out_dir)?;
    let range = opts.shard.range(opts.grid.total());
    if let Ok(scene) = Scene::from_toml(&opts.scene_text, &opts.scene_path, &opts.set) {
        for v in &opts.grid.varies {
            if let Some(why) = crate::scene::inert::inert_reason(&scene, &v.key) {
                say(&format!("warning: --vary {}: {why}\n", v.key));
            }
        }
    }
    let previous = sweep::previous_outputs(&opts.out_dir);
    if !previous.is_empty() {
        say(&format!(
            "{}    {}: {}\n",
            if opts.resume { "resume " } else { "replace" },
            opts.out_dir.display(),
            previous.join(", ")
        ));
    }
    say(&format!(
        "sweep      {}: {} runs{} on {} jobs\n",
        opts.scene_path.display(),
        range.len(),
        if opts.shard == Shard::WHOLE {
            String::new()
        } else {
            format!(
                " (shard {} of {} runs: {}..{}; {})",
                opts.shard,
                opts.grid.total(),
                range.start,
                range.end,
                opts.shard_source.as_deref().unwrap_or("--shard")
            )
        },
        if opts.jobs == 0 {
            rayon::current_num_threads()
        } else {
            opts.jobs
        }
    ));
    let started = std::time::Instant::now();
    let o = sweep::run_sweep(&opts, req.progress)?;
    let failed: Vec<_> = o.results.iter().filter(|r| r.outcome.is_err()).collect();
    say(&format!(
        "done       {} runs in {:.1} s, {} failed{}\n",
        o.results.len(),
        started.elapsed().as_secs_f64(),
        failed.len(),
        if o.resumed > 0 {
            format!(" (and {} kept from the interrupted sweep)", o.resumed)
        } else {
            String::new()
        }
    ));
    for r in failed.iter().take(5) {
        if let Err(e) = &r.outcome {
            say(&format!("  run {}: {e}\n", r.point.index));
        }
    }
    say(&format!("results    {}\n", o.results_csv.display()));
    say(&format!(
        "plots      {}\n",
        opts.out_dir.join("plots").display()
    ));
    Ok(())
}

/// Joins shard folders into the unsharded result in `out`.
pub fn merge(shards: &[PathBuf], out: &std::path::Path, say: Say) -> Result<(), CommandError> {
    let (csv, _plots) = sweep::merge(shards, out)?;
    say(&format!(
        "merged     {} shard folders ({})\n",
        shards.len(),
        sweep::MERGE_NOTE
    ));
    say(&format!("results    {}\n", csv.display()));
    say(&format!("plots      {}\n", out.join("plots").display()));
    Ok(())
}
