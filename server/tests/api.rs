//! The API's edges: tokens, bad input of every kind (each the right 4xx with a JSON error
//! naming the problem, existing jobs untouched), idempotent submission, content-addressed
//! assets, and an OpenAPI document listing exactly the routes served.

mod support;

use std::collections::BTreeSet;

use axum::http::{Method, StatusCode};
use serde_json::{Value, json};
use spindle_common::protocol::{JobInfo, asset_hash};
use support::*;

/// The body of an error response; fails unless it is `{"error": "..."}`.
fn error_of(bytes: &[u8]) -> String {
    let v: Value = serde_json::from_slice(bytes)
        .unwrap_or_else(|_| panic!("not JSON: {}", String::from_utf8_lossy(bytes)));
    let obj = v.as_object().unwrap();
    assert_eq!(obj.len(), 1, "{v}");
    obj["error"].as_str().unwrap().to_string()
}

#[tokio::test]
async fn tokens_guard_their_routes() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    for (method, uri, token) in [
        (Method::GET, "/v1/jobs", None),
        (Method::GET, "/v1/jobs", Some("wrong")),
        (Method::GET, "/v1/jobs", Some(WORKER)), // a worker token is not a client token
        (Method::POST, "/v1/workers", Some(CLIENT)), // and the other way round
        (Method::POST, "/v1/workers/1/lease", None),
        // The token exactly: no trimming, no prefix.
        (Method::GET, "/v1/jobs", Some(" client-secret")),
        (Method::GET, "/v1/jobs", Some("client-secret ")),
        (Method::GET, "/v1/jobs", Some("client-secre")),
    ] {
        let (status, body) = c.send(method.clone(), uri, token, "{}").await;
        assert_eq!(status, StatusCode::UNAUTHORIZED, "{method} {uri} {token:?}");
        assert!(!error_of(&body).is_empty());
    }
    for uri in ["/healthz", "/readyz", "/v1/openapi.json"] {
        assert_eq!(
            c.send(Method::GET, uri, None, "").await.0,
            StatusCode::OK,
            "{uri}"
        );
    }
    assert_eq!(
        c.send(Method::GET, "/v1/jobs", Some(CLIENT), "").await.0,
        StatusCode::OK
    );

    // Without tokens configured (loopback), routes are open.
    let open_dir = tempfile::tempdir().unwrap();
    let open = Coordinator::open(spindle_server::Config::new(open_dir.path())).await;
    assert_eq!(
        open.send(Method::GET, "/v1/jobs", None, "").await.0,
        StatusCode::OK
    );
}

