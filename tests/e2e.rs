//! End-to-end tests: the real binaries run as separate processes and talk over iceoryx2.
//!
//! Every test has its own private iceoryx2 domain (root path and prefix), so tests run in
//! parallel and never meet a running stack. Tests that need the real captures in
//! `../shared/data` print a SKIP line where the folder is missing.

/// The `mimnav` command line.
mod cli;
/// The foliage classifier behind the driver replaying a capture.
mod foliage;
/// The mapper on the real capture and behind the simulator and the driver.
mod mapper;
/// The simulator streaming to the driver, and lock-step with a stand-in planner.
mod sim;
/// `docs/topics.md` against the types and the services the `ipc` functions create.
mod topics_doc;
/// The systemd units, `mimnav install`, and the stack under a real systemd user manager.
mod systemd;
/// Helpers: finding the binaries, the shared data, receiving revolutions.
mod util;
/// The VLP-16 driver as a process: replay, UDP, bad input, config errors, SIGTERM.
mod velodyne;
