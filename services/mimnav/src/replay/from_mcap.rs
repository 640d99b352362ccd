//! `mimnav replay run.mcap`: a recording of `mimnav record` fed back into the stack.
//!
//! The recorded `lidar/points`, `lidar/scan2d` and `odom` are published again on their topics in
//! the configured iceoryx2 domain — where a running mapper, planner and classifier (perhaps
//! newer than the ones that ran in the field) take them as if the sensor and the base sent them
//! — at the pace they were recorded (by the messages' log times; `--speed`, `--fast`), with
//! every field as it was sent except `rx_mono_ns`, which is stamped now ([`restore`]). The other
//! recorded topics (maps, commands) are what the stack made of its inputs, and are not replayed:
//! the stack makes them again.
//!
//! The file is read as a stream, chunk by chunk, so a recording whose recorder was killed
//! replays up to its last complete chunk, and a long one never has to fit in memory. A message
//! that cannot be restored is counted and named (the first few), and the replay goes on.

use std::collections::HashMap;
use std::fs::File;
use std::io::Read;
use std::path::Path;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader};
use mimnav_config::Config;
use mimnav_shared::ipc::{self, IpcError};
use mimnav_shared::topics;
use mimnav_velodyne::revolution::{AssemblerConfig, max_scan_len};

use super::ReplayArgs;
use crate::record::restore::{self, BadRecord};

/// The first bytes of every MCAP file.
pub const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// Whether `path` starts like an MCAP file.
pub fn is_mcap(path: &Path) -> bool {
    let mut head = [0u8; 8];
    File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == MAGIC)
}

/// Damaged messages named on stderr before the rest are only counted.
const NAMED_BAD: u64 = 5;

/// A topic the replay publishes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Input {
    Points,
    Scan,
    Odom,
}

impl Input {
    fn of(topic: &str) -> Option<Input> {
        match topic {
            topics::LIDAR_POINTS => Some(Input::Points),
            topics::LIDAR_SCAN2D => Some(Input::Scan),
            topics::ODOM => Some(Input::Odom),
            _ => None,
        }
    }
}

/// What the replay did, per topic.
#[derive(Debug, Default)]
struct Counts {
    points: u64,
    scans: u64,
    odom: u64,
    /// Messages of other topics, not replayed.
    skipped: u64,
    bad: u64,
}

/// The publishers, opened on the first message of their topic (a recording of the lidar only
/// leaves `odom` to whoever else publishes it).
struct Outputs<'a> {
    node: &'a iceoryx2::prelude::Node<ipc::Svc>,
    config: &'a Config,
    points: Option<ipc::PointsPublisher>,
    scan: Option<ipc::ScanPublisher>,
    odom: Option<ipc::ValuePublisher<topics::Odometry>>,
}

/// A publisher that cannot be opened: most likely the sensor's own driver or base is running in
/// the same domain.
fn open_err(topic: &str, e: IpcError) -> anyhow::Error {
    anyhow::anyhow!(
        "cannot publish on {topic}: {e} (is the stack's own driver or base publishing it? stop it while replaying)"
    )
}

