//! Issue 27, item 1: the map built as the revolution arrives.
//!
//! The driver hands a revolution out in slices of whole packets (`lidar/slices`) and the mapper
//! bins each at once; at the revolution's last slice only what needs the whole revolution is
//! left. These tests drive the simulator through scenario 1 (glass) and scenario 4 (grass
//! around rocks) on a curving route, so the de-skew matters, and check:
//! - the assembler hands every revolution out whole, in order, in slices of at most the asked
//!   packets (one more after an early cut), its last slice carrying the revolution's header;
//! - the mapper binning a revolution in pieces maps it bit for bit as it maps it whole;
//! - the step maps a revolution from its slices whatever their size, and whole, the same map bit
//!   for bit, and the predicted de-skew it uses changes few cells against the exact one;
//! - a revolution whose slices break off is counted and mapped from `lidar/points` instead.

use mimnav_config::Config;
use mimnav_mapper::step::{MapStep, Mapped};
use mimnav_mapper::{Deskew, Mapper, Odom, OdomInput};
use mimnav_shared::pose::pose2;
use mimnav_shared::topics::{Point, PointsHeader, SliceHeader, cell_class};
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig, Revolution};

/// One datagram of the drive: its bytes, the host time it came at, the sensor time now.
struct Packet {
    data: Vec<u8>,
    host_ns: u64,
    now: u64,
    /// The odometry after it, when it completed a revolution.
    odom: Option<mimnav_shared::topics::Odometry>,
}

/// `revolutions` revolutions of a drive through `world` on a curving route (a turn of about
/// 90° over 4 m), every packet kept.
fn drive(world: &str, revolutions: u64) -> Vec<Packet> {
    let path = format!("{}/../../config/worlds/{world}", env!("CARGO_MANIFEST_DIR"));
    let world = WorldFile::load(std::path::Path::new(&path)).expect("the world loads");
    let config = Config::default();
    let mut sim = Sim::new(world.compile(), config.sim_settings(), 7, DEFAULT_EPOCH_NS);
    let start = sim.base().pose;
    let (x0, y0) = (start.translation.x, start.translation.y);
    let route = vec![[x0 + 2.0, y0], [x0 + 3.0, y0 + 1.0], [x0 + 3.0, y0 + 3.0]];
    let mut driver = WaypointDriver::new(route, 0.2);
    let limits = sim.settings().robot.clone();
    let mut asm = Assembler::new(AssemblerConfig::from_config(&config.velodyne));
    let (mut out, mut done) = (Vec::new(), 0u64);
    while sim.outcome() == Outcome::Running && done < revolutions {
        let step = sim.step();
        let now = sim.now_ns();
        let odom = step.completes_revolution.then(|| sim.odometry(done, now));
        if let Ok(Some(_)) = asm.push(&step.data, step.first_firing_ns, now) {
            done += 1;
            let (v, w) = driver.command(&sim.base().pose, &limits);
            sim.set_command(v, w);
        }
        out.push(Packet {
            data: step.data.to_vec(),
            host_ns: step.first_firing_ns,
            now,
            odom,
        });
    }
    assert_eq!(
        done,
        revolutions,
        "the drive ended early: {:?}",
        sim.outcome()
    );
    out
}

/// A slice as the topic carries it.
type Slice = (SliceHeader, Vec<Point>);

/// The packets through an assembler handing out slices of `packets` packets: every revolution
/// completed and every slice, each slice after the packet it followed (its index in `drive`).
fn assemble(drive: &[Packet], packets: u32) -> (Vec<Revolution>, Vec<(usize, Slice)>) {
    let config = Config::default();
    let mut asm = Assembler::new(AssemblerConfig::from_config(&config.velodyne));
    let (mut revs, mut slices) = (Vec::new(), Vec::new());
    for (k, p) in drive.iter().enumerate() {
        if let Ok(Some(rev)) = asm.push(&p.data, p.host_ns, p.now) {
            revs.push(rev.clone());
        }
        asm.take_slices(packets, |h, pts| slices.push((k, (*h, pts.to_vec()))));
    }
    (revs, slices)
}

