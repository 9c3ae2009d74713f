//! `shrad view`: watch and steer dynamic global illumination live in a browser.
//!
//! [`Server::start`] builds an [`Engine`] for a scene, runs it on a thread of its own and
//! serves one web page (`web/` in the repository, three.js from `web/node_modules`) and a
//! WebSocket at `/ws` over which the page steers the engine and receives every frame
//! (protocol: `docs/viewer-protocol.md`, [`protocol`]). [`serve`] does that until Ctrl-C.
//!
//! All clients share one engine, so they see one scene and each other's steering. Steering
//! never queues behind itself: a newer transform of an object (emission of a light, value of
//! a setting) replaces an older one the engine has not applied, and the engine applies the
//! newest state at the start of each frame ([`inbox`]). A client that reads slowly only skips
//! frames: frames go through a latest-value slot, and each client has a bound on the bytes
//! of frames it has not acknowledged (`client.rs`).
//!
//! ```no_run
//! let options = shrad_view::ServeOptions::new(shrad::scene::cornell_box());
//! shrad_view::serve(options).unwrap();
//! ```

use std::io::Write;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use shrad::engine::Engine;
use shrad::reference::ReferenceOptions;
use shrad::scene::Scene;
use shrad::solver::SolverChoice;
use shrad::vis::Backend;
use shrad::PatchSizing;
use tokio::sync::watch;

pub mod access;
mod client;
mod engine_loop;
mod http;
pub mod inbox;
mod lights;
mod probe_sphere;
pub mod protocol;
pub mod solvers;

pub use access::AccessOptions;
pub use engine_loop::settle_budget_ms;
use engine_loop::{EngineLoop, Shared};
pub use http::{HEADER_TIMEOUT, MAX_CONNECTIONS};
pub use inbox::InboxCounts;

/// What [`serve`] and [`Server::start`] need (no command-line parsing here: `shrad view`
/// fills it from its flags).
pub struct ServeOptions {
    /// The scene, loaded.
    pub scene: Scene,
    /// How finely to patch it.
    pub sizing: PatchSizing,
    /// Visibility backend.
    pub backend: Backend,
    /// The solver to start with (`dispersive`, `grid`, `reference`), unless `choice` says.
    pub solver: String,
    /// Its preset (`default`, `paper`...). The page is told the solver and preset the
    /// engine has (a preset's name while its settings are one, else `custom`).
    pub preset: String,
    /// The solver's settings; `None`: those of `solver` under `preset`.
    pub choice: Option<SolverChoice>,
    /// The reference the page's error button measures against (`shrad view
    /// --rays-per-patch N`); `None`: the engine's own (fast) reference.
    pub reference: Option<ReferenceOptions>,
    /// Address to bind (127.0.0.1 unless asked otherwise; any other needs a token, which
    /// [`Server::start`] generates unless `access.token` gives one).
    pub host: IpAddr,
    /// The token, the cap on clients and watch-only (`access.rs`).
    pub access: AccessOptions,
    /// Port (0: any free port).
    pub port: u16,
    /// The page's folder (`web/` with `src/` and `node_modules/three`).
    pub web_root: PathBuf,
}

impl ServeOptions {
    /// `scene` at 20,000 patches with the default dispersive solver, on 127.0.0.1:8080, the
    /// page from this repository's `web/`.
    pub fn new(scene: Scene) -> ServeOptions {
        ServeOptions {
            scene,
            sizing: PatchSizing::Count(20_000),
            backend: Backend::Auto,
            solver: "dispersive".to_string(),
            preset: "default".to_string(),
            choice: None,
            reference: None,
            host: IpAddr::V4(Ipv4Addr::LOCALHOST),
            access: AccessOptions::default(),
            port: 8080,
            web_root: default_web_root(),
        }
    }
}

/// The engine a server runs on `options`' scene (taken from it): `options.choice`, else
/// the solver and preset the page names, and `options.reference` for its error button.
fn build_engine(options: &mut ServeOptions) -> Result<Engine> {
    let choice = match options.choice {
        Some(c) => c,
        None => solvers::choice(&options.solver, &options.preset).map_err(anyhow::Error::msg)?,
    };
    let scene = std::mem::take(&mut options.scene);
    let mut engine = Engine::new(scene, options.sizing, options.backend, choice)
        .context("cannot build the engine")?;
    if let Some(r) = options.reference {
        engine.set_reference_options(r);
    }
    Ok(engine)
}

