//! `GET /v1/events`: the live event stream (Server-Sent Events) of [`crate::events`].

use std::convert::Infallible;
use std::net::SocketAddr;
use std::sync::Arc;

use axum::extract::{ConnectInfo, Request, State};
use axum::response::sse::{Event, KeepAlive, Sse};
use futures_util::stream::{self, Stream, StreamExt};
use spindle_common::protocol::{ApiError, FarmEvent, SseFarmEvent};
use utoipa_axum::routes;

use super::Declared;
use crate::AppState;
use crate::auth::Role;
use crate::error::Error;
use crate::events::{EVENT_SEND_BUFFER, EVENT_SEND_WAIT};
use crate::send_bound::{SendBound, Tightened};

pub(super) fn routes() -> Declared {
    vec![(Role::Client, routes!(events))]
}

/// Follows the farm: job state changes, finished tiles, workers joining, draining and lost, as
/// Server-Sent Events (`id:` the event id, `event:` its type, `data:` a `FarmEvent`). With
/// `Last-Event-ID`, the events after it come first (or a `reset` when they are no longer
/// kept, or when the id is past the newest: a coordinator counts from 1 again at every start).
/// A client too slow to keep up is disconnected (more than 256 events behind, or a write
/// waiting 2 s for it to read); it reconnects with its last id.
#[utoipa::path(get, path = "/v1/events",
    params(("Last-Event-ID" = Option<i64>, Header, nullable = false, minimum = 0, description = "the last event id received")),
    responses((status = 200, content_type = "text/event-stream", body = SseFarmEvent),
              (status = 400, body = ApiError), (status = 429, body = ApiError),
              (status = 503, body = ApiError)))]
async fn events(
    State(state): State<AppState>,
    request: Request,
) -> Result<Sse<impl Stream<Item = Result<Event, Infallible>>>, Error> {
    let peer = request
        .extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map(|c| c.0.ip());
    let last_id = match request.headers().get("last-event-id") {
        None => None,
        Some(v) => Some(
            v.to_str()
                .ok()
                .and_then(|s| s.trim().parse::<u64>().ok())
                .filter(|&id| id <= i64::MAX as u64)
                .ok_or_else(|| {
                    Error::BadRequest("Last-Event-ID: must be an event id (a number)".into())
                })?,
        ),
    };
    let sub = state.events().subscribe(last_id, peer)?;
    // A reader that stops is cut seconds after its buffers fill, freeing its place.
    if let Some(bound) = request.extensions().get::<SendBound>() {
        bound.tighten(Tightened {
            write_wait: EVENT_SEND_WAIT,
            send_buffer: EVENT_SEND_BUFFER,
        });
    }
    let backlog = stream::iter(sub.backlog);
    // Ends at the first error: the subscriber lagged (dropped) or the log is gone.
    let live = stream::unfold((sub.live, sub.slot), |(mut rx, slot)| async move {
        rx.recv().await.ok().map(|event| (event, (rx, slot)))
    });
    let stop = state.shutdown_token();
    let stream = backlog
        .chain(live)
        .map(|event| Ok(sse_event(&event)))
        .take_until(async move { stop.cancelled().await });
    Ok(Sse::new(stream).keep_alive(KeepAlive::default()))
}

fn sse_event(event: &Arc<FarmEvent>) -> Event {
    let data = serde_json::to_string(&**event).unwrap_or_else(|_| "{}".to_string());
    Event::default()
        .id(event.id.to_string())
        .event(event.kind.name())
        .data(data)
}

#[cfg(test)]
mod tests;
