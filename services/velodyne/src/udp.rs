//! Receiving VLP-16 datagrams from UDP sockets: data packets on one port, position packets on
//! another (2368 and 8308 by default), with an optional source-address filter.

use std::io;
use std::net::{IpAddr, SocketAddr, UdpSocket};
use std::os::fd::{AsRawFd, RawFd};

use crate::config::VelodyneConfig;

/// Which socket a datagram came in on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Port {
    /// The data port.
    Data,
    /// The position port.
    Position,
}

/// A received datagram (the bytes are in the caller's buffer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Received {
    /// Bytes received.
    pub len: usize,
    /// Sender.
    pub from: SocketAddr,
    /// Socket it came in on.
    pub port: Port,
}

/// The bound sockets.
#[derive(Debug)]
pub struct UdpSource {
    data: UdpSocket,
    position: Option<UdpSocket>,
    allowed_source: Option<IpAddr>,
    rejected: u64,
    last_rejected: Option<SocketAddr>,
}

impl UdpSource {
    /// Binds the sockets, non-blocking: the caller waits for readiness on [`UdpSource::fds`]
    /// (the service attaches them to its WaitSet) and then drains them with
    /// [`UdpSource::recv`].
    ///
    /// The sockets are those of `[velodyne]`: `bind_address`, `data_port`, `position_port` (0: not
    /// listened for), `allowed_source` and `recv_buffer_bytes` (the kernel may grant less:
    /// `net.core.rmem_max`).
    pub fn bind(config: &VelodyneConfig) -> io::Result<Self> {
        let position_port = (config.position_port != 0).then_some(config.position_port);
        Self::bind_ports(config, position_port)
    }

    /// [`UdpSource::bind`] with the position socket on `position_port` (`Some(0)`: a port the
    /// system picks, which `[velodyne]` cannot say).
    fn bind_ports(config: &VelodyneConfig, position_port: Option<u16>) -> io::Result<Self> {
        let data = UdpSocket::bind((config.bind_address, config.data_port))?;
        data.set_nonblocking(true)?;
        set_recv_buffer(&data, config.recv_buffer_bytes)?;
        let position = match position_port {
            Some(p) => {
                let s = UdpSocket::bind((config.bind_address, p))?;
                s.set_nonblocking(true)?;
                Some(s)
            }
            None => None,
        };
        let source = UdpSource {
            data,
            position,
            allowed_source: config.allowed_source,
            rejected: 0,
            last_rejected: None,
        };
        // the first request turns the kernel's receive time stamps on for the socket (through a
        // kernel work queue: datagrams in the first moments may still come unstamped)
        let _ = arrival_ns(source.data.as_raw_fd());
        let granted = source.recv_buffer_bytes().unwrap_or(0);
        if granted < config.recv_buffer_bytes {
            tracing::info!(
                asked = config.recv_buffer_bytes,
                granted,
                "the kernel granted a smaller UDP receive buffer (raise net.core.rmem_max to get more)"
            );
        }
        tracing::info!(
            data = %source.data_addr().map(|a| a.to_string()).unwrap_or_default(),
            position_port = ?position_port,
            allowed_source = ?config.allowed_source,
            "listening for VLP-16 datagrams"
        );
        Ok(source)
    }

