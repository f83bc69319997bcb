//! `agvsim sweep` and `agvsim sweep merge`: their arguments, the progress display and the
//! summary printed (the work is the library's `sweep` module).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;

use crate::cli_args::positive_seconds;

#[derive(clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    action: Option<SweepAction>,
    /// Scene file (TOML), e.g. scenes/high_gain_slip.toml.
    #[arg(required = true)]
    scene: Option<PathBuf>,
    /// A scene key and its values: a list (tyre.compound=hard_polyurethane,soft_rubber), a
    /// linear range LO..HI:N (controller.gain_scale=0.1..6:25) or a log range
    /// log:LO..HI:N. Repeat for a full grid; the first is the slowest in run order.
    #[arg(long = "vary", value_name = "KEY=VALUES", required = true)]
    vary: Vec<String>,
    /// Runs per grid point, with noise seeds sim.seed, sim.seed+1, ...
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=10000))]
    repeat: u32,
    /// Parallel runs [default: one per core]. Results do not depend on it.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    jobs: Option<u32>,
    /// Run only the I-th of N contiguous slices of the runs (e.g. a cluster job array);
    /// join the slices' folders with `agvsim sweep merge`.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Output folder [default: runs/sweep_SCENE_NAME, with _shard_I_of_N when sharded].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Override a scene value for every run, e.g. --set sim.duration_s=10 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Simulated time of each run, s (overrides sim.duration_s).
    #[arg(long, value_parser = positive_seconds)]
    duration: Option<f64>,
    /// Also write every run's path and lateral error (traces/run_NNNNN.csv).
    #[arg(long)]
    traces: bool,
    /// Refuse grids of more runs than this (a guard against a typo that asks for a
    /// million runs).
    #[arg(long, default_value_t = agvsim::sweep::DEFAULT_MAX_RUNS)]
    max_runs: usize,
    /// Continue an interrupted sweep in its --out folder (same arguments): its finished
    /// runs are kept and only the rest are run.
    #[arg(long)]
    resume: bool,
}

#[derive(Subcommand)]
pub enum SweepAction {
    /// Join the folders of `--shard` runs of one sweep into the unsharded result.
    Merge {
        /// The shard folders, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Folder for the merged results.csv, sweep.toml and plots.
        #[arg(long)]
        out: PathBuf,
    },
}

/// Reports sweep progress: a bar with rate and time left on a terminal, a plain line every
/// tenth of the runs otherwise (logs of batch jobs).
fn sweep_progress(total: usize) -> impl Fn(usize, usize) + Sync {
    use std::io::IsTerminal;
    let start = std::time::Instant::now();
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new(total as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} runs  {per_sec}  {eta} left",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    move |done, total| match &bar {
        Some(b) => {
            b.set_position(done as u64);
            if done == total {
                b.finish_and_clear();
            }
        }
        None => {
            let step = (total / 10).max(1);
            if done % step == 0 || done == total {
                let secs = start.elapsed().as_secs_f64();
                let rate = done as f64 / secs.max(1e-9);
                eprintln!(
                    "sweep: {done}/{total} runs, {rate:.2} runs/s, about {:.0} s left",
                    (total - done) as f64 / rate.max(1e-9)
                );
            }
        }
    }
}

/// Set by SIGINT or SIGTERM: the sweep finishes the runs in progress, writes their rows
/// and stops, so that `--resume` can continue it.
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

#[cfg(unix)]
extern "C" fn request_stop(signal: libc::c_int) {
    STOP.store(true, std::sync::atomic::Ordering::SeqCst);
    // A second signal ends the process at once: the default action is back.
    // SAFETY: `signal` is async-signal-safe; the handler touches only an atomic.
    unsafe {
        libc::signal(signal, libc::SIG_DFL);
    }
}

