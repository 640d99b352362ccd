//! Logging setup: `tracing` to stderr, filtered by the config's `log.level` or the `MIMNAV_LOG`
//! environment variable; iceoryx2's own messages arrive through `tracing` too (its `tracing`
//! feature), with its level set to match so it does not format what would be filtered out.
//!
//! Under systemd, when stderr is the journal (`JOURNAL_STREAM` names stderr's device and inode, as
//! systemd.exec(5) says to check), events go to the journal natively through `tracing-journald`:
//! with their priority, their fields as journal fields (`journalctl -o verbose` shows `SEQ=`,
//! `PROCESSING_US=`, …) and the target and source location. If the journal's socket cannot be
//! opened, stderr is used without timestamps or colours (the journal stamps each line itself).

use tracing_subscriber::EnvFilter;
use tracing_subscriber::filter::LevelFilter;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;

/// Environment variable that overrides the configured filter.
pub const LOG_ENV: &str = "MIMNAV_LOG";

/// Installs the global subscriber. `level` is the configured filter (`log.level`); a bad filter
/// falls back to `info` with a warning. Calling it twice keeps the first subscriber.
pub fn init(level: &str) {
    let (filter, bad) = match std::env::var(LOG_ENV) {
        Ok(v) if !v.is_empty() => match EnvFilter::try_new(&v) {
            Ok(f) => (f, None),
            Err(e) => (EnvFilter::new("info"), Some(format!("{LOG_ENV}={v}: {e}"))),
        },
        _ => match EnvFilter::try_new(level) {
            Ok(f) => (f, None),
            Err(e) => (
                EnvFilter::new("info"),
                Some(format!("log.level = {level:?}: {e}")),
            ),
        },
    };
    let max = filter.max_level_hint().unwrap_or(LevelFilter::TRACE);
    let journal = stderr_is_journal();
    let mut journal_error = None;
    let installed = match journal.then(tracing_journald::layer) {
        Some(Ok(layer)) => tracing_subscriber::registry()
            .with(filter)
            .with(layer)
            .try_init()
            .is_ok(),
        other => {
            if let Some(Err(e)) = other {
                journal_error = Some(e);
            }
            let ansi = !journal && std::io::IsTerminal::is_terminal(&std::io::stderr());
            // a closed stderr (the reader of a pipe gone) loses the lines, never the process:
            // without this the writer's error is reported with eprintln!, which panics
            let fmt = tracing_subscriber::fmt()
                .with_env_filter(filter)
                .with_writer(std::io::stderr)
                .log_internal_errors(false)
                .with_ansi(ansi);
            if journal {
                fmt.without_time().try_init().is_ok()
            } else {
                fmt.try_init().is_ok()
            }
        }
    };
    if let Some(e) = journal_error {
        tracing::warn!("cannot open the journal's socket, logging to stderr: {e}");
    }
    if installed {
        iceoryx2::prelude::set_log_level(iceoryx2_level(max));
    }
    if let Some(bad) = bad {
        tracing::warn!("invalid log filter, using `info`: {bad}");
    }
}

/// Whether stderr is the journal's stream: `JOURNAL_STREAM=<device>:<inode>` of stderr.
// dev_t and ino_t are not u64 on every platform
#[allow(clippy::unnecessary_cast)]
fn stderr_is_journal() -> bool {
    std::env::var("JOURNAL_STREAM")
        .ok()
        .and_then(|v| parse_journal_stream(&v))
        .is_some_and(|(dev, ino)| {
            let mut st = std::mem::MaybeUninit::<libc::stat>::uninit();
            // SAFETY: fstat writes a stat into the buffer it is given, and only reads fd 2
            let ok = unsafe { libc::fstat(2, st.as_mut_ptr()) } == 0;
            // SAFETY: fstat succeeded, so the buffer is initialised
            ok && {
                let st = unsafe { st.assume_init() };
                st.st_dev as u64 == dev && st.st_ino as u64 == ino
            }
        })
}

/// `"<device>:<inode>"`, both decimal.
fn parse_journal_stream(v: &str) -> Option<(u64, u64)> {
    let (dev, ino) = v.trim().split_once(':')?;
    Some((dev.parse().ok()?, ino.parse().ok()?))
}

fn iceoryx2_level(max: LevelFilter) -> iceoryx2::prelude::LogLevel {
    use iceoryx2::prelude::LogLevel;
    match max {
        LevelFilter::TRACE => LogLevel::Trace,
        LevelFilter::DEBUG => LogLevel::Debug,
        LevelFilter::INFO => LogLevel::Info,
        LevelFilter::WARN => LogLevel::Warn,
        _ => LogLevel::Error,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stderr_is_the_journal_only_when_journal_stream_names_it() {
        let mut st = std::mem::MaybeUninit::<libc::stat>::uninit();
        // SAFETY: fstat writes into the buffer it is given
        assert_eq!(unsafe { libc::fstat(2, st.as_mut_ptr()) }, 0);
        // SAFETY: fstat succeeded
        let st = unsafe { st.assume_init() };
        // SAFETY: nextest runs each test in a process of its own; nothing else reads it here
        unsafe { std::env::set_var("JOURNAL_STREAM", format!("{}:{}", st.st_dev, st.st_ino)) };
        assert!(stderr_is_journal());
        // inherited by a child whose stderr went elsewhere: not the journal
        unsafe { std::env::set_var("JOURNAL_STREAM", format!("{}:{}", st.st_dev, st.st_ino + 1)) };
        assert!(!stderr_is_journal());
        unsafe { std::env::remove_var("JOURNAL_STREAM") };
        assert!(!stderr_is_journal());
    }

    #[test]
    fn journal_stream_is_device_colon_inode() {
        assert_eq!(parse_journal_stream("8:123456"), Some((8, 123456)));
        assert_eq!(parse_journal_stream(" 66305:2\n"), Some((66305, 2)));
        assert_eq!(parse_journal_stream("8-123"), None);
        assert_eq!(parse_journal_stream("x:1"), None);
        assert_eq!(parse_journal_stream(""), None);
    }
}
