//! What `agvsim sweep` shows and hears on a terminal: the progress display, and SIGINT or
//! SIGTERM turned into a stop request (the work is the library's `commands::sweep`).

/// Reports sweep progress: a bar with rate and time left on a terminal, a plain line every
/// tenth of the runs otherwise (logs of batch jobs). The bar is made at the first report,
/// when the number of runs is known.
pub fn sweep_progress() -> impl Fn(usize, usize) + Sync {
    use std::io::IsTerminal;
    let start = std::time::Instant::now();
    let terminal = std::io::stderr().is_terminal();
    let bar: std::sync::OnceLock<indicatif::ProgressBar> = std::sync::OnceLock::new();
    move |done, total| {
        if terminal {
            let b = bar.get_or_init(|| {
                let b = indicatif::ProgressBar::new(total as u64);
                b.set_style(
                    indicatif::ProgressStyle::with_template(
                        "{bar:40} {pos}/{len} runs  {per_sec}  {eta} left",
                    )
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
                );
                b
            });
            b.set_position(done as u64);
            if done == total {
                b.finish_and_clear();
            }
        } else {
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
pub fn stop_on_signals() -> Option<&'static std::sync::atomic::AtomicBool> {
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