#[tokio::test]
async fn bad_input_gets_a_clear_4xx_and_leaves_existing_jobs_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.limits.max_triangles = 1000;
    cfg.limits.max_json_bytes = 64 << 10;
    let c = Coordinator::open(cfg).await;
    let existing = c
        .submit(json!({"scene": scene(16, 16), "tile_size": 8}))
        .await;
    let w = c.register("w").await;
    let lease = c.lease(w).await.unwrap();
    let before = c.job(existing.id).await;

    let with_scene = |edit: &dyn Fn(&mut Value)| {
        let mut body = json!({"scene": scene(16, 16)});
        edit(&mut body);
        body.to_string()
    };
    let huge = "x".repeat(100 << 10);
    let cases: Vec<(&str, String, StatusCode, &str)> = vec![
        (
            "malformed JSON",
            "{\"scene\": ".into(),
            StatusCode::BAD_REQUEST,
            "scene: EOF while parsing",
        ),
        (
            "not an object",
            "42".into(),
            StatusCode::BAD_REQUEST,
            "body: invalid type",
        ),
        (
            "unknown top-level field",
            with_scene(&|b| b["spp"] = json!(4)),
            StatusCode::BAD_REQUEST,
            "unknown field `spp`",
        ),
        (
            "unknown scene field",
            with_scene(&|b| b["scene"]["film"]["iso"] = json!(100)),
            StatusCode::BAD_REQUEST,
            "scene.film.iso: unknown field `iso`",
        ),
        (
            "wrong type",
            with_scene(&|b| b["scene"]["film"]["width"] = json!("wide")),
            StatusCode::BAD_REQUEST,
            "scene.film.width: invalid type",
        ),
        (
            "huge dimensions",
            with_scene(&|b| b["scene"]["film"]["width"] = json!(1_000_000)),
            StatusCode::BAD_REQUEST,
            "scene.film.width",
        ),
        (
            "a scene with time and no frame",
            with_scene(&|b| b["scene"]["animation"] = json!({"frames": {"start": 1, "end": 2}})),
            StatusCode::BAD_REQUEST,
            "frame: a scene with `animation` needs the frame the job renders",
        ),
        (
            "keys out of order",
            with_scene(&|b| {
                b["scene"]["animation"] = json!({"camera": {"fov_y": {"keys": [
                    {"frame": 2, "value": 30}, {"frame": 1, "value": 40}]}}})
            }),
            StatusCode::BAD_REQUEST,
            "scene.animation.camera.fov_y.keys[1].frame: must come after keys[0].frame (2)",
        ),
        (
            "invalid medium",
            with_scene(&|b| {
                b["scene"]["objects"][0]["material"]["medium"]["sigma_t"] = json!([1, -1, 1])
            }),
            StatusCode::BAD_REQUEST,
            "scene.objects[0].material.medium.sigma_t",
        ),
        (
            "camera beyond the scene's extent",
            with_scene(&|b| b["scene"]["camera"]["position"][0] = json!(1.7e308)),
            StatusCode::BAD_REQUEST,
            "scene.camera.position[0]: must be within ±1e6",
        ),
        (
            "scale beyond the scene's extent",
            with_scene(&|b| {
                b["scene"]["objects"][0]["transform"] = json!({"scale": [1e200, 1e200, 1e200]})
            }),
            StatusCode::BAD_REQUEST,
            "scene.objects[0].transform.scale[0]: must be between",
        ),
        (
            "an icosphere carried past the scene's extent",
            with_scene(&|b| {
                b["scene"]["objects"][0]["transform"] = json!({"translate": [999_999.5, 0, 0]})
            }),
            StatusCode::BAD_REQUEST,
            "scene.objects[0].transform: places the shape's bounding sphere (radius 1e0",
        ),
        (
            "spp beyond the one bound",
            with_scene(&|b| b["scene"]["film"]["spp"] = json!(65537)),
            StatusCode::BAD_REQUEST,
            "scene.film.spp: must be <= 65536",
        ),
        (
            "too many triangles",
            with_scene(&|b| b["scene"]["objects"][0]["shape"]["subdivisions"] = json!(3)),
            StatusCode::BAD_REQUEST,
            "more than 1000 triangles",
        ),
        (
            "tile size",
            with_scene(&|b| b["tile_size"] = json!(0)),
            StatusCode::BAD_REQUEST,
            "tile_size: must be between",
        ),
        (
            "too many tiles",
            with_scene(&|b| {
                b["scene"]["film"]["width"] = json!(4096);
                b["scene"]["film"]["height"] = json!(4096);
                b["tile_size"] = json!(4);
            }),
            StatusCode::BAD_REQUEST,
            "1048576 tiles, more than the limit of 65536",
        ),
        (
            "OBJ without its asset",
            with_scene(&|b| {
                b["scene"]["objects"][0]["shape"] = json!({"type": "obj", "path": "m.obj"})
            }),
            StatusCode::BAD_REQUEST,
            "scene.objects[0].shape.path: no asset given for \"m.obj\"",
        ),
        (
            "asset never uploaded",
            with_scene(&|b| {
                b["scene"]["objects"][0]["shape"] = json!({"type": "obj", "path": "m.obj"});
                b["assets"] = json!({"m.obj": asset_hash(b"not uploaded")});
            }),
            StatusCode::BAD_REQUEST,
            "is not uploaded",
        ),
        (
            "asset hash malformed",
            with_scene(&|b| b["assets"] = json!({"m.obj": "../../etc/passwd"})),
            StatusCode::BAD_REQUEST,
            "assets.m.obj: \"../../etc/passwd\" is not a blake3 hash",
        ),
        (
            "oversized body",
            json!({"scene": scene(16, 16), "pad": huge}).to_string(),
            StatusCode::PAYLOAD_TOO_LARGE,
            "larger than this route accepts",
        ),
    ];
    for (what, body, status, message) in cases {
        let (got, bytes) = c.send(Method::POST, "/v1/jobs", Some(CLIENT), body).await;
        let error = error_of(&bytes);
        assert_eq!(got, status, "{what}: {error}");
        assert!(
            error.contains(message),
            "{what}: {error:?} lacks {message:?}"
        );
    }

    // Other routes: bad path segment, bad hash, unknown route, wrong method, stale epoch.
    let (status, bytes) = c.send(Method::GET, "/v1/jobs/abc", Some(CLIENT), "").await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{}", error_of(&bytes));
    let (status, bytes) = c
        .send(Method::PUT, "/v1/assets/..%2F..%2Fetc", Some(CLIENT), "x")
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{}", error_of(&bytes));
    let (status, bytes) = c.send(Method::GET, "/v1/nothing", Some(CLIENT), "").await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(error_of(&bytes).contains("no route"));
    let (status, bytes) = c.send(Method::PATCH, "/v1/jobs", Some(CLIENT), "").await;
    assert_eq!(status, StatusCode::METHOD_NOT_ALLOWED);
    error_of(&bytes);
    let mut stale = upload_for(&lease, w);
    stale.epoch = 0;
    let (status, v) = c.upload(existing.id, lease.tile_index, &stale).await;
    assert_eq!(status, StatusCode::CONFLICT, "{v}");
    let (status, v) = c
        .worker(
            Method::POST,
            "/v1/workers",
            Some(json!({"name": "", "threads": 1})),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    let (status, bytes) = c
        .send(
            Method::PUT,
            &format!("/v1/jobs/{}/tiles/0", existing.id),
            Some(WORKER),
            "{]",
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{}", error_of(&bytes));

    // The existing job is as it was, and still the only one.
    let after = c.job(existing.id).await;
    assert_eq!(
        JobInfo {
            elapsed_s: 0.0,
            ..after
        },
        JobInfo {
            elapsed_s: 0.0,
            ..before
        },
        "only time moved"
    );
    let (_, list) = c.client(Method::GET, "/v1/jobs", None).await;
    assert_eq!(list["jobs"].as_array().unwrap().len(), 1);
    let (status, _) = c
        .upload(existing.id, lease.tile_index, &upload_for(&lease, w))
        .await;
    assert_eq!(status, StatusCode::OK, "the job still works");
}

#[tokio::test]
async fn the_job_count_is_limited() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.limits.max_active_jobs = 2;
    let c = Coordinator::open(cfg).await;
    let first = c.submit(json!({"scene": scene(8, 8)})).await;
    c.submit(json!({"scene": scene(8, 8)})).await;
    let (status, v) = c
        .client(
            Method::POST,
            "/v1/jobs",
            Some(json!({"scene": scene(8, 8)})),
        )
        .await;
    assert_eq!(status, StatusCode::TOO_MANY_REQUESTS, "{v}");
    assert!(v["error"].as_str().unwrap().contains("the limit is 2"));
    // A finished (here: cancelled) job no longer counts.
    c.client(Method::POST, &format!("/v1/jobs/{}/cancel", first.id), None)
        .await;
    c.submit(json!({"scene": scene(8, 8)})).await;
}

