use mimnav_mapper::glass::Pose2;
use mimnav_mapper::{Mapper, MapperParams, OdomInput};
use mimnav_shared::config::Config;
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Sim, SimSettings};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

#[test]
fn scratch() {
    let config = Config::default();
    let w = WorldFile::load(std::path::Path::new(&std::env::var("W").unwrap())).unwrap();
    let scene = w.compile();
    let mut sim = Sim::new(
        scene.clone(),
        SimSettings::from_config(&config),
        1,
        DEFAULT_EPOCH_NS,
    );
    let mut driver = WaypointDriver::new(scene.survey.clone(), 0.25);
    let mut asm = Assembler::new(AssemblerConfig::from_config(&config));
    let mut mapper = Mapper::new(MapperParams::from_config(&config));
    let grid = config.map.grid();
    let mut truth = Vec::new();
    let mut n = 0;
    let want: usize = std::env::var("N").unwrap().parse().unwrap();
    while !driver.done() && sim.outcome() == mimnav_sim::Outcome::Running {
        let step = sim.step();
        let Some(rev) = asm.push(&step.data, step.first_firing_ns, 0).unwrap() else {
            continue;
        };
        n += 1;
        let b = *sim.base();
        mapper.update(
            &rev.points,
            OdomInput::Fresh(mimnav_mapper::Odom {
                pose: Pose2 {
                    x: b.pose.x,
                    y: b.pose.y,
                    yaw: b.pose.yaw,
                },
                v: b.v,
                omega: b.omega,
            }),
            rev.header.stamp_ns,
        );
        sim.truth(grid, &mut truth);
        let (v, wv) = driver.command(b.pose, &sim.settings().limits);
        sim.set_command(v, wv);
        if want == 0 || n == want {
            let mut conf = [[0u32; 5]; 5];
            for i in 0..grid.len() {
                let (x, y) = grid.center_of(i / grid.cells, i % grid.cells);
                if x.hypot(y) > 4.5 {
                    continue;
                }
                conf[truth[i] as usize][mapper.classes()[i] as usize] += 1;
                if mapper.classes()[i] != truth[i]
                    && (mapper.classes()[i] == 1 || mapper.classes()[i] == 2)
                    && std::env::var("V").is_ok()
                {
                    let (sn, cs) = b.pose.yaw.sin_cos();
                    let (wx, wy) = (
                        b.pose.x + cs * x as f64 - sn * y as f64,
                        b.pose.y + sn * x as f64 + cs * y as f64,
                    );
                    eprintln!(
                        "truth {} map {} at ({x:.2},{y:.2}) world ({wx:.2},{wy:.2}) {:?}",
                        truth[i],
                        mapper.classes()[i],
                        mapper.cell_evidence(i)
                    );
                }
            }
            if want != 0 {
                eprintln!(
                    "pose {:?}\nconfusion truth x map (free solid passable glass unknown):",
                    b.pose
                );
                for (t, row) in conf.iter().enumerate() {
                    eprintln!("{t}: {row:?}");
                }
                break;
            }
        }
    }
}
