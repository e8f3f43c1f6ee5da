//! The farm across hosts, on one machine: three network namespaces stand for three machines —
//! "coordinator", "worker-a" and "worker-b" — joined by veth pairs on a bridge inside the
//! coordinator's namespace, on a private subnet that exists only inside them. The real
//! `spindle-server` serves HTTPS there (a throwaway CA's certificate for its namespace address,
//! client and worker tokens read from files), a real `spindle-worker` runs in each worker
//! namespace, and the `spindle` command submits, watches and fetches from inside the
//! coordinator's namespace (the test process itself has no address on the subnet).
//!
//! Along the way worker-a's link is cut while it renders a tile (its lease lapses and the tile
//! goes back to the queue; when the link returns the worker carries on) and the coordinator is
//! killed and started again in its namespace. The image must still be bit-identical to a
//! single-process render, with exactly one camera ray per pixel sample.
//!
//! Namespaces need root and `ip` (iproute2): elsewhere the test says why and skips. Their names
//! carry the test's pid, so a crashed run cannot break the next, and a guard deletes them even
//! when the test panics.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use spindle_common::image::Image;
use spindle_common::protocol::{JobInfo, JobState, WorkerList, WorkerState};
use spindle_tests::{
    Proc, TestCa, accepted_tiles, assert_bit_identical, binary, reference_image, test_scene,
};

/// The whole test, namespaces included, must finish within this.
const BUDGET: Duration = Duration::from_secs(60);
/// The coordinator's lease TTL: short, so a cut worker's tile is re-leased quickly.
const LEASE_TTL_S: f64 = 1.0;
/// The coordinator's address on the private subnet, and its port.
const COORDINATOR_IP: &str = "10.200.0.1";
const PORT: u16 = 7443;

/// Why this machine cannot run the test, if it cannot.
fn cannot_run() -> Option<String> {
    let uid = Command::new("id").arg("-u").output();
    match uid {
        Ok(out) if String::from_utf8_lossy(&out.stdout).trim() == "0" => {}
        Ok(_) => return Some("not running as root (network namespaces need it)".into()),
        Err(e) => return Some(format!("cannot run `id -u`: {e}")),
    }
    match Command::new("ip").arg("-V").output() {
        Ok(out) if out.status.success() => None,
        Ok(out) => Some(format!("`ip -V` failed: {}", out.status)),
        Err(e) => Some(format!("`ip` (iproute2) is not available: {e}")),
    }
}

