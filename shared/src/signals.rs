//! SIGTERM and SIGINT, remembered until the process has stopped.
//!
//! iceoryx2's signal handler keeps only the *last* signal the process received, and its check
//! (`SignalHandler::termination_requested`) clears what it read. A stop request was lost when
//! another signal it catches landed after the SIGTERM and before the loop looked:
//! - systemd sends SIGCONT right after SIGTERM (so a stopped process can act on it). In a
//!   process with threads of its own (the live view's WebSocket runtime), each may go to a
//!   different thread, and the SIGCONT could overwrite the SIGTERM before the main thread's
//!   WaitSet woke. The view then ran on until `TimeoutStopSec=` killed it, leaving its iceoryx2
//!   node dead (found by `tests/systemd/stack.rs`, 1 run in 5 on a loaded machine).
//! - any SIGUSR1 or SIGCONT delivered together with a SIGTERM to a busy or stopped process.
//!
//! [`install`] puts a handler of ours in front of iceoryx2's for SIGTERM and SIGINT. It counts
//! the requests, a count that nothing clears ([`requested`], [`count`]), writes to an eventfd the service loops wait on
//! ([`wake_fd`]), so the loop wakes whichever thread the signal was delivered to, and then calls
//! iceoryx2's handler, so iceoryx2's own waits still end.

use std::os::fd::RawFd;
use std::sync::Once;
use std::sync::atomic::{AtomicI32, AtomicU32, AtomicUsize, Ordering};

/// The signals that ask a process to stop.
pub const STOP_SIGNALS: [libc::c_int; 2] = [libc::SIGTERM, libc::SIGINT];

static REQUESTS: AtomicU32 = AtomicU32::new(0);
static WAKE: AtomicI32 = AtomicI32::new(-1);
static INSTALL: Once = Once::new();
/// The handler each of [`STOP_SIGNALS`] had before ours, and its `sa_flags`, to call on.
static PREVIOUS: [(AtomicUsize, AtomicUsize); 2] = [
    (AtomicUsize::new(0), AtomicUsize::new(0)),
    (AtomicUsize::new(0), AtomicUsize::new(0)),
];

/// Whether SIGTERM or SIGINT has asked the process to stop, since [`install`]. Never cleared.
pub fn requested() -> bool {
    count() > 0
}

/// How many times SIGTERM or SIGINT came, since [`install`]: a loop that goes on after the first
/// request (stopping the robot) ends early on the next one.
pub fn count() -> u32 {
    REQUESTS.load(Ordering::SeqCst)
}

/// An eventfd that becomes readable once a stop was requested (`None` before [`install`], or if
/// the system had no descriptor left for it: the loops then notice the request at their next
/// wake-up, at most a watchdog interval later).
pub fn wake_fd() -> Option<RawFd> {
    Some(WAKE.load(Ordering::SeqCst)).filter(|&fd| fd >= 0)
}

/// Installs the handler, once per process. Call it after iceoryx2 installed its own (the first
/// wait of a node does that), so ours runs first and then calls iceoryx2's.
pub fn install() {
    INSTALL.call_once(|| {
        // SAFETY: eventfd(2) has no memory arguments; a negative result is handled below.
        let fd = unsafe { libc::eventfd(0, libc::EFD_NONBLOCK | libc::EFD_CLOEXEC) };
        if fd >= 0 {
            WAKE.store(fd, Ordering::SeqCst);
        } else {
            tracing::warn!(
                "cannot create the eventfd that wakes the loop on SIGTERM: {}; a stop is seen \
                 at the next wake-up instead",
                std::io::Error::last_os_error()
            );
        }
        for (i, &signal) in STOP_SIGNALS.iter().enumerate() {
            // SAFETY: a zeroed sigaction is a valid value to fill in; `on_stop` has the
            // SA_SIGINFO signature; `old` is written by sigaction(2) before it is read.
            unsafe {
                let mut action: libc::sigaction = std::mem::zeroed();
                action.sa_sigaction = on_stop as *const () as libc::sighandler_t;
                // no SA_RESTART: the signal must cut a blocking wait short, as iceoryx2's does
                action.sa_flags = libc::SA_SIGINFO;
                libc::sigemptyset(&mut action.sa_mask);
                let mut old: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(signal, &action, &mut old) == 0 {
                    PREVIOUS[i].0.store(old.sa_sigaction, Ordering::SeqCst);
                    PREVIOUS[i].1.store(old.sa_flags as usize, Ordering::SeqCst);
                }
            }
        }
    });
}

