//! `mimnav-zenoh`: the stack's topics on other hosts over Zenoh (issue 25).
//!
//! Wiring only: one iceoryx2 subscriber per topic of `zenoh.topics` ([`Tap`]); each message
//! the [`Bridge`]'s rate cap admits goes out through the [`Link`] on `mimnav/<robot>/<topic>`
//! as the bytes docs/topics.md lays out. With `zenoh.accept_goals`, goals and stop requests
//! heard on `mimnav/<robot>/goal` and `…/stop` are checked by the bridge and published on
//! `mimnav/goal`; bad ones are counted and logged at a limited rate. Off unless
//! `zenoh.enabled`: then it says so, tells systemd it is ready, and exits successfully.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_shared::ipc::{self, Listening};
use mimnav_shared::service::{self, Service, ServiceCli};
use mimnav_shared::systemd::Notifier;
use mimnav_shared::topics;
use mimnav_zenoh::bridge::Bridge;
use mimnav_zenoh::link::{self, Link};
use mimnav_zenoh::remote::MAX_PAYLOAD;
use mimnav_zenoh::tap::Tap;

/// The Zenoh bridge: selected topics → mimnav/<robot>/<topic>; remote goals → mimnav/goal.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-zenoh", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }
}

/// How often remote input is looked at (and the loop wakes without local data).
const REMOTE_POLL: Duration = Duration::from_millis(20);
/// How often the counters are logged.
const STATS_INTERVAL: Duration = Duration::from_secs(10);

fn main() -> ExitCode {
    service::main("mimnav-zenoh", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

fn run(config: &Config) -> Result<()> {
    let zc = &config.zenoh;
    if !zc.enabled {
        tracing::info!("zenoh.enabled = false: the bridge does nothing");
        let mut sd = Notifier::from_env();
        sd.ready("disabled (zenoh.enabled = false)");
        sd.stopping("disabled");
        return Ok(());
    }
    let rates: Vec<(&str, f64)> = (zc.topics.iter())
        .map(|t| (t.as_str(), zc.rate_hz(t)))
        .collect();
    let mut bridge = Bridge::new(&zc.robot, &rates, zc.accept_goals)?;
    let svc = Service::open(config, "zenoh")?;
    let taps = (bridge.outgoing().iter())
        .map(|o| Tap::open(svc.node(), o.topic))
        .collect::<Result<Vec<_>, _>>()?;
    let goal_pub = match zc.accept_goals {
        true => Some(ipc::goal_publisher(svc.node())?),
        false => None,
    };
    let zenoh_config = link::zenoh_config(&zc.config_file)?;
    let link = Link::open(zenoh_config, &bridge).context("zenoh")?;
    let keys: Vec<_> = bridge.outgoing().iter().map(|o| o.key.as_str()).collect();
    tracing::info!(
        zid = link.zid(),
        accept_goals = zc.accept_goals,
        "topics open: publishing {}",
        keys.join(", ")
    );
    let guards = (taps.iter())
        .map(|t| svc.on_data(t))
        .collect::<Result<Vec<_>, _>>()?;
    let _tick = svc.every(REMOTE_POLL)?;
    let (mut health, mut last_report) = (svc.health(), Instant::now());
    let (mut buf, mut told) = (Vec::new(), None);
    svc.run(&mut health, "bridging", |turn, h| {
        let now_ns = ipc::monotonic_ns();
        for (i, tap) in taps.iter().enumerate() {
            let _ = tap.heard();
            loop {
                match tap.next(&mut buf, || bridge.admit(i, now_ns)) {
                    Ok(None) => break,
                    Ok(Some(false)) => {}
                    Ok(Some(true)) => {
                        let n = buf.len();
                        match link.publish(i, std::mem::take(&mut buf)) {
                            Ok(()) => bridge.sent(i, n),
                            Err(e) => _ = h.faults.record("publish_failed", turn.now, e),
                        }
                    }
                    Err(e) => {
                        h.faults.record("receive_failed", turn.now, e);
                        break;
                    }
                }
            }
        }
        for (key, payload) in link.remote(MAX_PAYLOAD) {
            let goal = bridge.remote(key, &payload, ipc::realtime_ns(), ipc::monotonic_ns());
            match (goal, &goal_pub) {
                (Ok(g), Some(p)) => {
                    let stop = g.flags & topics::goal_flags::STOP != 0;
                    match p.publish(g) {
                        Ok(0) => {
                            _ = h.faults.record(
                                "no_planner",
                                turn.now,
                                "no planner listens on mimnav/goal",
                            )
                        }
                        Ok(_) if stop => tracing::info!("stop request from the network forwarded"),
                        Ok(_) => tracing::info!(
                            x = g.x,
                            y = g.y,
                            tolerance_m = g.tolerance_m,
                            "goal from the network forwarded"
                        ),
                        Err(e) => _ = h.faults.record("publish_failed", turn.now, e),
                    }
                }
                (Ok(_), None) => {}
                (Err(e), _) => _ = h.faults.record(e.kind(), turn.now, e),
            }
        }
        // STATUS= is rebuilt only when what it says changes, not every turn
        let now_told = (bridge.goals, bridge.stops, h.faults.total());
        if told != Some(now_told) {
            told = Some(now_told);
            h.sd.status(&format!(
                "bridging {} topics; {} goals, {} stops forwarded; faults: {}",
                taps.len(),
                now_told.0,
                now_told.1,
                now_told.2
            ));
        }
        if last_report.elapsed() >= STATS_INTERVAL {
            report(&bridge, &h.faults.summary());
            last_report = Instant::now();
        }
    })?;
    drop(guards);
    report(&bridge, &health.faults.summary());
    link.close();
    Ok(())
}

/// One INFO line: per topic the messages and bytes sent and the messages dropped by the cap.
fn report(bridge: &Bridge, faults: &str) {
    let per_topic: Vec<String> = (bridge.outgoing().iter())
        .map(|o| {
            format!(
                "{} {} sent ({} B), {} dropped",
                o.topic.name(),
                o.sent,
                o.bytes,
                o.dropped
            )
        })
        .collect();
    tracing::info!(
        goals = bridge.goals,
        stops = bridge.stops,
        "bridged: {}; faults: {faults}",
        per_topic.join("; ")
    );
}