    /// How long the datagram last read from the data socket waited in the kernel, ns: from its
    /// arrival (the kernel's time stamp, `SIOCGSTAMPNS`) to now, at most 1 s; 0 when the kernel
    /// has no stamp for it. A revolution's latency is counted from its last packet's arrival,
    /// so the time a datagram waits while the driver paces its reads ([`crate::pace`]) counts.
    pub fn kernel_wait_ns(&self) -> u64 {
        let Some(arrival) = arrival_ns(self.data.as_raw_fd()) else {
            return 0;
        };
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() as u64);
        now.saturating_sub(arrival).min(1_000_000_000)
    }

    /// The local address of the data socket (useful when bound to port 0).
    pub fn data_addr(&self) -> io::Result<SocketAddr> {
        self.data.local_addr()
    }

    /// The local address of the position socket, if any.
    pub fn position_addr(&self) -> Option<io::Result<SocketAddr>> {
        self.position.as_ref().map(|s| s.local_addr())
    }

    /// The receive buffer the kernel granted the data socket, bytes.
    pub fn recv_buffer_bytes(&self) -> io::Result<usize> {
        let mut v: libc::c_int = 0;
        let mut len = std::mem::size_of::<libc::c_int>() as libc::socklen_t;
        // SAFETY: getsockopt writes one c_int through valid pointers on a socket we own.
        let r = unsafe {
            libc::getsockopt(
                self.data.as_raw_fd(),
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                (&mut v as *mut libc::c_int).cast(),
                &mut len,
            )
        };
        if r != 0 {
            return Err(io::Error::last_os_error());
        }
        Ok(v.max(0) as usize)
    }

    /// Datagrams the kernel dropped on these sockets because their receive buffer was full —
    /// the hop from the sensor to the driver (the `drops` column of `/proc/net/udp` and
    /// `/proc/net/udp6` for the sockets' inodes). `None` where `/proc` does not tell.
    pub fn kernel_drops(&self) -> Option<u64> {
        let inodes: Vec<u64> = (self.fds().into_iter()).filter_map(inode).collect();
        let tables = ["/proc/net/udp", "/proc/net/udp6"].map(std::fs::read_to_string);
        (tables.iter().flatten())
            .filter_map(|t| drops_of(t, &inodes))
            .reduce(|a, b| a + b)
    }

    /// The file descriptors to wait on: the data socket, then the position socket if any.
    pub fn fds(&self) -> Vec<RawFd> {
        let mut v = vec![self.data.as_raw_fd()];
        if let Some(p) = &self.position {
            v.push(p.as_raw_fd());
        }
        v
    }

    /// Datagrams dropped because they came from a sender other than the allowed one.
    pub fn rejected(&self) -> u64 {
        self.rejected
    }

    /// The sender of the last datagram dropped by the source filter.
    pub fn last_rejected(&self) -> Option<SocketAddr> {
        self.last_rejected
    }

    /// Receives the next waiting datagram into `buf`: a position packet first, else a data
    /// packet. `Ok(None)` when none is waiting. Datagrams larger than
    /// `buf` are truncated by the OS; the returned length then equals `buf.len()` and the
    /// decoder rejects it by size. A datagram from a sender other than `allowed_source` is
    /// dropped, counted and handed to `foreign` (its sender), so the caller can report it.
    pub fn recv(
        &mut self,
        buf: &mut [u8],
        foreign: &mut dyn FnMut(SocketAddr),
    ) -> io::Result<Option<Received>> {
        loop {
            if let Some(pos) = &self.position {
                match pos.recv_from(buf) {
                    Ok((len, from)) => {
                        if self.accepts(from) {
                            return Ok(Some(Received {
                                len,
                                from,
                                port: Port::Position,
                            }));
                        }
                        foreign(from);
                        continue;
                    }
                    Err(e) if e.kind() == io::ErrorKind::WouldBlock => {}
                    Err(e) => return Err(e),
                }
            }
            return match self.data.recv_from(buf) {
                Ok((len, from)) => {
                    if !self.accepts(from) {
                        foreign(from);
                        continue;
                    }
                    Ok(Some(Received {
                        len,
                        from,
                        port: Port::Data,
                    }))
                }
                Err(e)
                    if e.kind() == io::ErrorKind::WouldBlock
                        || e.kind() == io::ErrorKind::TimedOut
                        || e.kind() == io::ErrorKind::Interrupted =>
                {
                    Ok(None)
                }
                Err(e) => Err(e),
            };
        }
    }

    fn accepts(&mut self, from: SocketAddr) -> bool {
        match self.allowed_source {
            Some(a) if a != from.ip() => {
                self.rejected += 1;
                self.last_rejected = Some(from);
                false
            }
            _ => true,
        }
    }
}

/// The inode of the socket `fd`, as `/proc/net/udp` names it.
fn inode(fd: RawFd) -> Option<u64> {
    // SAFETY: fstat writes one `stat` through a valid pointer for a descriptor we own.
    let mut st: libc::stat = unsafe { std::mem::zeroed() };
    (unsafe { libc::fstat(fd, &mut st) } == 0).then_some(st.st_ino)
}