/// Runs `ip ARGS`, failing with its stderr.
fn ip(args: &[&str]) -> Result<()> {
    let out = Command::new("ip")
        .args(args)
        .output()
        .with_context(|| format!("running ip {}", args.join(" ")))?;
    if !out.status.success() {
        bail!(
            "ip {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(())
}

/// The three namespaces; deleted on drop (which also deletes their links and bridge).
struct Namespaces {
    coordinator: String,
    workers: [String; 2],
}

impl Namespaces {
    /// Makes the namespaces: a bridge `br0` in the coordinator's carrying 10.200.0.1/24, and a
    /// veth pair per worker, `eth0` (10.200.0.2 and .3) in the worker's namespace and its peer
    /// on the bridge.
    fn create() -> Result<Namespaces> {
        let pid = std::process::id();
        let ns = Namespaces {
            coordinator: format!("spindle-coordinator-{pid}"),
            workers: [
                format!("spindle-worker-a-{pid}"),
                format!("spindle-worker-b-{pid}"),
            ],
        };
        // From here on, drop cleans up whatever was made.
        for name in ns.all() {
            ip(&["netns", "add", name])?;
            ip(&["-n", name, "link", "set", "lo", "up"])?;
        }
        let c = ns.coordinator.as_str();
        ip(&["-n", c, "link", "add", "br0", "type", "bridge"])?;
        ip(&[
            "-n",
            c,
            "addr",
            "add",
            &format!("{COORDINATOR_IP}/24"),
            "dev",
            "br0",
        ])?;
        ip(&["-n", c, "link", "set", "br0", "up"])?;
        for (i, worker) in ns.workers.iter().enumerate() {
            let port = format!("port{i}");
            ip(&[
                "-n", c, "link", "add", &port, "type", "veth", "peer", "name", "eth0", "netns",
                worker,
            ])?;
            ip(&["-n", c, "link", "set", &port, "master", "br0"])?;
            ip(&["-n", c, "link", "set", &port, "up"])?;
            let addr = format!("10.200.0.{}/24", i + 2);
            ip(&["-n", worker, "addr", "add", &addr, "dev", "eth0"])?;
            ip(&["-n", worker, "link", "set", "eth0", "up"])?;
        }
        Ok(ns)
    }

    fn all(&self) -> impl Iterator<Item = &str> {
        std::iter::once(self.coordinator.as_str()).chain(self.workers.iter().map(String::as_str))
    }

    /// Takes a worker's link down (`up == false`) or up again.
    fn set_worker_link(&self, worker: usize, up: bool) -> Result<()> {
        let state = if up { "up" } else { "down" };
        ip(&["-n", &self.workers[worker], "link", "set", "eth0", state])
    }
}

impl Drop for Namespaces {
    fn drop(&mut self) {
        for name in self.all() {
            // A namespace that was never made fails to delete, which is fine.
            let _ = ip(&["netns", "del", name]);
        }
    }
}

/// `ip netns exec NS PROGRAM`.
fn in_namespace(ns: &str, program: &Path) -> Command {
    let mut cmd = Command::new("ip");
    cmd.args(["netns", "exec", ns]).arg(program);
    cmd
}

/// The farm across the namespaces. Field order matters: processes are killed before the
/// namespaces they live in are deleted.
struct Hosts {
    server: Option<Proc>,
    workers: Vec<Proc>,
    ns: Namespaces,
    ca: TestCa,
    dir: tempfile::TempDir,
    client_token: String,
    started: Instant,
}

impl Hosts {
    fn create() -> Result<Hosts> {
        let started = Instant::now();
        let dir = tempfile::tempdir()?;
        let ns = Namespaces::create()?;
        let ca = TestCa::create_for(dir.path(), &[COORDINATOR_IP])?;
        let nonce = format!(
            "{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)?
                .as_nanos()
        );
        let client_token = format!("client-token-{nonce}");
        std::fs::write(dir.path().join("client.token"), &client_token)?;
        std::fs::write(
            dir.path().join("worker.token"),
            format!("worker-token-{nonce}"),
        )?;
        Ok(Hosts {
            server: None,
            workers: Vec::new(),
            ns,
            ca,
            dir,
            client_token,
            started,
        })
    }

    fn base(&self) -> String {
        format!("https://{COORDINATOR_IP}:{PORT}")
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    /// Fails when the test's time is up.
    fn check_budget(&self, waiting_for: &str) -> Result<()> {
        if self.started.elapsed() > BUDGET {
            bail!(
                "out of time ({BUDGET:?}) waiting for {waiting_for}\n{}",
                self.logs()
            );
        }
        Ok(())
    }

    /// Starts (or restarts) the coordinator in its namespace and waits until it answers.
    fn start_server(&mut self) -> Result<()> {
        let mut cmd = in_namespace(&self.ns.coordinator, &binary("spindle-server"));
        cmd.arg("--listen")
            .arg(format!("{COORDINATOR_IP}:{PORT}"))
            .arg("--data")
            .arg(self.path("data"))
            .arg("--lease-ttl-s")
            .arg(LEASE_TTL_S.to_string())
            .arg("--tls-cert")
            .arg(&self.ca.server_cert)
            .arg("--tls-key")
            .arg(&self.ca.server_key)
            .arg("--token-file")
            .arg(self.path("client.token"))
            .arg("--worker-token-file")
            .arg(self.path("worker.token"));
        let mut proc = Proc::spawn(cmd, &[], self.dir.path(), "server")?;
        loop {
            if let Some(status) = proc.try_status() {
                bail!("spindle-server exited at start ({status}):\n{}", proc.log());
            }
            if self.spindle(&["jobs"]).is_ok() {
                break;
            }
            if self.started.elapsed() > BUDGET {
                bail!("spindle-server not ready:\n{}", proc.log());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.server = Some(proc);
        Ok(())
    }

    /// Starts a one-thread worker in worker namespace `i`.
    fn start_worker(&mut self, i: usize, name: &str) -> Result<()> {
        let mut cmd = in_namespace(&self.ns.workers[i], &binary("spindle-worker"));
        cmd.arg("--coordinator")
            .arg(self.base())
            .arg("--ca-cert")
            .arg(&self.ca.ca_cert)
            .arg("--token-file")
            .arg(self.path("worker.token"))
            .arg("--threads")
            .arg("1")
            .arg("--name")
            .arg(name);
        let proc = Proc::spawn(cmd, &[], self.dir.path(), name)?;
        self.workers.push(proc);
        Ok(())
    }

    /// Runs `spindle ARGS` in the coordinator's namespace with the client token; its stdout.
    fn spindle(&self, args: &[&str]) -> Result<String> {
        let out = in_namespace(&self.ns.coordinator, &binary("spindle"))
            .args(args)
            .env("SPINDLE_TOKEN", &self.client_token)
            .env("SPINDLE_SERVER", self.base())
            .env("SPINDLE_CA_CERT", &self.ca.ca_cert)
            .output()
            .context("running spindle")?;
        if !out.status.success() {
            bail!(
                "spindle {} failed: {}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr).trim()
            );
        }
        Ok(String::from_utf8(out.stdout)?)
    }

    fn job(&self, id: u64) -> Result<JobInfo> {
        Ok(serde_json::from_str(&self.spindle(&[
            "status",
            &id.to_string(),
            "--json",
        ])?)?)
    }

    fn workers(&self) -> Result<WorkerList> {
        Ok(serde_json::from_str(
            &self.spindle(&["workers", "--json"])?,
        )?)
    }

    /// Polls `probe` until it answers `Some`, tolerating a coordinator that is away.
    fn wait<T>(&self, what: &str, mut probe: impl FnMut(&Hosts) -> Result<Option<T>>) -> Result<T> {
        loop {
            if let Ok(Some(value)) = probe(self) {
                return Ok(value);
            }
            self.check_budget(what)?;
            std::thread::sleep(Duration::from_millis(30));
        }
    }

    fn logs(&self) -> String {
        let mut s = String::new();
        for p in self.server.iter().chain(&self.workers) {
            s += &format!("----- {} -----\n{}\n", p.name, p.log());
        }
        s
    }
}

#[test]
fn workers_in_other_namespaces_render_through_a_cut_link_and_a_coordinator_restart() {
    if let Some(reason) = cannot_run() {
        eprintln!("SKIPPED: the across-hosts test needs network namespaces: {reason}");
        return;
    }
    scenario().unwrap();
}

fn scenario() -> Result<()> {
    // 48 tiles of 8×8, each about a third of a second on one thread (24 spp took 25 ms a
    // tile): the job outlasts the cut and the restart below.
    let (width, height, spp) = (64, 48, 256);
    let (scene, assets) = test_scene(width, height, spp);
    let mut hosts = Hosts::create()?;
    let reference = reference_image(&scene, &assets)?;
    std::fs::create_dir_all(hosts.path("meshes"))?;
    for (path, bytes) in &assets {
        std::fs::write(hosts.path(path), bytes)?;
    }
    std::fs::write(hosts.path("scene.json"), serde_json::to_vec(&scene)?)?;
    hosts.start_server()?;
    hosts.start_worker(0, "worker-a")?;
    hosts.start_worker(1, "worker-b")?;

    let scene_file = hosts.path("scene.json");
    let id: u64 = hosts
        .spindle(&["submit", scene_file.to_str().unwrap(), "--tile-size", "8"])?
        .trim()
        .parse()
        .context("the job id printed by spindle submit")?;

    // Both workers, each from its own namespace, have delivered tiles.
    hosts.wait("both workers to deliver a tile", |h| {
        let list = h.workers()?;
        let done = |name: &str| {
            list.workers
                .iter()
                .find(|w| w.name == name)
                .map_or(0, |w| w.tiles_done)
        };
        Ok((done("worker-a") >= 1 && done("worker-b") >= 1).then_some(()))
    })?;

    // Cut worker-a's link while it holds a lease, for longer than the lease lives.
    let tile = hosts.wait("worker-a to hold a lease", |h| {
        Ok(h.workers()?
            .workers
            .into_iter()
            .find(|w| w.name == "worker-a")
            .and_then(|w| w.tile))
    })?;
    // Paused, the job hands out no new lease, so it cannot finish while worker-a is away or
    // before the coordinator is killed below, however fast this machine renders.
    hosts.spindle(&["pause", &id.to_string()])?;
    hosts.ns.set_worker_link(0, false)?;
    let at_cut = hosts.job(id)?;
    let delivered_before_cut = accepted_tiles(&hosts.workers[0].log());
    let server_log = |h: &Hosts| h.server.as_ref().map(Proc::log).unwrap_or_default();
    hosts.wait("worker-a's lease to lapse", |h| {
        let lapsed = server_log(h).lines().any(|l| {
            l.contains("lease expired; tile back in the queue")
                && l.contains(&format!("job={id}"))
                && l.contains(&format!("tile={tile}"))
        });
        Ok(lapsed.then_some(()))
    })?;
    hosts.ns.set_worker_link(0, true)?;
    let link_up_ms = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)?
        .as_millis() as i64;
    if at_cut.tiles_done == at_cut.tiles_total {
        bail!("the job finished before the link was cut; make the scene slower");
    }
    // Worker-a is heard from again over the restored link; then the job goes on.
    hosts.wait("worker-a to be heard from again", |h| {
        Ok(h.workers()?
            .workers
            .iter()
            .any(|w| {
                w.name == "worker-a" && w.last_seen_ms >= link_up_ms && w.state != WorkerState::Lost
            })
            .then_some(()))
    })?;
    hosts.spindle(&["resume", &id.to_string()])?;
    // It rejoins: a tile delivered and accepted after the link came back.
    hosts.wait("worker-a to deliver again", |h| {
        Ok((accepted_tiles(&h.workers[0].log()) > delivered_before_cut).then_some(()))
    })?;

    // Kill the coordinator mid-job (paused, so it is still unfinished) and start it again in
    // its namespace; the job is resumed there.
    hosts.spindle(&["pause", &id.to_string()])?;
    let before_restart = hosts.job(id)?;
    if before_restart.state.is_finished() {
        bail!(
            "the job finished before the coordinator was killed; make the scene slower\n{}",
            hosts.logs()
        );
    }
    if let Some(mut server) = hosts.server.take() {
        server.kill();
    }
    std::thread::sleep(Duration::from_millis(500));
    hosts.start_server()?;
    hosts.spindle(&["resume", &id.to_string()])?;

    let done = hosts.wait("the job to finish", |h| {
        let job = h.job(id)?;
        Ok(job.state.is_finished().then_some(job))
    })?;
    if done.state != JobState::Done {
        bail!(
            "job ended {:?}: {:?}\n{}",
            done.state,
            done.error,
            hosts.logs()
        );
    }
    let exr = hosts.path("out.exr");
    hosts.spindle(&["fetch", &id.to_string(), "-o", exr.to_str().unwrap()])?;
    let image = Image::from_exr_bytes(&std::fs::read(&exr)?).map_err(|e| anyhow!("{e}"))?;
    assert_bit_identical(&image, &reference);
    assert_eq!(done.tiles_done, done.tiles_total);
    // Nothing lost and nothing counted twice: one camera ray per pixel sample.
    assert_eq!(
        done.stats.camera_rays,
        u64::from(width * height * spp),
        "{}",
        hosts.logs()
    );
    for w in &mut hosts.workers {
        assert!(w.try_status().is_none(), "{} exited\n{}", w.name, w.log());
    }
    eprintln!(
        "across hosts: {} tiles, cut at {}/{}, restart at {}/{}, {:.1} s",
        done.tiles_total,
        at_cut.tiles_done,
        at_cut.tiles_total,
        before_restart.tiles_done,
        before_restart.tiles_total,
        hosts.started.elapsed().as_secs_f64()
    );
    Ok(())
}
