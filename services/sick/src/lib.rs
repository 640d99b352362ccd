//! # mimnav-sick — SICK 2D ladars over CoLa
//!
//! The planar ladar the foliage classifier of *"Foliage discrimination using a rotating ladar"*
//! was built for: a TCP client for SICK's LMS1xx, LMS5xx (with its multiple echoes) and
//! TiM5xx/7xx scanners, speaking CoLa-A (ASCII) or CoLa-B (binary), with no I/O of its own.
//! The service `mimnav-sick` owns the socket; this library is every rule.
//!
//! Follow the bytes in this order:
//! - [`cola`]: finding telegrams in the stream (`STX … ETX`, or `0x02020202`, length, payload,
//!   XOR checksum), counting and naming every byte that is not part of a good one;
//! - [`command`]: the requests (log in, configure the scan, the output, the echoes, run,
//!   stream) and the answers, with the device's error codes;
//! - [`session`]: one connection: each start-up request sent when the previous one is
//!   answered, then the stream; a refusal, a missing answer or a silent scanner gives the
//!   connection up;
//! - [`scandata`]: `LMDscandata` parsed (device status, counters, time stamps, every channel
//!   with its scale, offset, start angle, step and count) and written back;
//! - [`convert`]: a scan's channels as [`mimnav_shared::topics::ScanReturn`]s, in REP-103 and
//!   moved by the scanner's mounting pose: the contract the foliage classifier reads;
//! - [`status`]: the device status bytes named;
//! - [`link`]: the TCP connection kept up (connect, the session, back-off), the only I/O;
//! - [`device`]: the other end: an emulated scanner, for the simulator and the tests.
//!
//! ```
//! use mimnav_sick::cola::{Dialect, Framer};
//! use mimnav_sick::config::Model;
//! use mimnav_sick::device::Device;
//! use mimnav_sick::scandata::ScanData;
//!
//! let mut dev = Device::new(Model::Tim5xx, Dialect::ColaA, 1);
//! let g = dev.geometry();
//! let mut wire = Vec::new();
//! dev.scan_telegram(0, &[vec![278; g.count]], &[vec![154; g.count]], &mut wire);
//! let mut framer = Framer::new(Dialect::ColaA, 1 << 16);
//! framer.push(&wire);
//! let payload = framer.next().unwrap().unwrap();
//! let mut scan = ScanData::default();
//! scan.parse(Dialect::ColaA, payload).unwrap();
//! assert_eq!(scan.channel(b"DIST1").unwrap().values[0], 278);
//! assert_eq!(scan.channel(b"DIST1").unwrap().start_angle, -450_000);
//! ```
//!
//! # Protocol facts used, and where they come from
//!
//! SICK's telegram listing for the LMS1xx/LMS5xx/TiM families ("Telegram Listing, LMS1xx, LMS5xx,
//! TiM5xx, …") and the operating instructions' technical data: the framing of both dialects,
//! the number format of CoLa-A (hex unless a sign marks a decimal), `SetAccessMode 03
//! F4724744` (the authorised client), `mLMPsetscancfg` and its result codes, `LMDscandatacfg`,
//! `FREchoFilter`, `Run`, `sEN LMDscandata 1`, the field order of `LMDscandata`, the SOPAS
//! error codes of `sFA`, and the device angle convention (a 270° scanner from −45° to 225°,
//! 90° straight ahead). `../shared/data/sick/` holds three real telegrams; the tests decode
//! them to the values its README gives.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod cola;
pub mod command;
pub mod config;
pub mod convert;
pub mod device;
pub mod link;
pub mod scandata;
pub mod session;
pub mod status;

pub use config::{Model, SickConfig};
