//! `docs/topics.md` against the code, so the contract outside clients read cannot rot silently:
//! every layout table against `offset_of!`/`size_of`/`align_of` and the versioned type name, and
//! the topic, QoS and event tables against the services iceoryx2 records when the project's own
//! `ipc` functions open every topic.

use std::any::type_name;
use std::collections::{BTreeMap, BTreeSet};
use std::mem::{align_of, offset_of, size_of};

use iceoryx2::prelude::*;
use iceoryx2::service::static_config::StaticConfig;
use iceoryx2::service::static_config::message_type_details::TypeVariant;
use iceoryx2::service::static_config::messaging_pattern::MessagingPattern as Pattern;
use mimnav_config::Config;
use mimnav_shared::ipc::{self, PrivateDomain, Svc};
use mimnav_shared::topics::{
    BaseState, EVENT_END_OF_STREAM, EVENT_NEW_DATA, FoliageHeader, FoliageReturn, Goal, MapHeader,
    Odometry, PlanCell, Point, PointsHeader, RawPacket, ScanHeader, ScanReturn, SliceHeader,
    TruthHeader, VelocityCommand,
};

use crate::util::{root, shipped_config};

/// A markdown table.
#[derive(Debug)]
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

fn cells(line: &str) -> Vec<String> {
    let inner = line.trim().trim_start_matches('|').trim_end_matches('|');
    inner.split('|').map(|c| c.trim().to_string()).collect()
}

/// Without the backticks.
pub fn plain(s: &str) -> String {
    s.replace('`', "")
}

/// Every table of `md`.
pub fn tables(md: &str) -> Vec<Table> {
    let mut out = Vec::new();
    let lines: Vec<&str> = md.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        if l.starts_with('|') && lines.get(i + 1).is_some_and(|n| n.starts_with("|---")) {
            let mut t = Table {
                header: cells(l),
                rows: Vec::new(),
            };
            i += 2;
            while i < lines.len() && lines[i].starts_with('|') {
                t.rows.push(cells(lines[i]));
                i += 1;
            }
            out.push(t);
            continue;
        }
        i += 1;
    }
    out
}

/// One field of a layout: offset, size, name, Rust type.
pub type Field = (usize, usize, String, String);

/// A type's layout as documented (or as the compiler has it).
#[derive(Debug, PartialEq)]
pub struct Layout {
    pub type_name: String,
    pub size: usize,
    pub align: usize,
    pub padding: usize,
    pub fields: Vec<Field>,
}

/// The `## Layouts` section: type → its layout (the `mimnav/X/vN: size S, alignment A, padding P`
/// line under each `### X` heading, then its field table).
pub fn documented_layouts(md: &str) -> BTreeMap<String, Layout> {
    let section = md
        .split("\n## ")
        .find(|s| s.starts_with("Layouts"))
        .expect("docs/topics.md has a `## Layouts` section");
    let mut out = BTreeMap::new();
    for part in section.split("\n### ").skip(1) {
        let name = plain(part.lines().next().unwrap_or_default().trim());
        let summary = part
            .lines()
            .find(|l| l.starts_with("`mimnav/"))
            .unwrap_or_else(|| {
                panic!("{name}: no `mimnav/…`: size …, alignment …, padding … line")
            });
        let (tn, rest) = summary
            .split_once(": ")
            .unwrap_or_else(|| panic!("{name}: bad summary line {summary:?}"));
        let num = |key: &str| -> usize {
            rest.split(", ")
                .find_map(|kv| kv.strip_prefix(key))
                .and_then(|v| v.trim().parse().ok())
                .unwrap_or_else(|| panic!("{name}: no `{key}N` in {summary:?}"))
        };
        let table = tables(part)
            .into_iter()
            .find(|t| t.header.first().map(String::as_str) == Some("offset"))
            .unwrap_or_else(|| panic!("{name}: no field table"));
        let fields = table
            .rows
            .iter()
            .map(|r| {
                let n = |i: usize| -> usize {
                    r[i].parse()
                        .unwrap_or_else(|_| panic!("{name}: bad number in {r:?}"))
                };
                (n(0), n(1), plain(&r[2]), plain(&r[3]))
            })
            .collect();
        out.insert(
            name.clone(),
            Layout {
                type_name: plain(tn),
                size: num("size "),
                align: num("alignment "),
                padding: num("padding "),
                fields,
            },
        );
    }
    out
}