impl Outputs<'_> {
    /// Publishes one message; `Ok(Err(_))` when the message itself is bad.
    /// For a revolution, its sequence number and point count.
    fn publish(
        &mut self,
        input: Input,
        msg: &[u8],
    ) -> Result<Result<Option<(u64, usize)>, BadRecord>> {
        let now = ipc::monotonic_ns();
        match input {
            Input::Points => {
                let (h, pts) = match restore::points(msg) {
                    Ok(r) => r,
                    Err(e) => return Ok(Err(e)),
                };
                if self.points.is_none() {
                    let asm = AssemblerConfig::from_config(&self.config.velodyne);
                    self.points = Some(
                        ipc::points_publisher(self.node, asm.max_points)
                            .map_err(|e| open_err(topics::LIDAR_POINTS, e))?,
                    );
                }
                let Some(p) = &self.points else {
                    return Ok(Ok(None));
                };
                if pts.len() > p.capacity() {
                    return Ok(Err(BadRecord(format!(
                        "{} points, more than a revolution holds here ({}; velodyne.max_points)",
                        pts.len(),
                        p.capacity()
                    ))));
                }
                let h = topics::PointsHeader {
                    rx_mono_ns: now,
                    ..h
                };
                p.publish(h, &pts)?;
                return Ok(Ok(Some((h.seq, pts.len()))));
            }
            Input::Scan => {
                let (h, returns) = match restore::scan(msg) {
                    Ok(r) => r,
                    Err(e) => return Ok(Err(e)),
                };
                if self.scan.is_none() {
                    let v = &self.config.velodyne;
                    let asm = AssemblerConfig::from_config(v);
                    let max = max_scan_len(v.rpm, asm.max_duration_ns as f64 * 1e-9);
                    self.scan = Some(
                        ipc::scan_publisher(self.node, max)
                            .map_err(|e| open_err(topics::LIDAR_SCAN2D, e))?,
                    );
                }
                let Some(p) = &self.scan else {
                    return Ok(Ok(None));
                };
                if returns.len() > p.capacity() {
                    return Ok(Err(BadRecord(format!(
                        "a scan of {} returns, more than one holds here ({})",
                        returns.len(),
                        p.capacity()
                    ))));
                }
                let h = topics::ScanHeader {
                    rx_mono_ns: now,
                    ..h
                };
                p.publish(h, &returns)?;
            }
            Input::Odom => {
                let o = match restore::odom(msg) {
                    Ok(o) => o,
                    Err(e) => return Ok(Err(e)),
                };
                if self.odom.is_none() {
                    self.odom = Some(
                        ipc::odom_publisher(self.node).map_err(|e| open_err(topics::ODOM, e))?,
                    );
                }
                if let Some(p) = &self.odom {
                    p.publish(topics::Odometry {
                        rx_mono_ns: now,
                        ..o
                    })?;
                }
            }
        }
        Ok(Ok(None))
    }
}

/// Paces the replay by the recording's log times.
struct Pace {
    speed: Option<f64>,
    first: Option<(u64, Instant)>,
}

impl Pace {
    /// Sleeps until the message logged at `log_ns` is due; false once Ctrl-C or SIGTERM came.
    fn wait(&mut self, node: &iceoryx2::prelude::Node<ipc::Svc>, log_ns: u64) -> bool {
        let Some(speed) = self.speed else {
            // as fast as possible: only look for a stop request
            return ipc::sleep(node, Duration::ZERO);
        };
        let (t0, start) = *self.first.get_or_insert((log_ns, Instant::now()));
        // log times may step back a little between topics (the recorder drains one topic at a
        // time): such a message is simply due at once
        let due = start + Duration::from_secs_f64(log_ns.saturating_sub(t0) as f64 * 1e-9 / speed);
        let now = Instant::now();
        if due > now {
            return ipc::sleep(node, due - now);
        }
        true
    }
}

