//! `mimnav replay FILE`: runs the driver on a capture as its own process and prints every
//! revolution it publishes on `lidar/points`; or, for an MCAP recording of `mimnav record`,
//! publishes the recorded sensor topics into the running stack ([`from_mcap`]).

mod from_mcap;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;
use indicatif::{ProgressBar, ProgressStyle};
use mimnav_config::Config;
use mimnav_shared::config::toml_quote;
use mimnav_shared::ipc::{self, Listening, PrivateDomain, Svc};
use mimnav_shared::topics::{PointsHeader, cut_reason};
use mimnav_velodyne::capture::CaptureReader;

use crate::procs::{Service, service_binary};

/// Captures longer than this many data packets get a progress bar (about 7 s of a dual-return
/// sensor).
const PROGRESS_MIN_PACKETS: u64 = 10_000;

/// Arguments of `mimnav replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The capture (pcap or pcapng), or an MCAP recording of `mimnav record`, whose
    /// lidar/points, lidar/scan2d and odom are published into the running stack.
    file: PathBuf,
    /// Replay speed factor (1.0 is real time).
    #[arg(long, default_value_t = 1.0)]
    speed: f64,
    /// Replay as fast as possible (revolutions a slow terminal cannot keep up with are counted
    /// as lost).
    #[arg(long, conflicts_with = "speed")]
    fast: bool,
    /// Start over at the end of the capture, until Ctrl-C.
    #[arg(long = "loop")]
    repeat: bool,
    /// Publish in the configured iceoryx2 domain, so a running stack receives the replay
    /// (default: a private domain only this command sees).
    #[arg(long)]
    shared: bool,
    /// Print the summary only, not a line per revolution.
    #[arg(long, short)]
    quiet: bool,
}

/// What the replay saw.
#[derive(Debug, Default)]
struct Tally {
    revolutions: u64,
    points: u64,
    packets: u64,
    lost: u64,
    next_seq: Option<u64>,
    last_stamp_ns: Option<u64>,
    first_stamp_ns: Option<u64>,
    end_of_stream: bool,
}

impl Tally {
    fn add(&mut self, h: &PointsHeader) -> String {
        // the driver is our child and numbers its revolutions from 0: the ones overwritten before
        // the first we read are lost too (the last one is never overwritten, so a gap is all a
        // loss can be)
        self.lost += h.seq.saturating_sub(self.next_seq.unwrap_or(0));
        self.next_seq = Some(h.seq + 1);
        self.revolutions += 1;
        self.points += u64::from(h.point_count);
        self.packets += u64::from(h.packet_count);
        let rate = match self.last_stamp_ns {
            Some(prev) if h.stamp_ns > prev => {
                format!("{:6.2} Hz", 1e9 / (h.stamp_ns - prev) as f64)
            }
            _ => "     - Hz".into(),
        };
        self.first_stamp_ns.get_or_insert(h.stamp_ns);
        self.last_stamp_ns = Some(h.stamp_ns);
        let n = f64::from(h.point_count.max(1));
        let pct = |c: u32| 100.0 * f64::from(c) / n;
        let note = match h.cut_reason {
            cut_reason::AZIMUTH => "",
            cut_reason::DURATION => "  (cut early: gap in the stream)",
            cut_reason::CAPACITY => "  (cut early: capacity)",
            cut_reason::MODE_CHANGE => "  (cut early: return mode changed)",
            _ => "  (partial: end of capture)",
        };
        format!(
            "rev {:>5}  {:>6} points  strongest {:5.1}%  last {:5.1}%  both {:5.1}%  {:>4} packets  {}{}",
            h.seq,
            h.point_count,
            pct(h.strongest_count),
            pct(h.last_count),
            pct(h.both_count),
            h.packet_count,
            rate,
            note
        )
    }
}

fn count_data_packets(path: &Path) -> Result<u64> {
    let mut reader = CaptureReader::open(path)?;
    let mut n = 0;
    // a broken capture is counted up to the damage; the driver reports the damage itself
    while let Ok(Some(d)) = reader.next() {
        if d.payload.len() == mimnav_shared::topics::DATA_PACKET_LEN {
            n += 1;
        }
    }
    Ok(n)
}