#[test]
fn every_revolution_is_handed_out_whole_in_slices_of_whole_packets() {
    let mut packets = drive("scenario1_glass_wall.toml", 6);
    // a gap in the stream: the revolution under way is cut early, before the late packet
    let late = packets.len() / 2 + 7;
    for p in &mut packets[late..] {
        p.host_ns += 2_000_000_000;
    }
    for size in [1u32, 3, 4, 16] {
        let (revs, slices) = assemble(&packets, size);
        let mut rebuilt: Vec<(PointsHeader, Vec<Point>)> = Vec::new();
        let mut open: Option<(PointsHeader, Vec<Point>, u32)> = None;
        for (_, (h, pts)) in &slices {
            let points_per_packet = 384;
            assert!(
                pts.len() <= (size as usize + 1) * points_per_packet,
                "a slice of {} points for {size} packets",
                pts.len()
            );
            let (header, buf, next) = open.get_or_insert((h.revolution, Vec::new(), 0));
            assert_eq!(h.index, *next, "slices numbered in order from 0");
            assert_eq!(
                h.first_point as usize,
                buf.len(),
                "no point lost or repeated"
            );
            assert_eq!(h.revolution.seq, header.seq);
            assert_eq!(h.revolution.stamp_ns, header.stamp_ns);
            buf.extend_from_slice(pts);
            *next += 1;
            if h.last != 0 {
                let (_, buf, _) = open.take().expect("open");
                rebuilt.push((h.revolution, buf));
            }
        }
        assert_eq!(rebuilt.len(), revs.len(), "slices of {size} packets");
        assert!(
            revs.iter().any(|r| r.header.cut_reason != 0),
            "the gap cut a revolution early"
        );
        for ((h, pts), rev) in rebuilt.iter().zip(&revs) {
            assert_eq!(
                *h, rev.header,
                "the last slice carries the revolution's header"
            );
            assert!(pts == &rev.points, "revolution {} rebuilt whole", h.seq);
        }
    }
}

fn odom_input(o: &mimnav_shared::topics::Odometry) -> OdomInput {
    OdomInput::Fresh(Odom {
        pose: pose2(o.x, o.y, o.yaw),
        v: f64::from(o.v),
        omega: f64::from(o.omega),
    })
}

fn snapshot(m: &Mapper) -> (Vec<u8>, Vec<u8>, Vec<u32>) {
    (
        m.classes().to_vec(),
        m.cost().to_vec(),
        m.layers().map(f32::to_bits).collect(),
    )
}

#[test]
fn a_revolution_binned_in_pieces_maps_bit_for_bit_as_whole() {
    let packets = drive("scenario4_grass_intertwined.toml", 12);
    let (revs, _) = assemble(&packets, 0);
    let odoms: Vec<_> = packets.iter().filter_map(|p| p.odom).collect();
    let params = Config::default().mapper_params();
    let (mut whole, mut pieces) = (Mapper::new(params.clone()), Mapper::new(params));
    let mut cut = 12_345usize;
    let (mut at_end_whole, mut at_end_pieces) = (0u64, 0u64);
    for (rev, o) in revs.iter().zip(&odoms) {
        let input = odom_input(o);
        at_end_whole += u64::from(
            whole
                .update(&rev.points, input, rev.header.stamp_ns)
                .classified_at_end,
        );
        let t_end = rev.points.last().map_or(0, |p| p.time_offset_ns);
        pieces.begin(Deskew::of(input, t_end));
        let pts = &rev.points;
        let mut at = 0;
        while at < pts.len() {
            // pieces of any length, ending between firings (a pair stays together)
            cut = cut.wrapping_mul(1_103_515_245).wrapping_add(12_345) % 4096;
            let mut end = (at + 1 + cut).min(pts.len());
            while end < pts.len() && pts[end].time_offset_ns == pts[end - 1].time_offset_ns {
                end += 1;
            }
            pieces.bin_slice(&pts[at..end]);
            at = end;
        }
        at_end_pieces += u64::from(pieces.finish(input, rev.header.stamp_ns).classified_at_end);
        assert!(
            snapshot(&whole) == snapshot(&pieces),
            "revolution {} differs",
            rev.header.seq
        );
    }
    let solid = whole
        .classes()
        .iter()
        .filter(|&&c| c == cell_class::SOLID)
        .count();
    assert!(solid > 50, "the grass world's map has solids: {solid}");
    // most cells were classified as the pieces came, not after the last one (issue 27)
    println!("cells classified after the last piece: {at_end_pieces} of {at_end_whole}");
    assert!(
        at_end_pieces * 5 < at_end_whole,
        "{at_end_pieces} of {at_end_whole} cells classified after the last piece"
    );
}

