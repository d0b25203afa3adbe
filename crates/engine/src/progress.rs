//! How a run or a solve tells its caller how far it is: a trait the caller
//! implements (a terminal bar in the binary, tqdm in Python). The engine never
//! prints.

use std::sync::Arc;

/// Receives a computation's progress. Every method has a default that does
/// nothing; calls come from any thread of the pool, one at a time per computation.
pub trait Progress: Send + Sync {
    /// `total` poses are to be computed by this call, `done` of them already are
    /// (kept by `--resume`).
    fn start(&self, total: u64, done: u64) {
        let _ = (total, done);
    }
    /// What is being computed now, e.g. `variant 2 kinetostatic`.
    fn stage(&self, what: &str) {
        let _ = what;
    }
    /// `n` more poses are done, `done` in all.
    fn advance(&self, n: u64, done: u64) {
        let _ = (n, done);
    }
    /// Every pose is computed; what follows (the discontinuity search and the
    /// summary) has no pose count.
    fn finish(&self) {}
    /// The search for discontinuities and the summary begin.
    fn searching(&self) {}
}

/// A [`Progress`] to pass in options: nothing by default.
#[derive(Clone, Default)]
pub struct Reporter(Option<Arc<dyn Progress>>);

impl Reporter {
    pub fn new(progress: Arc<dyn Progress>) -> Self {
        Self(Some(progress))
    }

    pub(crate) fn get(&self) -> &dyn Progress {
        match &self.0 {
            Some(p) => p.as_ref(),
            None => &Silent,
        }
    }
}

impl std::fmt::Debug for Reporter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(if self.0.is_some() { "Reporter(..)" } else { "Reporter(none)" })
    }
}

struct Silent;
impl Progress for Silent {}
