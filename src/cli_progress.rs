//! What a fitting command (diagnose, calibrate) shows while it works, on standard error
//! so that the report on standard output stays clean for pipes. On a terminal: each stage
//! as a line, under a live line with the current stage, the solver's iterations and the
//! record simulations so far, and the time taken. Elsewhere (a log, a pipe): the same
//! counts on each stage's plain line.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use agvsim::ident::activity;

/// The display of this process's fitting command.
struct Display {
    command: &'static str,
    start: Instant,
    bar: Option<indicatif::ProgressBar>,
    /// The last stage told, for the live line.
    stage: Arc<Mutex<String>>,
    stop: Arc<AtomicBool>,
    ticker: Mutex<Option<std::thread::JoinHandle<()>>>,
}

static DISPLAY: OnceLock<Display> = OnceLock::new();

/// The counts so far, for a line: `412 iterations, 5,310 simulations, 12.4 s`.
fn counts(start: Instant) -> String {
    let a = activity::totals();
    format!(
        "{} iterations, {} simulations, {:.1} s",
        grouped(a.iterations),
        grouped(a.evaluations),
        start.elapsed().as_secs_f64()
    )
}

/// A count with thousands separated by commas.
fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Starts the display for `command`. Call once, before the command's work.
pub fn start(command: &'static str) {
    let start = Instant::now();
    let stop = Arc::new(AtomicBool::new(false));
    let bar = std::io::stderr().is_terminal().then(|| {
        let b = indicatif::ProgressBar::new_spinner();
        b.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {prefix:10} {wide_msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        b.set_prefix(command);
        b
    });
    let stage = Arc::new(Mutex::new(String::new()));
    let ticker = bar.clone().map(|b| {
        let (stop, stage) = (stop.clone(), stage.clone());
        std::thread::spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                let now = stage.lock().map(|s| s.clone()).unwrap_or_default();
                b.set_message(format!("{now}  [{}]", counts(start)));
                b.tick();
                std::thread::sleep(Duration::from_millis(200));
            }
        })
    });
    let _ = DISPLAY.set(Display {
        command,
        start,
        bar,
        stage,
        stop,
        ticker: Mutex::new(ticker),
    });
}

/// Tells the stage the command has reached (callable from worker threads).
pub fn stage(msg: &str) {
    let Some(d) = DISPLAY.get() else {
        eprintln!("{msg}");
        return;
    };
    if let Ok(mut s) = d.stage.lock() {
        *s = msg.to_string();
    }
    let line = format!("{:<10} {msg}  [{}]", d.command, counts(d.start));
    match &d.bar {
        Some(b) => b.println(line),
        None => eprintln!("{line}"),
    }
}

/// Ends the display: the live line is cleared, the stage lines stay.
pub fn finish() {
    let Some(d) = DISPLAY.get() else { return };
    d.stop.store(true, Ordering::Relaxed);
    if let Some(t) = d.ticker.lock().ok().and_then(|mut t| t.take()) {
        let _ = t.join();
    }
    if let Some(b) = &d.bar {
        b.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn counts_are_grouped_by_thousands() {
        assert_eq!(super::grouped(0), "0");
        assert_eq!(super::grouped(999), "999");
        assert_eq!(super::grouped(1000), "1,000");
        assert_eq!(super::grouped(1234567), "1,234,567");
    }
}