/// What [`Server::start`] refuses before any work (the page's files, the sharing rules), for
/// a front end to check before it says "patching and precomputing" (the refusal read as if
/// it came after the work).
pub fn check_options(options: &ServeOptions) -> Result<()> {
    for need in ["src/index.html", "node_modules/three/build/three.module.js"] {
        let file = options.web_root.join(need);
        if !file.is_file() {
            bail!(
                "{}: missing (the viewer's page; run scripts/setup-browser to install three.js into web/node_modules)",
                file.display()
            );
        }
    }
    if options.access.max_clients == 0 {
        bail!("--max-clients must be at least 1");
    }
    if let Some(t) = &options.access.token {
        access::check_token(t).map_err(|e| anyhow::anyhow!("--token: {e}"))?;
    }
    Ok(())
}

/// The sharing rules `options` ask for, checked by [`check_options`]: beyond loopback a
/// token is required, generated unless one is given.
fn access_rules(options: &ServeOptions) -> Result<Arc<access::Access>> {
    let mut rules = options.access.clone();
    if rules.token.is_none() && !options.host.is_loopback() {
        rules.token = Some(access::generate_token().map_err(anyhow::Error::msg)?);
    }
    Ok(access::Access::new(rules))
}

/// This repository's `web/` (where `scripts/setup-browser` installs three.js).
pub fn default_web_root() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../web"))
}

/// A running viewer server.
pub struct Server {
    addr: SocketAddr,
    runtime: Option<tokio::runtime::Runtime>,
    stop: watch::Sender<bool>,
    shared: Arc<Shared>,
    token: Option<String>,
    engine_thread: Option<JoinHandle<()>>,
    http_task: Option<tokio::task::JoinHandle<std::io::Result<()>>>,
}

