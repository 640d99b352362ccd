//! The mimnav planner as a library (no IPC): obstacle inflation on the intensity map and the
//! dynamic window approach that turns it into a velocity command.
//!
//! - [`inflate`]: the adaptive kernel (equations 8–9), inflation (eq. 10) and the planning map
//!   (eq. 11), with uniform inflation as the paper's ablation;
//! - [`dwa`]: the footprint clearance, the dynamic window and the trajectory scores (eq. 12).
//!
//! The service that feeds them `map/plan`, `odom` and the goal and publishes `cmd_vel` comes with
//! issue 5.
#![deny(missing_docs)]

pub mod dwa;
pub mod inflate;