#[tokio::test]
async fn an_idempotency_key_returns_the_same_job() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let body = json!({"scene": scene(8, 8)}).to_string();
    let submit = |key: &'static str, body: String| {
        let app = c.app.clone();
        async move {
            use http_body_util::BodyExt;
            use tower::ServiceExt;
            let request = axum::http::Request::post("/v1/jobs")
                .header("authorization", format!("Bearer {CLIENT}"))
                .header("idempotency-key", key)
                .body(axum::body::Body::from(body))
                .unwrap();
            let response = app.oneshot(request).await.unwrap();
            let status = response.status();
            let bytes = response.into_body().collect().await.unwrap().to_bytes();
            (status, bytes)
        }
    };
    let (s1, b1) = submit("retry-1", body.clone()).await;
    let (s2, b2) = submit("retry-1", body.clone()).await;
    assert_eq!((s1, s2), (StatusCode::CREATED, StatusCode::OK));
    let (j1, j2): (JobInfo, JobInfo) = (
        serde_json::from_slice(&b1).unwrap(),
        serde_json::from_slice(&b2).unwrap(),
    );
    assert_eq!(j1.id, j2.id);
    // The same key with a different request is a conflict, not a silent reuse.
    let (s3, b3) = submit(
        "retry-1",
        json!({"scene": scene(8, 8), "priority": 3}).to_string(),
    )
    .await;
    assert_eq!(s3, StatusCode::CONFLICT, "{}", error_of(&b3));
    let (_, list) = c.client(Method::GET, "/v1/jobs", None).await;
    assert_eq!(list["jobs"].as_array().unwrap().len(), 1);
    // The key survives a restart.
    drop(c);
    let c = Coordinator::open(config(dir.path())).await;
    let request = axum::http::Request::post("/v1/jobs")
        .header("authorization", format!("Bearer {CLIENT}"))
        .header("idempotency-key", "retry-1")
        .body(axum::body::Body::from(body))
        .unwrap();
    let response = tower::ServiceExt::oneshot(c.app.clone(), request)
        .await
        .unwrap();
    assert_eq!(response.status(), StatusCode::OK);
}