/// The summed `drops` column of the rows of a `/proc/net/udp` table whose inode is one of
/// `inodes`; `None` when no row is.
pub fn drops_of(table: &str, inodes: &[u64]) -> Option<u64> {
    // sl local rem st tx:rx tr:when retrnsmt uid timeout inode ref pointer drops
    (table.lines().skip(1))
        .filter_map(|row| {
            let cols: Vec<&str> = row.split_whitespace().collect();
            let ino: u64 = cols.get(9)?.parse().ok()?;
            inodes
                .contains(&ino)
                .then(|| cols.get(12)?.parse::<u64>().ok())?
        })
        .reduce(|a, b| a + b)
}

/// The summed `drops` column of the rows of a `/proc/net/udp` table bound to local `port`;
/// `None` when no row is (how an outside observer, such as `mimnav soak`, reads the driver's
/// count).
pub fn drops_on_port(table: &str, port: u16) -> Option<u64> {
    (table.lines().skip(1))
        .filter_map(|row| {
            let cols: Vec<&str> = row.split_whitespace().collect();
            let local = cols.get(1)?.rsplit_once(':')?.1;
            let bound = u16::from_str_radix(local, 16).ok()?;
            (bound == port).then(|| cols.get(12)?.parse::<u64>().ok())?
        })
        .reduce(|a, b| a + b)
}

fn set_recv_buffer(socket: &UdpSocket, bytes: usize) -> io::Result<()> {
    let v = libc::c_int::try_from(bytes).unwrap_or(libc::c_int::MAX);
    // SAFETY: setsockopt reads one c_int through a valid pointer on a socket we own.
    let r = unsafe {
        libc::setsockopt(
            socket.as_raw_fd(),
            libc::SOL_SOCKET,
            libc::SO_RCVBUF,
            (&v as *const libc::c_int).cast(),
            std::mem::size_of::<libc::c_int>() as libc::socklen_t,
        )
    };
    if r != 0 {
        Err(io::Error::last_os_error())
    } else {
        Ok(())
    }
}

/// `SIOCGSTAMPNS` (asm-generic/sockios.h; the native `timespec` on 64-bit Linux): the receive
/// time stamp of the last datagram read from a socket.
const SIOCGSTAMPNS: libc::c_ulong = 0x8907;

