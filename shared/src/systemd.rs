//! Talking to the service manager (sd_notify(3)): `READY=1` once every topic is open,
//! `WATCHDOG=1` from the event loop, one-line `STATUS=` texts, `STOPPING=1` on the way out.
//!
//! Outside systemd (`NOTIFY_SOCKET` unset) every call does nothing, so a service runs the same
//! from a shell. The watchdog is pinged from the loop that does the work, never from a thread of
//! its own, so a hung loop stops the pings and systemd kills it (`WatchdogSec=`). A stale input is
//! not a reason to stop pinging: it shows in the status instead (DESIGN §11).

use std::time::{Duration, Instant};

/// How often the loop must at least wake when no watchdog is configured (for status updates).
const IDLE_TICK: Duration = Duration::from_secs(1);

/// The service's side of the sd_notify protocol.
#[derive(Debug)]
pub struct Notifier {
    /// `NOTIFY_SOCKET` was set: there is a manager listening.
    enabled: bool,
    /// `WatchdogSec=` of the unit, when it names this process.
    watchdog: Option<Duration>,
    last_ping: Option<Instant>,
    status: String,
    ready: bool,
    /// Notifications that could not be sent (logged once, then counted).
    failures: u64,
}

impl Notifier {
    /// Reads `NOTIFY_SOCKET`, `WATCHDOG_USEC` and `WATCHDOG_PID` from the environment.
    pub fn from_env() -> Self {
        let enabled = std::env::var_os("NOTIFY_SOCKET").is_some_and(|s| !s.is_empty());
        let watchdog = if enabled {
            sd_notify::watchdog_enabled().filter(|d| !d.is_zero())
        } else {
            None
        };
        Notifier {
            enabled,
            watchdog,
            last_ping: None,
            status: String::new(),
            ready: false,
            failures: 0,
        }
    }

    /// Whether a service manager is listening.
    pub fn enabled(&self) -> bool {
        self.enabled
    }

    /// The unit's watchdog timeout, if any.
    pub fn watchdog(&self) -> Option<Duration> {
        self.watchdog
    }

    /// How often the event loop must at least wake up: a quarter of the watchdog timeout, so one
    /// late wake-up never costs the service its life; one second without a watchdog.
    pub fn tick(&self) -> Duration {
        self.watchdog.map_or(IDLE_TICK, |w| {
            (w / 4).clamp(Duration::from_millis(10), IDLE_TICK)
        })
    }

    /// `READY=1` with a first status: call once every publisher and subscriber is open. Sent
    /// once: a later call only updates the status. (The manager arms the watchdog on the first
    /// `READY=1` and ignores the rest; a looped replay that sent it on every pass, resetting the
    /// ping clock each time without a `WATCHDOG=1`, was killed by the watchdog — issue 23.)
    pub fn ready(&mut self, status: &str) {
        if self.ready {
            self.status(status);
            return;
        }
        self.status = status.to_string();
        self.ready = true;
        self.send(&[
            sd_notify::NotifyState::Ready,
            sd_notify::NotifyState::Status(status),
        ]);
        self.last_ping = Some(Instant::now());
    }

    /// `WATCHDOG=1` when a ping is due (every [`Notifier::tick`]); call on every turn of the loop.
    pub fn alive(&mut self, now: Instant) {
        if self.watchdog.is_none() || !self.ready {
            return;
        }
        let due = self
            .last_ping
            .is_none_or(|t| now.saturating_duration_since(t) >= self.tick());
        if due {
            self.send(&[sd_notify::NotifyState::Watchdog]);
            self.last_ping = Some(now);
        }
    }

    /// `STATUS=` — sent only when the text changed. Keep it one line.
    pub fn status(&mut self, status: &str) {
        if status == self.status {
            return;
        }
        self.status.clear();
        self.status.push_str(status);
        self.send(&[sd_notify::NotifyState::Status(status)]);
    }

    /// A status naming a silent input: `stale input: {what} for N s` once `last` (the latest
    /// input) is `after` or more before `now`; nothing before that.
    pub fn silent(&mut self, now: Instant, last: Instant, after: Duration, what: &str) {
        let quiet = now.saturating_duration_since(last);
        if quiet >= after {
            self.status(&format!("stale input: {what} for {} s", quiet.as_secs()));
        }
    }

