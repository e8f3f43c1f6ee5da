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

/// Reads `body` whole, refusing it with 413 once it passes `limit` bytes (without reading
/// further): for a route whose limit depends on what the path names ([`crate::api`]'s tile
/// upload), decided before any of the body is read.
pub async fn read_body(body: axum::body::Body, limit: usize) -> Result<Bytes, Error> {
    axum::body::to_bytes(body, limit).await.map_err(|e| {
        let mut source: Option<&(dyn std::error::Error + 'static)> = Some(&e);
        while let Some(s) = source {
            if s.is::<http_body_util::LengthLimitError>() {
                return Error::TooLarge(format!("body: larger than {limit} bytes"));
            }
            if s.is::<tower_http::timeout::TimeoutError>() {
                return Error::Timeout("body: not received in time".into());
            }
            source = s.source();
        }
        Error::BadRequest(format!("body: {e}"))
    })
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
///
/// A number written with a fraction or exponent that is a whole number (`679.0`, `1e3`) is
/// accepted where an integer is expected, as JSON Schema's `integer` accepts it: when the
/// direct parse fails, the body is read again with such numbers made integers, and the first
/// parse's error stands if that fails too (so the extra work is only done for bodies that
/// would be refused otherwise).
pub fn parse_json<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, Error> {
    let direct = parse_json_exact(bytes);
    if direct.is_ok() {
        return direct;
    }
    let Ok(mut value) = serde_json::from_slice::<serde_json::Value>(bytes) else {
        return direct;
    };
    if !integral_floats_to_integers(&mut value) {
        return direct;
    }
    serde_path_to_error::deserialize(value).or(direct)
}

fn parse_json_exact<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, Error> {
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

/// Replaces every float that is exactly a whole number in the range of `i64` or `u64` (but not
/// `-0.0`, whose sign a float field keeps) by that integer; says whether any was replaced. An
/// `f64` field reads the integer back as the same value.
fn integral_floats_to_integers(value: &mut serde_json::Value) -> bool {
    use serde_json::Value;
    match value {
        Value::Number(n) if n.is_f64() => {
            let f = n.as_f64().unwrap_or(f64::NAN);
            let whole = f.fract() == 0.0 && !(f == 0.0 && f.is_sign_negative());
            // 2^63 and 2^64: the first floats beyond i64 and u64.
            let integer = if !whole {
                None
            } else if (-9.223_372_036_854_776e18..9.223_372_036_854_776e18).contains(&f) {
                Some(serde_json::Number::from(f as i64))
            } else if (0.0..1.844_674_407_370_955_2e19).contains(&f) {
                Some(serde_json::Number::from(f as u64))
            } else {
                None
            };
            match integer {
                Some(i) => {
                    *n = i;
                    true
                }
                None => false,
            }
        }
        Value::Array(items) => items
            .iter_mut()
            .fold(false, |any, v| integral_floats_to_integers(v) | any),
        Value::Object(fields) => fields
            .values_mut()
            .fold(false, |any, v| integral_floats_to_integers(v) | any),
        _ => false,
    }
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

    #[test]
    fn whole_numbers_written_as_floats_are_integers() {
        // JSON Schema's `integer` accepts 679.0 and 1e3; so does the coordinator.
        let hb = parse_json::<Heartbeat>(br#"{"worker_id":679.0,"epoch":1e3}"#).unwrap();
        assert_eq!((hb.worker_id, hb.epoch), (679, 1000));
        let big = parse_json::<Heartbeat>(br#"{"worker_id":1e19,"epoch":0}"#);
        assert_eq!(big.unwrap().worker_id, 10_000_000_000_000_000_000);
        // Not whole, negative for a u64, beyond u64: the first parse's error stands.
        let m = message(parse_json(br#"{"worker_id":679.5,"epoch":1}"#));
        assert!(
            m.starts_with("worker_id: invalid type: floating point `679.5`"),
            "{m}"
        );
        let m = message(parse_json(br#"{"worker_id":-1.0,"epoch":1}"#));
        assert!(m.starts_with("worker_id: invalid"), "{m}");
        let m = message(parse_json(br#"{"worker_id":1e20,"epoch":1}"#));
        assert!(
            m.starts_with("worker_id: invalid type: floating point"),
            "{m}"
        );
        // Beside an integer read again, a float field keeps its value, and -0.0 its sign.
        let (n, floats): (u64, [f64; 4]) = parse_json(b"[5.0, [3.0, -0.0, 2.5, 1e300]]").unwrap();
        assert_eq!(n, 5);
        assert_eq!(
            floats.map(f64::to_bits),
            [3.0f64, -0.0, 2.5, 1e300].map(f64::to_bits)
        );
    }
}
