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

#[cfg(test)]
mod tests {
    use super::*;

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