/// When the kernel received the datagram last read from `fd` (CLOCK_REALTIME, ns).
fn arrival_ns(fd: RawFd) -> Option<u64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec the call writes; `fd` is an open socket of ours.
    let r = unsafe { libc::ioctl(fd, SIOCGSTAMPNS as _, &mut ts) };
    (r == 0 && ts.tv_sec >= 0 && ts.tv_nsec >= 0)
        .then(|| ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 23, the soak: the hop from the sensor to the driver has a drop counter too — the
    /// datagrams the kernel threw away while the socket's buffer was full.
    #[test]
    fn datagrams_the_kernel_dropped_on_a_full_buffer_are_counted() {
        let cfg = VelodyneConfig {
            bind_address: IpAddr::from([127, 0, 0, 1]),
            data_port: 0,
            recv_buffer_bytes: 4096,
            ..VelodyneConfig::default()
        };
        let src = UdpSource::bind_ports(&cfg, None).expect("bind");
        let Some(before) = src.kernel_drops() else {
            println!("SKIP datagrams_the_kernel_dropped…: /proc/net/udp does not list the socket");
            return;
        };
        assert_eq!(before, 0);
        let tx = UdpSocket::bind("127.0.0.1:0").expect("tx");
        let to = src.data_addr().expect("addr");
        // nobody reads: a buffer of a few kB holds a few of them, the kernel drops the rest
        for _ in 0..200 {
            tx.send_to(&[0u8; 1206], to).expect("send");
        }
        let dropped = src.kernel_drops().expect("still listed");
        assert!((100..=200).contains(&dropped), "{dropped} dropped of 200");
    }

    #[test]
    fn the_drops_column_is_read_for_the_sockets_inodes_only() {
        let table = "\
   sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  timeout inode ref pointer drops
  100: 0100007F:0940 00000000:0000 07 00000000:00000000 00:00000000 00000000  1000        0 4711 2 0000000000000000 17
  101: 00000000:206C 00000000:0000 07 00000000:00000000 00:00000000 00000000  1000        0 4712 2 0000000000000000 3
  102: 00000000:0044 00000000:0000 07 00000000:00000000 00:00000000 00000000     0        0 999 2 0000000000000000 50
";
        assert_eq!(drops_of(table, &[4711, 4712]), Some(20));
        assert_eq!(drops_of(table, &[4711]), Some(17));
        assert_eq!(drops_of(table, &[1]), None);
        assert_eq!(drops_of("", &[4711]), None);
        assert_eq!(drops_on_port(table, 0x206C), Some(3));
        assert_eq!(drops_on_port(table, 2368), Some(17));
        assert_eq!(drops_on_port(table, 9), None);
    }

    /// A datagram read 30 ms after it arrived waited that long in the kernel (the driver's
    /// paced reads count in the latency); one read at once waited far less.
    #[test]
    fn the_wait_in_the_kernel_is_read_from_its_time_stamp() {
        let cfg = VelodyneConfig {
            bind_address: IpAddr::from([127, 0, 0, 1]),
            data_port: 0,
            recv_buffer_bytes: 1 << 16,
            ..VelodyneConfig::default()
        };
        let mut src = UdpSource::bind_ports(&cfg, None).expect("bind");
        let to = src.data_addr().expect("addr");
        let tx = UdpSocket::bind("127.0.0.1:0").expect("sender");
        let mut buf = [0u8; 64];
        let mut read = |src: &mut UdpSource| {
            for _ in 0..200 {
                if let Ok(Some(_)) = src.recv(&mut buf, &mut |_| {}) {
                    return src.kernel_wait_ns();
                }
                std::thread::sleep(std::time::Duration::from_millis(1));
            }
            panic!("no datagram");
        };
        // The kernel turns its stamps on from a work queue after bind asks for them, so a
        // datagram in the first moments may arrive unstamped (read as a wait of ~0): let one
        // through first (the failure CI met at stop 57: "waited 2484 ns").
        std::thread::sleep(std::time::Duration::from_millis(50));
        tx.send_to(b"warm", to).expect("send");
        let _ = read(&mut src);
        tx.send_to(b"late", to).expect("send");
        std::thread::sleep(std::time::Duration::from_millis(30));
        let late = read(&mut src);
        assert!(
            (30_000_000..1_000_000_000).contains(&late),
            "waited {late} ns"
        );
        tx.send_to(b"prompt", to).expect("send");
        let prompt = read(&mut src);
        assert!(prompt < late, "waited {prompt} ns, the late one {late} ns");
    }

    #[test]
    fn receives_on_both_ports_and_filters_the_sender() {
        let cfg = VelodyneConfig {
            bind_address: IpAddr::from([127, 0, 0, 1]),
            data_port: 0,
            allowed_source: Some(IpAddr::from([127, 0, 0, 1])),
            recv_buffer_bytes: 1 << 20,
            ..VelodyneConfig::default()
        };
        let mut src = UdpSource::bind_ports(&cfg, Some(0)).expect("bind");
        let data_addr = src.data_addr().expect("addr");
        let pos_addr = src.position_addr().expect("pos").expect("addr");
        let tx = UdpSocket::bind("127.0.0.1:0").expect("tx");
        tx.send_to(&[1u8; 1206], data_addr).expect("send");
        tx.send_to(&[2u8; 512], pos_addr).expect("send");
        std::thread::sleep(std::time::Duration::from_millis(20));
        let mut buf = [0u8; 2048];
        let mut foreign = Vec::new();
        let mut on_foreign = |a| foreign.push(a);
        let a = src.recv(&mut buf, &mut on_foreign).expect("recv");
        let a = a.expect("datagram");
        assert_eq!((a.port, a.len), (Port::Position, 512));
        let b = src.recv(&mut buf, &mut on_foreign).expect("recv");
        let b = b.expect("datagram");
        assert_eq!((b.port, b.len), (Port::Data, 1206));
        assert_eq!(src.recv(&mut buf, &mut on_foreign).expect("recv"), None);

        // a sender on another loopback address is dropped and counted
        let other = UdpSocket::bind("127.0.0.2:0");
        if let Ok(other) = other {
            other.send_to(&[1u8; 1206], data_addr).expect("send");
            std::thread::sleep(std::time::Duration::from_millis(20));
            assert_eq!(src.recv(&mut buf, &mut on_foreign).expect("recv"), None);
            assert_eq!(src.rejected(), 1);
            let from = other.local_addr().ok();
            assert_eq!(src.last_rejected(), from);
            assert_eq!(foreign, from.into_iter().collect::<Vec<_>>());
        }
    }
}
