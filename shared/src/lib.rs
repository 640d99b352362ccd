//! What every mimnav process shares: the topic contract ([`topics`]), the IPC layer that opens
//! them with the project's settings ([`ipc`]), the config loader ([`config`]), logging
//! ([`logging`]), rate-limited fault counting ([`faults`]) and the latency settings: CPU wake-up
//! latency and real-time scheduling ([`realtime`]).
#![deny(missing_docs)]

pub mod cli;
pub mod config;
pub mod faults;
pub mod grid;
pub mod hop;
pub mod ipc;
pub mod logging;
pub mod pose;
pub mod realtime;
pub mod service;
pub mod signals;
pub mod systemd;
pub mod topics;
