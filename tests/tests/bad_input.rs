//! Bad input over real HTTP: each mistake gets the right 4xx with a JSON error naming the
//! problem, and leaves the jobs already on the coordinator exactly as they were.

use std::time::Duration;

use reqwest::{Method, RequestBuilder, StatusCode};
use serde_json::{Value, json};
use spindle_common::protocol::{
    JobInfo, JobList, Lease, TileAck, TileOutcome, TileUpload, WORKER_SECRET_HEADER,
    WorkerRegistered, pixel_hash,
};
use spindle_common::tile::TilePixels;
use spindle_tests::{Farm, test_scene};

const TEST_TIMEOUT: Duration = Duration::from_secs(90);

/// Sends `req`; returns the status and the `error` message of the JSON body (if any).
async fn send(req: reqwest::RequestBuilder) -> (StatusCode, String) {
    let resp = req.send().await.expect("the coordinator answers");
    let status = resp.status();
    let text = resp.text().await.unwrap_or_default();
    let message = serde_json::from_str::<Value>(&text)
        .ok()
        .and_then(|v| v.get("error").and_then(Value::as_str).map(String::from))
        .unwrap_or_else(|| format!("(no JSON error body: {text:?})"));
    (status, message)
}

/// The coordinator's job list.
async fn jobs(farm: &Farm) -> Vec<JobInfo> {
    let resp = farm.client(Method::GET, "/v1/jobs").send().await.unwrap();
    assert_eq!(resp.status(), StatusCode::OK);
    resp.json::<JobList>().await.unwrap().jobs
}

/// Asserts the only job is `job`, unchanged in everything but elapsed time.
async fn assert_untouched(farm: &Farm, job: &JobInfo, after: &str) {
    let now = jobs(farm).await;
    assert_eq!(now.len(), 1, "after {after}: {now:?}");
    let j = &now[0];
    assert_eq!(
        (
            j.id,
            j.state,
            j.tiles_done,
            j.tiles_total,
            j.width,
            j.height,
            &j.error
        ),
        (
            job.id,
            job.state,
            job.tiles_done,
            job.tiles_total,
            job.width,
            job.height,
            &job.error
        ),
        "after {after}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_requests_get_the_right_4xx_and_leave_jobs_alone() {
    tokio::time::timeout(TEST_TIMEOUT, async {
        let farm = Farm::start(0.5).await.unwrap();
        let (scene, assets) = test_scene(8, 8, 1);
        let job = farm.submit(&scene, &assets, 4).await.unwrap();
        assert_untouched(&farm, &job, "submitting").await;

        let submit = |body: Value| farm.client(Method::POST, "/v1/jobs").json(&body);
        let with_assets = |scene: Value| {
            let hash = spindle_common::protocol::asset_hash(&assets["meshes/floor.obj"]);
            json!({ "scene": scene, "assets": { "meshes/floor.obj": hash } })
        };

        // Malformed JSON.
        let (status, msg) = send(
            farm.client(Method::POST, "/v1/jobs")
                .header("content-type", "application/json")
                .body("{\"scene\": {\"camera\": "),
        )
        .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "malformed JSON: {msg}");
        assert_untouched(&farm, &job, "malformed JSON").await;

        // An unknown field, named in the answer.
        let mut bad = scene.clone();
        bad["film"]["exposure"] = json!(2.0);
        let (status, msg) = send(submit(with_assets(bad))).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "unknown field: {msg}");
        assert!(msg.contains("exposure"), "unknown field: {msg}");
        assert_untouched(&farm, &job, "an unknown field").await;

        // Huge dimensions, naming the field.
        let mut bad = scene.clone();
        bad["film"]["width"] = json!(1_000_000);
        let (status, msg) = send(submit(with_assets(bad))).await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "huge width: {msg}");
        assert!(msg.contains("film.width"), "huge width: {msg}");
        assert_untouched(&farm, &job, "a huge width").await;

        // An asset whose bytes do not hash to its name.
        let wrong = spindle_common::protocol::asset_hash(b"something else");
        let (status, msg) = send(
            farm.client(Method::PUT, &format!("/v1/assets/{wrong}"))
                .body(b"v 0 0 0\n".to_vec()),
        )
        .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "wrong asset hash: {msg}");
        assert_untouched(&farm, &job, "a wrong asset hash").await;

        // A job naming an asset the coordinator does not have.
        let (status, msg) = send(submit(json!({
            "scene": scene,
            "assets": { "meshes/floor.obj": wrong }
        })))
        .await;
        assert!(status.is_client_error(), "unknown asset: {status} {msg}");
        assert_untouched(&farm, &job, "an unknown asset").await;

        // No token, a wrong token, and the worker token on a client route.
        let url = farm.url("/v1/jobs");
        let (status, _) = send(farm.http.post(&url).json(&with_assets(scene.clone()))).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED, "missing token");
        let (status, _) = send(farm.http.get(&url).bearer_auth("not-the-token")).await;
        assert_eq!(status, StatusCode::UNAUTHORIZED, "wrong token");
        let (status, _) = send(farm.worker(Method::GET, "/v1/jobs")).await;
        assert_eq!(
            status,
            StatusCode::UNAUTHORIZED,
            "worker token on a client route"
        );
        let (status, _) = send(
            farm.client(Method::POST, "/v1/workers")
                .json(&json!({"name": "x", "threads": 1})),
        )
        .await;
        assert_eq!(
            status,
            StatusCode::UNAUTHORIZED,
            "client token on a worker route"
        );
        assert_untouched(&farm, &job, "missing or wrong tokens").await;

        // A body over the JSON limit (4 MiB). The coordinator answers before reading it all
        // and closes the connection, so this goes on a connection of its own rather than one
        // the shared client would try to reuse.
        let padding = "x".repeat(5 << 20);
        let once = spindle_tests::http_builder()
            .no_proxy()
            .pool_max_idle_per_host(0)
            .build()
            .unwrap();
        let (status, msg) = send(
            once.post(farm.url("/v1/jobs"))
                .bearer_auth(&farm.client_token)
                .header("content-type", "application/json")
                .body(format!("{{\"scene\": \"{padding}\"}}")),
        )
        .await;
        assert_eq!(
            status,
            StatusCode::PAYLOAD_TOO_LARGE,
            "oversized body: {msg}"
        );
        assert_untouched(&farm, &job, "an oversized body").await;

        // Still healthy after all that.
        let (status, _) = send(farm.http.get(farm.url("/healthz"))).await;
        assert_eq!(status, StatusCode::OK);
    })
    .await
    .expect("the test finished in time");
}

