use super::*;

/// The test's view of every topic: the time and the count of what arrived.
pub(crate) struct Taps {
    pub(crate) _node: iceoryx2::prelude::Node<ipc::Svc>,
    pub(crate) points: ipc::PointsSubscriber,
    pub(crate) scan: ipc::ScanSubscriber,
    pub(crate) layers: ipc::LayersSubscriber,
    pub(crate) plan: ipc::PlanSubscriber,
    pub(crate) foliage: ipc::FoliageSubscriber,
    pub(crate) cmd: ipc::ValueSubscriber<VelocityCommand>,
    /// Topic name → (samples, time of the last one).
    pub(crate) seen: Vec<(&'static str, u64, Option<Instant>)>,
    /// Every command with its arrival time.
    pub(crate) cmds: Vec<(Instant, VelocityCommand)>,
}

pub(crate) const TOPICS: [&str; 6] = [
    "lidar/points",
    "lidar/scan2d",
    "map/layers",
    "map/plan",
    "foliage/alarm",
    "cmd_vel",
];

/// Which topic shows that a service is working again.
pub(crate) fn output_of(service: &str) -> &'static str {
    match service {
        "velodyne" => "lidar/points",
        "mapper" => "map/plan",
        "foliage" => "foliage/alarm",
        _ => "cmd_vel",
    }
}

impl Taps {
    pub(crate) fn open(config: &Config) -> Taps {
        let node = ipc::node(config, "e2e-systemd-tap").expect("node");
        Taps {
            points: ipc::points_subscriber(&node).expect("points"),
            scan: ipc::scan_subscriber(&node).expect("scan"),
            layers: ipc::layers_subscriber(&node).expect("layers"),
            plan: ipc::plan_subscriber(&node).expect("plan"),
            foliage: ipc::foliage_subscriber(&node).expect("foliage"),
            cmd: ipc::cmd_vel_subscriber(&node).expect("cmd_vel"),
            _node: node,
            seen: TOPICS.iter().map(|&t| (t, 0, None)).collect(),
            cmds: Vec::new(),
        }
    }

    pub(crate) fn mark(&mut self, i: usize, n: u64, now: Instant) {
        if n > 0 {
            self.seen[i].1 += n;
            self.seen[i].2 = Some(now);
        }
    }

    /// Drains every topic once.
    pub(crate) fn poll(&mut self) {
        fn drain<F: FnMut() -> bool>(mut f: F) -> u64 {
            let mut n = 0;
            while f() {
                n += 1;
            }
            n
        }
        let now = Instant::now();
        let n = drain(|| matches!(self.points.receive(), Ok(Some(_))));
        self.mark(0, n, now);
        let n = drain(|| matches!(self.scan.receive(), Ok(Some(_))));
        self.mark(1, n, now);
        let n = drain(|| matches!(self.layers.receive(), Ok(Some(_))));
        self.mark(2, n, now);
        let n = drain(|| matches!(self.plan.receive(), Ok(Some(_))));
        self.mark(3, n, now);
        let n = drain(|| matches!(self.foliage.receive(), Ok(Some(_))));
        self.mark(4, n, now);
        let mut n = 0;
        while let Ok(Some(c)) = self.cmd.receive() {
            self.cmds.push((now, c));
            n += 1;
        }
        self.mark(5, n, now);
    }

    pub(crate) fn count(&self, topic: &str) -> u64 {
        self.seen.iter().find(|s| s.0 == topic).map_or(0, |s| s.1)
    }

    /// Polls until `done(self)` or `timeout`; the time it took, or None.
    pub(crate) fn until(
        &mut self,
        timeout: Duration,
        mut done: impl FnMut(&Taps) -> bool,
    ) -> Option<Duration> {
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            self.poll();
            if done(self) {
                return Some(t0.elapsed());
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        None
    }
}

/// Publishes a standing robot's odometry (20 Hz) and a goal 5 m ahead (every 0.5 s, so a
/// restarted planner has it again), as a robot base and an operator would.
pub(crate) fn odom_and_goal(config: Config, stop: Arc<AtomicBool>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let node = ipc::node(&config, "e2e-systemd-base").expect("node");
        let odom = ipc::odom_publisher(&node).expect("odom");
        let goal = ipc::goal_publisher(&node).expect("goal");
        let mut k = 0u64;
        while !stop.load(Ordering::Relaxed) {
            let now = ipc::monotonic_ns();
            let _ = odom.publish(Odometry {
                seq: k,
                stamp_ns: ipc::realtime_ns(),
                rx_mono_ns: now,
                ..Odometry::default()
            });
            if k.is_multiple_of(10) {
                let _ = goal.publish(Goal {
                    seq: k / 10,
                    stamp_mono_ns: now,
                    x: 5.0,
                    y: 0.0,
                    tolerance_m: 0.3,
                    ..Goal::default()
                });
            }
            k += 1;
            std::thread::sleep(Duration::from_millis(50));
        }
    })
}

pub(crate) fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// True when `pid` is gone (or a zombie).
pub(crate) fn gone(pid: i32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(s) => {
            s.rsplit(')')
                .next()
                .and_then(|r| r.split_whitespace().next())
                == Some("Z")
        }
    }
}
