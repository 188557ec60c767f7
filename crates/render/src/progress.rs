//! Work counter a technique bumps as it finishes pixels, so a caller can show progress from
//! another thread. Cloning shares the counter.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

#[derive(Clone, Debug, Default)]
pub struct Progress {
    done: Arc<AtomicU64>,
}

impl Progress {
    pub fn add(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }

    pub fn done(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }

    pub fn reset(&self) {
        self.done.store(0, Ordering::Relaxed);
    }
}
