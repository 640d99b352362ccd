//! `mimnav snapshot --out map.png`: the next map the mapper publishes, as a picture.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use mimnav_config::Config;
use mimnav_mapper::render::{Image, Marks, render_layers, render_map_with_legend};
use mimnav_shared::grid::GridSpec;
use mimnav_shared::ipc::{self, Listening};
use mimnav_shared::pose::{Pose2Ext, pose2};
use mimnav_shared::topics::{MapHeader, PlanCell};

/// Arguments of `mimnav snapshot`.
#[derive(Debug, clap::Args)]
pub struct SnapshotArgs {
    /// Where to write the PNG.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Write every layer of map/layers side by side instead of the classes.
    #[arg(long)]
    layers: bool,
    /// Mark a goal given in the odometry frame.
    #[arg(long, num_args = 2, value_names = ["X", "Y"], allow_negative_numbers = true)]
    goal: Option<Vec<f64>>,
    /// Give up after this many seconds without a map.
    #[arg(long, default_value_t = 5.0)]
    timeout: f64,
}

/// Writes `img` as an RGB PNG, the path named in the error.
pub fn write_png(path: &std::path::Path, img: &Image) -> Result<()> {
    img.write_png(path)
        .with_context(|| format!("cannot write {}", path.display()))
}

/// The robot's rectangular body (length, width), when its profile gives one.
pub fn body_of(config: &Config) -> Option<(f64, f64)> {
    let r = &config.robot;
    (r.length_m > 0.0 && r.width_m > 0.0).then_some((r.length_m, r.width_m))
}

/// The brightest main layer's I_j of every cell (for the shading of solid cells).
fn brightest(layers: &[f32], header: &MapHeader) -> Vec<f32> {
    let n2 = (header.cells as usize).pow(2);
    let m = header.layers as usize;
    (0..n2)
        .map(|i| {
            (0..m.min(3))
                .map(|j| layers.get(j * n2 + i).copied().unwrap_or(0.0))
                .fold(0.0, f32::max)
        })
        .collect()
}

/// Waits for the next map/plan and map/layers and writes the picture.
pub fn run(config: &Config, args: &SnapshotArgs) -> Result<ExitCode> {
    let node = ipc::node(config, "mimnav-snapshot")?;
    let plan = ipc::plan_subscriber(&node)?;
    let layers = ipc::layers_subscriber(&node)?;
    let until = Instant::now() + Duration::from_secs_f64(args.timeout.max(0.1));
    let mut got_plan: Option<(MapHeader, Vec<PlanCell>)> = None;
    let mut got_layers: Option<(MapHeader, Vec<f32>)> = None;
    loop {
        if let Some(s) = plan.receive()? {
            got_plan = Some((*s.user_header(), s.payload().to_vec()));
        }
        if let Some(s) = layers.receive()? {
            got_layers = Some((*s.user_header(), s.payload().to_vec()));
        }
        let matched = match (&got_plan, &got_layers) {
            (Some((a, _)), Some((b, _))) => a.seq == b.seq,
            _ => false,
        };
        if matched {
            break;
        }
        if Instant::now() >= until {
            bail!(
                "no map on {} within {} s: is mimnav-mapper running with the same iceoryx2 root-path ({}) and prefix ({})?",
                mimnav_shared::topics::MAP_PLAN,
                args.timeout,
                config.iceoryx2.global.root_path(),
                config.iceoryx2.global.prefix
            );
        }
        if !ipc::sleep(&node, Duration::ZERO) {
            return Ok(ExitCode::from(130));
        }
        plan.heard_within(Duration::from_millis(50));
    }
    let (header, cells) = got_plan.context("no plan")?;
    let (_, layer_values) = got_layers.context("no layers")?;
    let grid = GridSpec {
        cells: header.cells as usize,
        cell_m: header.cell_m,
    };
    let img = if args.layers {
        render_layers(grid, &layer_values, header.layers as usize)
    } else {
        let classes: Vec<u8> = cells.iter().map(|c| c.class).collect();
        let robot = pose2(header.x, header.y, header.yaw);
        let goal = args.goal.as_ref().map(|g| robot.to_local(g[0], g[1]));
        let marks = Marks {
            robot_radius_m: config.robot.radius_m,
            body_m: body_of(config),
            goal,
            path: Vec::new(),
        };
        render_map_with_legend(
            grid,
            &classes,
            &brightest(&layer_values, &header),
            &marks,
            &format!("map {}", header.seq),
        )
    };
    write_png(&args.out, &img)?;
    outln!(
        "{}: map {} of revolution {} ({} × {} cells of {} m{}), {} × {} px",
        args.out.display(),
        header.seq,
        header.source_seq,
        header.cells,
        header.cells,
        header.cell_m,
        if args.layers {
            format!(", {} layers side by side", header.layers)
        } else {
            String::new()
        },
        img.width,
        img.height
    )?;
    Ok(ExitCode::SUCCESS)
}