fn field_of<T, F>(_: impl Fn(&T) -> &F) -> (&'static str, usize) {
    (type_name::<F>(), size_of::<F>())
}

/// The compiler's layout of a topic type; the pattern without `..` makes leaving out a field a
/// compile error.
macro_rules! layout {
    ($t:ident, [$($f:ident),+ $(,)?]) => {{
        #[allow(dead_code)]
        fn every_field_is_listed(v: $t) {
            let $t { $($f: _),+ } = v;
        }
        let fields: Vec<Field> = vec![$({
            let (ty, size) = field_of(|s: &$t| &s.$f);
            // a topic type inside another by its own name, as the tables write it
            let ty = ty.rsplit("::").next().unwrap_or(ty);
            (offset_of!($t, $f), size, stringify!($f).to_string(), ty.to_string())
        }),+];
        let used: usize = fields.iter().map(|f| f.1).sum();
        (
            stringify!($t).to_string(),
            Layout {
                // SAFETY: reading the type's name has no precondition; it is unsafe only for
                // implementors, who must make it unique
                type_name: unsafe { <$t as ZeroCopySend>::type_name() }.to_string(),
                size: size_of::<$t>(),
                align: align_of::<$t>(),
                padding: size_of::<$t>() - used,
                fields,
            },
        )
    }};
}

/// Every payload and header type of `shared/src/topics.rs` as the compiler lays it out.
#[rustfmt::skip] // one type a line
pub fn rust_layouts() -> BTreeMap<String, Layout> {
    BTreeMap::from([
        layout!(Point, [x, y, z, time_offset_ns, distance_raw, azimuth_cdeg, intensity, laser_id, ring, return_type]),
        layout!(PointsHeader, [seq, stamp_ns, rx_mono_ns, first_packet_seq, packet_count, point_count,
            strongest_count, last_count, both_count, return_mode, product, cut_reason, reserved]),
        layout!(SliceHeader, [revolution, index, first_point, last, reserved]),
        layout!(ScanReturn, [angle_rad, range_m, intensity, return_type, reserved]),
        layout!(ScanHeader, [seq, stamp_ns, rx_mono_ns, count, elevation_rad, laser_id, return_select, reserved]),
        layout!(RawPacket, [seq, host_ns, rx_mono_ns, len, port, reserved, data]),
        layout!(VelocityCommand, [seq, stamp_mono_ns, source_stamp_ns, source_seq, valid_until_mono_ns, v, omega,
            status, flags, reserved]),
        layout!(Odometry, [seq, stamp_ns, rx_mono_ns, x, y, yaw, v, omega]),
        layout!(Goal, [seq, stamp_mono_ns, x, y, tolerance_m, flags, reserved]),
        layout!(BaseState, [seq, rx_mono_ns, base_stamp_ms, battery_v, halted, base, link, bumper, cliff, wheel_drop,
            buttons, charger, over_current, reserved, rejected, link_losses]),
        layout!(TruthHeader, [seq, stamp_ns, x, y, yaw, cells, cell_m]),
        layout!(MapHeader, [seq, source_seq, stamp_ns, rx_mono_ns, odom_seq, odom_stamp_ns, x, y, yaw, cells, cell_m,
            layers, processing_us, status, reserved]),
        layout!(PlanCell, [class, cost]),
        layout!(FoliageReturn, [angle_rad, range_m, class, reserved]),
        layout!(FoliageHeader, [seq, source_seq, stamp_ns, rx_mono_ns, count, sectors, obstacles, processing_us, alarm,
            laser_id, reserved, nearest_m]),
    ])
}

pub fn topics_md() -> String {
    let p = root().join("docs/topics.md");
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// The table whose first header cell is `first`.
pub fn table<'a>(all: &'a [Table], first: &str) -> &'a Table {
    all.iter()
        .find(|t| t.header.first().map(String::as_str) == Some(first))
        .unwrap_or_else(|| panic!("docs/topics.md has no table starting with `{first}`"))
}

