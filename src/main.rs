//! The `agvsim` command: parses arguments, calls the library's command, prints.

use std::process::ExitCode;

use clap::Parser;

use cli_args::{BatchAction, Cli, Command, SweepAction, SweepArgs};

mod cli_args;
mod cli_progress;
mod cli_sweep;

use agvsim::commands::{self, CommandError};

/// Piped into `head` or a pager that quits, the program ends quietly when the reader
/// closes, as command-line tools do, instead of panicking on the failed write (Rust
/// ignores SIGPIPE by default).
#[cfg(unix)]
fn quiet_on_closed_pipe() {
    // SAFETY: setting a signal's disposition to the default at start-up, before any thread
    // exists, has no preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

#[cfg(not(unix))]
fn quiet_on_closed_pipe() {}

/// Prints a command's report as it comes, above any live progress line (which goes on).
fn say(text: &str) {
    cli_progress::above(|| print!("{text}"));
}

/// A reference's text, printed whole.
fn print(text: &str) -> Result<(), CommandError> {
    say(text);
    Ok(())
}

fn main() -> ExitCode {
    quiet_on_closed_pipe();
    let cli = Cli::parse();
    let result = dispatch(cli.command);
    cli_progress::finish();
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if e.is_notice() {
                eprintln!("{e}");
            } else {
                eprintln!("error: {e}");
            }
            ExitCode::from(e.exit_code())
        }
    }
}

/// Runs the command the arguments name.
fn dispatch(command: Command) -> Result<(), CommandError> {
    use commands::*;
    match command {
        Command::Run(r) => run::run(&r, &say),
        Command::Replay(r) => replay::run(&r, &say),
        Command::Calibrate(mut r) => {
            r.progress = cli_progress::stage;
            cli_progress::start("calibrate");
            calibrate::run(&r, &say)
        }
        Command::Diagnose(mut r) => {
            r.progress = Some(cli_progress::stage);
            cli_progress::start("diagnose");
            diagnose::run(&r, &say)
        }
        Command::Identify(r) => identify::run(&r, &say),
        Command::Prove(r) => diagnose::prove(&r, &say),
        Command::Experiment(r) => experiment::run(&r, &say),
        Command::Import { format } => format.run(&say),
        Command::Sweep(args) => sweep(args),
        Command::Linearize(r) => linearize::run(&r, &say),
        Command::Study(r) => study::run(&r, &say),
        Command::Presets => print(&agvsim::scene::presets_table::render()),
        Command::Keys => print(&agvsim::scene::keys::markdown()),
        Command::New(args) => new::run(&args.request(commands::command_line())?, &say),
        Command::Batch { action } => batch(action),
        Command::Check(r) => new::check(&r, &say),
    }
}

/// `agvsim sweep` and `agvsim sweep merge`.
fn sweep(args: SweepArgs) -> Result<(), CommandError> {
    if let Some(SweepAction::Merge { shards, out }) = args.action {
        return commands::sweep::merge(&shards, &out, &say);
    }
    let progress = cli_sweep::sweep_progress();
    let request = commands::sweep::SweepRequest {
        flags: args.flags,
        progress: &progress,
        stop: cli_sweep::stop_on_signals(),
    };
    commands::sweep::run(&request, &say)
}

/// `agvsim batch diagnose|calibrate|merge`.
fn batch(action: BatchAction) -> Result<(), CommandError> {
    let mut request = match action {
        BatchAction::Merge { shards, out } => return commands::batch::merge(&shards, &out, &say),
        BatchAction::Diagnose { request, rig } => commands::batch::BatchRequest { rig, ..request },
        BatchAction::Calibrate { request, scene } => commands::batch::BatchRequest {
            scene: Some(scene),
            ..request
        },
    };
    request.progress = |line| eprintln!("{line}");
    commands::batch::run(&request, &say)
}
