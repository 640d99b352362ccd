//! `mimnav install`: puts the stack on a robot's computer the way systemd expects it — binaries in
//! `/usr/bin`, units in `/usr/lib/systemd/system`, the system user and the runtime directory in
//! `/usr/lib/{sysusers,tmpfiles}.d`, the config in `/etc/mimnav` (never overwriting one that is
//! there) — then creates the user and the directory and reloads systemd. With `--root DIR` it only
//! writes the files under DIR (for a package or an image) and prints the commands left to run.
//!
//! The units and entries are the files under `systemd/` in the repository, built into this
//! binary, so what is installed is what `systemd-analyze verify` checked.

use std::io::ErrorKind;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{Context, Result, bail};

/// The services' binaries, which the units start from `/usr/bin`, and the front end.
pub const BINARIES: [&str; 9] = [
    "mimnav-velodyne",
    "mimnav-mapper",
    "mimnav-foliage",
    "mimnav-planner",
    "mimnav-kobuki",
    "mimnav-view",
    "mimnav-zenoh",
    "mimnav-sick",
    "mimnav",
];

/// The root path the deployed stack gives iceoryx2 (tmpfiles.d creates it; the units may write
/// only there and to `/dev/shm`).
pub const DEPLOYED_IOX2_ROOT: &str = "/run/mimnav/iceoryx2/";

