//! Decode throughput, telegrams/s: an LMS5xx scan at its finest step of the default rate
//! (1/6°, 1 141 measurements) with all five echoes and their remission (10 channels), through
//! the driver's whole path — framing, `LMDscandata` parsing and the conversion to returns with
//! the last echo chosen — in CoLa-B and CoLa-A, one core, the telegram looped in memory. Also
//! the real TiM5xx telegram (CoLa-A) when `../shared/data/sick` is there.
//!
//! `cargo bench -p mimnav-sick --bench decode` (criterion's "thrpt" is telegrams/s).

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mimnav_sick::SickConfig;
use mimnav_sick::cola::{Dialect, Framer};
use mimnav_sick::config::Model;
use mimnav_sick::device::Device;
use mimnav_sick::scandata::ScanData;

/// An LMS5xx telegram: 5 echoes, each with remission, at 25 Hz and 1/6°.
fn lms5xx(d: Dialect) -> Vec<u8> {
    let mut dev = Device::new(Model::Lms5xx, d, 1);
    let mut to_dev = Vec::new();
    // log in and ask for every echo, as the driver does
    let cfg = SickConfig {
        protocol: d,
        model: Model::Lms5xx,
        ..SickConfig::default()
    };
    let mut s = mimnav_sick::session::Session::new(cfg.session());
    s.begin(0, &mut to_dev);
    for _ in 0..8 {
        let mut a = Vec::new();
        dev.receive(&std::mem::take(&mut to_dev), &mut a);
        s.receive(&a, 0, &mut to_dev, |_| {});
    }
    let g = dev.geometry();
    assert_eq!(g.count, 1141);
    let echoes: Vec<Vec<u16>> = (0..5)
        .map(|e| {
            (0..g.count)
                .map(|i| (2000 + 500 * e + (i * 37) % 3000) as u16)
                .collect()
        })
        .collect();
    let rssi: Vec<Vec<u16>> = (0..5)
        .map(|e| (0..g.count).map(|i| ((i + e) % 256) as u16).collect())
        .collect();
    let mut wire = Vec::new();
    dev.scan_telegram(0, &echoes, &rssi, &mut wire);
    wire
}

fn decode(c: &mut Criterion, name: &str, d: Dialect, wire: &[u8]) {
    let conv = SickConfig {
        model: Model::Lms5xx,
        ..SickConfig::default()
    }
    .converter();
    let mut framer = Framer::new(d, 1 << 20);
    let (mut scan, mut out) = (ScanData::default(), Vec::new());
    let mut g = c.benchmark_group("sick decode");
    g.throughput(Throughput::Elements(1));
    g.bench_function(format!("{name} ({} bytes)", wire.len()), |b| {
        b.iter(|| {
            framer.push(black_box(wire));
            let Some(Ok(p)) = framer.next() else {
                panic!("a telegram")
            };
            scan.parse(d, p).expect("parses");
            conv.convert(&scan, &mut out).expect("converts");
            black_box(out.len())
        })
    });
    g.finish();
}

fn benches(c: &mut Criterion) {
    for d in [Dialect::ColaB, Dialect::ColaA] {
        let wire = lms5xx(d);
        decode(
            c,
            &format!("LMS5xx 5 echoes + RSSI, 1141 values, {}", d.name()),
            d,
            &wire,
        );
    }
    let dir = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("sick"),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sick"),
    };
    match std::fs::read(dir.join("tim5xx_continuous_scan.cola")) {
        Ok(t) => decode(
            c,
            "real TiM5xx, 271 values + RSSI, cola_a",
            Dialect::ColaA,
            &t,
        ),
        Err(e) => println!("SKIP the real TiM5xx telegram: {}: {e}", dir.display()),
    }
}

criterion_group!(sick, benches);
criterion_main!(sick);
