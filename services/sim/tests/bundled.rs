//! The capture the end-to-end tests replay is the simulator's own output: regenerating it
//! from the shipped config gives the same bytes.

use std::path::PathBuf;

use mimnav_config::Config;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Sim, write_capture};

#[test]
fn the_bundled_capture_is_reproducible() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let config = Config::load(&root.join("config/mimnav.toml"), &[]).expect("shipped config");
    let world =
        WorldFile::load(&root.join("config/worlds/scenario2_curtain_door.toml")).expect("world");
    let mut sim = Sim::new(
        world.compile(),
        config.sim_settings(),
        config.sim.seed,
        DEFAULT_EPOCH_NS,
    );
    let mut bytes = Vec::new();
    let ports = (config.velodyne.data_port, config.velodyne.position_port);
    let stats = write_capture(&mut sim, 0.5, ports, &mut bytes).expect("write");
    assert_eq!(stats.packets, 754);
    let bundled =
        std::fs::read(root.join("captures/scenario2_curtain_door.pcap")).expect("bundled capture");
    assert!(
        bundled.len() < 1 << 20,
        "small enough to ship: {} bytes",
        bundled.len()
    );
    assert!(
        bytes == bundled,
        "captures/scenario2_curtain_door.pcap differs from what the simulator writes now; \
         regenerate it with the command in docs/commands.md (mimnav sim)"
    );
}