/// The packets through a step fed as the mapper service feeds it: slices of `size` packets
/// (0: none), the odometry before the revolution's last packet, then the whole revolution on
/// `lidar/points`, skipping the slice numbered `skip` of the revolution `skip_in`. Returns every
/// map (and whether its slices made it) and the step.
fn run_step(
    packets: &[Packet],
    size: u32,
    skip: Option<(u64, u32)>,
) -> (Vec<(Mapped, bool, Vec<u8>)>, MapStep) {
    let config = Config::default();
    let mut step = config.map_step();
    let mut asm = Assembler::new(AssemblerConfig::from_config(&config.velodyne));
    let mut maps = Vec::new();
    for p in packets {
        if let Some(o) = &p.odom {
            step.odom(o).expect("finite");
        }
        let rev = asm.push(&p.data, p.host_ns, p.now).ok().flatten().cloned();
        // 0: the driver publishes no slices
        let size = if size == 0 { u32::MAX } else { size };
        asm.take_slices(size, |h, pts| {
            if size == u32::MAX || skip == Some((h.revolution.seq, h.index)) {
                return;
            }
            if let Some(m) = step.slice(h, pts, p.now) {
                maps.push((m, true, step.mapper().classes().to_vec()));
            }
        });
        if let Some(rev) = rev
            && let Some(m) = step.revolution(&rev.header, &rev.points, p.now)
        {
            maps.push((m, false, step.mapper().classes().to_vec()));
        }
    }
    (maps, step)
}

#[test]
fn the_step_maps_from_slices_of_any_size_and_whole_the_same_map() {
    let packets = drive("scenario1_glass_wall.toml", 14);
    let (whole, _) = run_step(&packets, 0, None);
    assert!(
        whole.iter().all(|m| !m.1),
        "no slices: every map from lidar/points"
    );
    let (four, step) = run_step(&packets, 4, None);
    assert_eq!(step.broken_slices(), 0);
    assert!(four.iter().all(|m| m.1), "every map from its slices");
    assert_eq!(step.maps_from_slices(), four.len() as u64);
    assert_eq!(four.len(), whole.len(), "one map per revolution");
    for size in [1, 16] {
        let (other, _) = run_step(&packets, size, None);
        for (a, b) in four.iter().zip(&other) {
            assert_eq!(a.0.header, b.0.header);
            assert!(a.2 == b.2, "slices of 4 and {size} packets map alike");
        }
    }
    // the same de-skew either way: the same maps, bit for bit
    for (a, b) in four.iter().zip(&whole) {
        assert_eq!(a.0.header, b.0.header);
        assert!(
            a.2 == b.2,
            "revolution {}: slices and whole alike",
            a.0.header.source_seq
        );
    }
    // and the prediction it rests on is close to de-skewing each revolution to its own end
    // with the odometry after it: the robot turns and accelerates here, and still the maps
    // differ only in cells at the edge of what a few centimetres move
    let odoms: Vec<_> = packets.iter().filter_map(|p| p.odom).collect();
    let (revs, _) = assemble(&packets, 0);
    let mut mapper = Mapper::new(Config::default().mapper_params());
    let (mut known, mut differ) = (0usize, 0usize);
    for ((rev, o), a) in revs.iter().zip(&odoms).zip(&four) {
        mapper.update(&rev.points, odom_input(o), rev.header.stamp_ns);
        for (&x, &y) in a.2.iter().zip(mapper.classes()) {
            if x != cell_class::UNKNOWN || y != cell_class::UNKNOWN {
                known += 1;
                differ += usize::from(x != y);
            }
        }
    }
    let share = differ as f64 / known as f64;
    eprintln!("predicted against exact de-skew: {differ} of {known} known cells differ");
    assert!(known > 10_000, "{known} cells known");
    assert!(share < 0.01, "{differ} of {known} known cells differ");
}

#[test]
fn a_revolution_whose_slices_break_off_is_mapped_from_lidar_points() {
    let packets = drive("scenario1_glass_wall.toml", 8);
    let (maps, step) = run_step(&packets, 4, Some((4, 9)));
    assert_eq!(step.broken_slices(), 1, "counted once");
    let from: Vec<(u64, bool)> = maps.iter().map(|m| (m.0.header.source_seq, m.1)).collect();
    let expected: Vec<(u64, bool)> = (0..8).map(|s| (s, s != 4)).collect();
    assert_eq!(
        from, expected,
        "revolution 4 from lidar/points, the rest from slices"
    );
    assert_eq!(step.points_hop().dropped(), 0);
}
