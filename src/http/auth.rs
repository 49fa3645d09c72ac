//! Optional bearer API keys. With keys configured every `/v1` request needs
//! `Authorization: Bearer <key>`; the job's owner is a hash of the key, so jobs of one key are
//! invisible (404) to another. Keys are compared in constant time: every configured key is
//! compared (SHA-256 digests, `subtle::ConstantTimeEq`) and the results combined without an
//! early exit, so timing says nothing about which bytes or which key matched.
use axum::extract::{Request, State};
use axum::http::header;
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};
use subtle::{ConditionallySelectable, ConstantTimeEq};

use super::error::ApiError;
use super::AppState;

/// Who is calling: the owner id of their key, `None` when the service has no keys.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Owner(pub Option<String>);

/// The configured keys, as digests.
#[derive(Debug, Clone, Default)]
pub(crate) struct Keys {
    digests: Vec<[u8; 32]>,
}

fn digest(key: &str) -> [u8; 32] {
    Sha256::digest(key.as_bytes()).into()
}

/// The owner id of a key: the first 16 bytes of its SHA-256, hex (the key itself is never
/// stored).
fn owner_of(d: &[u8; 32]) -> String {
    d[..16].iter().map(|b| format!("{b:02x}")).collect()
}

impl Keys {
    pub(crate) fn new(keys: &[String]) -> Keys {
        Keys {
            digests: keys
                .iter()
                .map(|k| k.trim())
                .filter(|k| !k.is_empty())
                .map(digest)
                .collect(),
        }
    }

    pub(crate) fn enabled(&self) -> bool {
        !self.digests.is_empty()
    }

    /// The owner of `presented` if it is one of the keys (constant time over all keys).
    pub(crate) fn check(&self, presented: &str) -> Option<String> {
        let d = digest(presented);
        let mut found = subtle::Choice::from(0);
        let mut index = 0u32;
        for (i, k) in self.digests.iter().enumerate() {
            let eq = k.ct_eq(&d);
            index = u32::conditional_select(&index, &(i as u32), eq);
            found |= eq;
        }
        bool::from(found).then(|| owner_of(&self.digests[index as usize]))
    }
}

/// Middleware: checks the bearer key and puts the [`Owner`] in the request extensions.
pub(crate) async fn require_key(
    State(state): State<AppState>,
    mut req: Request,
    next: Next,
) -> Response {
    let owner = if state.keys.enabled() {
        let presented = req
            .headers()
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| {
                v.strip_prefix("Bearer ")
                    .or_else(|| v.strip_prefix("bearer "))
            })
            .map(str::trim);
        let Some(presented) = presented else {
            return ApiError::unauthorized(
                "this service needs an API key: send `Authorization: Bearer <key>`",
            )
            .into_response();
        };
        match state.keys.check(presented) {
            Some(owner) => Owner(Some(owner)),
            None => {
                return ApiError::unauthorized(
                    "the API key is not valid; check it with the operator of this service",
                )
                .into_response()
            }
        }
    } else {
        Owner(None)
    };
    req.extensions_mut().insert(owner);
    next.run(req).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_match_exactly_and_owners_differ() {
        let keys = Keys::new(&["alpha".into(), "beta".into(), " ".into()]);
        assert!(keys.enabled());
        let a = keys.check("alpha").unwrap();
        let b = keys.check("beta").unwrap();
        assert_ne!(a, b);
        assert_eq!(a.len(), 32);
        assert_eq!(keys.check("alpha"), Some(a));
        assert_eq!(keys.check("alph"), None);
        assert_eq!(keys.check(""), None);
        assert!(!Keys::new(&[]).enabled());
    }
}
