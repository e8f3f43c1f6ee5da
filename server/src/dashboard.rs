//! The web dashboard: a page to watch and steer the farm, served on its own listener
//! (`--dashboard-listen`) together with the whole `/v1` API, so the page's calls are
//! same-origin.
//!
//! The page is plain HTML, CSS and ES modules from `server/dashboard/`, embedded in the binary
//! (no build step, nothing fetched from elsewhere). It holds no secret: every data call carries
//! the client token the user typed, exactly as the CLI's do, so the dashboard listener grants
//! nothing the API listener does not. `/docs` renders `/v1/openapi.json` in the browser.
//! Every page answer carries a Content-Security-Policy that allows only this origin's scripts
//! (none inline), forbids framing, and `X-Content-Type-Options: nosniff`.

use axum::Router;
use axum::http::{HeaderName, HeaderValue, header};
use axum::response::IntoResponse;
use axum::routing::get;
use tower_http::set_header::SetResponseHeaderLayer;

/// The policy of every page and script: own-origin scripts, styles, calls and images (blob:
/// for the fetched previews and downloads), no framing, no plugins.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'none'; script-src 'self'; \
    style-src 'self'; img-src 'self' blob: data:; connect-src 'self'; \
    frame-ancestors 'none'; base-uri 'none'; form-action 'none'";

/// One embedded file: its path under the listener, content type and bytes.
struct Asset {
    path: &'static str,
    content_type: &'static str,
    body: &'static str,
}

const HTML: &str = "text/html; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";
const CSS: &str = "text/css; charset=utf-8";

const ASSETS: &[Asset] = &[
    Asset {
        path: "/",
        content_type: HTML,
        body: include_str!("../dashboard/index.html"),
    },
    Asset {
        path: "/docs",
        content_type: HTML,
        body: include_str!("../dashboard/docs.html"),
    },
    Asset {
        path: "/dashboard/app.js",
        content_type: JS,
        body: include_str!("../dashboard/app.js"),
    },
    Asset {
        path: "/dashboard/sse.js",
        content_type: JS,
        body: include_str!("../dashboard/sse.js"),
    },
    Asset {
        path: "/dashboard/blake3.js",
        content_type: JS,
        body: include_str!("../dashboard/blake3.js"),
    },
    Asset {
        path: "/dashboard/vendor/noble-hashes/_blake.js",
        content_type: JS,
        body: include_str!("../dashboard/vendor/noble-hashes/_blake.js"),
    },
    Asset {
        path: "/dashboard/vendor/noble-hashes/_md.js",
        content_type: JS,
        body: include_str!("../dashboard/vendor/noble-hashes/_md.js"),
    },
    Asset {
        path: "/dashboard/vendor/noble-hashes/_u64.js",
        content_type: JS,
        body: include_str!("../dashboard/vendor/noble-hashes/_u64.js"),
    },
    Asset {
        path: "/dashboard/vendor/noble-hashes/blake2.js",
        content_type: JS,
        body: include_str!("../dashboard/vendor/noble-hashes/blake2.js"),
    },
    Asset {
        path: "/dashboard/vendor/noble-hashes/blake3.js",
        content_type: JS,
        body: include_str!("../dashboard/vendor/noble-hashes/blake3.js"),
    },
    Asset {
        path: "/dashboard/vendor/noble-hashes/utils.js",
        content_type: JS,
        body: include_str!("../dashboard/vendor/noble-hashes/utils.js"),
    },
    Asset {
        path: "/dashboard/docs.js",
        content_type: JS,
        body: include_str!("../dashboard/docs.js"),
    },
    Asset {
        path: "/dashboard/style.css",
        content_type: CSS,
        body: include_str!("../dashboard/style.css"),
    },
];

/// The dashboard listener's router: the embedded pages, with security headers, in front of
/// `api` (the coordinator's router, [`crate::app`]), which answers everything else.
pub fn router(api: Router) -> Router {
    let mut pages = Router::new();
    for asset in ASSETS {
        let (content_type, body) = (asset.content_type, asset.body);
        pages = pages.route(
            asset.path,
            get(move || async move {
                (
                    [
                        (header::CONTENT_TYPE, content_type),
                        (header::CACHE_CONTROL, "no-cache"),
                    ],
                    body,
                )
                    .into_response()
            }),
        );
    }
    let pages = pages
        .layer(SetResponseHeaderLayer::overriding(
            header::CONTENT_SECURITY_POLICY,
            HeaderValue::from_static(CONTENT_SECURITY_POLICY),
        ))
        .layer(SetResponseHeaderLayer::overriding(
            header::X_CONTENT_TYPE_OPTIONS,
            HeaderValue::from_static("nosniff"),
        ))
        .layer(SetResponseHeaderLayer::overriding(
            header::X_FRAME_OPTIONS,
            HeaderValue::from_static("DENY"),
        ))
        .layer(SetResponseHeaderLayer::overriding(
            HeaderName::from_static("referrer-policy"),
            HeaderValue::from_static("no-referrer"),
        ));
    pages.merge(api)
}