/// (path under the root, contents) of every unit and entry.
pub const SYSTEMD_FILES: [(&str, &str); 12] = [
    (
        "usr/lib/systemd/system/mimnav-velodyne.service",
        include_str!("../../../systemd/system/mimnav-velodyne.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-mapper.service",
        include_str!("../../../systemd/system/mimnav-mapper.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-foliage.service",
        include_str!("../../../systemd/system/mimnav-foliage.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-planner.service",
        include_str!("../../../systemd/system/mimnav-planner.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-kobuki.service",
        include_str!("../../../systemd/system/mimnav-kobuki.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-spot.service",
        include_str!("../../../systemd/system/mimnav-spot.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-view.service",
        include_str!("../../../systemd/system/mimnav-view.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-zenoh.service",
        include_str!("../../../systemd/system/mimnav-zenoh.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav-sick.service",
        include_str!("../../../systemd/system/mimnav-sick.service"),
    ),
    (
        "usr/lib/systemd/system/mimnav.target",
        include_str!("../../../systemd/system/mimnav.target"),
    ),
    (
        "usr/lib/sysusers.d/mimnav.conf",
        include_str!("../../../systemd/sysusers.d/mimnav.conf"),
    ),
    (
        "usr/lib/tmpfiles.d/mimnav.conf",
        include_str!("../../../systemd/tmpfiles.d/mimnav.conf"),
    ),
];

/// The Spot bridge and the client it runs on, for `mimnav-spot.service` (its `PYTHONPATH`).
pub const PYTHON_FILES: [(&str, &str); 2] = [
    (
        "usr/lib/mimnav/python/mimnav_client.py",
        include_str!("../../../clients/python/mimnav_client.py"),
    ),
    (
        "usr/lib/mimnav/python/mimnav_spot.py",
        include_str!("../../../clients/python/mimnav_spot.py"),
    ),
];

/// The Spot bridge's Python environment (the unit's `ExecStart`).
pub const SPOT_VENV: &str = "/usr/lib/mimnav/spot-venv";

/// What the Spot bridge's environment holds: Boston Dynamics' SDK and iceoryx2's binding, the
/// versions the tests ran against.
pub const SPOT_PACKAGES: [&str; 3] = [
    "bosdyn-client==5.2.0",
    "bosdyn-api==5.2.0",
    "iceoryx2==0.10.0",
];

const CONFIG: &str = include_str!("../../../config/mimnav.toml");
const ROBOTS: [(&str, &str); 2] = [
    (
        "spot.toml",
        include_str!("../../../config/robots/spot.toml"),
    ),
    (
        "turtlebot2.toml",
        include_str!("../../../config/robots/turtlebot2.toml"),
    ),
];

#[derive(Debug, clap::Args)]
pub struct InstallArgs {
    /// Write everything under this folder instead of `/`, and run nothing (for a package or a
    /// robot's image); prints the commands left to run on the robot.
    #[arg(long, value_name = "DIR")]
    root: Option<PathBuf>,
    /// Where the built binaries are [default: the folder of this `mimnav`].
    #[arg(long, value_name = "DIR")]
    bin_dir: Option<PathBuf>,
    /// Also make the Spot bridge's Python environment (/usr/lib/mimnav/spot-venv: Boston
    /// Dynamics' SDK and iceoryx2's binding from PyPI; needs python3-venv and the network).
    /// With --root, prints the commands instead.
    #[arg(long)]
    spot: bool,
}

/// The shipped config, deployed: iceoryx2's root path under `/run` (`/tmp` is read-only to the
/// services, and a private `/tmp` would split the stack).
pub fn deployed_config() -> Result<String> {
    let from = format!(
        "root-path = \"{}\"",
        mimnav_shared::config::DEFAULT_IOX2_ROOT
    );
    if !CONFIG.contains(&from) {
        bail!("the shipped config has no `{from}` line to point at {DEPLOYED_IOX2_ROOT}");
    }
    Ok(CONFIG.replacen(&from, &format!("root-path = \"{DEPLOYED_IOX2_ROOT}\""), 1))
}

pub fn run(args: &InstallArgs) -> Result<ExitCode> {
    let bin_dir = match &args.bin_dir {
        Some(d) => d.clone(),
        None => std::env::current_exe()
            .context("cannot find this program's own path (give --bin-dir)")?
            .parent()
            .map(Path::to_path_buf)
            .context("this program's path has no folder (give --bin-dir)")?,
    };
    let missing: Vec<&str> = BINARIES
        .iter()
        .copied()
        .filter(|b| !bin_dir.join(b).is_file())
        .collect();
    if !missing.is_empty() {
        bail!(
            "{} not found in {} (build them with `cargo build --release --workspace`, or give \
             --bin-dir)",
            missing.join(", "),
            bin_dir.display()
        );
    }
    let root = args.root.clone().unwrap_or_else(|| PathBuf::from("/"));
    let live = args.root.is_none();
    for b in BINARIES {
        let to = root.join("usr/bin").join(b);
        install_binary(&bin_dir.join(b), &to)?;
        outln!("installed {}", to.display())?;
    }
    for (path, text) in SYSTEMD_FILES {
        let to = root.join(path);
        write(&to, text.as_bytes(), 0o644)?;
        outln!("installed {}", to.display())?;
    }
    for (path, text) in PYTHON_FILES {
        let to = root.join(path);
        write(&to, text.as_bytes(), 0o644)?;
        outln!("installed {}", to.display())?;
    }
    let etc = root.join("etc/mimnav");
    for (name, text) in ROBOTS {
        let to = etc.join("robots").join(name);
        write(&to, text.as_bytes(), 0o644)?;
        outln!("installed {}", to.display())?;
    }
    let config = deployed_config()?;
    let to = etc.join("mimnav.toml");
    if to.exists() {
        let dist = etc.join("mimnav.toml.dist");
        write(&dist, config.as_bytes(), 0o644)?;
        outln!(
            "kept {} (yours); the shipped one is {}: compare them",
            to.display(),
            dist.display()
        )?;
    } else {
        write(&to, config.as_bytes(), 0o644)?;
        outln!("installed {}", to.display())?;
    }
    let pip = format!("{SPOT_VENV}/bin/pip");
    let mut steps: Vec<Vec<&str>> = vec![
        vec!["systemd-sysusers", "mimnav.conf"],
        vec!["systemd-tmpfiles", "--create", "mimnav.conf"],
        vec!["systemctl", "daemon-reload"],
    ];
    if args.spot {
        steps.push(vec!["python3", "-m", "venv", SPOT_VENV]);
        let mut install = vec![pip.as_str(), "install", "--quiet"];
        install.extend(SPOT_PACKAGES);
        steps.push(install);
    }
    if live {
        for step in &steps {
            let status = Command::new(step[0])
                .args(&step[1..])
                .status()
                .with_context(|| format!("cannot run {}", step.join(" ")))?;
            if !status.success() {
                bail!("`{}` failed ({status})", step.join(" "));
            }
            outln!("ran {}", step.join(" "))?;
        }
    } else {
        outln!("then, on the robot:")?;
        for step in &steps {
            outln!("  {}", step.join(" "))?;
        }
    }
    outln!(
        "the robot's base, part of mimnav.target once enabled:  systemctl enable mimnav-kobuki.service \
         (Turtlebot 2; docs/deployment.md has its udev rule) or mimnav-spot.service (Spot: install \
         with --spot, credentials in /etc/mimnav/spot-credentials, mode 0600)"
    )?;
    outln!(
        "the Zenoh bridge (topics for other hosts, remote goals; docs/zenoh.md): set [zenoh] \
         enabled = true in the config, then  systemctl enable mimnav-zenoh.service"
    )?;
    outln!(
        "a SICK planar ladar for the foliage classifier (docs/sick.md): set foliage.source = \
         \"sick\" and [sick] host, model and mount in the config, then  systemctl enable \
         mimnav-sick.service"
    )?;
    outln!(
        "start the stack now and at every boot:  systemctl enable --now mimnav.target\n\
         see it:   systemctl status 'mimnav-*'    journalctl -u 'mimnav-*' -f\n\
         the config is {}; after editing it: systemctl restart mimnav.target",
        mimnav_shared::config::DEFAULT_CONFIG_PATH
    )?;
    Ok(ExitCode::SUCCESS)
}

/// Writes `bytes` to `to` (through a temporary file beside it, so a running reader never sees half
/// a file), creating its folder, with `mode`.
fn write(to: &Path, bytes: &[u8], mode: u32) -> Result<()> {
    let dir = to
        .parent()
        .with_context(|| format!("{} has no folder", to.display()))?;
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let tmp = dir.join(format!(
        ".{}.mimnav-install",
        to.file_name().and_then(|n| n.to_str()).unwrap_or("file")
    ));
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::set_permissions(&tmp, std::fs::Permissions::from_mode(mode))
        .with_context(|| format!("cannot set the mode of {}", tmp.display()))?;
    std::fs::rename(&tmp, to).with_context(|| format!("cannot write {}", to.display()))?;
    Ok(())
}

/// Copies a binary; replacing one that is running works because the new file gets a new inode.
fn install_binary(from: &Path, to: &Path) -> Result<()> {
    let bytes = match std::fs::read(from) {
        Ok(b) => b,
        Err(e) if e.kind() == ErrorKind::NotFound => bail!("{} not found", from.display()),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", from.display())),
    };
    write(to, &bytes, 0o755)
}
