use super::*;

#[test]
fn install_places_every_file_and_keeps_an_edited_config() {
    let t = TempDir::new("install");
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    for s in UNITS {
        let unit =
            t.0.join(format!("usr/lib/systemd/system/mimnav-{s}.service"));
        let repo = root().join(format!("systemd/system/mimnav-{s}.service"));
        assert_eq!(
            std::fs::read_to_string(&unit).expect("unit"),
            std::fs::read_to_string(&repo).expect("repo unit"),
            "{s}: the installed unit is the repository's"
        );
        if s == "spot" {
            // a Python module, run from its own environment
            continue;
        }
        let b = t.0.join(format!("usr/bin/mimnav-{s}"));
        let mode = std::fs::metadata(&b).expect("binary").permissions().mode();
        assert_eq!(mode & 0o777, 0o755, "{}", b.display());
    }
    for f in ["mimnav_client.py", "mimnav_spot.py"] {
        let installed = t.0.join("usr/lib/mimnav/python").join(f);
        let repo = root().join("clients/python").join(f);
        assert_eq!(
            std::fs::read(&installed).expect("installed"),
            std::fs::read(&repo).expect("repo"),
            "{f}: the Spot bridge's Python is the repository's"
        );
    }
    for f in [
        "usr/bin/mimnav",
        "usr/lib/systemd/system/mimnav.target",
        "usr/lib/sysusers.d/mimnav.conf",
        "usr/lib/tmpfiles.d/mimnav.conf",
        "etc/mimnav/robots/spot.toml",
        "etc/mimnav/robots/turtlebot2.toml",
    ] {
        assert!(t.0.join(f).is_file(), "{f} installed");
    }
    // the deployed config parses, with iceoryx2's root under /run (tmpfiles.d makes it)
    let etc = t.0.join("etc/mimnav/mimnav.toml");
    let config = Config::resolve(Some(&etc), &[]).expect("the installed config parses");
    assert_eq!(
        config.iceoryx2.global.root_path().to_string(),
        "/run/mimnav/iceoryx2/"
    );
    let tmpfiles = std::fs::read_to_string(t.0.join("usr/lib/tmpfiles.d/mimnav.conf")).unwrap();
    assert!(
        tmpfiles
            .lines()
            .any(|l| l.starts_with("d")
                && l.split_whitespace().nth(1) == Some("/run/mimnav/iceoryx2")),
        "{tmpfiles}"
    );
    // a second install keeps the owner's edits and leaves the shipped config beside them
    std::fs::write(&etc, "# mine\n").expect("edit");
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(std::fs::read_to_string(&etc).unwrap(), "# mine\n");
    assert!(t.0.join("etc/mimnav/mimnav.toml.dist").is_file());
    assert!(text(&o).contains("kept"), "{}", text(&o));
    // a missing binary is named, and nothing is half-installed from a wrong folder
    let o = Command::new(crate::util::bin("mimnav"))
        .args(["install", "--root"])
        .arg(t.0.join("other"))
        .arg("--bin-dir")
        .arg(&t.0)
        .output()
        .expect("run");
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o).contains("mimnav-velodyne"), "{}", text(&o));
    assert!(!t.0.join("other").exists());
}

/// A root for `systemd-analyze verify --root`: the installed units, with the targets they name.
fn verify_root(tag: &str) -> Option<TempDir> {
    if which("systemd-analyze").is_none() {
        println!("SKIP {tag}: no systemd-analyze on this machine");
        return None;
    }
    let t = TempDir::new(tag);
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    // verify resolves the units a unit pulls in; an empty unit file would count as masked
    for target in [
        "sysinit",
        "basic",
        "shutdown",
        "network",
        "network-online",
        "multi-user",
    ] {
        let p = t.0.join(format!("usr/lib/systemd/system/{target}.target"));
        std::fs::write(p, "[Unit]\nDescription=stub for verify\n").expect("stub");
    }
    // the Spot bridge's Python, which `mimnav install --spot` makes on the robot (--root only
    // prints the commands)
    let python = t.0.join("usr/lib/mimnav/spot-venv/bin/python");
    std::fs::create_dir_all(python.parent().expect("folder")).expect("venv folder");
    std::fs::write(&python, "#!/bin/sh\n").expect("stub python");
    std::fs::set_permissions(&python, std::fs::Permissions::from_mode(0o755)).expect("mode");
    Some(t)
}

fn verify(root_dir: &Path, unit: &str) -> Output {
    Command::new("systemd-analyze")
        .arg("verify")
        .arg(format!("--root={}", root_dir.display()))
        .arg("--man=no")
        .arg(unit)
        .output()
        .expect("run systemd-analyze verify")
}

