//! `mimnav record --out run.mcap`: the stack's topics into an MCAP file that Foxglove and the
//! `mcap` tools read.
//!
//! Subscribes to every topic (or the `--topic`s named) and writes each sample as a JSON message
//! ([`convert`]) into lz4-compressed chunks of about 1 MiB. A chunk goes to the file when it
//! fills and at least once a second, so a recorder killed outright (SIGKILL, power) leaves a file
//! whose complete chunks a streaming reader still reads; only a clean end (`--seconds`,
//! `--max-bytes`, SIGINT, SIGTERM) writes the summary (indexes, statistics) that seeking
//! readers want.
//!
//! Times: a message's **log time** is when the recorder received it, on `CLOCK_MONOTONIC`,
//! converted to ns since the Unix epoch with the offset between the two clocks measured at the
//! start (so log times increase with arrival, also while replaying an old capture); its
//! **publish time** is the sample's own sensor stamp (`stamp_ns`) where its type has one
//! (points, scans, odometry, maps, truth, foliage verdicts), else the log time. The Foxglove
//! messages' `timestamp` is the sensor stamp.

pub mod convert;
pub mod restore;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use mimnav_config::Config;
use mimnav_shared::hop::Hop;
use mimnav_shared::ipc::{self, Svc};

use convert::{BadSample, Topic};

/// Arguments of `mimnav record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// The MCAP file to write (replaced if it exists).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Record this topic (repeatable), e.g. `lidar/points` or `mimnav/odom` [default: all of
    /// lidar/points, lidar/scan2d, cmd_vel, odom, goal, base/state, sim/truth, map/layers,
    /// map/plan, foliage/alarm].
    #[arg(long = "topic", value_name = "NAME")]
    topics: Vec<String>,
    /// End the recording after this many seconds.
    #[arg(long, value_name = "S")]
    seconds: Option<f64>,
    /// End the recording once the file holds this many bytes (the summary adds a little).
    #[arg(long, value_name = "N", default_value_t = 4 << 30)]
    max_bytes: u64,
    /// Go on in a new file once the current one holds this many bytes: FILE, then FILE-1,
    /// FILE-2, … before the extension (run.mcap, run-1.mcap, …), each a whole MCAP file with
    /// its own summary. --max-bytes counts them all.
    #[arg(long, value_name = "N")]
    rotate_bytes: Option<u64>,
}

/// The `k`-th file of a rotated recording: `out` itself, then `out`'s stem with `-k`.
fn rotated(out: &std::path::Path, k: u32) -> PathBuf {
    if k == 0 {
        return out.to_path_buf();
    }
    let stem = out
        .file_stem()
        .map_or_else(Default::default, |s| s.to_string_lossy());
    let name = match out.extension() {
        Some(e) => format!("{stem}-{k}.{}", e.to_string_lossy()),
        None => format!("{stem}-{k}"),
    };
    out.with_file_name(name)
}

/// One open MCAP file: its writer, its channels' ids (in the order of the topics), the
/// transforms' channel, and how far it is written.
struct Open {
    writer: mcap::Writer<Counted>,
    ids: Vec<u16>,
    tf: Option<u16>,
    end: Arc<AtomicU64>,
    path: PathBuf,
}

impl Open {
    /// Creates `path` with a channel for each topic and, with odometry, the transforms'.
    fn create(path: PathBuf, topics: &[Topic]) -> Result<Open> {
        let file =
            File::create(&path).with_context(|| format!("cannot create {}", path.display()))?;
        let end = Arc::new(AtomicU64::new(0));
        let counted = Counted {
            file: BufWriter::with_capacity(1 << 16, file),
            pos: 0,
            end: end.clone(),
        };
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Lz4))
            .chunk_size(Some(CHUNK_BYTES))
            .create(counted)
            .with_context(|| format!("cannot write {}", path.display()))?;
        let mut ids = Vec::new();
        for topic in topics {
            let schema = serde_json::to_vec(&topic.schema())?;
            let schema_id = writer.add_schema(topic.schema_name(), "jsonschema", &schema)?;
            ids.push(writer.add_channel(schema_id, topic.name(), "json", &BTreeMap::new())?);
        }
        // the frames' transforms ride with odometry
        let tf = if topics.contains(&Topic::Odom) {
            let schema = serde_json::to_vec(&convert::transforms_schema())?;
            let schema_id = writer.add_schema(convert::TF_SCHEMA, "jsonschema", &schema)?;
            Some(writer.add_channel(schema_id, convert::TF_CHANNEL, "json", &BTreeMap::new())?)
        } else {
            None
        };
        Ok(Open {
            writer,
            ids,
            tf,
            end,
            path,
        })
    }

    /// Writes the summary and closes the file; its size.
    fn finish(mut self) -> Result<u64> {
        self.writer
            .finish()
            .with_context(|| format!("cannot finish {}", self.path.display()))?;
        Ok(self.end.load(Ordering::Relaxed))
    }
}