/// Runs the replay; the exit code is 0 when the whole capture was replayed.
pub fn run(
    config: &Config,
    config_path: Option<&Path>,
    sets: &[String],
    args: &ReplayArgs,
) -> Result<ExitCode> {
    if args.speed.is_nan() || args.speed <= 0.0 {
        bail!("--speed must be above 0, got {}", args.speed);
    }
    if from_mcap::is_mcap(&args.file) {
        return from_mcap::run(config, args);
    }
    let total = count_data_packets(&args.file)?;
    let binary = service_binary("mimnav-velodyne")?;
    let domain = (!args.shared).then(|| PrivateDomain::new("replay"));
    let local = match &domain {
        Some(d) => d.apply(config.clone()),
        None => config.clone(),
    };
    let node = ipc::node(&local, "mimnav-replay")?;
    // subscribe before the driver starts, so the first revolution is not missed; in our own
    // domain we create the topic, with room for REPLAY_BUFFER revolutions: a short capture
    // replayed --fast is not overwritten while this process waits for the CPU (issue 23 item 8).
    // In the stack's domain (--shared) the topic keeps the stack's buffer, losses are counted.
    let points = match domain {
        Some(_) => ipc::points_subscriber_with_buffer(&node, ipc::REPLAY_BUFFER)?,
        None => ipc::points_subscriber(&node)?,
    };

    let mut child_args: Vec<String> = Vec::new();
    if let Some(p) = config_path {
        child_args.extend(["--config".into(), p.display().to_string()]);
    }
    for s in sets {
        child_args.extend(["--set".into(), s.clone()]);
    }
    if let Some(d) = &domain {
        child_args.extend(d.set_args());
    }
    child_args.extend(["--pcap".into(), args.file.display().to_string()]);
    child_args.extend([
        "--set".into(),
        format!("velodyne.replay_speed={}", args.speed),
    ]);
    child_args.extend([
        "--set".into(),
        format!("velodyne.replay_fast={}", args.fast),
    ]);
    child_args.extend([
        "--set".into(),
        format!("velodyne.replay_loop={}", args.repeat),
    ]);
    child_args.extend(["--set".into(), "velodyne.replay_linger_s=10".into()]);
    child_args.extend(["--set".into(), format!("log.level={}", toml_quote("warn"))]);

    let bar = if total >= PROGRESS_MIN_PACKETS {
        let b = ProgressBar::new(total);
        b.set_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} packets {msg}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    outln!(
        "replaying {} ({total} data packets) through {}",
        args.file.display(),
        binary.display()
    )?;
    let started = Instant::now();
    let mut driver = Service::start(&binary, &child_args)?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<Svc>()
        .map_err(|e| anyhow::anyhow!("cannot create the WaitSet: {e:?}"))?;
    let _data = waitset
        .attach_notification(points.listener())
        .map_err(|e| anyhow::anyhow!("cannot wait on lidar/points: {e:?}"))?;
    let _tick = waitset
        .attach_interval(Duration::from_millis(200))
        .map_err(|e| anyhow::anyhow!("cannot attach an interval: {e:?}"))?;

    let mut tally = Tally::default();
    let (mut receive_error, mut output_error) = (None, None);
    // false once stdout is closed
    let mut drain = |tally: &mut Tally| -> bool {
        loop {
            match points.receive() {
                Ok(Some(sample)) => {
                    let h = *sample.user_header();
                    drop(sample);
                    let line = tally.add(&h);
                    if total > 0 {
                        bar.set_position(
                            (h.first_packet_seq + u64::from(h.packet_count)) % (total + 1),
                        );
                    }
                    if !args.quiet
                        && output_error.is_none()
                        && let Err(e) = bar.suspend(|| outln!("{line}"))
                    {
                        // stdout closed (`| head`): stop here, the driver is stopped below
                        output_error = Some(e);
                    }
                }
                Ok(None) => break,
                Err(e) => {
                    receive_error = Some(e);
                    break;
                }
            }
        }
        output_error.is_none()
    };
    let run = ipc::run_waitset(&waitset, |_id| {
        let heard = points.heard();
        if !drain(&mut tally) {
            return CallbackProgression::Stop;
        }
        if heard.end_of_stream {
            tally.end_of_stream = true;
            return CallbackProgression::Stop;
        }
        if driver.exited().is_some() {
            drain(&mut tally);
            return CallbackProgression::Stop;
        }
        CallbackProgression::Continue
    });
    bar.finish_and_clear();
    let interrupted = matches!(
        run,
        Ok(WaitSetRunResult::Interrupt | WaitSetRunResult::TerminationRequest)
    );
    let status = driver.stop(Duration::from_secs(3));
    let elapsed = started.elapsed().as_secs_f64();
    if let Some(e) = output_error {
        return Err(e.into());
    }
    if let Some(e) = receive_error {
        bail!("{e}");
    }
    run.map_err(|e| anyhow::anyhow!("WaitSet failed: {e:?}"))?;
    let sensor_span = match (tally.first_stamp_ns, tally.last_stamp_ns) {
        (Some(a), Some(b)) if b > a && tally.revolutions > 1 => {
            format!(
                ", {:.2} revolutions/s by sensor time",
                (tally.revolutions - 1) as f64 * 1e9 / (b - a) as f64
            )
        }
        _ => String::new(),
    };
    outln!(
        "{} revolutions, {} points, {} data packets in {elapsed:.2} s{sensor_span}; {} revolutions lost",
        tally.revolutions,
        tally.points,
        tally.packets,
        tally.lost
    )?;
    if interrupted {
        mimnav_shared::cli::stderr_line(format_args!("mimnav: replay interrupted"));
        return Ok(ExitCode::from(130));
    }
    if !tally.end_of_stream {
        bail!(
            "{} ended before the end of the capture ({})",
            driver.name(),
            status.map_or_else(|| "status unknown".into(), |s| s.to_string())
        );
    }
    if let Some(s) = status
        && !s.success()
    {
        bail!("{} exited with {s}", driver.name());
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tally_counts_lost_revolutions_and_rate() {
        let mut t = Tally::default();
        let h = |seq, stamp_ns| PointsHeader {
            seq,
            stamp_ns,
            point_count: 10,
            both_count: 10,
            ..PointsHeader::default()
        };
        t.add(&h(0, 1_000_000_000));
        let line = t.add(&h(1, 1_100_000_000));
        assert!(line.contains(" 10.00 Hz"), "{line}");
        assert!(line.contains("both 100.0%"), "{line}");
        t.add(&h(4, 1_400_000_000));
        assert_eq!((t.revolutions, t.lost, t.points), (3, 2, 30));
    }

    /// Issue 23 item 8: the revolutions overwritten before the first one read were not counted
    /// ("2 revolutions … 0 revolutions lost" of 8).
    #[test]
    fn lost_revolutions_before_the_first_one_read_are_counted() {
        let mut t = Tally::default();
        let h = |seq| PointsHeader {
            seq,
            ..PointsHeader::default()
        };
        t.add(&h(6));
        t.add(&h(7));
        assert_eq!((t.revolutions, t.lost), (2, 6));
    }
}