#[tokio::test]
async fn assets_are_stored_by_verified_hash_and_obj_triangles_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = config(dir.path());
    cfg.limits.max_triangles = 20 * 16 + 2; // the sphere (s = 2) and a quad
    cfg.limits.max_asset_bytes = 4096;
    let c = Coordinator::open(cfg).await;
    let mesh = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n".to_vec();
    let hash = asset_hash(&mesh);

    let (status, v) = c
        .client(
            Method::POST,
            "/v1/assets/missing",
            Some(json!({"hashes": [hash, hash]})),
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(v["missing"], json!([hash]));

    let wrong = asset_hash(b"something else");
    let (status, bytes) = c
        .send(
            Method::PUT,
            &format!("/v1/assets/{wrong}"),
            Some(CLIENT),
            mesh.clone(),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST);
    assert!(error_of(&bytes).contains(&format!("hash to {hash}")));
    let (status, bytes) = c
        .send(
            Method::PUT,
            &format!("/v1/assets/{wrong}"),
            Some(CLIENT),
            vec![b'v'; 5000],
        )
        .await;
    assert_eq!(
        status,
        StatusCode::PAYLOAD_TOO_LARGE,
        "{}",
        error_of(&bytes)
    );
    assert_eq!(
        std::fs::read_dir(dir.path().join("assets/tmp"))
            .unwrap()
            .count(),
        0,
        "failed uploads leave nothing behind"
    );

    let (status, _) = c
        .send(
            Method::PUT,
            &format!("/v1/assets/{hash}"),
            Some(CLIENT),
            mesh.clone(),
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    let (_, v) = c
        .client(
            Method::POST,
            "/v1/assets/missing",
            Some(json!({"hashes": [hash]})),
        )
        .await;
    assert_eq!(v["missing"], json!([]));
    c.register("w").await; // assets are read by registered workers
    let (status, bytes) = c
        .send(Method::GET, &format!("/v1/assets/{hash}"), Some(WORKER), "")
        .await;
    assert_eq!((status, bytes.to_vec()), (StatusCode::OK, mesh.clone()));

    let mut s = scene(8, 8);
    s["objects"].as_array_mut().unwrap().push(json!({
        "shape": {"type": "obj", "path": "meshes/quad.obj"},
        "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
    }));
    let job = c
        .submit(json!({"scene": s, "assets": {"meshes/quad.obj": hash}}))
        .await;
    let (status, spec) = c
        .worker(Method::GET, &format!("/v1/jobs/{}/spec", job.id), None)
        .await;
    assert_eq!(status, StatusCode::OK);
    assert_eq!(spec["assets"]["meshes/quad.obj"], json!(hash));
    // One more triangle would exceed the limit: the OBJ's faces are counted.
    let bigger = [mesh.as_slice(), b"f 1 2 3\n"].concat();
    let (status, v) = submit_with_mesh(&c, &s, bigger).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(v["error"].as_str().unwrap().contains("triangles"), "{v}");
    // A mesh no worker could build (a face naming a vertex the file lacks) is refused at
    // submission, naming the asset and the line, not at the first lease.
    let broken = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 9\n".to_vec();
    let (status, v) = submit_with_mesh(&c, &s, broken).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert_eq!(
        v["error"],
        "assets.meshes/quad.obj: line 5: a face names vertex 9, but the file has 4 vertices",
        "{v}"
    );
}

/// Uploads `mesh` (the upload must succeed) and submits `scene` with it as `meshes/quad.obj`.
async fn submit_with_mesh(c: &Coordinator, scene: &Value, mesh: Vec<u8>) -> (StatusCode, Value) {
    let hash = asset_hash(&mesh);
    let (status, _) = c
        .send(
            Method::PUT,
            &format!("/v1/assets/{hash}"),
            Some(CLIENT),
            mesh,
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    c.client(
        Method::POST,
        "/v1/jobs",
        Some(json!({"scene": scene, "assets": {"meshes/quad.obj": hash}})),
    )
    .await
}

/// The routes `docs/api.md` lists, as (path, method, token).
fn routes_in_api_md() -> BTreeSet<(String, String, String)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/api.md");
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .filter_map(|line| {
            let cells: Vec<&str> = line.split('|').map(str::trim).collect();
            let method = *cells.get(1)?;
            let path = cells.get(2)?.strip_prefix('`')?.strip_suffix('`')?;
            ["GET", "PUT", "POST", "DELETE", "PATCH"]
                .contains(&method)
                .then(|| (path.to_string(), method.to_string(), cells[3].to_string()))
        })
        .collect()
}

#[tokio::test]
async fn the_openapi_document_lists_exactly_the_routes_served() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let (status, doc) = c.client(Method::GET, "/v1/openapi.json", None).await;
    assert_eq!(status, StatusCode::OK);
    let methods = ["GET", "PUT", "POST", "DELETE", "PATCH"];
    // (path, method, token) as documented: the token is the operation's security scheme.
    let documented: BTreeSet<(String, String, String)> = doc["paths"]
        .as_object()
        .unwrap()
        .iter()
        .flat_map(|(path, item)| {
            item.as_object()
                .unwrap()
                .iter()
                .filter(|(k, _)| methods.contains(&k.to_uppercase().as_str()))
                .map(move |(m, op)| {
                    let token = match op["security"][0].as_object() {
                        None => "none".to_string(),
                        Some(s) => s
                            .keys()
                            .find_map(|k| k.strip_suffix("_token"))
                            .unwrap()
                            .into(),
                    };
                    (path.clone(), m.to_uppercase(), token)
                })
        })
        .collect();
    assert_eq!(documented, routes_in_api_md());
    assert_eq!(documented.len(), 29);
    for (path, method, token) in &documented {
        let uri = path
            .replace("{hash}", &asset_hash(b""))
            .replace("{id}", "1")
            .replace("{job}", "1")
            .replace("{tile}", "0");
        let (right, wrong) = match token.as_str() {
            "client" => (Some(CLIENT), Some(WORKER)),
            "worker" => (Some(WORKER), Some(CLIENT)),
            _ => (None, None),
        };
        // Every documented route is reached by its method (not the 404/405 fallbacks) ...
        if path == "/v1/events" {
            // An event stream does not end: its status is all there is to read.
            let mut request = axum::http::Request::builder().uri(&uri);
            if let Some(token) = right {
                request = request.header("authorization", format!("Bearer {token}"));
            }
            let response = tower::ServiceExt::oneshot(
                c.app.clone(),
                request.body(axum::body::Body::empty()).unwrap(),
            )
            .await
            .unwrap();
            assert_eq!(response.status(), StatusCode::OK, "{path}");
        }
        let (status, bytes) = if path == "/v1/events" {
            (StatusCode::OK, Default::default())
        } else {
            c.send(method.parse().unwrap(), &uri, right, "{}").await
        };
        assert_ne!(status, StatusCode::METHOD_NOT_ALLOWED, "{method} {path}");
        if status == StatusCode::NOT_FOUND {
            assert!(!error_of(&bytes).contains("no route"), "{method} {path}");
        }
        // ... behind the token the document names.
        if right.is_some() {
            for token in [None, wrong] {
                let (status, _) = c.send(method.parse().unwrap(), &uri, token, "{}").await;
                assert_eq!(
                    status,
                    StatusCode::UNAUTHORIZED,
                    "{method} {path} {token:?}"
                );
            }
        }
        // Routes enter the router only through `utoipa_axum::routes!`, which documents them;
        // so a documented path answers its undocumented methods with 405.
        for other in methods {
            if !documented.iter().any(|(p, m, _)| p == path && m == other) {
                let (status, _) = c.send(other.parse().unwrap(), &uri, right, "{}").await;
                assert_eq!(status, StatusCode::METHOD_NOT_ALLOWED, "{other} {path}");
            }
        }
    }
    assert!(doc["components"]["schemas"]["TileUpload"].is_object());
    assert!(doc["components"]["securitySchemes"]["worker_token"].is_object());
}

