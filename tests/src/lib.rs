//! Helpers for the end-to-end tests in `tests/tests/`: start the real `spindle-server` and
//! `spindle-worker` binaries on loopback, talk to them over HTTP, and render the same scene in
//! this process as the single-process reference.
//!
//! Every process is killed when its handle is dropped (so a failing test leaves nothing
//! running), every wait has a deadline, and ports are chosen at run time. The binaries are
//! found beside the test executable's directory (`target/<profile>/`), where `cargo test
//! --workspace` puts them before any test runs (`binary`).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use serde_json::Value;
use spindle_common::image::Image;
use spindle_common::protocol::{JobInfo, SubmitJob, asset_hash};
use spindle_common::tile::split_centre_first;
use spindle_render::{Assets, Scene, render_tile};

/// The path of one of the workspace's binaries (`spindle-server`, `spindle-worker`,
/// `spindle`), next to the directory of the running test executable.
///
/// `cargo test --workspace` builds them before any test runs: Cargo builds a package's binaries
/// for that package's own integration tests, and each of the three packages has some
/// (`worker/tests/command_line.rs` is the worker's). A lone `cargo test -p spindle-tests` does
/// not: it needs `cargo build --workspace --all-targets` first, and says so.
pub fn binary(name: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    // target/<profile>/deps/<test>-<hash> → target/<profile>/<name>
    let profile_dir = exe
        .parent()
        .and_then(Path::parent)
        .expect("the test executable lives in target/<profile>/deps");
    let path = profile_dir.join(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    assert!(
        path.is_file(),
        "{} is missing: `cargo test --workspace` builds it; with `-p spindle-tests` alone, run \
         `cargo build --workspace --all-targets` first",
        path.display()
    );
    path
}

/// A port on 127.0.0.1 that was free a moment ago.
pub fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("binding 127.0.0.1:0");
    listener.local_addr().expect("a bound address").port()
}

/// A child process whose stdout and stderr go to a log file; killed (SIGKILL) on drop.
pub struct Proc {
    pub name: String,
    child: Child,
    log: PathBuf,
}

