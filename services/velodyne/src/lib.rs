//! The mimnav VLP-16 driver library: everything between bytes on the wire and an assembled
//! revolution, with no inter-process communication.
//!
//! Follow a packet through it in this order:
//! - [`packet`]: validated views of the 1206-byte data packet and the 512-byte position packet,
//!   and the typed [`packet::DecodeError`] every bad datagram becomes;
//! - [`decode`]: one data packet into [`Point`](mimnav_shared::topics::Point)s and the planar
//!   scan returns of one laser;
//! - [`revolution`]: packets into revolutions, cut by azimuth, duration or capacity;
//! - [`driver`]: the service's step: a datagram in, a finished revolution out, counted;
//! - [`capture`] and [`udp`]: where the datagrams come from (a pcap/pcapng file or a socket), and
//!   [`replay`]: pacing a capture by its timestamps.
//!
//! ```
//! use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};
//! let mut assembler = Assembler::new(AssemblerConfig::default());
//! // a datagram of the wrong size is rejected and changes nothing
//! assert!(assembler.push(&[0u8; 100], 0, 0).is_err());
//! assert!(assembler.finish().is_none());
//! ```
#![deny(missing_docs)]

pub mod capture;
pub mod config;
pub mod decode;
pub mod driver;
pub mod pace;
pub mod packet;
pub mod replay;
pub mod revolution;
pub mod udp;