#[test]
fn systemd_analyze_verify_passes_every_unit_without_a_warning() {
    let Some(t) = verify_root("verify") else {
        return;
    };
    for unit in UNITS
        .iter()
        .map(|s| format!("mimnav-{s}.service"))
        .chain(["mimnav.target".to_string()])
    {
        let o = verify(&t.0, &unit);
        // verify exits 0 on warnings (an unknown key is "ignoring"): the output must be empty
        assert!(
            o.status.success() && text(&o).trim().is_empty(),
            "{unit}: {} {}",
            o.status,
            text(&o)
        );
    }
    // and it does see a broken unit: an unknown key and a bad value
    let mapper = t.0.join("usr/lib/systemd/system/mimnav-mapper.service");
    let good = std::fs::read_to_string(&mapper).unwrap();
    std::fs::write(
        &mapper,
        good.replace("WatchdogSec=2s", "WatchdogSecs=2s\nProtectHome=maybe"),
    )
    .unwrap();
    let out = text(&verify(&t.0, "mimnav-mapper.service"));
    assert!(out.contains("WatchdogSecs"), "{out}");
    assert!(out.contains("protect home"), "{out}");
}

#[test]
fn every_unit_is_exposed_at_most_3_of_10() {
    if which("systemd-analyze").is_none() {
        println!("SKIP security exposure: no systemd-analyze on this machine");
        return;
    }
    for s in UNITS {
        let unit = root().join(format!("systemd/system/mimnav-{s}.service"));
        let o = Command::new("systemd-analyze")
            .args(["security", "--offline=yes", "--no-pager"])
            .arg(&unit)
            .output()
            .expect("run systemd-analyze security");
        let out = text(&o);
        let Some(level) = out
            .lines()
            .find_map(|l| l.split("Overall exposure level for ").nth(1))
            .and_then(|rest| rest.split(": ").nth(1))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse::<f64>().ok())
        else {
            panic!("no exposure level for {s}: {out}");
        };
        println!("mimnav-{s}.service exposure {level}");
        assert!(level <= 3.0, "mimnav-{s}: {level}\n{out}");
    }
}

#[test]
fn sysusers_and_tmpfiles_entries_make_the_user_and_the_runtime_folder() {
    let (Some(_), Some(_)) = (which("systemd-sysusers"), which("systemd-tmpfiles")) else {
        println!("SKIP sysusers/tmpfiles: systemd-sysusers or systemd-tmpfiles missing");
        return;
    };
    let t = TempDir::new("sysusers");
    let o = install(&t.0);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::create_dir_all(t.0.join("etc")).unwrap();
    let o = Command::new("systemd-sysusers")
        .arg(format!("--root={}", t.0.display()))
        .arg("mimnav.conf")
        .output()
        .expect("run systemd-sysusers");
    assert!(o.status.success(), "{}", text(&o));
    let passwd = std::fs::read_to_string(t.0.join("etc/passwd")).expect("passwd");
    let line = passwd
        .lines()
        .find(|l| l.starts_with("mimnav:"))
        .unwrap_or_else(|| panic!("no mimnav user: {passwd}"));
    let uid: u32 = line.split(':').nth(2).unwrap().parse().unwrap();
    assert!(uid < 1000, "a system user: {line}");
    // tmpfiles chowns to the new user, which needs root
    // SAFETY: geteuid has no preconditions
    if unsafe { libc::geteuid() } != 0 {
        println!("SKIP tmpfiles --create: not root");
        return;
    }
    // a stand-in for the PM QoS device, which the z line hands to the mimnav group
    std::fs::create_dir_all(t.0.join("dev")).unwrap();
    std::fs::write(t.0.join("dev/cpu_dma_latency"), b"").unwrap();
    let o = Command::new("systemd-tmpfiles")
        .arg(format!("--root={}", t.0.display()))
        .args(["--create", "mimnav.conf"])
        .output()
        .expect("run systemd-tmpfiles");
    assert!(o.status.success(), "{}", text(&o));
    let meta = std::fs::metadata(t.0.join("run/mimnav/iceoryx2")).expect("runtime folder");
    use std::os::unix::fs::MetadataExt;
    assert_eq!(meta.uid(), uid);
    assert_eq!(meta.mode() & 0o777, 0o750);
    let group = std::fs::read_to_string(t.0.join("etc/group")).expect("group");
    let gid: u32 = group
        .lines()
        .find(|l| l.starts_with("mimnav:"))
        .and_then(|l| l.split(':').nth(2))
        .and_then(|g| g.parse().ok())
        .unwrap_or_else(|| panic!("no mimnav group: {group}"));
    let dev = std::fs::metadata(t.0.join("dev/cpu_dma_latency")).expect("device stand-in");
    assert_eq!(dev.uid(), 0, "the device stays root's");
    assert_eq!(
        dev.gid(),
        gid,
        "the mimnav group may write the PM QoS device"
    );
    assert_eq!(dev.mode() & 0o777, 0o660);
}
