//! What the server keeps between requests: its limits, the tables loaded or measured (by id,
//! the oldest dropped beyond [`crate::Limits::max_tables`]), and the latest cancellation token
//! of each (page, kind) so that a page's new request cancels its stale one.

use crate::cancel::{Guard, Registry, Token};
use crate::limits::Limits;
use axum::http::HeaderMap;
use fiberlab_io::table::{LobeSlices, TableKind};
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::sync::{Arc, Mutex, MutexGuard};

/// A goniophotometer table held by the server.
#[derive(Clone, Debug)]
pub struct Table {
    /// Where it came from (a file name, or `measured: …`).
    pub name: String,
    /// Fiber table (θ from the normal plane, φ relative) or surface table.
    pub kind: TableKind,
    /// Its lobes (path classes).
    pub lobes: BTreeMap<String, LobeSlices>,
}

/// The server's state, shared by the handlers.
#[derive(Clone)]
pub struct AppState(Arc<Shared>);

struct Shared {
    limits: Limits,
    background: rayon::ThreadPool,
    tables: Mutex<Tables>,
    latest: Mutex<HashMap<(String, &'static str), Token>>,
    tokens: Registry,
}

#[derive(Default)]
struct Tables {
    next: u64,
    held: VecDeque<(u64, Arc<Table>)>,
}

/// A poisoned lock only means a handler panicked while holding it; the data stay usable.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The header that names a page (any string the page chose, e.g. a random id).
pub const PAGE_HEADER: &str = "x-fiberlab-page";

impl AppState {
    /// A fresh state.
    #[must_use]
    pub fn new(limits: Limits) -> Self {
        // One thread: the slices, read-outs and comparisons queue there, so that
        // the maps a slider drag asks for keep rayon's global pool to themselves.
        let background = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .thread_name(|_| "explorer-background".into())
            .build()
            .unwrap_or_else(|_| rayon::ThreadPoolBuilder::new().build().expect("a thread pool"));
        Self(Arc::new(Shared {
            limits,
            background,
            tables: Mutex::default(),
            latest: Mutex::default(),
            tokens: Registry::default(),
        }))
    }

    /// The request limits.
    #[must_use]
    pub fn limits(&self) -> &Limits {
        &self.0.limits
    }

    /// Runs `work` on the background pool (one thread): the slices, read-outs and
    /// comparisons, which follow the knobs less urgently than the map.
    pub fn in_background<T: Send>(&self, work: impl FnOnce() -> T + Send) -> T {
        self.0.background.install(work)
    }

    /// Keeps `table`; returns its id.
    pub fn add_table(&self, table: Table) -> u64 {
        let mut t = lock(&self.0.tables);
        t.next += 1;
        let id = t.next;
        t.held.push_back((id, Arc::new(table)));
        while t.held.len() > self.0.limits.max_tables.max(1) {
            t.held.pop_front();
        }
        id
    }

    /// The table `id`, if still held.
    #[must_use]
    pub fn table(&self, id: u64) -> Option<Arc<Table>> {
        lock(&self.0.tables).held.iter().find(|(i, _)| *i == id).map(|(_, t)| t.clone())
    }

    /// A token for a request of `kind` from the page named in `headers` (if any): the page's
    /// previous token of that kind is cancelled. The guard cancels the new token when the
    /// request is dropped.
    pub fn supersede(&self, headers: &HeaderMap, kind: &'static str) -> (Token, Guard) {
        let token = self.0.tokens.token();
        if let Some(page) = headers.get(PAGE_HEADER).and_then(|v| v.to_str().ok()) {
            let mut latest = lock(&self.0.latest);
            if let Some(old) = latest.insert((page.to_string(), kind), token.clone()) {
                old.cancel();
            }
            // Forget finished pages' entries now and then (each is a few bytes).
            if latest.len() > 4096 {
                latest.retain(|_, t| !t.is_cancelled());
            }
        }
        let guard = token.guard();
        (token, guard)
    }

    /// The server is shutting down: cancels every request's work in flight (their streams
    /// end) and every later one. Returns how many were still running.
    pub fn cancel_all(&self) -> usize {
        self.0.tokens.cancel_all()
    }
}
