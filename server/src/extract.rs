//! Request extractors whose failures are the API's JSON errors.
//!
//! axum's own extractors answer bad input with plain-text bodies; these wrap them so every
//! rejection is an [`Error`] naming the problem: JSON bodies report the path of the bad field
//! (`scene.film.width: invalid type: string "x", expected u32`), an oversized body is a 413,
//! and a malformed path segment is a 400.

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{FromRequest, FromRequestParts, Path, Request};
use axum::http::StatusCode;
use axum::http::request::Parts;
use serde::de::DeserializeOwned;

use crate::error::Error;

/// The raw body, within the route's size limit.
pub struct RawBody(pub Bytes);

impl<S: Send + Sync> FromRequest<S> for RawBody {
    type Rejection = Error;

    async fn from_request(req: Request, state: &S) -> Result<Self, Error> {
        Bytes::from_request(req, state)
            .await
            .map(RawBody)
            .map_err(bytes_rejection)
    }
}

fn bytes_rejection(e: BytesRejection) -> Error {
    if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
        return Error::TooLarge("body: larger than this route accepts".into());
    }
    let mut source: Option<&(dyn std::error::Error + 'static)> = Some(&e);
    while let Some(s) = source {
        if s.is::<tower_http::timeout::TimeoutError>() {
            return Error::Timeout("body: not received in time".into());
        }
        source = s.source();
    }
    Error::BadRequest(format!("body: {}", e.body_text()))
}

/// A JSON body of type `T`.
pub struct JsonBody<T>(pub T);

impl<S: Send + Sync, T: DeserializeOwned> FromRequest<S> for JsonBody<T> {
    type Rejection = Error;

    async fn from_request(req: Request, state: &S) -> Result<Self, Error> {
        let RawBody(bytes) = RawBody::from_request(req, state).await?;
        parse_json(&bytes).map(JsonBody)
    }
}

/// Parses JSON, naming the path of the first bad value; trailing text is an error.
pub fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, Error> {
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        // `.` is the whole document; `?` a position serde could not name (a syntax error).
        if path == "." || path == "?" {
            Error::BadRequest(format!("body: {inner}"))
        } else {
            Error::BadRequest(format!("{path}: {inner}"))
        }
    })?;
    de.end()
        .map_err(|e| Error::BadRequest(format!("body: {e}")))?;
    Ok(value)
}

/// Path parameters of type `T`.
pub struct ApiPath<T>(pub T);

impl<S: Send + Sync, T: DeserializeOwned + Send> FromRequestParts<S> for ApiPath<T> {
    type Rejection = Error;

    async fn from_request_parts(parts: &mut Parts, state: &S) -> Result<Self, Error> {
        Path::<T>::from_request_parts(parts, state)
            .await
            .map(|Path(t)| ApiPath(t))
            .map_err(|e| Error::BadRequest(format!("path: {}", e.body_text())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spindle_common::protocol::Heartbeat;

    fn message(r: Result<Heartbeat, Error>) -> String {
        r.unwrap_err().to_string()
    }

    #[test]
    fn json_errors_name_the_field() {
        assert_eq!(
            parse_json::<Heartbeat>(br#"{"worker_id":1,"epoch":2}"#).unwrap(),
            Heartbeat {
                worker_id: 1,
                epoch: 2
            }
        );
        let m = message(parse_json(br#"{"worker_id":1,"epoch":"x"}"#));
        assert!(m.starts_with("epoch: invalid type"), "{m}");
        let m = message(parse_json(br#"{"worker_id":1,"epoch":2,"extra":0}"#));
        assert!(m.contains("unknown field `extra`"), "{m}");
        let m = message(parse_json(br#"{"worker_id":1,"epoch":2} trailing"#));
        assert!(m.starts_with("body: trailing characters"), "{m}");
        let m = message(parse_json(b"{not json"));
        assert!(m.starts_with("body: key must be a string"), "{m}");
    }
}
