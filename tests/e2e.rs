//! End-to-end tests: the real binaries run as separate processes and talk over iceoryx2.
//!
//! Every test has its own private iceoryx2 domain (root path and prefix), so tests run in
//! parallel and never meet a running stack. Tests that need the real captures in
//! `../shared/data` print a SKIP line where the folder is missing, and so do the tests of the Python
//! client where there is no Python with iceoryx2's binding (`MIMNAV_PYTHON`, which `.ci/run` sets,
//! makes a missing one an error), and the Spot bridge's test where there is no Python with
//! `bosdyn-client` (`MIMNAV_SPOT_PYTHON`, likewise).

/// Issue 23: worlds, goals, configs and captures the stack cannot use, at the command line.
mod bad_input;
/// The `mimnav` command line.
mod cli;
/// The foliage classifier behind the driver replaying a capture.
mod foliage;
/// Issue 23's defects under bad input and faults, a regression test named after each.
mod hardening;
/// The Kobuki base's service against a simulated base on a pseudo-terminal (issue 24).
mod kobuki;
/// Signals and leftovers (issue 23, items 9 and 10): the demo's children, shared memory after a
/// SIGKILL, file modes.
mod lifecycle;
/// The lock-step runner against the services as processes: the same commands.
mod lockstep;
/// The mapper on the real capture and behind the simulator and the driver.
mod mapper;
/// The Python client on iceoryx2's binding: its contract, behind the driver, as a publisher.
mod python_client;
/// `mimnav record`: the stack's topics into an MCAP file, read back with PyPI's `mcap`.
mod record;
/// The SICK ladar's service against an emulated scanner on a loopback TCP port (issue 26).
mod sick;
/// The simulator streaming to the driver, and lock-step with a stand-in planner (the whole
/// stack in lock-step is in `lockstep`); its simulated SICK served over TCP.
mod sim;
/// The Spot bridge (`clients/python/mimnav_spot.py`) against a fake Spot made of `bosdyn-api`'s
/// servicers (issue 24).
mod spot;
/// The systemd units, `mimnav install`, and the stack under a real systemd user manager.
mod systemd;
/// `docs/topics.md` against the types and the services the `ipc` functions create.
mod topics_doc;
/// Helpers: finding the binaries, the shared data, receiving revolutions.
mod util;
/// The VLP-16 driver as a process: replay, UDP, bad input, config errors, SIGTERM.
mod velodyne;
/// `mimnav-view`: the Foxglove live view, watched by PyPI's `websockets` (issue 25).
mod view;
/// Generated worlds (issue 22): determinism, well-formedness, reachability, eval per family.
mod worlds;
/// `mimnav-zenoh` between two network namespaces, with PyPI's `eclipse-zenoh` as the remote host
/// (issue 25).
mod zenoh;