#[test]
fn the_documented_layouts_are_the_compilers() {
    let doc = documented_layouts(&topics_md());
    let rust = rust_layouts();
    assert_eq!(
        doc.keys().collect::<Vec<_>>(),
        rust.keys().collect::<Vec<_>>(),
        "docs/topics.md documents every payload and header type, and no other"
    );
    for (name, r) in &rust {
        assert_eq!(&doc[name], r, "docs/topics.md's layout of {name}");
    }
}

/// The topics `shared/src/topics.rs` names (every `pub const …: &str = "mimnav/…"`).
fn topic_constants() -> BTreeSet<String> {
    let src = include_str!("../shared/src/topics.rs");
    src.lines()
        .filter(|l| l.starts_with("pub const ") && l.contains(": &str = \"mimnav/"))
        .filter_map(|l| l.split('"').nth(1).map(str::to_string))
        .collect()
}

/// The static config iceoryx2 records for every service of `domain`.
fn services(domain: &PrivateDomain) -> Vec<StaticConfig> {
    let mut out = Vec::new();
    <Svc as iceoryx2::service::Service>::list(&domain.config().iceoryx2, |d| {
        out.push(d.static_details);
        CallbackProgression::Continue
    })
    .expect("list services");
    out
}

/// iceoryx2's type name, size and alignment of a documented payload or header cell (`[T]`: T;
/// `—`: the empty header).
fn documented_type(cell: &str, layouts: &BTreeMap<String, Layout>) -> (String, usize, usize) {
    let t = plain(cell);
    let t = t.trim_start_matches('[').trim_end_matches(']');
    match t {
        "—" => ("()".into(), 0, 1),
        "u8" => ("u8".into(), 1, 1),
        "f32" => ("f32".into(), 4, 4),
        _ => {
            let l = layouts
                .get(t)
                .unwrap_or_else(|| panic!("docs/topics.md: `{t}` has no layout section"));
            (l.type_name.clone(), l.size, l.align)
        }
    }
}