/// Turns the first SIGINT or SIGTERM into a stop request for the sweep.
fn stop_on_signals() -> Option<&'static std::sync::atomic::AtomicBool> {
    #[cfg(unix)]
    // SAFETY: installs a handler that only stores to an atomic and resets the disposition,
    // both async-signal-safe.
    unsafe {
        let handler = request_stop as extern "C" fn(libc::c_int) as libc::sighandler_t;
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
    }
    Some(&STOP)
}

pub fn sweep_command(args: SweepArgs) -> ExitCode {
    use agvsim::sweep;
    if let Some(SweepAction::Merge { shards, out }) = args.action {
        return match sweep::merge(&shards, &out) {
            Ok((csv, _plots)) => {
                println!(
                    "merged     {} shard folders ({})",
                    shards.len(),
                    sweep::MERGE_NOTE
                );
                println!("results    {}", csv.display());
                println!("plots      {}", out.join("plots").display());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    let Some(scene) = args.scene else {
        eprintln!("error: a sweep needs a scene file");
        return ExitCode::from(2);
    };
    let prepared = (|| {
        let varies = args
            .vary
            .iter()
            .map(|v| sweep::parse_vary(v))
            .collect::<Result<Vec<_>, _>>()?;
        sweep::check_size(&varies, args.repeat as usize, args.max_runs)?;
        let shard = match &args.shard {
            Some(s) => sweep::parse_shard(s)?,
            None => sweep::Shard::WHOLE,
        };
        let mut set = args.set.clone();
        if let Some(d) = args.duration {
            set.push(format!("sim.duration_s={d}"));
        }
        let name = scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        let out = args.out.clone().unwrap_or_else(|| {
            let mut n = format!("sweep_{name}");
            if shard != sweep::Shard::WHOLE {
                n.push_str(&format!("_shard_{}_of_{}", shard.index, shard.count));
            }
            PathBuf::from("runs").join(n)
        });
        sweep::SweepOptions::new(
            &scene,
            set,
            varies,
            args.repeat as usize,
            shard,
            args.jobs.unwrap_or(0) as usize,
            args.traces,
            out,
        )
    })();
    let mut opts = match prepared {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    opts.resume = args.resume;
    opts.stop = stop_on_signals();
    let range = opts.shard.range(opts.grid.total());
    let previous = sweep::previous_outputs(&opts.out_dir);
    if !previous.is_empty() {
        println!(
            "{}    {}: {}",
            if opts.resume { "resume " } else { "replace" },
            opts.out_dir.display(),
            previous.join(", ")
        );
    }
    println!(
        "sweep      {}: {} runs{} on {} jobs",
        scene.display(),
        range.len(),
        if opts.shard == sweep::Shard::WHOLE {
            String::new()
        } else {
            format!(
                " (shard {} of {} runs: {}..{})",
                opts.shard,
                opts.grid.total(),
                range.start,
                range.end
            )
        },
        if opts.jobs == 0 {
            rayon::current_num_threads()
        } else {
            opts.jobs
        }
    );
    let started = std::time::Instant::now();
    match sweep::run_sweep(&opts, &sweep_progress(range.len())) {
        Ok(o) => {
            let failed: Vec<_> = o.results.iter().filter(|r| r.outcome.is_err()).collect();
            println!(
                "done       {} runs in {:.1} s, {} failed{}",
                o.results.len(),
                started.elapsed().as_secs_f64(),
                failed.len(),
                if o.resumed > 0 {
                    format!(" (and {} kept from the interrupted sweep)", o.resumed)
                } else {
                    String::new()
                }
            );
            for r in failed.iter().take(5) {
                if let Err(e) = &r.outcome {
                    println!("  run {}: {e}", r.point.index);
                }
            }
            println!("results    {}", o.results_csv.display());
            println!("plots      {}", opts.out_dir.join("plots").display());
            ExitCode::SUCCESS
        }
        Err(e @ sweep::SweepError::Interrupted { .. }) => {
            eprintln!("{e}");
            // The shell's code for a process ended by SIGINT.
            ExitCode::from(130)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
