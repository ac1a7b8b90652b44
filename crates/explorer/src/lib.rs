//! `fiberlab explore`: a local web application to look at every model of the registry, turn
//! its knobs and see what they do — the (θ_r, φ) map of `f_s` at a light direction one drags,
//! M(θ) and N(φ) per lobe, the fiber in 3D with its specular cone, the albedo, reciprocity and
//! ∫pdf read-outs of the validation harness, comparisons with a second model or with a
//! goniophotometer table (loaded, or measured on the server), fits, and a progressive render
//! preview — in the spirit of Disney's BRDF Explorer, made for fibers.
//!
//! This crate is a front end: an HTTP server (axum on tokio) with a JSON API ([`api`]) whose
//! every number comes from the libraries (`fiberlab-scatter`, `-check`, `-fit`, `-gonio`,
//! `-render`), and the built single-page application embedded in the binary ([`bundle`]), so
//! that `fiberlab explore` needs nothing but the executable. Every request's work is bounded
//! before it starts ([`limits`]); a page's newer request of a kind cancels its older one
//! ([`cancel`]); a render is one per page and stops when the page goes away.
//!
//! ```no_run
//! let server = fiberlab_explorer::bind(&fiberlab_explorer::Config::default()).unwrap();
//! println!("{}", server.url());
//! server.run().unwrap();
//! ```
#![forbid(unsafe_code)]

pub mod api;
pub mod bundle;
pub mod cancel;
pub mod error;
pub mod limits;
pub mod preview;
pub mod request;
pub mod state;

use std::net::SocketAddr;

pub use limits::Limits;
pub use state::AppState;

/// Where and how to serve.
#[derive(Clone, Debug)]
pub struct Config {
    /// Address to listen on (default `127.0.0.1`: this machine only).
    pub host: String,
    /// Port (default 8765; 0 picks a free one).
    pub port: u16,
    /// Bounds on each request's work and memory.
    pub limits: Limits,
}

impl Default for Config {
    fn default() -> Self {
        Self { host: "127.0.0.1".into(), port: 8765, limits: Limits::default() }
    }
}

/// Why the server could not start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The host and port do not make an address.
    #[error("--host {host} --port {port}: not an address to listen on ({reason})")]
    Address {
        /// Host given.
        host: String,
        /// Port given.
        port: u16,
        /// Why.
        reason: String,
    },
    /// Binding or serving failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The error.
        source: std::io::Error,
    },
}

/// A server bound to its address, not yet serving ([`Server::run`]).
pub struct Server {
    runtime: tokio::runtime::Runtime,
    listener: tokio::net::TcpListener,
    address: SocketAddr,
    state: AppState,
}

/// Binds the listening socket (so that the address is known, and a port in use is an error
/// before anything is printed).
pub fn bind(config: &Config) -> Result<Server, ServeError> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|source| ServeError::Io { what: "starting the server's runtime".into(), source })?;
    let host = config.host.trim_start_matches('[').trim_end_matches(']');
    let address: SocketAddr = match host.parse::<std::net::IpAddr>() {
        Ok(ip) => SocketAddr::new(ip, config.port),
        Err(_) if host == "localhost" => SocketAddr::new(std::net::Ipv4Addr::LOCALHOST.into(), config.port),
        Err(e) => {
            return Err(ServeError::Address { host: config.host.clone(), port: config.port, reason: e.to_string() });
        }
    };
    let listener = runtime
        .block_on(tokio::net::TcpListener::bind(address))
        .map_err(|source| ServeError::Io { what: format!("listening on {address}"), source })?;
    let address =
        listener.local_addr().map_err(|source| ServeError::Io { what: "reading the bound address".into(), source })?;
    Ok(Server { runtime, listener, address, state: AppState::new(config.limits.clone()) })
}

impl Server {
    /// The bound address.
    #[must_use]
    pub fn address(&self) -> SocketAddr {
        self.address
    }

    /// `http://HOST:PORT/`.
    #[must_use]
    pub fn url(&self) -> String {
        format!("http://{}/", self.address)
    }

    /// Serves until the process is interrupted (Ctrl-C ends it gracefully: see
    /// [`Server::run_until`]).
    pub fn run(self) -> Result<Shutdown, ServeError> {
        self.run_until(async {
            let _ = tokio::signal::ctrl_c().await;
        })
    }

    /// Serves until `stop` completes, then shuts down gracefully: no new connections, every
    /// request's work in flight cancelled (its stream ends with a `cancelled` event), and the
    /// open connections given [`SHUTDOWN_GRACE`] to finish before the server returns anyway.
    pub fn run_until(
        self,
        stop: impl std::future::Future<Output = ()> + Send + 'static,
    ) -> Result<Shutdown, ServeError> {
        let state = self.state.clone();
        let app = api::router(self.state);
        let listener = self.listener;
        let (stopped_tx, stopped_rx) = tokio::sync::oneshot::channel::<usize>();
        let runtime = self.runtime;
        let ended = runtime.block_on(async move {
            let serving = axum::serve(listener, app).with_graceful_shutdown(async move {
                stop.await;
                let _ = stopped_tx.send(state.cancel_all());
            });
            let serving = std::future::IntoFuture::into_future(serving);
            tokio::pin!(serving);
            tokio::select! {
                done = &mut serving => {
                    done.map_err(|source| ServeError::Io { what: "serving".into(), source })?;
                    Ok(Shutdown { cancelled: 0, closed_connections: true })
                }
                Ok(cancelled) = stopped_rx => {
                    match tokio::time::timeout(SHUTDOWN_GRACE, serving).await {
                        Ok(done) => {
                            done.map_err(|source| ServeError::Io { what: "serving".into(), source })?;
                            Ok(Shutdown { cancelled, closed_connections: true })
                        }
                        Err(_) => Ok(Shutdown { cancelled, closed_connections: false }),
                    }
                }
            }
        });
        // The cancelled work on the blocking pool ends at its next poll of the token; wait for
        // it that long at most.
        runtime.shutdown_timeout(SHUTDOWN_GRACE);
        ended
    }
}

/// How long a shutdown waits for open connections to finish.
pub const SHUTDOWN_GRACE: std::time::Duration = std::time::Duration::from_secs(5);

/// How the server ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shutdown {
    /// Requests whose work was still running and was cancelled.
    pub cancelled: usize,
    /// Whether every connection closed within [`SHUTDOWN_GRACE`] (if not, the server
    /// returned anyway, dropping them).
    pub closed_connections: bool,
}

/// Binds and serves, calling `ready` with the URL once the socket is bound (what the CLI
/// prints).
pub fn serve(config: &Config, ready: impl FnOnce(&str)) -> Result<Shutdown, ServeError> {
    let server = bind(config)?;
    ready(&server.url());
    server.run()
}

/// As [`serve`], shutting down gracefully ([`Server::run_until`]) once `stop` is raised (the
/// command line's signal flag; polled every 50 ms).
pub fn serve_until(
    config: &Config,
    ready: impl FnOnce(&str),
    stop: &'static std::sync::atomic::AtomicBool,
) -> Result<Shutdown, ServeError> {
    let server = bind(config)?;
    ready(&server.url());
    server.run_until(async move {
        while !stop.load(std::sync::atomic::Ordering::SeqCst) {
            tokio::time::sleep(std::time::Duration::from_millis(50)).await;
        }
    })
}
