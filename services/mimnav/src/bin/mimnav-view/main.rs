//! `mimnav-view`: the Foxglove live view.
//!
//! Wiring only: the library's [`Inputs`] subscribe to the stack's topics, its [`Bridge`] turns
//! what a client asked for into Foxglove messages, its [`Server`] serves them over
//! `foxglove.websocket.v1` on `view.bind:view.port` (ws://127.0.0.1:8765 by default). The loop
//! wakes on every topic and at the slow channels' rate; the counters (missed, thinned, bad) go
//! to `/view/stats`, to systemd's STATUS= and to the log every `view.log_interval_s`.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_config::Config;
use mimnav_shared::ipc;
use mimnav_shared::service::{self, Service, ServiceCli};
use mimnav_view::bridge::Bridge;
use mimnav_view::pump::{Inputs, Seen};
use mimnav_view::server::Server;

/// The Foxglove live view: the stack's topics → ws://view.bind:view.port.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-view", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }

    /// The view is never real-time and holds no CPU wake-up request, whatever `[latency]` gives
    /// the control path: it must not compete with it.
    fn overrides(&self) -> Vec<String> {
        vec![
            "latency.realtime_priority=0".into(),
            "latency.cpu_wakeup_us=-1".into(),
        ]
    }
}

fn main() -> ExitCode {
    service::main("mimnav-view", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

fn run(config: &Config) -> Result<()> {
    let view = &config.view;
    let svc = Service::open(config, "view")?;
    if !view.enabled {
        let _tick = svc.every(Duration::from_secs(1))?;
        let mut health = svc.health();
        tracing::info!("view.enabled = false: not serving");
        svc.run(&mut health, "disabled (view.enabled = false)", |_, _| {})?;
        return Ok(());
    }
    let mut bridge = Bridge::new(view, config.robot.mount, config.robot.sensor_height_m)?;
    let server = Server::start(view, bridge.context())?;
    let inputs = Inputs::open(svc.node())?;
    let url = format!("ws://{}", server.addr());
    tracing::info!("serving Foxglove on {url} (foxglove.websocket.v1)");
    let _guards = (
        svc.on_data(&inputs.points)?,
        svc.on_data(&inputs.layers)?,
        svc.on_data(&inputs.plan)?,
        svc.on_data(&inputs.odom)?,
        svc.on_data(&inputs.goal)?,
        svc.on_data(&inputs.cmd_vel)?,
        svc.on_data(&inputs.foliage)?,
        svc.on_data(&inputs.base_state)?,
    );
    let _tick = svc.every(Duration::from_secs_f64(1.0 / view.slow_hz))?;
    let (start, mut seen, mut last_log) = (Instant::now(), Seen::default(), Instant::now());
    let mut last_status = start - Duration::from_secs(1);
    let log_every = Duration::from_secs_f64(view.log_interval_s);
    let mut health = svc.health();
    svc.run(&mut health, &format!("serving on {url}"), |turn, h| {
        inputs.clear_notifications();
        let (_, errors) = inputs.drain(&mut seen, &mut bridge, ipc::monotonic_ns);
        for e in errors {
            h.faults.record("receive_failed", turn.now, e);
        }
        let clients = server.clients().connected();
        bridge.tick(ipc::monotonic_ns(), start.elapsed().as_secs_f64(), clients);
        let c = bridge.counters();
        if last_log.elapsed() >= log_every {
            let subs = server.clients().subscriptions();
            tracing::info!(clients, subs, "{url}: {}", c.summary());
            last_log = Instant::now();
        }
        // STATUS= once a second at most (the counters change with every message)
        if last_status.elapsed() >= Duration::from_secs(1) {
            h.sd.status(&format!(
                "serving on {url}; {clients} clients; {}",
                c.summary()
            ));
            last_status = Instant::now();
        }
    })?;
    tracing::info!("view stopped: {}", bridge.counters().summary());
    drop(server);
    Ok(())
}
