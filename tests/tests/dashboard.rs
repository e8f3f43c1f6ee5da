//! The web dashboard in a real browser: headless Chromium, driven over WebDriver (chromedriver)
//! from here, against a real coordinator with its dashboard listener and two real workers.
//!
//! Skips, saying why, when `chromium` or `chromedriver` is not installed (`.ci/run` installs
//! both). Screenshots at desktop and phone width go to `$CARGO_TARGET_TMPDIR/dashboard/`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{Context, Result, anyhow, bail};
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{Value, json};
use spindle_common::protocol::JobState;
use spindle_tests::{Farm, Proc, free_port, http_builder, test_scene};

/// The longest the whole test may take before it fails by itself.
const TEST_TIMEOUT: Duration = Duration::from_secs(90);
/// The longest one condition in the page may take to become true.
const WAIT: Duration = Duration::from_secs(20);

fn find_program(env: &str, names: &[&str]) -> Option<PathBuf> {
    if let Some(path) = std::env::var_os(env) {
        return Some(PathBuf::from(path));
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|dir| names.iter().map(move |name| dir.join(name)))
        .find(|p| p.is_file())
}

/// Polls `check` (a script returning a value; `null`/`false` mean not yet) until it holds.
async fn wait_for(page: &Client, what: &str, script: &str) -> Result<Value> {
    let deadline = Instant::now() + WAIT;
    loop {
        let value = page
            .execute(script, vec![])
            .await
            .with_context(|| format!("waiting for {what}"))?;
        if !(value.is_null() || value == json!(false)) {
            return Ok(value);
        }
        if Instant::now() > deadline {
            let notice = page
                .execute(
                    "return document.getElementById('notice')?.textContent || ''",
                    vec![],
                )
                .await
                .unwrap_or_default();
            bail!("{what}: not seen within {WAIT:?} (page notice: {notice})");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// The text of the job row's state cell, as a script.
fn job_state_script(id: u64) -> String {
    format!("return document.querySelector('tr[data-job=\"{id}\"] td.state')?.textContent ?? null")
}

/// Clicks a job's row from within the page: the list is re-rendered as events arrive, so an
/// element found by WebDriver could be replaced before its click lands.
async fn click_row(page: &Client, id: u64) -> Result<()> {
    let clicked = page
        .execute(
            &format!(
                "const row = document.querySelector('tr[data-job=\"{id}\"]');
                 if (row) row.click();
                 return row !== null"
            ),
            vec![],
        )
        .await?;
    if clicked != json!(true) {
        bail!("no row for job {id}");
    }
    Ok(())
}

/// Starts chromedriver on a free loopback port and waits until it answers.
async fn start_chromedriver(driver: &Path, dir: &Path) -> Result<(Proc, String)> {
    let port = free_port();
    let mut cmd = Command::new(driver);
    cmd.arg(format!("--port={port}"))
        .arg("--allowed-ips=127.0.0.1");
    let proc = Proc::spawn(cmd, &[], dir, "chromedriver")?;
    let url = format!("http://127.0.0.1:{port}");
    let http = http_builder().no_proxy().build()?;
    let deadline = Instant::now() + WAIT;
    loop {
        let status = http.get(format!("{url}/status")).send().await;
        if matches!(&status, Ok(r) if r.status().is_success()) {
            return Ok((proc, url));
        }
        if Instant::now() > deadline {
            bail!(
                "chromedriver did not answer within {WAIT:?}:\n{}",
                proc.log()
            );
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

async fn open_browser(driver_url: &str, chromium: &Path) -> Result<Client> {
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chromium,
            // CI runs as root, hence --no-sandbox; no GPU on the machines.
            "args": ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     "--window-size=1280,800", "--no-first-run", "--disable-extensions"],
        }),
    );
    let connector = hyper_util::client::legacy::connect::HttpConnector::new();
    ClientBuilder::new(connector)
        .capabilities(caps)
        .connect(driver_url)
        .await
        .context("opening a Chromium session through chromedriver")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_dashboard_watches_and_steers_the_farm_in_a_browser() {
    let Some(chromium) = find_program("CHROMIUM", &["chromium", "chromium-browser"]) else {
        eprintln!("SKIPPED: chromium is not installed (apt-get install chromium chromium-driver)");
        return;
    };
    let Some(driver) = find_program("CHROMEDRIVER", &["chromedriver"]) else {
        eprintln!("SKIPPED: chromedriver is not installed (apt-get install chromium-driver)");
        return;
    };
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("dashboard");
    let outcome = tokio::time::timeout(TEST_TIMEOUT, scenario(&chromium, &driver, &shots)).await;
    match outcome {
        Ok(result) => result.unwrap(),
        Err(_) => panic!("the dashboard test did not finish within {TEST_TIMEOUT:?}"),
    }
}

async fn scenario(chromium: &Path, driver: &Path, shots: &Path) -> Result<()> {
    let mut farm = Farm::start_with_dashboard(5.0).await?;
    let base = farm.dashboard().expect("a dashboard listener");
    farm.add_worker("w1", 1)?;
    farm.add_worker("w2", 1)?;
    let (_driver, driver_url) = start_chromedriver(driver, farm.dir.path()).await?;
    let page = open_browser(&driver_url, chromium).await?;
    let result = drive(&mut farm, &page, &base, shots).await;
    if result.is_err() {
        let _ = std::fs::create_dir_all(shots);
        if let Ok(png) = page.screenshot().await {
            let _ = std::fs::write(shots.join("failure.png"), png);
        }
    }
    let _ = page.close().await;
    result.map_err(|e| anyhow!("{e:#}\n{}", farm.logs()))
}

async fn drive(farm: &mut Farm, page: &Client, base: &str, shots: &Path) -> Result<()> {
    // Without a token: only the prompt, and the API refuses a call without the header.
    page.goto(&format!("{base}/")).await?;
    wait_for(
        page,
        "the token prompt",
        "return !document.getElementById('login').hidden && document.getElementById('app').hidden",
    )
    .await?;
    let status = page
        .execute_async(
            "const done = arguments[arguments.length - 1];
             fetch('/v1/jobs').then(r => done(r.status), e => done(String(e)));",
            vec![],
        )
        .await?;
    assert_eq!(status, json!(401), "a data call without the token");
    // A wrong token: the first call answers 401 and the prompt comes back, saying so.
    page.goto(&format!("{base}/#token=not-the-token")).await?;
    let message = wait_for(
        page,
        "the prompt after a refused token",
        "const m = document.getElementById('login-message').textContent;
         return !document.getElementById('login').hidden && m.includes('refused') ? m : null",
    )
    .await?;
    assert!(
        message.as_str().unwrap().contains("wrong token"),
        "{message}"
    );

    // With the token in the fragment: the app, and the fragment gone from the address bar.
    page.goto(&format!("{base}/#token={}", farm.client_token))
        .await?;
    wait_for(
        page,
        "the app after the token",
        "return !document.getElementById('app').hidden && document.getElementById('live').textContent === 'live'",
    )
    .await?;
    let url = page.current_url().await?;
    assert_eq!(
        url.fragment(),
        None,
        "the token stays out of the address bar: {url}"
    );

    // Both workers listed.
    farm.wait_registered(0).await?;
    farm.wait_registered(1).await?;
    for name in ["w1", "w2"] {
        wait_for(
            page,
            &format!("worker {name} listed"),
            &format!("return document.querySelector('tr[data-worker=\"{name}\"]') !== null"),
        )
        .await?;
    }

    // Two jobs over the API: a tiny one, and a bigger one paused at once so it stays busy.
    let (small, small_assets) = test_scene(32, 24, 1);
    let quick = farm.submit(&small, &small_assets, 16).await?;
    let (big, big_assets) = test_scene(96, 64, 16);
    let held = farm.submit(&big, &big_assets, 16).await?;
    let paused = farm
        .client(
            reqwest::Method::POST,
            &format!("/v1/jobs/{}/pause", held.id),
        )
        .send()
        .await?;
    assert!(paused.status().is_success(), "pause: {}", paused.status());
    for job in [quick.id, held.id] {
        wait_for(page, &format!("job {job} listed"), &job_state_script(job)).await?;
    }

    // The small one reaches 100% in the list, and its preview loads in the job view.
    wait_for(
        page,
        "the small job done at 100%",
        &format!(
            "const row = document.querySelector('tr[data-job=\"{}\"]');
             return row && row.querySelector('td.state').textContent === 'done'
                 && row.textContent.includes('100%')",
            quick.id
        ),
    )
    .await?;
    click_row(page, quick.id).await?;
    let width = wait_for(
        page,
        "the preview image",
        "const img = document.getElementById('preview');
         return img && img.complete && img.naturalWidth > 0 ? img.naturalWidth : null",
    )
    .await?;
    assert_eq!(width, json!(32), "the preview is the job's image");
    wait_for(
        page,
        "the tile map of the small job",
        "const t = document.querySelectorAll('#tilemap .tile');
         return t.length === 4 && [...t].every(c => c.classList.contains('done'))",
    )
    .await?;
    // Each done tile's hover text names its worker and its render time.
    let titles = wait_for(
        page,
        "worker and render time on every done tile",
        "const t = [...document.querySelectorAll('#tilemap .tile.done')];
         return t.length === 4
             && t.every(c => /worker w[12], rendered in \\d+\\.\\d\\d s/.test(c.title))
             ? t.map(c => c.title) : null",
    )
    .await?;
    eprintln!("tile titles: {titles}");
    // The plan, as the workers built the scene, shown as text.
    let plan = wait_for(
        page,
        "the job's plan",
        "const p = document.getElementById('job-plan-text');
         return p && p.checkVisibility() && p.textContent.includes('single scattering: objects[')
             ? p.textContent : null",
    )
    .await?;
    assert!(
        plan.as_str().unwrap().contains("triangles"),
        "plan text: {plan}"
    );
    std::fs::create_dir_all(shots)?;
    std::fs::write(shots.join("desktop.png"), page.screenshot().await?)?;

    // Cancel the other one from its job view, accepting the confirmation.
    click_row(page, held.id).await?;
    wait_for(
        page,
        "the held job's view",
        &format!(
            "return document.getElementById('job-title')?.textContent.includes('job {}')",
            held.id
        ),
    )
    .await?;
    page.find(Locator::Css("#job button[data-action=\"cancel\"]"))
        .await?
        .click()
        .await?;
    page.accept_alert().await?;
    wait_for(
        page,
        "the held job cancelled in the list",
        &format!(
            "return ({}) === 'cancelled'",
            &job_state_script(held.id)[7..]
        ),
    )
    .await?;
    assert_eq!(farm.job(held.id).await?.state, JobState::Cancelled);

    // Submit from the page: a scene file and its mesh, hashed and uploaded by the page.
    let files = farm.dir.path().join("upload");
    std::fs::create_dir_all(&files)?;
    let (scene, assets) = test_scene(16, 16, 1);
    std::fs::write(files.join("scene.json"), serde_json::to_vec(&scene)?)?;
    for (path, bytes) in &assets {
        let name = Path::new(path).file_name().expect("a file name");
        std::fs::write(files.join(name), bytes)?;
    }
    let chosen = ["scene.json", "floor.obj"]
        .map(|f| files.join(f).display().to_string())
        .join("\n");
    page.find(Locator::Css("#files"))
        .await?
        .send_keys(&chosen)
        .await?;
    page.find(Locator::Css("#submit-button"))
        .await?
        .click()
        .await?;
    let said = wait_for(
        page,
        "the page's submission",
        "const m = document.getElementById('submit-message').textContent;
         return /^Submitted job|:/.test(m) ? m : null",
    )
    .await?;
    let said = said.as_str().unwrap_or_default().to_string();
    let id: u64 = said
        .strip_prefix("Submitted job ")
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| anyhow!("the page did not submit: {said}"))?;
    let submitted = farm.job(id).await?;
    assert_eq!(submitted.name, "scene");
    assert_eq!((submitted.width, submitted.height), (16, 16));
    wait_for(page, "the page's job listed", &job_state_script(id)).await?;

    page.set_window_size(390, 844).await?;
    // Let the layout settle into one column before the phone-width screenshot.
    wait_for(
        page,
        "the phone layout",
        "return document.getElementById('workers').getBoundingClientRect().left < 50",
    )
    .await?;
    std::fs::write(shots.join("phone.png"), page.screenshot().await?)?;
    eprintln!("screenshots in {}", shots.display());
    Ok(())
}