#[test]
fn the_documented_topics_and_qos_are_what_the_services_create() {
    let md = topics_md();
    let all = tables(&md);
    let layouts = documented_layouts(&md);
    let topic_table = table(&all, "service name");
    let qos_table = table(&all, "QoS");
    let event_table = table(&all, "event service");

    let documented: BTreeSet<String> = topic_table.rows.iter().map(|r| plain(&r[0])).collect();
    assert_eq!(
        documented,
        topic_constants(),
        "docs/topics.md lists every topic of shared/src/topics.rs"
    );

    // open every topic the way the services do
    let domain = PrivateDomain::new("topicsdoc");
    let node = ipc::node(&domain.config(), "topics-doc").expect("node");
    let _ports = (
        ipc::points_subscriber(&node).expect("points"),
        ipc::slices_subscriber(&node).expect("slices"),
        ipc::scan_subscriber(&node).expect("scan2d"),
        ipc::packets_publisher(&node).expect("packets"),
        ipc::cmd_vel_subscriber(&node).expect("cmd_vel"),
        ipc::odom_subscriber(&node).expect("odom"),
        ipc::goal_subscriber(&node).expect("goal"),
        ipc::base_state_subscriber(&node).expect("base/state"),
        ipc::truth_subscriber(&node).expect("truth"),
        ipc::layers_subscriber(&node).expect("layers"),
        ipc::plan_subscriber(&node).expect("plan"),
        ipc::foliage_subscriber(&node).expect("foliage"),
    );
    let found = services(&domain);
    let find = |name: &str, event: bool| -> &StaticConfig {
        found
            .iter()
            .find(|s| {
                s.name().as_str() == name
                    && matches!(s.messaging_pattern(), Pattern::Event(_)) == event
            })
            .unwrap_or_else(|| {
                panic!(
                    "no {} service `{name}`",
                    if event { "event" } else { "pub-sub" }
                )
            })
    };
    let num = |s: &str| -> usize { s.parse().unwrap_or_else(|_| panic!("not a number: {s:?}")) };

    for row in &topic_table.rows {
        let name = plain(&row[0]);
        let ps = find(&name, false).publish_subscribe();
        let details = ps.message_type_details();
        let (payload, header, qos) = (&row[1], &row[2], plain(&row[3]));

        let slice = payload.contains('[');
        let want_variant = if slice {
            TypeVariant::Dynamic
        } else {
            TypeVariant::FixedSize
        };
        assert_eq!(
            details.payload.variant(),
            want_variant,
            "{name}: payload {payload}"
        );
        let (tn, size, align) = documented_type(payload, &layouts);
        assert_eq!(
            details.payload.type_name().to_string(),
            tn,
            "{name}: payload type name"
        );
        assert_eq!(
            (details.payload.size(), details.payload.alignment()),
            (size, align),
            "{name}: payload size and alignment"
        );
        let (tn, size, align) = documented_type(header, &layouts);
        assert_eq!(
            details.user_header.type_name().to_string(),
            tn,
            "{name}: user header type name"
        );
        assert_eq!(
            (details.user_header.size(), details.user_header.alignment()),
            (size, align),
            "{name}: user header size and alignment"
        );

        // `slices`: the slice QoS with the buffer lidar/slices needs
        let kinds: &[&str] = if slice {
            &["slice", "slices"]
        } else {
            &["value"]
        };
        assert!(kinds.contains(&qos.as_str()), "{name}: QoS kind {qos}");
        let q = qos_table
            .rows
            .iter()
            .find(|r| plain(&r[0]) == qos)
            .unwrap_or_else(|| panic!("no QoS row `{qos}`"));
        let got = (
            if ps.has_safe_overflow() { "on" } else { "off" }.to_string(),
            ps.history_size(),
            ps.subscriber_max_buffer_size(),
            ps.subscriber_max_borrowed_samples(),
            ps.max_publishers(),
            ps.max_subscribers(),
            ps.max_nodes(),
        );
        let doc = (
            q[1].clone(),
            num(&q[2]),
            num(&q[3]),
            num(&q[4]),
            num(&q[5]),
            num(&q[6]),
            num(&q[7]),
        );
        assert_eq!(
            got, doc,
            "{name}: QoS (safe overflow, history, buffer, borrowed, publishers, subscribers, nodes)"
        );

        let ev = find(&name, true).event();
        let e = &event_table.rows[0];
        assert_eq!(
            (ev.max_notifiers(), ev.max_listeners(), ev.max_nodes()),
            (num(&e[1]), num(&e[2]), num(&e[3])),
            "{name}: event service (notifiers, listeners, nodes)"
        );
        assert_eq!(
            (
                ev.deadline(),
                ev.notifier_created_event(),
                ev.notifier_dropped_event(),
                ev.notifier_dead_event()
            ),
            (None, None, None, None),
            "{name}: no deadline, no notifier events, as documented"
        );
    }

    let ids = table(&all, "id");
    let id_of = |c: &str| -> usize {
        ids.rows
            .iter()
            .find(|r| plain(&r[1]) == c)
            .map(|r| num(&r[0]))
            .unwrap_or_else(|| panic!("no event id row for {c}"))
    };
    assert_eq!(
        id_of("EVENT_NEW_DATA"),
        EVENT_NEW_DATA,
        "event id of new data"
    );
    assert_eq!(
        id_of("EVENT_END_OF_STREAM"),
        EVENT_END_OF_STREAM,
        "event id of end of stream"
    );

    let join = table(&all, "setting");
    let shipped = |key: &str| -> String {
        join.rows
            .iter()
            .find(|r| plain(&r[0]) == key)
            .map(|r| plain(&r[1]))
            .unwrap_or_else(|| panic!("no `{key}` row in the joining table"))
    };
    let config = Config::load(&shipped_config(), &[]).expect("config/mimnav.toml");
    let global = &config.iceoryx2.global;
    assert_eq!(
        shipped("[iceoryx2.global] root-path"),
        global.root_path().to_string(),
        "the shipped config's root path"
    );
    assert_eq!(
        shipped("[iceoryx2.global] prefix"),
        global.prefix.to_string(),
        "the shipped config's prefix"
    );
}
