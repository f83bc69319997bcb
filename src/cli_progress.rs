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

/// What the fits under way have left, for the live line: the longest by its pace so far
/// (`3 fits under way, the longest at iteration 4 of at most 30: about 1 min 5 s more at
/// its pace so far`), or nothing while none runs. An estimate, not a bound: a fit stops
/// early once it converges, and its later iterations may cost more than its first (a
/// stage that confirms through the simulator).
fn time_left() -> String {
    let fits = activity::running_fits();
    let longest = fits
        .iter()
        .filter_map(|f| f.most_left_s().map(|s| (s, f)))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let Some((left_s, f)) = longest else {
        return String::new();
    };
    let many = if fits.len() > 1 {
        format!("{} fits under way, the longest", fits.len())
    } else {
        "fit".to_string()
    };
    format!(
        "; {many} at iteration {} of at most {}: about {} more at its pace so far",
        f.done,
        f.max,
        duration_words(left_s)
    )
}

/// A duration as people say it: `45 s`, `3 min 20 s`, `1 h 5 min`.
fn duration_words(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..=59 => format!("{s} s"),
        60..=3599 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, (s % 3600) / 60),
    }
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
    let ticker = match bar.clone() {
        Some(b) => Some(live_ticker(b, start, stop.clone(), stage.clone())),
        None => Some(log_ticker(command, start, stop.clone(), stage.clone())),
    };
    let _ = DISPLAY.set(Display {
        command,
        start,
        bar,
        stage,
        stop,
        ticker: Mutex::new(ticker),
    });
}

/// How often a log (not a terminal) gets a line while a stage goes on.
const LOG_EVERY: Duration = Duration::from_secs(30);

/// The terminal's live line, redrawn five times a second.
fn live_ticker(
    b: indicatif::ProgressBar,
    start: Instant,
    stop: Arc<AtomicBool>,
    stage: Arc<Mutex<String>>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        while !stop.load(Ordering::Relaxed) {
            let now = stage.lock().map(|s| s.clone()).unwrap_or_default();
            // The counts and time left first: a narrow terminal cuts the stage's end.
            b.set_message(format!("[{}{}]  {now}", counts(start), time_left()));
            b.tick();
            std::thread::sleep(Duration::from_millis(200));
        }
    })
}

/// In a log: a line after every [`LOG_EVERY`] without a stage line, with the counts and
/// the time left, so that a long stage shows it is going on.
fn log_ticker(
    command: &'static str,
    start: Instant,
    stop: Arc<AtomicBool>,
    stage: Arc<Mutex<String>>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut last = Instant::now();
        let mut seen = String::new();
        while !stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(100));
            let now = stage.lock().map(|s| s.clone()).unwrap_or_default();
            if now != seen {
                // A stage line was just printed.
                (seen, last) = (now, Instant::now());
            }
            if last.elapsed() >= LOG_EVERY {
                last = Instant::now();
                eprintln!(
                    "{command:<10} still working  [{}{}]",
                    counts(start),
                    time_left()
                );
            }
        }
    })
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

/// Runs `print` (which writes to standard output) with the live line cleared, then
/// draws the line again: a report printed as it comes does not end the display.
pub fn above(print: impl FnOnce()) {
    match DISPLAY.get().and_then(|d| d.bar.as_ref()) {
        Some(b) => b.suspend(print),
        None => print(),
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
    fn durations_read_as_people_say_them() {
        assert_eq!(super::duration_words(44.6), "45 s");
        assert_eq!(super::duration_words(200.0), "3 min 20 s");
        assert_eq!(super::duration_words(3900.0), "1 h 5 min");
    }

    #[test]
    fn counts_are_grouped_by_thousands() {
        assert_eq!(super::grouped(0), "0");
        assert_eq!(super::grouped(999), "999");
        assert_eq!(super::grouped(1000), "1,000");
        assert_eq!(super::grouped(1234567), "1,234,567");
    }
}
