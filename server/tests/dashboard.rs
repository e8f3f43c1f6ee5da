//! The dashboard listener's router: the embedded pages with their security headers, the same
//! API behind the same tokens, and the tile map route the page draws from.

mod support;

use axum::body::Body;
use axum::http::{Method, Request, StatusCode, header};
use http_body_util::BodyExt;
use serde_json::json;
use spindle_common::protocol::JobState;
use spindle_server::dashboard;
use support::{CLIENT, Coordinator, config, scene, test_provenance, upload_for};
use tower::ServiceExt;

async fn get(
    router: &axum::Router,
    uri: &str,
    token: Option<&str>,
) -> (StatusCode, axum::http::HeaderMap, String) {
    let mut request = Request::builder().uri(uri);
    if let Some(token) = token {
        request = request.header("authorization", format!("Bearer {token}"));
    }
    let response = router
        .clone()
        .oneshot(request.body(Body::empty()).unwrap())
        .await
        .unwrap();
    let (parts, body) = response.into_parts();
    let body = body.collect().await.unwrap().to_bytes();
    (
        parts.status,
        parts.headers,
        String::from_utf8_lossy(&body).into(),
    )
}

#[tokio::test]
async fn pages_are_served_with_security_headers_in_front_of_the_same_api() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let router = dashboard::router(c.app.clone());
    for (uri, content_type, contains) in [
        ("/", "text/html", "/dashboard/app.js"),
        ("/docs", "text/html", "/dashboard/docs.js"),
        ("/dashboard/app.js", "text/javascript", "/v1/events"),
        (
            "/dashboard/sse.js",
            "text/javascript",
            "export async function readEvents",
        ),
        (
            "/dashboard/blake3.js",
            "text/javascript",
            "export function blake3Hex",
        ),
        (
            "/dashboard/vendor/noble-hashes/blake3.js",
            "text/javascript",
            "export const blake3",
        ),
        ("/dashboard/docs.js", "text/javascript", "/v1/openapi.json"),
        ("/dashboard/style.css", "text/css", "@media"),
    ] {
        let (status, headers, body) = get(&router, uri, None).await;
        assert_eq!(status, StatusCode::OK, "{uri}");
        assert!(
            headers[header::CONTENT_TYPE]
                .to_str()
                .unwrap()
                .starts_with(content_type),
            "{uri}: {headers:?}"
        );
        assert!(body.contains(contains), "{uri} lacks {contains:?}");
        let csp = headers[header::CONTENT_SECURITY_POLICY].to_str().unwrap();
        assert!(csp.contains("script-src 'self'"), "{uri}: {csp}");
        assert!(!csp.contains("unsafe-inline"), "{uri}: {csp}");
        assert!(csp.contains("frame-ancestors 'none'"), "{uri}: {csp}");
        assert_eq!(headers[header::X_CONTENT_TYPE_OPTIONS], "nosniff", "{uri}");
    }
    // No inline script in the pages: every <script> has a src.
    for uri in ["/", "/docs"] {
        let (_, _, html) = get(&router, uri, None).await;
        for tag in html.split("<script").skip(1) {
            assert!(
                tag.trim_start().starts_with("type=\"module\" src="),
                "{uri}: {tag}"
            );
        }
    }
    // The API behind it, with its tokens and its JSON 404s.
    let (status, _, body) = get(&router, "/v1/jobs", None).await;
    assert_eq!(status, StatusCode::UNAUTHORIZED, "{body}");
    let (status, _, body) = get(&router, "/v1/jobs", Some(CLIENT)).await;
    assert_eq!(status, StatusCode::OK, "{body}");
    let (status, _, body) = get(&router, "/v1/openapi.json", None).await;
    assert_eq!(status, StatusCode::OK);
    assert!(body.contains("/v1/jobs/{id}/tiles"));
    let (status, _, body) = get(&router, "/nothing", None).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
    assert!(body.contains("no route for GET /nothing"), "{body}");
    // The API listener itself serves no page.
    let (status, _, _) = get(&c.app, "/", None).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn the_tile_map_shows_queued_leased_failed_and_done_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let c = Coordinator::open(config(dir.path())).await;
    let job = c
        .submit(json!({"scene": scene(64, 32), "tile_size": 32}))
        .await;
    let uri = format!("/v1/jobs/{}/tiles", job.id);
    let (status, map) = c.client(Method::GET, &uri, None).await;
    assert_eq!(status, StatusCode::OK, "{map}");
    let tiles = map["tiles"].as_array().unwrap();
    assert_eq!(tiles.len(), 2);
    assert!(tiles.iter().all(|t| t["state"] == "queued"), "{map}");
    let mut rects: Vec<(u64, u64)> = tiles
        .iter()
        .map(|t| {
            (
                t["rect"]["x"].as_u64().unwrap(),
                t["rect"]["width"].as_u64().unwrap(),
            )
        })
        .collect();
    rects.sort();
    assert_eq!(rects, [(0, 32), (32, 32)]);

    let alice = c.register("alice").await;
    let bob = c.register("bob").await;
    let first = c.lease(alice).await.unwrap();
    let second = c.lease(bob).await.unwrap();
    let (_, map) = c.client(Method::GET, &uri, None).await;
    let tile = |map: &serde_json::Value, i: u32| map["tiles"][i as usize].clone();
    assert_eq!(tile(&map, first.tile_index)["state"], "leased", "{map}");
    assert_eq!(tile(&map, first.tile_index)["worker"], "alice", "{map}");
    assert_eq!(tile(&map, second.tile_index)["worker"], "bob", "{map}");

    // A hostile worker's report is refused, naming the field, and stores nothing.
    let mut hostile = upload_for(&first, alice);
    hostile.provenance.as_mut().unwrap().plan = vec!["x".repeat(100_000)];
    let (status, v) = c.upload(job.id, first.tile_index, &hostile).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(
        v["error"].as_str().unwrap().contains("provenance.plan[0]"),
        "{v}"
    );
    let mut hostile = upload_for(&first, alice);
    hostile.render_seconds = Some(-1.0);
    let (status, v) = c.upload(job.id, first.tile_index, &hostile).await;
    assert_eq!(status, StatusCode::BAD_REQUEST, "{v}");
    assert!(
        v["error"].as_str().unwrap().starts_with("render_seconds"),
        "{v}"
    );
    assert_eq!(c.job(job.id).await.provenance, None);

    let (status, ack) = c
        .upload(job.id, first.tile_index, &upload_for(&first, alice))
        .await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(c.job(job.id).await.provenance, Some(test_provenance()));
    let (status, v) = c
        .worker(
            Method::POST,
            &format!("/v1/leases/{}/{}/fail", job.id, second.tile_index),
            Some(json!({"worker_id": bob, "epoch": second.epoch, "reason": "out of memory"})),
        )
        .await;
    assert_eq!(status, StatusCode::NO_CONTENT, "{v}");
    let (_, map) = c.client(Method::GET, &uri, None).await;
    assert_eq!(tile(&map, first.tile_index)["state"], "done", "{map}");
    assert_eq!(tile(&map, first.tile_index)["render_seconds"], 0.5, "{map}");
    assert_eq!(tile(&map, second.tile_index)["state"], "failed", "{map}");
    assert_eq!(tile(&map, second.tile_index)["failures"], 1, "{map}");
    assert!(
        tile(&map, second.tile_index)["render_seconds"].is_null(),
        "{map}"
    );

    // Done: the job keeps no tiles in memory and no tile rows, but the map still says who
    // rendered each tile and how long it took, and the EXR header carries the provenance.
    let carol = c.register("carol").await; // bob failed it: he is not leased it again
    let again = c.lease(carol).await.unwrap();
    let mut last = upload_for(&again, carol);
    last.render_seconds = Some(2.25);
    let (status, ack) = c.upload(job.id, again.tile_index, &last).await;
    assert_eq!(status, StatusCode::OK, "{ack}");
    assert_eq!(c.wait_finished(job.id).await.state, JobState::Done);
    let (_, map) = c.client(Method::GET, &uri, None).await;
    assert_eq!(tile(&map, first.tile_index)["worker"], "alice", "{map}");
    assert_eq!(tile(&map, first.tile_index)["render_seconds"], 0.5, "{map}");
    assert_eq!(tile(&map, again.tile_index)["worker"], "carol", "{map}");
    assert_eq!(
        tile(&map, again.tile_index)["render_seconds"],
        2.25,
        "{map}"
    );
    let image =
        spindle_common::image::read_exr(dir.path().join(format!("jobs/{}/image.exr", job.id)))
            .unwrap();
    for (name, value) in test_provenance().header_attributes() {
        assert_eq!(image.attributes.get(&name), Some(&value), "{name}");
    }

    let (status, _) = c.client(Method::GET, "/v1/jobs/999/tiles", None).await;
    assert_eq!(status, StatusCode::NOT_FOUND);
}