impl Proc {
    /// Starts `command` with exactly the spindle tokens in `env` (none inherited), logging to
    /// `dir/<name>.log` (appending, so a restarted process keeps one log).
    pub fn spawn(
        mut command: Command,
        env: &[(&str, &str)],
        dir: &Path,
        name: &str,
    ) -> Result<Proc> {
        let log = dir.join(format!("{name}.log"));
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .with_context(|| format!("opening {}", log.display()))?;
        command
            .stdin(Stdio::null())
            .stdout(file.try_clone()?)
            .stderr(file)
            .env("RUST_LOG", "info")
            .env_remove("SPINDLE_TOKEN")
            .env_remove("SPINDLE_WORKER_TOKEN")
            .env_remove("SPINDLE_COORDINATOR")
            .env_remove("SPINDLE_SERVER")
            .envs(env.iter().copied());
        let child = command
            .spawn()
            .with_context(|| format!("starting {name} ({command:?})"))?;
        Ok(Proc {
            name: name.to_string(),
            child,
            log,
        })
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// The log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// SIGKILL, and reap.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// SIGTERM (through `kill(1)`, to keep this crate free of `unsafe` and libc).
    pub fn terminate(&self) -> Result<()> {
        let status = Command::new("kill")
            .args(["-TERM", &self.pid().to_string()])
            .status()
            .context("running kill -TERM")?;
        if !status.success() {
            bail!("kill -TERM {} failed: {status}", self.pid());
        }
        Ok(())
    }

    /// The exit status, if the process has ended.
    pub fn try_status(&mut self) -> Option<ExitStatus> {
        self.child.try_wait().ok().flatten()
    }

    /// Waits up to `timeout` for the process to end.
    pub async fn wait_exit(&mut self, timeout: Duration) -> Result<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(status) = self.try_status() {
                return Ok(status);
            }
            if Instant::now() > deadline {
                bail!(
                    "{} did not exit within {timeout:?}; log:\n{}",
                    self.name,
                    self.log()
                );
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A throwaway certificate authority and a server certificate it signed for `localhost` and
/// 127.0.0.1, as PEM files.
pub struct TestCa {
    pub ca_cert: PathBuf,
    pub server_cert: PathBuf,
    pub server_key: PathBuf,
    /// The CA's certificate, DER, for this process's own client.
    pub ca_der: Vec<u8>,
}

impl TestCa {
    /// Makes the CA and the server certificate, writing the files into `dir`.
    pub fn create(dir: &Path) -> Result<TestCa> {
        TestCa::create_for(dir, &["localhost", "127.0.0.1"])
    }

    /// [`TestCa::create`] with a server certificate for these names and IP addresses.
    pub fn create_for(dir: &Path, names: &[&str]) -> Result<TestCa> {
        let ca_key = rcgen::KeyPair::generate()?;
        let mut ca_params = rcgen::CertificateParams::new(Vec::<String>::new())?;
        ca_params.is_ca = rcgen::IsCa::Ca(rcgen::BasicConstraints::Unconstrained);
        ca_params
            .distinguished_name
            .push(rcgen::DnType::CommonName, "spindle test CA");
        let ca = rcgen::CertifiedIssuer::self_signed(ca_params, ca_key)?;
        let server_key = rcgen::KeyPair::generate()?;
        let names = names.iter().map(|n| n.to_string()).collect::<Vec<_>>();
        let server = rcgen::CertificateParams::new(names)?.signed_by(&server_key, &ca)?;
        let files = TestCa {
            ca_cert: dir.join("ca.pem"),
            server_cert: dir.join("server.pem"),
            server_key: dir.join("server-key.pem"),
            ca_der: ca.der().to_vec(),
        };
        std::fs::write(&files.ca_cert, ca.pem())?;
        std::fs::write(&files.server_cert, server.pem())?;
        std::fs::write(&files.server_key, server_key.serialize_pem())?;
        Ok(files)
    }

    /// A reqwest client builder that trusts only this CA.
    pub fn client_builder(&self) -> Result<reqwest::ClientBuilder> {
        let mut roots = rustls::RootCertStore::empty();
        roots.add(self.ca_der.clone().into())?;
        let provider = std::sync::Arc::new(rustls::crypto::ring::default_provider());
        let config = rustls::ClientConfig::builder_with_provider(provider)
            .with_safe_default_protocol_versions()?
            .with_root_certificates(roots)
            .with_no_client_auth();
        Ok(reqwest::Client::builder().tls_backend_preconfigured(config))
    }
}

/// A client builder for plain-HTTP test clients. reqwest is built without a default TLS
/// provider (the programs configure ring themselves), and a builder without one refuses to
/// build, so the process default is set to ring first.
pub fn http_builder() -> reqwest::ClientBuilder {
    // Err only when a provider is installed already, which is as good.
    let _ = rustls::crypto::ring::default_provider().install_default();
    reqwest::Client::builder()
}

/// A coordinator and its workers on loopback, with their own tokens and data directory.
pub struct Farm {
    pub dir: tempfile::TempDir,
    pub port: u16,
    pub client_token: String,
    pub worker_token: String,
    pub lease_ttl_s: f64,
    pub server: Option<Proc>,
    pub workers: Vec<Proc>,
    pub http: reqwest::Client,
    /// Set: the coordinator serves HTTPS with this CA's certificate, and workers trust it.
    pub tls: Option<TestCa>,
    /// Set: the coordinator also serves the dashboard (`--dashboard-listen`) on this port.
    pub dashboard_port: Option<u16>,
}

impl Farm {
    /// Starts a coordinator whose leases last `lease_ttl_s` without a heartbeat.
    pub async fn start(lease_ttl_s: f64) -> Result<Farm> {
        Farm::start_with(lease_ttl_s, false).await
    }

    /// [`Farm::start`] with two registered workers, `w1` and `w2`, of one thread each.
    pub async fn of_two_workers(lease_ttl_s: f64) -> Result<Farm> {
        let mut farm = Farm::start(lease_ttl_s).await?;
        farm.add_worker("w1", 1)?;
        farm.add_worker("w2", 1)?;
        farm.wait_registered(0).await?;
        farm.wait_registered(1).await?;
        Ok(farm)
    }

    /// [`Farm::start`], serving HTTPS with a certificate of a throwaway CA when `tls`.
    pub async fn start_with(lease_ttl_s: f64, tls: bool) -> Result<Farm> {
        Farm::start_full(lease_ttl_s, tls, false).await
    }

    /// [`Farm::start`] with the dashboard listener on a port of its own ([`Farm::dashboard`]).
    pub async fn start_with_dashboard(lease_ttl_s: f64) -> Result<Farm> {
        Farm::start_full(lease_ttl_s, false, true).await
    }

    async fn start_full(lease_ttl_s: f64, tls: bool, dashboard: bool) -> Result<Farm> {
        let dir = tempfile::tempdir()?;
        let tls = if tls {
            Some(TestCa::create(dir.path())?)
        } else {
            None
        };
        let builder = match &tls {
            Some(ca) => ca.client_builder()?,
            None => http_builder(),
        };
        let http = builder
            .no_proxy()
            .timeout(Duration::from_secs(30))
            .build()?;
        let mut farm = Farm {
            tls,
            dir,
            port: free_port(),
            client_token: format!("client-{}", std::process::id()),
            worker_token: format!("worker-{}", std::process::id()),
            lease_ttl_s,
            server: None,
            workers: Vec::new(),
            http,
            dashboard_port: dashboard.then(free_port),
        };
        // `free_port` only says the port was free a moment ago: another process may take it
        // before the coordinator binds it. Then try other ports.
        for _ in 0..4 {
            match farm.start_server().await {
                Err(e) if format!("{e:#}").contains("Address already in use") => {
                    farm.port = free_port();
                    farm.dashboard_port = dashboard.then(free_port);
                }
                other => return other.map(|()| farm),
            }
        }
        farm.start_server().await?;
        Ok(farm)
    }

    /// `http://127.0.0.1:PORT`, or `https://localhost:PORT` with TLS.
    pub fn base(&self) -> String {
        match self.tls {
            Some(_) => format!("https://localhost:{}", self.port),
            None => format!("http://127.0.0.1:{}", self.port),
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{}", self.base(), path)
    }

    /// `http://127.0.0.1:PORT` of the dashboard listener, if it was asked for.
    pub fn dashboard(&self) -> Option<String> {
        self.dashboard_port
            .map(|port| format!("http://127.0.0.1:{port}"))
    }

    /// Starts (or restarts) the coordinator on the farm's port and data directory, and waits
    /// until it is ready.
    pub async fn start_server(&mut self) -> Result<()> {
        let mut cmd = Command::new(binary("spindle-server"));
        cmd.arg("--listen")
            .arg(format!("127.0.0.1:{}", self.port))
            .arg("--data")
            .arg(self.dir.path().join("data"))
            .arg("--lease-ttl-s")
            .arg(self.lease_ttl_s.to_string());
        if let Some(port) = self.dashboard_port {
            cmd.arg("--dashboard-listen")
                .arg(format!("127.0.0.1:{port}"));
        }
        if let Some(ca) = &self.tls {
            cmd.arg("--tls-cert")
                .arg(&ca.server_cert)
                .arg("--tls-key")
                .arg(&ca.server_key);
        }
        // Tokens through the environment, as in a deployment.
        let env = [
            ("SPINDLE_TOKEN", self.client_token.as_str()),
            ("SPINDLE_WORKER_TOKEN", self.worker_token.as_str()),
        ];
        let mut proc = Proc::spawn(cmd, &env, self.dir.path(), "server")?;
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if let Some(status) = proc.try_status() {
                bail!(
                    "spindle-server exited at start ({status}); log:\n{}",
                    proc.log()
                );
            }
            let ready = self.http.get(self.url("/readyz")).send().await;
            if matches!(&ready, Ok(r) if r.status().is_success()) {
                break;
            }
            if Instant::now() > deadline {
                bail!("spindle-server not ready after 30 s; log:\n{}", proc.log());
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        self.server = Some(proc);
        Ok(())
    }

    /// SIGKILLs the coordinator.
    pub fn kill_server(&mut self) {
        if let Some(mut s) = self.server.take() {
            s.kill();
        }
    }

    /// Starts a worker with `threads` render threads; returns its index in `workers`.
    pub fn add_worker(&mut self, name: &str, threads: usize) -> Result<usize> {
        self.add_worker_with(name, threads, &[])
    }

    /// [`Farm::add_worker`] with more command-line arguments (`--label pool=night`).
    pub fn add_worker_with(&mut self, name: &str, threads: usize, args: &[&str]) -> Result<usize> {
        let mut cmd = Command::new(binary("spindle-worker"));
        cmd.arg("--coordinator")
            .arg(self.base())
            .arg("--threads")
            .arg(threads.to_string())
            .arg("--name")
            .arg(name)
            .args(args);
        if let Some(ca) = &self.tls {
            cmd.arg("--ca-cert").arg(&ca.ca_cert);
        }
        let env = [("SPINDLE_WORKER_TOKEN", self.worker_token.as_str())];
        let proc = Proc::spawn(cmd, &env, self.dir.path(), name)?;
        self.workers.push(proc);
        Ok(self.workers.len() - 1)
    }

    /// Waits until worker `i` has registered with the coordinator.
    pub async fn wait_registered(&self, i: usize) -> Result<()> {
        let deadline = Instant::now() + Duration::from_secs(30);
        while !self.workers[i]
            .log()
            .contains("registered with the coordinator")
        {
            if Instant::now() > deadline {
                bail!(
                    "worker {} did not register within 30 s\n{}",
                    self.workers[i].name,
                    self.logs()
                );
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        Ok(())
    }

    /// A client request with the client token.
    pub fn client(&self, method: reqwest::Method, path: &str) -> reqwest::RequestBuilder {
        self.http
            .request(method, self.url(path))
            .bearer_auth(&self.client_token)
    }

    /// A worker request with the worker token.
    pub fn worker(&self, method: reqwest::Method, path: &str) -> reqwest::RequestBuilder {
        self.http
            .request(method, self.url(path))
            .bearer_auth(&self.worker_token)
    }

    /// Uploads the scene's assets and submits it; returns the new job.
    pub async fn submit(&self, scene: &Value, assets: &Assets, tile_size: u32) -> Result<JobInfo> {
        let mut table = BTreeMap::new();
        for (path, bytes) in assets {
            let hash = asset_hash(bytes);
            let resp = self
                .client(reqwest::Method::PUT, &format!("/v1/assets/{hash}"))
                .body(bytes.clone())
                .send()
                .await?;
            if !resp.status().is_success() {
                bail!("asset upload: {} {}", resp.status(), resp.text().await?);
            }
            table.insert(path.clone(), hash);
        }
        let job = SubmitJob {
            scene: serde_json::from_value(scene.clone())?,
            assets: table,
            tile_size,
            priority: 0,
            requires: BTreeMap::new(),
            name: None,
            submitter: None,
            crop: None,
            frame: None,
        };
        let resp = self
            .client(reqwest::Method::POST, "/v1/jobs")
            .json(&job)
            .send()
            .await?;
        let status = resp.status();
        let text = resp.text().await?;
        if !status.is_success() {
            bail!("submit: {status} {text}");
        }
        Ok(serde_json::from_str(&text)?)
    }

    /// `GET /v1/jobs/{id}`.
    pub async fn job(&self, id: u64) -> Result<JobInfo> {
        let resp = self
            .client(reqwest::Method::GET, &format!("/v1/jobs/{id}"))
            .send()
            .await?;
        let status = resp.status();
        let text = resp.text().await?;
        if !status.is_success() {
            bail!("job {id}: {status} {text}");
        }
        Ok(serde_json::from_str(&text)?)
    }

    /// Polls until `ready(job)` or the deadline; tolerates the coordinator being down.
    pub async fn wait_job(
        &self,
        id: u64,
        timeout: Duration,
        ready: impl Fn(&JobInfo) -> bool,
    ) -> Result<JobInfo> {
        let deadline = Instant::now() + timeout;
        let mut last = None;
        loop {
            match self.job(id).await {
                Ok(info) if ready(&info) => return Ok(info),
                Ok(info) => last = Some(info),
                Err(_) if Instant::now() < deadline => {}
                Err(e) => return Err(e),
            }
            if Instant::now() > deadline {
                return Err(anyhow!(
                    "job {id} not ready within {timeout:?}; last seen {last:?}\n{}",
                    self.logs()
                ));
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    }

    /// Waits until the job is finished, and requires it done.
    pub async fn wait_done(&self, id: u64, timeout: Duration) -> Result<JobInfo> {
        let info = self
            .wait_job(id, timeout, |j| j.state.is_finished())
            .await?;
        if info.state != spindle_common::protocol::JobState::Done {
            bail!(
                "job {id} ended {:?}: {:?}\n{}",
                info.state,
                info.error,
                self.logs()
            );
        }
        Ok(info)
    }

    /// The job's final EXR, decoded.
    pub async fn image(&self, id: u64) -> Result<Image> {
        let resp = self
            .client(reqwest::Method::GET, &format!("/v1/jobs/{id}/image.exr"))
            .send()
            .await?;
        if !resp.status().is_success() {
            bail!("image of job {id}: {}", resp.status());
        }
        let bytes = resp.bytes().await?;
        Image::from_exr_bytes(&bytes).map_err(|e| anyhow!("decoding the EXR of job {id}: {e}"))
    }

    /// Every process's log, for failure messages.
    pub fn logs(&self) -> String {
        let mut s = String::new();
        for p in self.server.iter().chain(&self.workers) {
            s += &format!("----- {} -----\n{}\n", p.name, p.log());
        }
        s
    }
}

/// Tiles this worker's log reports as delivered and accepted by the coordinator.
pub fn accepted_tiles(log: &str) -> usize {
    log.lines()
        .filter(|l| l.contains("tile delivered") && l.contains("Accepted"))
        .count()
}

/// A small scene with one OBJ asset (a box) and a procedural sphere, so assets travel.
/// Writes `scene` as `dir/scene.json` and its assets beside it (at their relative paths, as a
/// scene file names them); returns the scene file's path.
pub fn write_scene_files(dir: &Path, scene: &Value, assets: &Assets) -> Result<PathBuf> {
    for (path, bytes) in assets {
        let file = dir.join(path);
        if let Some(parent) = file.parent() {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::write(file, bytes)?;
    }
    let path = dir.join("scene.json");
    std::fs::write(&path, serde_json::to_string_pretty(scene)?)?;
    Ok(path)
}

pub fn test_scene(width: u32, height: u32, spp: u32) -> (Value, Assets) {
    let scene = serde_json::json!({
        "camera": { "position": [0.0, 1.2, 5.0], "look_at": [0.0, 0.8, 0.0], "fov_y": 35.0 },
        "film": { "width": width, "height": height, "spp": spp, "seed": 7 },
        "lights": [
            { "type": "point", "position": [0.6, 2.6, -3.0], "intensity": [30.0, 30.0, 30.0] },
            { "type": "sphere", "center": [-2.5, 2.0, -3.5], "radius": 0.6, "radiance": [8.0, 7.5, 7.0] }
        ],
        "objects": [
            {
                "shape": { "type": "obj", "path": "meshes/floor.obj" },
                "material": { "type": "diffuse", "reflectance": [0.7, 0.7, 0.7] }
            },
            {
                "shape": { "type": "icosphere", "radius": 1.0, "subdivisions": 2 },
                "transform": { "translate": [0.0, 1.0, 0.0] },
                "material": {
                    "type": "dielectric",
                    "eta": 1.5,
                    "medium": { "sigma_t": [0.3, 0.35, 0.4], "albedo": [0.95, 0.95, 0.95] }
                }
            }
        ],
        "background": [0.05, 0.05, 0.06],
        // The farm tests time kills and heartbeats against tile cost: keep the integrator out of
        // them; `scattering_test_scene` puts it back for the bit-identity test.
        "integrator": { "single_scatter": { "method": "none" } }
    });
    let floor = "v -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\nf 1 3 2\nf 1 4 3\n";
    let assets = Assets::from([("meshes/floor.obj".to_string(), floor.as_bytes().to_vec())]);
    (scene, assets)
}

/// [`test_scene`] with the interval single-scattering integrator switched on, so a farm render
/// is compared bit for bit with every layer non-trivial.
pub fn scattering_test_scene(width: u32, height: u32, spp: u32) -> (Value, Assets) {
    let (mut scene, assets) = test_scene(width, height, spp);
    scene["integrator"]["single_scatter"]["method"] = serde_json::json!("interval");
    (scene, assets)
}

/// Renders the whole frame in this process: the single-process reference.
pub fn reference_image(scene: &Value, assets: &Assets) -> Result<Image> {
    let desc = serde_json::from_value(scene.clone())?;
    let scene = Scene::build(&desc, assets).map_err(|e| anyhow!("reference scene: {e}"))?;
    let film = scene.film();
    let mut image =
        Image::new(film.width, film.height).with_passes(spindle_render::film_passes(&scene));
    for rect in split_centre_first(film.width, film.height, 16) {
        image
            .insert_tile(&render_tile(&scene, rect))
            .map_err(|e| anyhow!("{e}"))?;
    }
    // A black frame would make every comparison trivially true.
    if !image.total.iter().any(|&v| v > 0.0) {
        bail!("the reference render is black");
    }
    Ok(image)
}

/// Panics unless every layer of `a` and `b` (alpha and `stderr` too) is the same bits, naming
/// the first difference. Header attributes are not compared: `renderTime` differs run to run.
pub fn assert_bit_identical(a: &Image, b: &Image) {
    assert_eq!(
        (a.width, a.height, a.placement),
        (b.width, b.height, b.placement),
        "image sizes or places in the film differ"
    );
    for ((kind, la), lb) in spindle_common::tile::LAYERS
        .iter()
        .zip(a.layers())
        .zip(b.layers())
    {
        let name = kind.name;
        assert_eq!(la.len(), lb.len(), "layer {name} lengths differ");
        if let Some(i) = (0..la.len()).find(|&i| la[i].to_bits() != lb[i].to_bits()) {
            let (px, ch) = (i / kind.channels, i % kind.channels);
            panic!(
                "layer {name} differs at pixel ({}, {}) channel {ch}: {} vs {}",
                px as u32 % a.width,
                px as u32 / a.width,
                la[i],
                lb[i]
            );
        }
    }
    assert_eq!(a.passes, b.passes, "the optional passes differ");
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert!(
        bits(&a.aov) == bits(&b.aov),
        "the optional passes' values differ"
    );
}

/// Runs the `spindle` command with `args` in `cwd` (or here), with the farm's address and client
/// token in its environment when `farm` is given (and no other spindle settings inherited);
/// killed if it outlives `timeout`.
pub async fn run_spindle(
    cwd: Option<&Path>,
    args: &[&str],
    farm: Option<&Farm>,
    timeout: Duration,
) -> std::process::Output {
    let mut cmd = Command::new(binary("spindle"));
    if let Some(cwd) = cwd {
        cmd.current_dir(cwd);
    }
    cmd.args(args)
        .env_remove("SPINDLE_SERVER")
        .env_remove("SPINDLE_TOKEN");
    if let Some(farm) = farm {
        cmd.env("SPINDLE_SERVER", farm.base())
            .env("SPINDLE_TOKEN", &farm.client_token);
    }
    let mut cmd = tokio::process::Command::from(cmd);
    cmd.kill_on_drop(true);
    tokio::time::timeout(timeout, cmd.output())
        .await
        .expect("spindle finished in time")
        .expect("spindle ran")
}

/// A finished command's status, stdout and stderr, for assertion messages.
pub fn output_text(out: &std::process::Output) -> String {
    format!(
        "status {}\nstdout:\n{}\nstderr:\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}
