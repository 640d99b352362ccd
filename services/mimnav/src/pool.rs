//! Running evaluation episodes on every core: one episode per thread at a time, with a progress
//! bar. Shared by `mimnav eval` and `mimnav foliage-eval`.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

use indicatif::{ProgressBar, ProgressStyle};

/// The threads to use: as many as asked (`--jobs`), else one per core; 1 to 64.
pub fn workers(asked: Option<usize>) -> usize {
    asked
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, 64)
}

/// Runs `run` on every job on `workers` threads and returns the results in job order. The
/// progress bar (hidden when `quiet`) is handed to `run`, which may set its message.
pub fn run_all<J: Sync, T: Send>(
    jobs: &[J],
    workers: usize,
    quiet: bool,
    run: impl Fn(&J, &ProgressBar) -> T + Sync,
) -> Vec<T> {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        let b = ProgressBar::new(jobs.len() as u64);
        b.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:40}] {pos}/{len} episodes, {eta} left {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    };
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, T)>> = Mutex::new(Vec::with_capacity(jobs.len()));
    std::thread::scope(|s| {
        for _ in 0..workers.min(jobs.len()) {
            s.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(job) = jobs.get(k) else {
                        break;
                    };
                    let r = run(job, &bar);
                    if let Ok(mut v) = results.lock() {
                        v.push((k, r));
                    }
                    bar.inc(1);
                }
            });
        }
    });
    bar.finish_and_clear();
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.sort_by_key(|&(k, _)| k);
    results.into_iter().map(|(_, r)| r).collect()
}
