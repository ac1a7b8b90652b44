//! Cancellation of stale work. A request that names its page (header `x-fiberlab-page`)
//! registers a [`Token`] under (page, kind); the page's next request of the same kind cancels
//! it. A token is also cancelled when the request's future is dropped (the client went away):
//! the handler holds a [`Guard`]. Long loops poll [`Token::is_cancelled`] between rows, rays
//! chunks or render passes.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A flag that long work polls.
#[derive(Clone, Debug, Default)]
pub struct Token(Arc<AtomicBool>);

impl Token {
    /// A fresh token.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether the work should stop.
    #[must_use]
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// Stops the work.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// The flag itself, for library calls that take an `&AtomicBool` (the goniophotometer's
    /// and the renderer's `stop`).
    #[must_use]
    pub fn flag(&self) -> &AtomicBool {
        &self.0
    }

    /// A guard that cancels this token when dropped.
    #[must_use]
    pub fn guard(&self) -> Guard {
        Guard(self.clone())
    }
}

/// Cancels its token when dropped (when the request's future is dropped).
#[derive(Debug)]
pub struct Guard(Token);

impl Drop for Guard {
    fn drop(&mut self) {
        self.0.cancel();
    }
}
