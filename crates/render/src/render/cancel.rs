//! Stopping a render early on request (Ctrl-C): a shared flag that the pass loops read. A pass that is
//! under way when the flag is raised is dropped whole (its remaining tiles are skipped), so the image
//! holds the samples of the finished passes, the same number in every pixel, and the stop comes within
//! one tile's work rather than one pass's.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A request to stop, shared between whoever raises it (a signal handler) and the render loops.
/// The default flag is never raised.
#[derive(Clone, Debug, Default)]
pub struct CancelFlag(Option<Arc<AtomicBool>>);

impl CancelFlag {
    /// A flag that reads `flag`.
    pub fn new(flag: Arc<AtomicBool>) -> Self {
        CancelFlag(Some(flag))
    }

    /// True once a stop was asked for.
    pub fn is_set(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::Relaxed))
    }
}
