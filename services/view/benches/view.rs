//! The live view's CPU per revolution: converting a real-size revolution and map into Foxglove
//! messages, and the whole bridge (conversion, protobuf encoding, and the hand-over to a
//! subscribed client's queue) with a client connected over loopback that reads everything.
//!
//! Sizes: 14 900 points (a revolution of the real dual capture), 27 500 (scenario 1 simulated)
//! and 87 936 (the driver's worst case, dual return at 1.5 turns); the shipped 200 × 200 grid
//! with 4 layers. The contents are synthetic (the cost does not depend on them: every point and
//! cell is copied the same way).
//!
//! `cargo bench -p mimnav-view --bench view`

use std::hint::black_box;
use std::net::TcpStream;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use mimnav_config::ViewConfig;
use mimnav_shared::topics::{MapHeader, PlanCell, Point, PointsHeader};
use mimnav_view::bridge::{Bridge, LAYERS, PLAN, POINTS};
use mimnav_view::convert;
use mimnav_view::server::Server;
use tungstenite::client::IntoClientRequest;

const CELLS: u32 = 200;
const LAYERS_N: u32 = 4;

fn revolution(n: usize) -> (PointsHeader, Vec<Point>) {
    let pts = (0..n)
        .map(|i| {
            let a = i as f32 * 0.001;
            Point {
                x: 5.0 * a.cos(),
                y: 5.0 * a.sin(),
                z: (i % 16) as f32 * 0.1 - 0.8,
                intensity: (i % 101) as u8,
                ..Default::default()
            }
        })
        .collect();
    let h = PointsHeader {
        point_count: n as u32,
        stamp_ns: 1_700_000_000_000_000_000,
        ..Default::default()
    };
    (h, pts)
}

fn map() -> (MapHeader, Vec<PlanCell>, Vec<f32>) {
    let h = MapHeader {
        cells: CELLS,
        cell_m: 0.05,
        layers: LAYERS_N,
        x: 1.0,
        y: 2.0,
        yaw: 0.3,
        ..Default::default()
    };
    let n2 = (CELLS * CELLS) as usize;
    let plan = (0..n2)
        .map(|i| PlanCell {
            class: (i % 6) as u8,
            cost: (i % 256) as u8,
        })
        .collect();
    let layers = (0..n2 * LAYERS_N as usize)
        .map(|i| i as f32 * 1e-3)
        .collect();
    (h, plan, layers)
}

/// A Foxglove client on `port` subscribed to `topics`, reading and discarding every frame on a
/// thread of its own until the server closes.
fn reader(port: u16, topics: &[&str]) {
    let mut req = format!("ws://127.0.0.1:{port}")
        .into_client_request()
        .expect("request");
    req.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        "foxglove.sdk.v1".parse().expect("header"),
    );
    let stream = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    let (mut ws, _) = tungstenite::client(req, stream).expect("handshake");
    let mut ids = std::collections::HashMap::new();
    while ids.len() < topics.len() {
        if let Ok(tungstenite::Message::Text(t)) = ws.read() {
            let v: serde_json::Value = serde_json::from_str(&t).expect("JSON");
            for c in v["channels"].as_array().into_iter().flatten() {
                let topic = c["topic"].as_str().unwrap_or_default().to_string();
                if topics.contains(&topic.as_str()) {
                    ids.insert(topic, c["id"].as_u64().unwrap_or(0));
                }
            }
        }
    }
    let subs: Vec<serde_json::Value> = (ids.values().enumerate())
        .map(|(i, id)| serde_json::json!({"id": i + 1, "channelId": id}))
        .collect();
    let msg = serde_json::json!({"op": "subscribe", "subscriptions": subs}).to_string();
    ws.send(tungstenite::Message::text(msg)).expect("subscribe");
    std::thread::spawn(move || while ws.read().is_ok() {});
}

fn conversion(c: &mut Criterion) {
    let mut g = c.benchmark_group("convert");
    for n in [14_900, 27_500, 87_936] {
        let (h, pts) = revolution(n);
        g.bench_function(format!("points {n}"), |b| {
            b.iter(|| black_box(convert::points(&h, black_box(&pts))))
        });
    }
    let (h, plan, layers) = map();
    g.bench_function("plan 200x200", |b| {
        b.iter(|| black_box(convert::plan(&h, black_box(&plan))))
    });
    g.bench_function("glass 200x200", |b| {
        b.iter(|| black_box(convert::glass(&h, black_box(&plan))))
    });
    g.bench_function("layers 200x200x4", |b| {
        b.iter(|| black_box(convert::layers(&h, black_box(&layers))))
    });
    g.finish();
}

fn bridge(c: &mut Criterion) {
    let view = ViewConfig {
        port: 0,
        points_hz: 0.0,
        grids_hz: 0.0,
        client_backlog: 1024,
        ..Default::default()
    };
    let mut bridge = Bridge::new(&view, Default::default(), 0.5).expect("bridge");
    let server = Server::start(&view, bridge.context()).expect("server");
    reader(server.addr().port(), &[POINTS, PLAN, LAYERS, "/map/glass"]);
    // until the subscription is in
    let (h, pts) = revolution(27_500);
    for _ in 0..200 {
        bridge.on_points(&h, &pts, 0);
        if bridge
            .counters()
            .channels
            .get(POINTS)
            .is_some_and(|c| c.sent > 0)
        {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        bridge.counters().channels[POINTS].sent > 0,
        "the client subscribed"
    );
    let (mh, plan, layers) = map();
    let mut g = c.benchmark_group("bridge, one client");
    g.bench_function("points 27500", |b| {
        b.iter(|| bridge.on_points(&h, black_box(&pts), 0))
    });
    g.bench_function("plan + glass 200x200", |b| {
        b.iter(|| bridge.on_plan(&mh, black_box(&plan), 0))
    });
    g.bench_function("layers 200x200x4", |b| {
        b.iter(|| bridge.on_layers(&mh, black_box(&layers), 0))
    });
    g.bench_function("revolution: points 27500 + plan + glass + layers", |b| {
        b.iter(|| {
            bridge.on_points(&h, black_box(&pts), 0);
            let _ = bridge.on_plan(&mh, black_box(&plan), 0);
            let _ = bridge.on_layers(&mh, black_box(&layers), 0);
        })
    });
    g.finish();
    drop(server);
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(Duration::from_secs(4));
    targets = conversion, bridge
}
criterion_main!(benches);
