//! The network side: one Zenoh session, a publisher per outgoing topic with its encoding, and
//! (when goals are accepted) subscribers on `mimnav/<robot>/goal` and `…/stop`.
//!
//! Zenoh runs its own threads (a tokio runtime); the bridge's loop uses the synchronous API
//! (`zenoh::Wait`): a put with `CongestionControl::Drop` never blocks on a slow network, and
//! remote messages wait in bounded ring buffers ([`REMOTE_RING`] each, the oldest dropped first)
//! until the loop takes them.

use std::path::Path;

use zenoh::Wait;
use zenoh::bytes::Encoding;
use zenoh::handlers::{RingChannel, RingChannelHandler};
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::qos::CongestionControl;
use zenoh::sample::Sample;

use crate::bridge::Bridge;
use crate::remote::RemoteKey;

/// Remote messages kept per key between two turns of the loop.
pub const REMOTE_RING: usize = 16;

/// Why the link could not be opened or used.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// Zenoh's config file could not be read or is invalid.
    #[error("Zenoh config {path}: {detail}")]
    Config {
        /// The file.
        path: String,
        /// Zenoh's message.
        detail: String,
    },
    /// The session could not be opened (bad endpoints, certificates, …).
    #[error("cannot open the Zenoh session: {0}")]
    Open(String),
    /// A publisher or subscriber could not be declared.
    #[error("cannot declare {key}: {detail}")]
    Declare {
        /// The key expression.
        key: String,
        /// Zenoh's message.
        detail: String,
    },
    /// A put failed.
    #[error("cannot publish on {key}: {detail}")]
    Put {
        /// The key expression.
        key: String,
        /// Zenoh's message.
        detail: String,
    },
}

/// Zenoh's config: `file` when given, else Zenoh's defaults.
pub fn zenoh_config(file: &Path) -> Result<zenoh::Config, LinkError> {
    if file.as_os_str().is_empty() {
        return Ok(zenoh::Config::default());
    }
    zenoh::Config::from_file(file).map_err(|e| LinkError::Config {
        path: file.display().to_string(),
        detail: e.to_string(),
    })
}

/// The open session with its publishers and subscribers.
pub struct Link {
    session: zenoh::Session,
    publishers: Vec<Publisher<'static>>,
    remote: Vec<(RemoteKey, Subscriber<RingChannelHandler<Sample>>)>,
}

impl std::fmt::Debug for Link {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Link")
            .field("zid", &self.session.zid())
            .field("publishers", &self.publishers.len())
            .field("remote", &self.remote.len())
            .finish()
    }
}

impl Link {
    /// Opens a session with `config` and declares what `bridge` publishes and hears.
    pub fn open(config: zenoh::Config, bridge: &Bridge) -> Result<Link, LinkError> {
        let session = zenoh::open(config)
            .wait()
            .map_err(|e| LinkError::Open(e.to_string()))?;
        let mut publishers = Vec::new();
        for o in bridge.outgoing() {
            let p = session
                .declare_publisher(o.key.clone())
                .encoding(Encoding::APPLICATION_OCTET_STREAM.with_schema(o.topic.schema()))
                .congestion_control(CongestionControl::Drop)
                .wait()
                .map_err(|e| LinkError::Declare {
                    key: o.key.clone(),
                    detail: e.to_string(),
                })?;
            publishers.push(p);
        }
        let mut remote = Vec::new();
        if bridge.accepts_goals() {
            for key in [RemoteKey::Goal, RemoteKey::Stop] {
                let k = bridge.remote_key(key);
                let s = session
                    .declare_subscriber(k.clone())
                    .with(RingChannel::new(REMOTE_RING))
                    .wait()
                    .map_err(|e| LinkError::Declare {
                        key: k,
                        detail: e.to_string(),
                    })?;
                remote.push((key, s));
            }
        }
        Ok(Link {
            session,
            publishers,
            remote,
        })
    }

    /// The session's Zenoh id (for the log).
    pub fn zid(&self) -> String {
        self.session.zid().to_string()
    }

    /// Publishes `bytes` on outgoing topic `i` (dropped by Zenoh, not blocking, when the
    /// network is congested).
    pub fn publish(&self, i: usize, bytes: Vec<u8>) -> Result<(), LinkError> {
        let Some(p) = self.publishers.get(i) else {
            return Ok(());
        };
        p.put(bytes).wait().map_err(|e| LinkError::Put {
            key: p.key_expr().to_string(),
            detail: e.to_string(),
        })
    }

    /// The remote messages waiting, oldest first, with the key each came on (payloads larger
    /// than `max` bytes are cut to `max + 1`, which the parser refuses as too large).
    pub fn remote(&self, max: usize) -> Vec<(RemoteKey, Vec<u8>)> {
        let mut got = Vec::new();
        for (key, s) in &self.remote {
            while let Ok(Some(sample)) = s.try_recv() {
                let p = sample.payload();
                let bytes = if p.len() > max {
                    vec![0; max + 1]
                } else {
                    p.to_bytes().into_owned()
                };
                got.push((*key, bytes));
            }
        }
        got
    }

    /// Closes the session (undeclaring everything).
    pub fn close(self) {
        let _ = self.session.close().wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// docs/zenoh.md's example (TLS, mutual TLS, access control) is a config Zenoh accepts.
    #[test]
    fn the_documented_robot_config_parses() {
        let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/zenoh-robot.json5");
        let c = zenoh_config(&doc).expect("docs/zenoh-robot.json5 parses");
        let json = c
            .get_json("access_control/default_permission")
            .expect("key");
        assert_eq!(json, "\"deny\"");
        let mtls = c.get_json("transport/link/tls/enable_mtls").expect("key");
        assert_eq!(mtls, "true");
    }

    #[test]
    fn a_bad_config_file_is_named() {
        let e = zenoh_config(Path::new("/nonexistent/zenoh.json5")).expect_err("missing");
        assert!(e.to_string().contains("/nonexistent/zenoh.json5"), "{e}");
        assert!(
            zenoh_config(Path::new("")).is_ok(),
            "no file: Zenoh's defaults"
        );
    }
}
