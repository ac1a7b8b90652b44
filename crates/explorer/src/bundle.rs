//! The built front end, embedded in the binary: `web/dist/` as `npm run build` writes it
//! (sources under `web/src/`; CI rebuilds it and checks that the committed bundle is what the
//! sources build to, byte for byte). `/` is the page; `/assets/…` its script and styles; any
//! other path that is not under `/api` is the page too (its state lives in the URL).

use axum::http::{HeaderValue, StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};

/// The files of the bundle: path, content type, bytes.
pub const FILES: &[(&str, &str, &[u8])] = &[
    ("/index.html", "text/html; charset=utf-8", include_bytes!("../web/dist/index.html")),
    ("/assets/app.js", "text/javascript; charset=utf-8", include_bytes!("../web/dist/assets/app.js")),
    ("/assets/app.css", "text/css; charset=utf-8", include_bytes!("../web/dist/assets/app.css")),
];

/// The file served at `path`: an asset by its path, else the page.
#[must_use]
pub fn file(path: &str) -> (&'static str, &'static [u8]) {
    let found =
        FILES.iter().find(|(p, _, _)| *p == path).or_else(|| FILES.iter().find(|(p, _, _)| *p == "/index.html"));
    found.map_or(("text/plain", b"" as &[u8]), |(_, t, b)| (*t, *b))
}

/// Serves the bundle.
pub async fn asset(uri: Uri) -> Response {
    if uri.path().starts_with("/assets/") && !FILES.iter().any(|(p, _, _)| *p == uri.path()) {
        return (StatusCode::NOT_FOUND, "no such asset").into_response();
    }
    let (content_type, bytes) = file(uri.path());
    let mut response = bytes.into_response();
    response.headers_mut().insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    response.headers_mut().insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    response
}