/// iceoryx2's signal handler (installed by the first wait) catches SIGABRT and SIGQUIT as well as
/// SIGTERM and SIGINT, and only records them. A hung loop would then survive systemd's watchdog
/// signal (SIGABRT) until `TimeoutAbortSec=` ends it with SIGKILL, and without the core dump the
/// watchdog's abort is for. Give both back their default action: end the process with a core.
pub fn restore_fatal_signals() {
    for signal in [libc::SIGABRT, libc::SIGQUIT] {
        // SAFETY: SIG_DFL is always a valid disposition; no handler of ours is replaced
        unsafe { libc::signal(signal, libc::SIG_DFL) };
    }
}

/// The handler: only async-signal-safe work (atomics, write(2)), errno left as it was.
extern "C" fn on_stop(signal: libc::c_int, info: *mut libc::siginfo_t, context: *mut libc::c_void) {
    // SAFETY: __errno_location() is the calling thread's errno, valid for the thread's life.
    let errno = unsafe { *libc::__errno_location() };
    REQUESTS.fetch_add(1, Ordering::SeqCst);
    let fd = WAKE.load(Ordering::SeqCst);
    if fd >= 0 {
        let one = 1u64;
        // SAFETY: writes 8 bytes from a live u64 to our own eventfd; a full counter (EAGAIN)
        // still leaves it readable, which is all that is needed.
        unsafe { libc::write(fd, (&one as *const u64).cast(), 8) };
    }
    if let Some(i) = STOP_SIGNALS.iter().position(|&s| s == signal) {
        let handler = PREVIOUS[i].0.load(Ordering::SeqCst);
        let flags = PREVIOUS[i].1.load(Ordering::SeqCst) as libc::c_int;
        if handler != libc::SIG_DFL && handler != libc::SIG_IGN {
            // SAFETY: `handler` was the installed handler of this signal, with the signature
            // its SA_SIGINFO flag says; it is called with the arguments the kernel gave us.
            unsafe {
                if flags & libc::SA_SIGINFO != 0 {
                    let f: extern "C" fn(libc::c_int, *mut libc::siginfo_t, *mut libc::c_void) =
                        std::mem::transmute(handler);
                    f(signal, info, context);
                } else {
                    let f: extern "C" fn(libc::c_int) = std::mem::transmute(handler);
                    f(signal);
                }
            }
        }
    }
    // SAFETY: as above.
    unsafe { *libc::__errno_location() = errno };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn readable(fd: RawFd) -> bool {
        let mut p = libc::pollfd {
            fd,
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd, no wait
        unsafe { libc::poll(&mut p, 1, 0) == 1 && p.revents & libc::POLLIN != 0 }
    }

    /// A SIGTERM is remembered and wakes the eventfd, whatever signal comes after it; the
    /// process is not ended by it (nothing but iceoryx2's handler would be behind ours).
    #[test]
    fn a_sigterm_stays_requested_after_a_later_signal_and_wakes_the_eventfd() {
        install();
        let fd = wake_fd().expect("an eventfd");
        assert!(!requested());
        assert!(!readable(fd));
        // SAFETY: raise(3) on this process; SIGCONT's default action on a running process is
        // to do nothing
        unsafe {
            libc::raise(libc::SIGTERM);
            libc::raise(libc::SIGCONT);
        }
        assert!(requested());
        assert_eq!(count(), 1);
        assert!(readable(fd));
        // SAFETY: as above
        unsafe { libc::raise(libc::SIGINT) };
        assert_eq!(count(), 2);
    }
}
