//! Writes the seed corpus of every fuzz target to `DIR/TARGET/` (default `fuzz/corpus`), made
//! from the real captures in `../shared/data/velodyne` and the repository's `config/`.
//! `fuzz/seed.sh` runs it.
use std::path::PathBuf;

fn main() {
    let dir = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("fuzz/corpus"));
    if mimnav_fuzz_bodies::real_captures().is_empty() {
        eprintln!(
            "note: no captures in {}: the velodyne_stream and capture corpora are empty",
            mimnav_fuzz_bodies::captures_dir().display()
        );
    }
    for target in mimnav_fuzz_bodies::TARGETS {
        let out = dir.join(target);
        std::fs::create_dir_all(&out).expect("create the corpus folder");
        let seeds = mimnav_fuzz_bodies::seeds(target);
        for (name, bytes) in &seeds {
            std::fs::write(out.join(name), bytes).expect("write a seed");
        }
        println!("{target}: {} seeds in {}", seeds.len(), out.display());
    }
}
