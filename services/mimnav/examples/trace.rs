//! Debug: runs one episode of a world and writes the planner's map every N revolutions and at
//! the last ones. `cargo run --release -p mimnav --example trace -- WORLD OUTDIR [EVERY] [--set K=V]…`
use std::path::PathBuf;

use mimnav_config::Config;
use mimnav_mapper::render::{Marks, render_map};
use mimnav_runner::{Lockstep, Options};
use mimnav_shared::pose::Pose2Ext;
use mimnav_sim::world::WorldFile;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let world = PathBuf::from(&args[0]);
    let out = PathBuf::from(&args[1]);
    let every: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let sets: Vec<String> = args
        .windows(2)
        .filter(|w| w[0] == "--set")
        .map(|w| w[1].clone())
        .collect();
    std::fs::create_dir_all(&out)?;
    let config = Config::resolve(Some(std::path::Path::new("config/mimnav.toml")), &sets)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let scene = WorldFile::load(&world)
        .map_err(|e| anyhow::anyhow!("{e}"))?
        .compile();
    let goal = scene.goal;
    let mut run = Lockstep::new(&config, scene, 1, Options::deployed(&config))?;
    run.set_goal(goal[0], goal[1], config.sim.goal_tolerance_m)?;
    let grid = config.map.grid();
    let mut frames: Vec<(usize, mimnav_mapper::render::Image)> = Vec::new();
    let mut n = 0;
    while let Some(turn) = run.next_revolution()? {
        n += 1;
        let pose = run.sim().base().pose;
        let (gx, gy) = pose.to_local(goal[0], goal[1]);
        let img = render_map(
            grid,
            run.classes(),
            &[],
            &Marks {
                robot_radius_m: config.robot.radius_m,
                goal: Some((gx, gy)),
            },
        );
        let cmd = turn.command.map(|(d, c)| (d.status, c.v, c.omega));
        println!(
            "rev {n} pose ({:.2},{:.2},{:.2}) cmd {:?}",
            pose.x(),
            pose.y(),
            pose.rotation.angle(),
            cmd
        );
        if n % every == 0 {
            write(&out.join(format!("rev{n:04}.png")), &img)?;
        }
        frames.push((n, img));
        if frames.len() > 4 {
            frames.remove(0);
        }
    }
    for (n, img) in &frames {
        write(&out.join(format!("last{n:04}.png")), img)?;
    }
    println!("outcome {:?}", run.sim().outcome());
    Ok(())
}

fn write(path: &std::path::Path, img: &mimnav_mapper::render::Image) -> anyhow::Result<()> {
    let file = std::fs::File::create(path)?;
    let mut enc = png::Encoder::new(
        std::io::BufWriter::new(file),
        img.width as u32,
        img.height as u32,
    );
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()?.write_image_data(&img.rgb)?;
    Ok(())
}