#[tokio::test]
async fn an_obj_face_of_too_many_corners_is_refused_at_submission() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let mut s = scene(8, 8);
    s["objects"].as_array_mut().unwrap().push(json!({
        "shape": {"type": "obj", "path": "meshes/fan.obj"},
        "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
    }));
    // One face of 10,002 corners (about 10 s of scene build on every worker): refused at
    // submission, naming the asset and the line, though its 10,000 triangles are far within
    // the triangle limit.
    let fan = format!("v 0 0 0\nv 1 0 0\nv 1 1 0\nf{}\n", " 1 2 3".repeat(3334));
    let fan_hash = asset_hash(fan.as_bytes());
    let (status, _) = c
        .send(
            Method::PUT,
            &format!("/v1/assets/{fan_hash}"),
            Some(CLIENT),
            fan.into_bytes(),
        )
        .await;
    assert_eq!(status, StatusCode::OK);
    let (status, v) = c
        .client(
            Method::POST,
            "/v1/jobs",
            Some(json!({"scene": s, "assets": {"meshes/fan.obj": fan_hash}})),
        )
        .await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert_eq!(
        v["error"],
        "assets.meshes/fan.obj: line 4: a face of 10002 corners; at most 64 (split it into \
         smaller faces)",
        "{v}"
    );
}

