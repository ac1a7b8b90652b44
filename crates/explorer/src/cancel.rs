//! Cancellation of stale work. A request that names its page (header `x-fiberlab-page`)
//! registers a [`Token`] under (page, kind); the page's next request of the same kind cancels
//! it. A token is also cancelled when the request's future is dropped (the client went away):
//! the handler holds a [`Guard`]. Long loops poll [`Token::is_cancelled`] between rows, rays
//! chunks or render passes. When the server shuts down, every live token is cancelled
//! ([`Registry::cancel_all`]) so that streams in flight end instead of holding the shutdown.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError, Weak};

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

/// The live tokens (held weakly: a finished request's token is dropped with it), so that a
/// shutdown cancels all of them, and every token made after the shutdown starts cancelled.
#[derive(Debug, Default)]
pub struct Registry {
    live: Mutex<Vec<Weak<AtomicBool>>>,
    closed: AtomicBool,
}

impl Registry {
    /// A fresh token, registered (already cancelled once [`Registry::cancel_all`] ran).
    pub fn token(&self) -> Token {
        let token = Token::new();
        let mut live = self.live.lock().unwrap_or_else(PoisonError::into_inner);
        // Checked under the lock: `cancel_all` cannot slip between the check and the push.
        if self.closed.load(Ordering::SeqCst) {
            token.cancel();
        }
        if live.len() >= 1024 {
            live.retain(|w| w.strong_count() > 0);
        }
        live.push(Arc::downgrade(&token.0));
        token
    }

    /// Cancels every live token and every later one; returns how many were still running.
    pub fn cancel_all(&self) -> usize {
        let mut live = self.live.lock().unwrap_or_else(PoisonError::into_inner);
        self.closed.store(true, Ordering::SeqCst);
        let mut running = 0;
        for flag in live.drain(..).filter_map(|w| w.upgrade()) {
            if !flag.swap(true, Ordering::SeqCst) {
                running += 1;
            }
        }
        running
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cancel_all_reaches_live_tokens_and_later_ones() {
        let registry = Registry::default();
        let a = registry.token();
        let b = registry.token();
        b.cancel();
        drop(registry.token());
        assert_eq!(registry.cancel_all(), 1, "only `a` was still running");
        assert!(a.is_cancelled() && b.is_cancelled());
        assert!(registry.token().is_cancelled(), "a token made after the shutdown starts cancelled");
    }
}
