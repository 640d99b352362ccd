//! The WebSocket server: the Foxglove SDK's, serving the bridge's context over
//! `foxglove.websocket.v1`, on a tokio runtime of its own with `view.threads` threads (the
//! process's iceoryx2 loop never runs on it, and it never runs in the iceoryx2 loop).

use std::net::SocketAddr;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use foxglove::websocket::{ChannelView, Client, ServerListener};
use foxglove::{Context, WebSocketServer, WebSocketServerHandle};

use mimnav_config::ViewConfig;

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub enum ServerError {
    /// The runtime's threads could not be made.
    #[error("cannot start the WebSocket server's runtime: {0}")]
    Runtime(std::io::Error),
    /// The address could not be bound (in use, not on this machine, …).
    #[error("cannot serve on {addr}: {detail}")]
    Bind {
        /// `view.bind:view.port`.
        addr: String,
        /// What the SDK said.
        detail: String,
    },
}

/// Connections and subscriptions, as the SDK reports them.
#[derive(Debug, Default)]
pub struct Clients {
    connected: AtomicUsize,
    connections: AtomicU64,
    subscriptions: AtomicUsize,
}

impl Clients {
    /// Clients connected now.
    pub fn connected(&self) -> usize {
        self.connected.load(Ordering::Relaxed)
    }

    /// Connections since the start.
    pub fn connections(&self) -> u64 {
        self.connections.load(Ordering::Relaxed)
    }

    /// Subscriptions open now, over every client.
    pub fn subscriptions(&self) -> usize {
        self.subscriptions.load(Ordering::Relaxed)
    }
}

struct Listener(Arc<Clients>);

impl ServerListener for Listener {
    fn on_client_connect(&self) {
        self.0.connected.fetch_add(1, Ordering::Relaxed);
        self.0.connections.fetch_add(1, Ordering::Relaxed);
        tracing::info!("a Foxglove client connected");
    }

    fn on_client_disconnect(&self) {
        // saturating: never below zero, whatever order the SDK reports in
        let _ = (self.0.connected).fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| {
            Some(n.saturating_sub(1))
        });
        tracing::info!("a Foxglove client disconnected");
    }

    fn on_subscribe(&self, client: Client, channel: ChannelView) {
        self.0.subscriptions.fetch_add(1, Ordering::Relaxed);
        tracing::debug!(client = ?client.id(), "subscribed to {}", channel.topic());
    }

    fn on_unsubscribe(&self, client: Client, channel: ChannelView) {
        let _ = (self.0.subscriptions).fetch_update(Ordering::Relaxed, Ordering::Relaxed, |n| {
            Some(n.saturating_sub(1))
        });
        tracing::debug!(client = ?client.id(), "unsubscribed from {}", channel.topic());
    }
}

/// The running server; dropping it stops the server and its runtime.
pub struct Server {
    handle: Option<WebSocketServerHandle>,
    clients: Arc<Clients>,
    addr: SocketAddr,
    runtime: Option<tokio::runtime::Runtime>,
}

impl std::fmt::Debug for Server {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Server").field("addr", &self.addr).finish()
    }
}

impl Server {
    /// Serves `ctx` on `view.bind:view.port`, each client's queue `view.client_backlog`
    /// messages long.
    pub fn start(view: &ViewConfig, ctx: &Arc<Context>) -> Result<Server, ServerError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(view.threads.max(1))
            .thread_name("mimnav-view-ws")
            .enable_all()
            .build()
            .map_err(ServerError::Runtime)?;
        let clients = Arc::new(Clients::default());
        let bind = view.bind.trim().to_string();
        let handle = WebSocketServer::new()
            .name("mimnav")
            .context(ctx)
            .bind(bind.clone(), view.port)
            .message_backlog_size(view.client_backlog)
            .listener(Arc::new(Listener(clients.clone())))
            .tokio_runtime(runtime.handle())
            .start_blocking()
            .map_err(|e| ServerError::Bind {
                addr: format!("{bind}:{}", view.port),
                detail: e.to_string(),
            })?;
        let ip = bind.parse().unwrap_or(std::net::Ipv4Addr::LOCALHOST.into());
        let addr = SocketAddr::new(ip, handle.port());
        Ok(Server {
            handle: Some(handle),
            clients,
            addr,
            runtime: Some(runtime),
        })
    }

    /// Where it listens (the port the system chose for `view.port = 0`).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Its clients.
    pub fn clients(&self) -> &Clients {
        &self.clients
    }
}

/// How long a stopping server waits for its clients' connections to close. The SDK's shutdown
/// waits for every client's task, and the task of a client that reads nothing waits on its
/// full socket: unbounded, a viewer that stalled kept the view from stopping until it went
/// away (9 s in the test), past the unit's `TimeoutStopSec=5s`, whose SIGKILL leaves the
/// view's iceoryx2 node dead.
const SHUTDOWN_WAIT: std::time::Duration = std::time::Duration::from_millis(500);

impl Drop for Server {
    fn drop(&mut self) {
        if let (Some(h), Some(rt)) = (self.handle.take(), self.runtime.as_ref()) {
            // stop() returns a handle to wait on; the runtime must still run for that. Waited
            // for on the runtime, and here for at most `SHUTDOWN_WAIT`: the runtime's shutdown
            // below then drops the wait, and with it (the SDK's rule) every client's task.
            let done = h.stop();
            let (tx, rx) = std::sync::mpsc::channel();
            rt.spawn(async move {
                done.wait().await;
                let _ = tx.send(());
            });
            if rx.recv_timeout(SHUTDOWN_WAIT).is_err() {
                tracing::warn!(
                    "the Foxglove clients' connections did not close within {} ms of the stop; \
                     they are dropped",
                    SHUTDOWN_WAIT.as_millis()
                );
            }
        }
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_timeout(std::time::Duration::from_secs(1));
        }
    }
}
