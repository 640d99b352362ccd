//! An independent decoder, velodyne-decoder 3.1.0 from PyPI, takes the simulator's captures
//! without complaint and finds the same revolutions with the same point counts as the driver.
//!
//! It needs a Python with velodyne-decoder, dpkt and numpy: `MIMNAV_VD_PYTHON`, else
//! `target/vd-venv/bin/python` (`.ci/run` makes that virtual environment). Without one the test
//! prints a SKIP line.

use std::path::PathBuf;
use std::process::Command;

use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Sim, SimSettings};
use mimnav_velodyne::capture::{CaptureReader, PcapDatagramWriter};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

fn python() -> Option<PathBuf> {
    let p = match std::env::var_os("MIMNAV_VD_PYTHON") {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/vd-venv/bin/python"),
    };
    let ok = Command::new(&p)
        .args(["-c", "import velodyne_decoder, dpkt, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if ok {
        Some(p)
    } else {
        println!(
            "SKIP: no Python with velodyne-decoder at {} (python3 -m venv target/vd-venv && \
             target/vd-venv/bin/pip install velodyne-decoder==3.1.0 dpkt numpy)",
            p.display()
        );
        None
    }
}

#[test]
fn velodyne_decoder_finds_the_same_revolutions_in_simulated_captures() {
    let Some(python) = python() else { return };
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/vd_frame_counts.py");
    for world in ["scenario1_glass_wall", "scenario4_grass_intertwined"] {
        let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join(format!("../../config/worlds/{world}.toml"));
        let scene = WorldFile::load(&path).expect("world").compile();
        let mut sim = Sim::new(scene, SimSettings::default(), 11, DEFAULT_EPOCH_NS);
        let out =
            std::env::temp_dir().join(format!("mimnav-vd-{}-{world}.pcap", std::process::id()));
        {
            let file = std::fs::File::create(&out).expect("create");
            let mut w = PcapDatagramWriter::new(std::io::BufWriter::new(file)).expect("header");
            let src = (std::net::Ipv4Addr::new(192, 168, 1, 201), 2368);
            let dst = (std::net::Ipv4Addr::BROADCAST, 2368);
            while sim.elapsed_s() < 0.55 {
                let step = sim.step();
                w.write(step.send_ns, src, dst, &step.data).expect("write");
            }
            use std::io::Write;
            w.into_inner().flush().expect("flush");
        }
        // ours
        let mut asm = Assembler::new(AssemblerConfig::default());
        let mut reader = CaptureReader::open(&out).expect("open");
        let mut ours = Vec::new();
        while let Some(d) = reader.next().expect("read") {
            if let Some(r) = asm
                .push(d.payload, d.ts_ns, 0)
                .expect("the driver decodes every packet")
            {
                ours.push(r.points.len());
            }
        }
        if let Some(r) = asm.finish() {
            ours.push(r.points.len());
        }
        // theirs
        let o = Command::new(&python)
            .arg(&script)
            .arg(&out)
            .output()
            .expect("run python");
        assert!(
            o.status.success(),
            "velodyne-decoder refused the capture: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let theirs: Vec<usize> = String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(|l| l.trim().parse().expect("a count"))
            .collect();
        println!("{world}: driver {ours:?}, velodyne-decoder {theirs:?}");
        assert!(ours.len() >= 5, "{ours:?}");
        assert_eq!(ours, theirs, "{world}: point counts per revolution");
        std::fs::remove_file(&out).ok();
    }
}
