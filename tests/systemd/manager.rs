use super::*;

// ---------------------------------------------------------------------------------------------
// Under a real systemd user manager

/// The user-mode variant of a system unit: no `User=`/`Group=` (a user manager cannot switch
/// identity), the installed binary and config with the test's iceoryx2 location, the test's
/// runtime folder in place of `/run/mimnav`, and the log in a file (there is no journal).
pub(crate) fn user_unit(
    system: &str,
    service: &str,
    exec: &str,
    run_dir: &Path,
    log: &Path,
    drop_protect_home: bool,
) -> String {
    let mut out = String::new();
    let (mut exec_done, mut rw_done) = (false, false);
    let exec_from = format!("ExecStart=/usr/bin/mimnav-{service} --config /etc/mimnav/mimnav.toml");
    for line in system.lines() {
        let key = line.split('=').next().unwrap_or("");
        match key {
            "User" | "Group" => continue,
            "ProtectHome" if drop_protect_home => continue,
            "ReadWritePaths" if line == "ReadWritePaths=/run/mimnav" => {
                out.push_str(&format!("ReadWritePaths={}\n", run_dir.display()));
                rw_done = true;
            }
            "ExecStart" if line == exec_from => {
                out.push_str(&format!("ExecStart={exec}\n"));
                out.push_str(&format!("StandardOutput=append:{}\n", log.display()));
                out.push_str("StandardError=inherit\nEnvironment=MIMNAV_LOG=info\n");
                exec_done = true;
            }
            _ => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    assert!(exec_done, "{service}: no `{exec_from}` line to rewrite");
    assert!(
        rw_done,
        "{service}: no `ReadWritePaths=/run/mimnav` line to rewrite"
    );
    out
}

/// Why the systemd test cannot run here, if it cannot.
pub(crate) fn cannot_run() -> Result<(PathBuf, PathBuf), String> {
    // SAFETY: geteuid has no preconditions
    if unsafe { libc::geteuid() } != 0 {
        return Err("needs root (a mount namespace and a cgroup of its own)".into());
    }
    for cmd in ["unshare", "systemctl", "mount", "mknod", "mkfifo"] {
        if which(cmd).is_none() {
            return Err(format!("no `{cmd}` on this machine"));
        }
    }
    let systemd = ["/lib/systemd/systemd", "/usr/lib/systemd/systemd"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
        .ok_or("no systemd binary (/lib/systemd/systemd)")?;
    let fs_type = |p: &str| {
        let c = std::ffi::CString::new(p).unwrap();
        let mut st = std::mem::MaybeUninit::<libc::statfs>::uninit();
        // SAFETY: statfs writes into the buffer it is given
        (unsafe { libc::statfs(c.as_ptr(), st.as_mut_ptr()) } == 0)
            // SAFETY: statfs succeeded
            .then(|| unsafe { st.assume_init() }.f_type)
    };
    const CGROUP2_MAGIC: libc::c_long = 0x6367_7270;
    let v2 = ["/sys/fs/cgroup", "/sys/fs/cgroup/unified"]
        .into_iter()
        .find(|p| fs_type(p) == Some(CGROUP2_MAGIC as _))
        .ok_or("no cgroup2 hierarchy")?;
    Ok((systemd, PathBuf::from(v2)))
}

/// A throwaway `systemd --user`, in its own cgroup and mount namespace; ended when dropped.
pub(crate) struct Manager {
    pub(crate) child: Child,
    pub(crate) t: PathBuf,
    pub(crate) cgroup: PathBuf,
    pub(crate) exited: bool,
}

impl Manager {
    pub(crate) fn start(t: &Path, systemd: &Path, v2: &Path) -> Result<Manager, String> {
        let own = std::fs::read_to_string("/proc/self/cgroup")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("0::").map(str::to_string))
            })
            .ok_or("no cgroup2 line in /proc/self/cgroup")?;
        let cgroup = v2
            .join(own.trim_start_matches('/'))
            .join(format!("mimnav-e2e-systemd-{}", std::process::id()));
        if let Err(e) = std::fs::create_dir(&cgroup) {
            return Err(format!("cannot make a cgroup {}: {e}", cgroup.display()));
        }
        let script = r#"
            echo $$ > "$CGDIR/cgroup.procs"
            mount -t tmpfs -o mode=0755 tmpfs /run
            mkdir -p /run/systemd/system /run/systemd/inaccessible
            cd /run/systemd/inaccessible
            mkdir -m 0 dir; : > reg; chmod 0 reg; mkfifo -m 0 fifo
            mknod -m 0 chr c 0 0; mknod -m 0 blk b 0 0
            cd /
            [ "$V2" = /sys/fs/cgroup ] || mount --bind "$V2" /sys/fs/cgroup
            [ ! -e /dev/console ] || mount --bind /dev/null /dev/console
            s=$SYSTEMD; unset CGDIR V2 SYSTEMD
            exec "$s" --user --log-target=null --unit=mimnav-test-idle.target
        "#;
        let out = std::fs::File::create(t.join("manager.out")).map_err(|e| e.to_string())?;
        let child = Command::new("unshare")
            .args([
                "--mount",
                "--propagation",
                "private",
                "--",
                "/bin/sh",
                "-ec",
                script,
            ])
            .env_clear()
            .env("PATH", "/usr/sbin:/usr/bin:/sbin:/bin")
            .env("HOME", t.join("home"))
            .env("XDG_RUNTIME_DIR", t.join("runtime"))
            .env("XDG_CONFIG_HOME", t.join("config"))
            .env("CGDIR", &cgroup)
            .env("V2", v2)
            .env("SYSTEMD", systemd)
            .stdin(Stdio::null())
            .stdout(out.try_clone().map_err(|e| e.to_string())?)
            .stderr(out)
            .spawn()
            .map_err(|e| {
                let _ = std::fs::remove_dir(&cgroup);
                format!("cannot run unshare: {e}")
            })?;
        let mut m = Manager {
            child,
            t: t.to_path_buf(),
            cgroup,
            exited: false,
        };
        let until = Instant::now() + Duration::from_secs(15);
        loop {
            if let Ok(Some(status)) = m.child.try_wait() {
                m.exited = true;
                return Err(format!(
                    "the user manager ended at once ({status}): {}",
                    std::fs::read_to_string(t.join("manager.out")).unwrap_or_default()
                ));
            }
            if t.join("runtime/systemd/private").exists() {
                let state = m.systemctl(&["show", "-p", "SystemState", "--value"]);
                let state = String::from_utf8_lossy(&state.stdout).trim().to_string();
                if state == "running" || state == "degraded" {
                    return Ok(m);
                }
            }
            if Instant::now() > until {
                return Err("the user manager did not come up within 15 s".into());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    pub(crate) fn systemctl(&self, args: &[&str]) -> Output {
        Command::new("systemctl")
            .arg("--user")
            .args(args)
            .env("XDG_RUNTIME_DIR", self.t.join("runtime"))
            .env_remove("DBUS_SESSION_BUS_ADDRESS")
            .stdin(Stdio::null())
            .output()
            .expect("run systemctl")
    }

    pub(crate) fn prop(&self, unit: &str, name: &str) -> String {
        let o = self.systemctl(&["show", "-p", name, "--value", unit]);
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    }

    pub(crate) fn main_pid(&self, unit: &str) -> i32 {
        self.prop(unit, "MainPID").parse().unwrap_or(0)
    }

    /// PIDs still in the manager's cgroup tree (the manager's own included).
    pub(crate) fn pids(&self) -> Vec<i32> {
        let mut pids = Vec::new();
        let mut dirs = vec![self.cgroup.clone()];
        while let Some(d) = dirs.pop() {
            if let Ok(s) = std::fs::read_to_string(d.join("cgroup.procs")) {
                pids.extend(s.lines().filter_map(|l| l.parse::<i32>().ok()));
            }
            if let Ok(rd) = std::fs::read_dir(&d) {
                dirs.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
            }
        }
        pids
    }

    /// `systemctl --user exit`; true when the manager is gone within 5 s.
    pub(crate) fn exit(&mut self) -> bool {
        let _ = self.systemctl(&["exit"]);
        let until = Instant::now() + Duration::from_secs(5);
        while Instant::now() < until {
            if let Ok(Some(_)) = self.child.try_wait() {
                self.exited = true;
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }
}

impl Drop for Manager {
    fn drop(&mut self) {
        if !self.exited && !self.exit() {
            let pid = self.child.id() as libc::pid_t;
            // SAFETY: the manager is our child and not reaped yet
            unsafe { libc::kill(pid, libc::SIGTERM) };
            std::thread::sleep(Duration::from_millis(500));
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
        // whatever is still in our cgroup was started by our manager
        for pid in self.pids() {
            // SAFETY: kill(2) on a process in the cgroup this test made for its own manager
            unsafe { libc::kill(pid, libc::SIGKILL) };
        }
        for _ in 0..50 {
            let mut dirs = Vec::new();
            let mut stack = vec![self.cgroup.clone()];
            while let Some(d) = stack.pop() {
                if let Ok(rd) = std::fs::read_dir(&d) {
                    stack.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_dir()));
                }
                dirs.push(d);
            }
            for d in dirs.iter().rev() {
                let _ = std::fs::remove_dir(d);
            }
            if !self.cgroup.exists() {
                break;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}