impl Server {
    /// Patch the scene, precompute the solver, bind, and start serving.
    pub fn start(mut options: ServeOptions) -> Result<Server> {
        check_options(&options)?;
        let web_root = options.web_root.clone();
        let access = access_rules(&options)?;
        let engine = build_engine(&mut options)?;
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("shrad-view-io")
            .enable_all()
            .build()
            .context("cannot start the I/O runtime")?;
        let addr = SocketAddr::new(options.host, options.port);
        let listener = runtime
            .block_on(tokio::net::TcpListener::bind(addr))
            .with_context(|| format!("cannot listen on {addr}"))?;
        let addr = listener.local_addr()?;
        let shared = Arc::new(Shared::new());
        let (engine_loop, intro, frames) =
            EngineLoop::new(engine, shared.clone(), (options.sizing, options.backend));
        let engine_thread = std::thread::Builder::new()
            .name("shrad-engine".to_string())
            .spawn(move || engine_loop.run())
            .context("cannot start the engine thread")?;
        let (stop, stop_rx) = watch::channel(false);
        let app = Arc::new(http::App {
            web_root,
            intro,
            frames,
            shared: shared.clone(),
            stop: stop_rx.clone(),
            access: access.clone(),
            cookie: format!("shrad_token_{}", addr.port()),
        });
        let http_task = runtime.spawn(http::run(listener, app, stop_rx));
        Ok(Server {
            addr,
            runtime: Some(runtime),
            stop,
            shared,
            token: access.options().token.clone(),
            engine_thread: Some(engine_thread),
            http_task: Some(http_task),
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The page's URL (with `?token=...` when the server has a token).
    pub fn url(&self) -> String {
        match &self.token {
            Some(t) => format!("http://{}/?token={t}", self.addr),
            None => format!("http://{}/", self.addr),
        }
    }

    /// The token every request must carry, if the server has one.
    pub fn token(&self) -> Option<&str> {
        self.token.as_deref()
    }

    /// What went through the engine's inbox so far (requests received, superseded by a
    /// newer one of their key, transforms applied, the most waiting per key).
    pub fn inbox_counts(&self) -> InboxCounts {
        self.shared.inbox.counts()
    }

    /// Close every connection, stop the engine and wait for both.
    pub fn stop(mut self) -> Result<()> {
        self.shutdown()
    }

    fn shutdown(&mut self) -> Result<()> {
        self.shared.stop.store(true, Ordering::Relaxed);
        let _ = self.stop.send(true);
        let mut result = Ok(());
        if let (Some(rt), Some(task)) = (&self.runtime, self.http_task.take()) {
            match rt.block_on(async { tokio::time::timeout(Duration::from_secs(5), task).await }) {
                Ok(Ok(Ok(()))) => {}
                Ok(Ok(Err(e))) => {
                    result = Err(anyhow::Error::new(e).context("the HTTP server failed"))
                }
                Ok(Err(e)) => result = Err(anyhow::anyhow!("the HTTP server task failed: {e}")),
                Err(_) => result = Err(anyhow::anyhow!("the HTTP server did not stop within 5 s")),
            }
        }
        if let Some(t) = self.engine_thread.take() {
            if t.join().is_err() {
                result = Err(anyhow::anyhow!("the engine thread panicked"));
            }
        }
        if let Some(rt) = self.runtime.take() {
            rt.shutdown_timeout(Duration::from_secs(2));
        }
        result
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.shutdown();
    }
}

/// Start the server, print its URL and serve until Ctrl-C; then close every connection and
/// stop the engine.
pub fn serve(options: ServeOptions) -> Result<()> {
    let unspecified = options.host.is_unspecified();
    let server = Server::start(options)?;
    // Written, not `println!`: a reader that keeps only the address (`shrad view | head -1`)
    // closes the pipe, and the server must go on.
    let mut said = format!("shrad view: {}  (Ctrl-C to stop)\n", server.url());
    if unspecified {
        said += &format!(
            "  (listening on every interface: put this machine's name or address in place of {})\n",
            server.addr().ip()
        );
    }
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(said.as_bytes()).and_then(|()| out.flush());
    drop(out);
    let ctrl_c = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?
        .block_on(tokio::signal::ctrl_c());
    ctrl_c.context("cannot wait for Ctrl-C")?;
    eprintln!("shrad view: stopping");
    server.stop()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beyond_loopback_a_token_is_required_and_made_unless_given() {
        // (Nothing is bound here: the rules only.)
        let mut options = ServeOptions::new(shrad::scene::Scene::default());
        assert_eq!(access_rules(&options).unwrap().options().token, None);
        options.host = IpAddr::V4(Ipv4Addr::UNSPECIFIED);
        let made = access_rules(&options).unwrap().options().token.clone();
        assert_eq!(made.map(|t| t.len()), Some(48));
        options.access.token = Some("short".to_string());
        assert!(check_options(&options)
            .unwrap_err()
            .to_string()
            .contains("--token"));
        options.access.token = Some("a-token-of-enough-length".to_string());
        check_options(&options).unwrap();
        let given = access_rules(&options).unwrap().options().token.clone();
        assert_eq!(given.as_deref(), Some("a-token-of-enough-length"));
        options.access.max_clients = 0;
        let e = check_options(&options).unwrap_err().to_string();
        assert!(e.contains("--max-clients must be at least 1"), "{e}");
        options.access.max_clients = 1;
        options.web_root = PathBuf::from("/nonexistent-web");
        let e = check_options(&options).unwrap_err().to_string();
        assert!(
            e.contains("/nonexistent-web/src/index.html: missing"),
            "{e}"
        );
    }

    #[test]
    fn the_reference_options_reach_the_engine() {
        let mut options = ServeOptions::new(shrad::scene::cornell_box());
        options.sizing = PatchSizing::Count(300);
        let engine = build_engine(&mut options).unwrap();
        assert_eq!(
            *engine.reference_options(),
            ReferenceOptions::fast(),
            "none given: the engine's own"
        );
        let mut options = ServeOptions::new(shrad::scene::cornell_box());
        options.sizing = PatchSizing::Count(300);
        options.reference = Some(ReferenceOptions {
            rays_per_patch: 77,
            ..ReferenceOptions::fast()
        });
        let engine = build_engine(&mut options).unwrap();
        assert_eq!(engine.reference_options().rays_per_patch, 77);
        assert_eq!(engine.solver_choice().name(), "dispersive");
    }
}