/// Replays `args.file`, an MCAP recording, into the configured domain.
pub fn run(config: &Config, args: &ReplayArgs) -> Result<ExitCode> {
    let file =
        File::open(&args.file).with_context(|| format!("cannot open {}", args.file.display()))?;
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    let node = ipc::node(config, "mimnav-replay")?;
    let mut out = Outputs {
        node: &node,
        config,
        points: None,
        scan: None,
        odom: None,
    };
    let mut pace = Pace {
        speed: (!args.fast).then_some(args.speed),
        first: None,
    };
    outln!(
        "replaying {} ({:.1} MB) into the stack's iceoryx2 domain: lidar/points, lidar/scan2d, odom",
        args.file.display(),
        size as f64 / 1e6,
    )?;
    let started = Instant::now();
    let mut counts = Counts::default();
    let mut interrupted = false;
    let mut damage = None;
    loop {
        let pass = replay_once(&mut ReplayPass {
            file: &args.file,
            out: &mut out,
            pace: &mut pace,
            counts: &mut counts,
            quiet: args.quiet,
        })?;
        match pass {
            PassEnd::Interrupted => {
                interrupted = true;
                break;
            }
            PassEnd::Damaged(e) => {
                damage = Some(e);
                break;
            }
            PassEnd::Complete if args.repeat => {
                pace.first = None;
            }
            PassEnd::Complete => break,
        }
    }
    if let Some(p) = &out.points {
        // a mapper's or a replay's listener may wait for it
        let _ = p.end_of_stream();
    }
    outln!(
        "{} revolutions, {} scans, {} odometry samples replayed in {:.2} s; {} messages of other topics not replayed; {} damaged",
        counts.points,
        counts.scans,
        counts.odom,
        started.elapsed().as_secs_f64(),
        counts.skipped,
        counts.bad
    )?;
    if let Some(e) = &damage {
        mimnav_shared::cli::stderr_line(format_args!(
            "mimnav: {} ends early ({e}): replayed up to its last complete chunk (was the recorder killed?)",
            args.file.display()
        ));
    }
    if interrupted {
        mimnav_shared::cli::stderr_line(format_args!("mimnav: replay interrupted"));
        return Ok(ExitCode::from(130));
    }
    if counts.points + counts.scans + counts.odom == 0 {
        bail!(
            "{} holds no lidar/points, lidar/scan2d or odom messages to replay",
            args.file.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// How one pass over the file ended.
enum PassEnd {
    Complete,
    Interrupted,
    /// The file ends inside a record (a killed recorder) or is damaged there.
    Damaged(String),
}

struct ReplayPass<'a, 'b> {
    file: &'a Path,
    out: &'a mut Outputs<'b>,
    pace: &'a mut Pace,
    counts: &'a mut Counts,
    quiet: bool,
}

fn replay_once(p: &mut ReplayPass<'_, '_>) -> Result<PassEnd> {
    let mut file =
        File::open(p.file).with_context(|| format!("cannot open {}", p.file.display()))?;
    let mut reader = LinearReader::new();
    // channel id → what it carries (None: a topic not replayed)
    let mut channels: HashMap<u16, (Option<Input>, String)> = HashMap::new();
    while let Some(event) = reader.next_event() {
        let event = match event {
            Ok(e) => e,
            Err(e) => return Ok(PassEnd::Damaged(e.to_string())),
        };
        match event {
            LinearReadEvent::ReadRequest(n) => {
                let buf = reader.insert(n);
                let got = file
                    .read(buf)
                    .with_context(|| format!("cannot read {}", p.file.display()))?;
                reader.notify_read(got);
            }
            LinearReadEvent::Record { data, opcode } => {
                let record = match mcap::parse_record(opcode, data) {
                    Ok(r) => r,
                    Err(e) => return Ok(PassEnd::Damaged(e.to_string())),
                };
                match record {
                    Record::Channel(c) => {
                        channels.insert(c.id, (Input::of(&c.topic), c.topic));
                    }
                    Record::Message { header, data } => {
                        let Some((input, topic)) = channels.get(&header.channel_id) else {
                            p.counts.bad += 1;
                            continue;
                        };
                        let Some(input) = *input else {
                            p.counts.skipped += 1;
                            continue;
                        };
                        if !p.pace.wait(p.out.node, header.log_time) {
                            return Ok(PassEnd::Interrupted);
                        }
                        match p.out.publish(input, &data)? {
                            Ok(rev) => {
                                match input {
                                    Input::Points => p.counts.points += 1,
                                    Input::Scan => p.counts.scans += 1,
                                    Input::Odom => p.counts.odom += 1,
                                }
                                if let Some((seq, n)) = rev
                                    && !p.quiet
                                {
                                    outln!("rev {seq:>5}  {n:>6} points replayed")?;
                                }
                            }
                            Err(e) => {
                                p.counts.bad += 1;
                                if p.counts.bad <= NAMED_BAD {
                                    mimnav_shared::cli::stderr_line(format_args!(
                                        "mimnav: {}: {topic} message {} (log time {} ns) not replayed: {e}",
                                        p.file.display(),
                                        header.sequence,
                                        header.log_time
                                    ));
                                } else if p.counts.bad == NAMED_BAD + 1 {
                                    mimnav_shared::cli::stderr_line(format_args!(
                                        "mimnav: further damaged messages are only counted"
                                    ));
                                }
                            }
                        }
                    }
                    _ => {}
                }
            }
        }
    }
    Ok(PassEnd::Complete)
}