/// A mesh whose own coordinates are in the scene's extent, carried past it by its object's
/// transform, is refused at submission naming the object's transform, the file and the line
/// (a worker's build would refuse it at the first lease); the same mesh placed within the
/// extent, by the quick test or vertex by vertex, is admitted.
#[tokio::test]
async fn an_obj_its_transform_carries_past_the_extent_is_refused_at_submission() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let mesh = b"v 0 0 0\nv 2e5 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\n".to_vec();
    let with = |transform: Value| {
        let mut s = scene(8, 8);
        s["objects"].as_array_mut().unwrap().push(json!({
            "shape": {"type": "obj", "path": "meshes/quad.obj"},
            "transform": transform,
            "material": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]}
        }));
        s
    };
    // Vertex 2 scaled 6× is at x = 1.2e6.
    let (status, v) = submit_with_mesh(&c, &with(json!({"scale": [6, 1, 1]})), mesh.clone()).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    let error = v["error"].as_str().unwrap();
    assert!(
        error.starts_with(
            "scene.objects[1].transform: meshes/quad.obj: line 2: places a vertex at \
             [1200000.0, 0.0, 0.0], outside the scene's extent of ±1e6"
        ),
        "{v}"
    );
    // 4.5× is at 9e5: past what the radius test settles (4.5 · 2e5 + 2e5 of shift), inside
    // vertex by vertex; 2× needs no scan.
    let shifted = json!({"scale": [4.5, 1, 1], "translate": [0, 2e5, 0]});
    for transform in [shifted, json!({"scale": [2, 1, 1]})] {
        let (status, v) = submit_with_mesh(&c, &with(transform), mesh.clone()).await;
        assert_eq!(status, StatusCode::CREATED, "{v}");
    }
}