async fn register(farm: &Farm, name: &str) -> WorkerRegistered {
    let resp = farm
        .worker(Method::POST, "/v1/workers")
        .json(&json!({ "name": name, "threads": 1 }))
        .send()
        .await
        .unwrap();
    assert!(resp.status().is_success(), "register: {}", resp.status());
    resp.json::<WorkerRegistered>().await.unwrap()
}

/// A request of the registered worker `w`: the worker token and its secret.
fn as_worker(farm: &Farm, w: &WorkerRegistered, method: Method, path: &str) -> RequestBuilder {
    farm.worker(method, path)
        .header(WORKER_SECRET_HEADER, &w.worker_secret)
}

async fn lease(farm: &Farm, worker: &WorkerRegistered) -> Option<Lease> {
    let resp = as_worker(
        farm,
        worker,
        Method::POST,
        &format!("/v1/workers/{}/lease", worker.worker_id),
    )
    .json(&json!({ "wait_ms": 200 }))
    .send()
    .await
    .unwrap();
    match resp.status() {
        StatusCode::NO_CONTENT => None,
        StatusCode::OK => Some(resp.json().await.unwrap()),
        s => panic!("lease: {s} {}", resp.text().await.unwrap_or_default()),
    }
}

async fn upload(
    farm: &Farm,
    worker: &WorkerRegistered,
    lease: &Lease,
    pixels: &TilePixels,
) -> (StatusCode, String) {
    let body = TileUpload {
        worker_id: worker.worker_id,
        epoch: lease.epoch,
        hash: pixel_hash(pixels),
        pixels: pixels.clone(),
        render_seconds: None,
        provenance: None,
    };
    send(
        as_worker(
            farm,
            worker,
            Method::PUT,
            &format!("/v1/jobs/{}/tiles/{}", lease.job_id, lease.tile_index),
        )
        .json(&body),
    )
    .await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stale_lease_epoch_is_refused_and_a_late_identical_result_accepted() {
    tokio::time::timeout(TEST_TIMEOUT, async {
        // Leases lapse after 0.5 s without a heartbeat.
        let farm = Farm::start(0.5).await.unwrap();
        let (scene, assets) = test_scene(8, 8, 1);
        let job = farm.submit(&scene, &assets, 4).await.unwrap();

        let slow = register(&farm, "slow").await;
        let first = lease(&farm, &slow)
            .await
            .expect("a tile for the first worker");
        assert_eq!(first.job_id, job.id);

        // The slow worker misses its heartbeats; the tile is leased again with a newer epoch.
        let fast = register(&farm, "fast").await;
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        let second = loop {
            assert!(
                std::time::Instant::now() < deadline,
                "the tile was never leased again"
            );
            match lease(&farm, &fast).await {
                Some(l) if l.tile_index == first.tile_index => break l,
                _ => tokio::time::sleep(Duration::from_millis(100)).await,
            }
        };
        assert!(second.epoch > first.epoch, "{first:?} then {second:?}");

        let right = TilePixels::black(first.rect);
        let mut different = right.clone();
        different.total[0] = 1.0;

        // The stale epoch cannot write, whatever it sends, while the newer lease is out.
        let (status, msg) = upload(&farm, &slow, &first, &different).await;
        assert_eq!(status, StatusCode::CONFLICT, "stale upload: {msg}");
        let info: JobInfo = farm.job(job.id).await.unwrap();
        assert_eq!(info.tiles_done, 0, "a stale upload completed a tile");

        // A heartbeat on the stale lease is refused too.
        let (status, _) = send(
            as_worker(
                &farm,
                &slow,
                Method::POST,
                &format!("/v1/leases/{}/{}/heartbeat", job.id, first.tile_index),
            )
            .json(&json!({ "worker_id": slow.worker_id, "epoch": first.epoch })),
        )
        .await;
        assert_eq!(status, StatusCode::CONFLICT, "stale heartbeat");

        // The current lease writes; afterwards the stale worker's identical result is a
        // harmless duplicate and a different one is refused.
        let (status, msg) = upload(&farm, &fast, &second, &right).await;
        assert_eq!(status, StatusCode::OK, "current upload: {msg}");
        let resp = as_worker(
            &farm,
            &slow,
            Method::PUT,
            &format!("/v1/jobs/{}/tiles/{}", job.id, first.tile_index),
        )
        .json(&TileUpload {
            worker_id: slow.worker_id,
            epoch: first.epoch,
            hash: pixel_hash(&right),
            pixels: right.clone(),
            render_seconds: None,
            provenance: None,
        })
        .send()
        .await
        .unwrap();
        assert_eq!(resp.status(), StatusCode::OK, "late identical upload");
        assert_eq!(
            resp.json::<TileAck>().await.unwrap().outcome,
            TileOutcome::Duplicate
        );
        let (status, msg) = upload(&farm, &slow, &first, &different).await;
        assert_eq!(status, StatusCode::CONFLICT, "late different upload: {msg}");

        // A hash that does not match the pixels is refused outright.
        let mut lying = TileUpload {
            worker_id: fast.worker_id,
            epoch: second.epoch,
            hash: pixel_hash(&right),
            pixels: different.clone(),
            render_seconds: None,
            provenance: None,
        };
        lying.hash = pixel_hash(&right);
        let (status, msg) = send(
            as_worker(
                &farm,
                &fast,
                Method::PUT,
                &format!("/v1/jobs/{}/tiles/{}", job.id, first.tile_index),
            )
            .json(&lying),
        )
        .await;
        assert_eq!(status, StatusCode::BAD_REQUEST, "wrong pixel hash: {msg}");

        let info = farm.job(job.id).await.unwrap();
        assert_eq!(info.tiles_done, 1, "exactly the one good upload counted");
    })
    .await
    .expect("the test finished in time");
}