    /// `STOPPING=1` with a last status.
    pub fn stopping(&mut self, status: &str) {
        self.status = status.to_string();
        self.send(&[
            sd_notify::NotifyState::Stopping,
            sd_notify::NotifyState::Status(status),
        ]);
    }

    /// Notifications that could not be sent.
    pub fn failures(&self) -> u64 {
        self.failures
    }

    fn send(&mut self, state: &[sd_notify::NotifyState<'_>]) {
        if !self.enabled {
            return;
        }
        if let Err(e) = sd_notify::notify(state) {
            self.failures += 1;
            if self.failures == 1 || self.failures.is_power_of_two() {
                tracing::warn!(
                    failures = self.failures,
                    "cannot notify the service manager through NOTIFY_SOCKET: {e}"
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::net::UnixDatagram;

    /// Runs `f` with `NOTIFY_SOCKET` pointing at a socket of our own and returns what arrived.
    /// The environment is process-wide: this is the only test of the crate that touches it.
    #[test]
    fn notifications_reach_the_socket_and_pings_are_rate_limited() {
        let dir = std::env::temp_dir().join(format!("mimnav-notify-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("notify");
        let _ = std::fs::remove_file(&path);
        let socket = UnixDatagram::bind(&path).expect("bind");
        socket.set_nonblocking(true).expect("nonblocking");
        // SAFETY: no other test of this crate reads or writes these variables
        unsafe {
            std::env::set_var("NOTIFY_SOCKET", &path);
            std::env::set_var("WATCHDOG_USEC", "2000000");
            std::env::set_var("WATCHDOG_PID", std::process::id().to_string());
        }
        let mut n = Notifier::from_env();
        assert!(n.enabled());
        assert_eq!(n.watchdog(), Some(Duration::from_secs(2)));
        assert_eq!(n.tick(), Duration::from_millis(500));

        let t0 = Instant::now();
        n.alive(t0); // not ready yet: nothing
        n.ready("topics open");
        n.alive(t0 + Duration::from_millis(100)); // too soon after READY
        n.alive(t0 + Duration::from_millis(700));
        n.alive(t0 + Duration::from_millis(800)); // too soon after the last ping
        n.ready("topics open again"); // READY=1 once: only the status, the ping clock untouched
        n.alive(t0 + Duration::from_millis(1200)); // due: 500 ms after the last ping
        n.status("topics open again"); // unchanged: nothing
        n.status("stale input: no map for 0.2 s");
        let t1 = t0 + Duration::from_secs(5);
        n.silent(
            t1,
            t1 - Duration::from_millis(900),
            Duration::from_secs(1),
            "no scan",
        ); // not yet
        n.silent(
            t1,
            t1 - Duration::from_millis(2500),
            Duration::from_secs(1),
            "no scan",
        );
        n.silent(
            t1,
            t1 - Duration::from_millis(2600),
            Duration::from_secs(1),
            "no scan",
        ); // same
        n.stopping("stopping");

        // SAFETY: as above (sd_notify reads NOTIFY_SOCKET on every call, so it stayed set)
        unsafe {
            std::env::remove_var("NOTIFY_SOCKET");
            std::env::remove_var("WATCHDOG_USEC");
            std::env::remove_var("WATCHDOG_PID");
        }
        let mut got = Vec::new();
        let mut buf = [0u8; 512];
        while let Ok(len) = socket.recv(&mut buf) {
            got.push(String::from_utf8_lossy(&buf[..len]).into_owned());
        }
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(
            got,
            [
                "READY=1\nSTATUS=topics open\n",
                "WATCHDOG=1\n",
                "STATUS=topics open again\n",
                "WATCHDOG=1\n",
                "STATUS=stale input: no map for 0.2 s\n",
                "STATUS=stale input: no scan for 2 s\n",
                "STOPPING=1\nSTATUS=stopping\n",
            ]
        );
        assert_eq!(n.failures(), 0);
    }

    #[test]
    fn without_a_manager_nothing_is_sent_and_the_loop_still_ticks() {
        let n = Notifier {
            enabled: false,
            watchdog: None,
            last_ping: None,
            status: String::new(),
            ready: false,
            failures: 0,
        };
        assert_eq!(n.tick(), IDLE_TICK);
    }
}