/// Uncompressed size at which a chunk is closed and written.
const CHUNK_BYTES: u64 = 1 << 20;
/// A chunk is written at least this often, so a killed recorder loses at most this much.
const FLUSH_EVERY: Duration = Duration::from_secs(1);
/// How long the loop sleeps when every subscriber is empty.
const IDLE: Duration = Duration::from_millis(5);

/// A file that counts how far it has been written (the `mcap` writer owns it).
struct Counted {
    file: BufWriter<File>,
    pos: u64,
    end: Arc<AtomicU64>,
}

impl Write for Counted {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.pos += n as u64;
        self.end.fetch_max(self.pos, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Seek for Counted {
    fn seek(&mut self, to: SeekFrom) -> std::io::Result<u64> {
        self.pos = self.file.seek(to)?;
        Ok(self.pos)
    }
}

/// One subscribed topic.
enum Sub {
    Points(ipc::PointsSubscriber),
    Scan(ipc::ScanSubscriber),
    Odom(ipc::ValueSubscriber<mimnav_shared::topics::Odometry>),
    CmdVel(ipc::ValueSubscriber<mimnav_shared::topics::VelocityCommand>),
    Goal(ipc::ValueSubscriber<mimnav_shared::topics::Goal>),
    Plan(ipc::PlanSubscriber),
    Layers(ipc::LayersSubscriber),
    Foliage(ipc::FoliageSubscriber),
    BaseState(ipc::ValueSubscriber<mimnav_shared::topics::BaseState>),
    Truth(ipc::TruthSubscriber),
}

/// A converted sample: its sequence number, its sensor stamp if its type has one, the message,
/// and for odometry the frames' transforms at its pose.
type Converted = (
    u64,
    Option<u64>,
    Result<Vec<u8>, BadSample>,
    Option<Vec<u8>>,
);

/// Where the sensor sits on the robot, for the transforms written with odometry.
struct Frames {
    mount: mimnav_shared::pose::LidarMount,
    sensor_height_m: f64,
}

impl Sub {
    fn open(node: &iceoryx2::prelude::Node<Svc>, topic: Topic) -> Result<Sub, ipc::IpcError> {
        Ok(match topic {
            Topic::Points => Sub::Points(ipc::points_subscriber(node)?),
            Topic::Scan2d => Sub::Scan(ipc::scan_subscriber(node)?),
            Topic::Odom => Sub::Odom(ipc::odom_subscriber(node)?),
            Topic::CmdVel => Sub::CmdVel(ipc::cmd_vel_subscriber(node)?),
            Topic::Goal => Sub::Goal(ipc::goal_subscriber(node)?),
            Topic::Plan => Sub::Plan(ipc::plan_subscriber(node)?),
            Topic::Layers => Sub::Layers(ipc::layers_subscriber(node)?),
            Topic::Foliage => Sub::Foliage(ipc::foliage_subscriber(node)?),
            Topic::BaseState => Sub::BaseState(ipc::base_state_subscriber(node)?),
            Topic::Truth => Sub::Truth(ipc::truth_subscriber(node)?),
        })
    }

    /// The next sample, converted, if one is waiting. A slice sample is released before this
    /// returns (a slice subscriber may hold one at a time).
    fn next(&self, frames: &Frames) -> Result<Option<Converted>, ipc::IpcError> {
        use convert as c;
        Ok(match self {
            Sub::Points(s) => s.receive()?.map(|s| {
                let h = s.user_header();
                (h.seq, Some(h.stamp_ns), Ok(c::points(h, s.payload())), None)
            }),
            Sub::Scan(s) => s.receive()?.map(|s| {
                let h = s.user_header();
                (h.seq, Some(h.stamp_ns), Ok(c::scan(h, s.payload())), None)
            }),
            Sub::Plan(s) => s.receive()?.map(|s| {
                let h = s.user_header();
                (h.seq, Some(h.stamp_ns), c::plan(h, s.payload()), None)
            }),
            Sub::Layers(s) => s.receive()?.map(|s| {
                let h = s.user_header();
                (h.seq, Some(h.stamp_ns), c::layers(h, s.payload()), None)
            }),
            Sub::Foliage(s) => s.receive()?.map(|s| {
                let h = s.user_header();
                (
                    h.seq,
                    Some(h.stamp_ns),
                    Ok(c::foliage(h, s.payload())),
                    None,
                )
            }),
            Sub::Truth(s) => s.receive()?.map(|s| {
                let h = s.user_header();
                (h.seq, Some(h.stamp_ns), c::truth(h, s.payload()), None)
            }),
            Sub::Odom(s) => s.receive()?.map(|o| {
                let tf = c::transforms(&o, &frames.mount, frames.sensor_height_m);
                (o.seq, Some(o.stamp_ns), Ok(c::odom(&o)), Some(tf))
            }),
            Sub::CmdVel(s) => s
                .receive()?
                .map(|v| (v.seq, None, Ok(c::cmd_vel(&v)), None)),
            Sub::Goal(s) => s.receive()?.map(|g| (g.seq, None, Ok(c::goal(&g)), None)),
            Sub::BaseState(s) => s
                .receive()?
                .map(|b| (b.seq, None, Ok(c::base_state(&b)), None)),
        })
    }
}

/// What happened on one topic.
struct Channel {
    topic: Topic,
    sub: Sub,
    id: u16,
    hop: Hop,
    written: u64,
    bad: u64,
    errors: u64,
}

/// The topics named on the command line (all when none), each once.
fn selected(names: &[String]) -> Result<Vec<Topic>> {
    if names.is_empty() {
        return Ok(Topic::ALL.to_vec());
    }
    let mut topics = Vec::new();
    for n in names {
        let Some(t) = Topic::parse(n) else {
            let known: Vec<&str> = Topic::ALL.iter().map(|t| t.name()).collect();
            bail!("unknown topic {n:?}: one of {}", known.join(", "));
        };
        if !topics.contains(&t) {
            topics.push(t);
        }
    }
    Ok(topics)
}

/// Why the recording ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum End {
    Signal,
    Seconds,
    MaxBytes,
}

/// Records until a limit or a signal ends it, then writes the summary and prints the counts.
pub fn run(config: &Config, args: &RecordArgs) -> Result<ExitCode> {
    let topics = selected(&args.topics)?;
    if let Some(s) = args.seconds
        && !(s > 0.0 && s.is_finite())
    {
        bail!("--seconds must be positive: {s}");
    }
    if args.rotate_bytes == Some(0) {
        bail!("--rotate-bytes must be positive");
    }
    let node = ipc::node(config, "mimnav-record")?;
    let mut channels = Vec::new();
    let mut open = Open::create(args.out.clone(), &topics)?;
    for (&topic, &id) in topics.iter().zip(&open.ids) {
        channels.push(Channel {
            topic,
            sub: Sub::open(&node, topic)?,
            id,
            hop: Hop::new(),
            written: 0,
            bad: 0,
            errors: 0,
        });
    }
    // the files finished before the open one: path and size
    let mut done: Vec<(PathBuf, u64)> = Vec::new();
    let frames = Frames {
        mount: config.robot.mount,
        sensor_height_m: config.robot.sensor_height_m,
    };
    let mut tf_written = 0u64;
    let open_tf = open.tf.is_some();
    // CLOCK_MONOTONIC → Unix ns
    let epoch_offset = ipc::realtime_ns() as i128 - ipc::monotonic_ns() as i128;
    let start = Instant::now();
    let until = args.seconds.map(|s| start + Duration::from_secs_f64(s));
    let mut last_flush = Instant::now();
    tracing::info!(
        "recording {} topic(s) into {}",
        channels.len(),
        args.out.display()
    );
    let why = loop {
        let mut busy = false;
        for ch in &mut channels {
            // at most a few samples a topic a turn, so one busy topic cannot starve the others
            for _ in 0..8 {
                let got = match ch.sub.next(&frames) {
                    Ok(Some(got)) => got,
                    Ok(None) => break,
                    Err(e) => {
                        ch.errors += 1;
                        tracing::warn!("{}: {e}", ch.topic.name());
                        break;
                    }
                };
                busy = true;
                let (seq, stamp, message, tf) = got;
                ch.hop.see(seq);
                let message = match message {
                    Ok(m) => m,
                    Err(e) => {
                        ch.bad += 1;
                        tracing::warn!("{}: sample {seq} skipped: {e}", ch.topic.name());
                        continue;
                    }
                };
                let log_time = (ipc::monotonic_ns() as i128 + epoch_offset).max(0) as u64;
                let header = mcap::records::MessageHeader {
                    channel_id: ch.id,
                    sequence: seq as u32,
                    log_time,
                    publish_time: stamp.unwrap_or(log_time),
                };
                open.writer
                    .write_to_known_channel(&header, &message)
                    .with_context(|| format!("cannot write {}", open.path.display()))?;
                ch.written += 1;
                if let (Some(id), Some(tf)) = (open.tf, tf) {
                    let header = mcap::records::MessageHeader {
                        channel_id: id,
                        ..header
                    };
                    open.writer
                        .write_to_known_channel(&header, &tf)
                        .with_context(|| format!("cannot write {}", open.path.display()))?;
                    tf_written += 1;
                }
            }
        }
        let written = open.end.load(Ordering::Relaxed);
        if done.iter().map(|d| d.1).sum::<u64>() + written >= args.max_bytes {
            break End::MaxBytes;
        }
        if args.rotate_bytes.is_some_and(|r| written >= r) {
            let next = Open::create(rotated(&args.out, done.len() as u32 + 1), &topics)?;
            for (ch, &id) in channels.iter_mut().zip(&next.ids) {
                ch.id = id;
            }
            let old = std::mem::replace(&mut open, next);
            let path = old.path.clone();
            let size = old.finish()?;
            tracing::info!(
                "{}: {size} bytes, going on in {}",
                path.display(),
                open.path.display()
            );
            done.push((path, size));
            last_flush = Instant::now();
        }
        if until.is_some_and(|u| Instant::now() >= u) {
            break End::Seconds;
        }
        if last_flush.elapsed() >= FLUSH_EVERY {
            open.writer.flush()?;
            last_flush = Instant::now();
        }
        if !busy && !ipc::sleep(&node, IDLE) {
            break End::Signal;
        }
    };
    let path = open.path.clone();
    open.finish()?;
    let bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
    for (p, size) in &done {
        outln!("{}: {size} bytes", p.display())?;
    }
    outln!(
        "{}: {} bytes, {:.1} s, ended by {}",
        path.display(),
        bytes,
        start.elapsed().as_secs_f64(),
        match why {
            End::Signal => "a signal",
            End::Seconds => "--seconds",
            End::MaxBytes => "--max-bytes",
        }
    )?;
    for ch in &channels {
        outln!(
            "{}: {} written, {} dropped (not kept up with), {} bad, {} receive errors",
            ch.topic.name(),
            ch.written,
            ch.hop.dropped(),
            ch.bad,
            ch.errors
        )?;
    }
    if open_tf {
        outln!(
            "{}: {tf_written} written (with odometry)",
            convert::TF_CHANNEL
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotated_files_are_numbered_before_the_extension() {
        let p = std::path::Path::new("/data/run.mcap");
        assert_eq!(rotated(p, 0), p);
        assert_eq!(rotated(p, 2), std::path::Path::new("/data/run-2.mcap"));
        assert_eq!(
            rotated(std::path::Path::new("run"), 1),
            std::path::Path::new("run-1")
        );
    }

    #[test]
    fn topics_are_all_by_default_each_once_and_checked() {
        assert_eq!(selected(&[]).unwrap().len(), 10);
        let two = selected(&["odom".into(), "mimnav/odom".into(), "map/plan".into()]).unwrap();
        assert_eq!(two, [Topic::Odom, Topic::Plan]);
        let err = selected(&["lidar/nope".into()]).unwrap_err().to_string();
        assert!(
            err.contains("unknown topic") && err.contains("mimnav/lidar/points"),
            "{err}"
        );
    }
}
