//! What every mimnav process shares: the topic contract ([`topics`]), the IPC layer that opens
//! them with the project's settings ([`ipc`]), the config loader ([`config`]), logging
//! ([`logging`]) and rate-limited fault counting ([`faults`]).
#![deny(missing_docs)]

pub mod cli;
pub mod config;
pub mod faults;
pub mod grid;
pub mod ipc;
pub mod logging;
pub mod systemd;
pub mod topics;