/// A cancelled job's finished tiles come back as a partial EXR: the finished tile's pixels in
/// place, the missing tile transparent black (alpha 0), `spindle.tiles_done` = `1 of 2`. A job
/// still running has no image yet (409, saying when it will).
#[tokio::test]
async fn a_cancelled_jobs_finished_tiles_are_a_partial_exr() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(16, 8), "tile_size": 8}))
        .await; // 2 tiles, side by side
    let w = c.register("w").await;
    let first = c.lease(w).await.unwrap();
    c.upload(job.id, first.tile_index, &upload_for(&first, w))
        .await;
    let second = c.lease(w).await.unwrap();
    let uri = format!("/v1/jobs/{}/image.exr", job.id);
    let (status, body) = c
        .send(Method::GET, &uri, Some(CLIENT), axum::body::Body::empty())
        .await;
    assert_eq!(status, StatusCode::CONFLICT);
    assert!(
        error_of(&body).contains("once it is cancelled"),
        "{}",
        error_of(&body)
    );

    let (status, v) = c
        .client(Method::POST, &format!("/v1/jobs/{}/cancel", job.id), None)
        .await;
    assert_eq!(status, StatusCode::OK, "{v}");
    let (status, body) = c
        .send(Method::GET, &uri, Some(CLIENT), axum::body::Body::empty())
        .await;
    assert_eq!(status, StatusCode::OK, "{}", String::from_utf8_lossy(&body));
    let image = spindle_common::image::Image::from_exr_bytes(&body).unwrap();
    assert_eq!((image.width, image.height), (16, 8));
    assert_eq!(
        image
            .attributes
            .get("spindle.tiles_done")
            .map(String::as_str),
        Some("1 of 2")
    );
    for y in 0..8 {
        for x in 0..16 {
            let p = (y * 16 + x) as usize;
            let (alpha, red) = (image.alpha[p], image.total[3 * p]);
            if first.rect.x <= x && x < first.rect.x + first.rect.width {
                let expected = (
                    tile_colour(first.tile_index, 5, 0),
                    tile_colour(first.tile_index, 0, 0),
                );
                assert_eq!((alpha, red), expected, "({x}, {y}) of the finished tile");
            } else {
                assert!(second.rect.x <= x && x < second.rect.x + second.rect.width);
                assert_eq!((alpha, red), (0.0, 0.0), "({x}, {y}) of the missing tile");
            }
        }
    }
}
