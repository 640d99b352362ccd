//! `mimnav check-config`: the config is read and checked (as every command does first); this
//! prints where it came from and the settings in force that every service shares.

use std::process::ExitCode;

use anyhow::Result;
use mimnav_config::Config;

/// Prints the config's source, `[robot]`, `[velodyne]` and the iceoryx2 domain.
pub fn run(config: &Config) -> Result<ExitCode> {
    let source = match config.from_file() {
        true => config.path.display().to_string(),
        false => "built-in defaults".into(),
    };
    outln!(
        "{source}: ok\n[robot] {:#?}\n[velodyne] {:#?}\n[iceoryx2] root-path {} prefix {}",
        config.robot,
        config.velodyne,
        config.iceoryx2.global.root_path(),
        config.iceoryx2.global.prefix
    )?;
    Ok(ExitCode::SUCCESS)
}
