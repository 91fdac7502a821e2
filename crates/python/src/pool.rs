//! The worker threads every core call runs on, made safe after `fork` and
//! against re-entrant calls from progress callbacks.
//!
//! * **fork.** rayon's global pool is built once per process. A child made by
//!   `fork` inherits the pool's bookkeeping but none of its threads, so the
//!   first parallel call in the child waits forever for workers that do not
//!   exist. Every call here runs inside a pool owned by this module and
//!   tagged with the process id; a call in a process whose id differs from
//!   the tag builds a fresh pool. The parent's pool is leaked in the child on
//!   purpose: dropping it would signal condition variables that the
//!   parent's threads may have held at the moment of the fork.
//! * **Re-entrancy.** A progress callable runs on a worker thread, inside a
//!   parallel loop that may hold locks (the progress lock, rayon's jobs). A
//!   core call made from that callable can wait for those same workers and
//!   deadlock. Such a call is refused with `SpherifyError` instead: the
//!   thread-local flag below is set while a callable runs.
//!
//! The size of the pool is what `set_num_threads` asked for, else rayon's own
//! rule (`RAYON_NUM_THREADS`, else the number of CPUs). Results do not depend
//! on it: the core's parallel loops give the same bits for every thread count.

use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use pyo3::prelude::*;
use rayon::ThreadPool;

use crate::errors::spherify_error;

/// The pool and the process it was built in.
static POOL: Mutex<Option<(u32, Arc<ThreadPool>)>> = Mutex::new(None);

/// Threads the next pool is built with; 0 for rayon's own rule.
static THREADS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// True while this thread runs a Python progress callable for the core.
    static IN_CALLBACK: Cell<bool> = const { Cell::new(false) };
}

/// The pool of this process, built on first use (and again after a fork).
fn pool() -> PyResult<Arc<ThreadPool>> {
    let pid = std::process::id();
    let mut slot = POOL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some((owner, pool)) = slot.as_ref() {
        if *owner == pid {
            return Ok(Arc::clone(pool));
        }
    }
    if let Some((_, inherited)) = slot.take() {
        // Threads of the parent: never joined, never signalled (module doc).
        std::mem::forget(inherited);
    }
    let built = rayon::ThreadPoolBuilder::new()
        .thread_name(|i| format!("spherify-{i}"))
        .num_threads(THREADS.load(Ordering::Relaxed))
        .build()
        .map_err(|e| spherify_error(format!("cannot start worker threads: {e}")))?;
    let built = Arc::new(built);
    *slot = Some((pid, Arc::clone(&built)));
    Ok(built)
}

/// set_num_threads(n: int | None): the worker threads of later core calls;
/// `None` for the default (`RAYON_NUM_THREADS`, else the number of CPUs).
/// A call already running keeps its pool, which ends with it.
#[pyfunction]
#[pyo3(signature = (n))]
pub fn set_num_threads(n: Option<usize>) -> PyResult<()> {
    refuse_reentry()?;
    THREADS.store(n.unwrap_or(0), Ordering::Relaxed);
    let mut slot = POOL.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some((owner, pool)) = slot.take() {
        if owner != std::process::id() {
            std::mem::forget(pool); // a parent's threads (module doc)
        }
    }
    Ok(())
}

/// get_num_threads() -> the worker threads core calls run on.
#[pyfunction]
pub fn get_num_threads() -> PyResult<usize> {
    Ok(pool()?.current_num_threads())
}

/// Refuses a core call made from inside a progress callable (module doc).
fn refuse_reentry() -> PyResult<()> {
    if IN_CALLBACK.with(Cell::get) {
        return Err(spherify_error(
            "spherify functions cannot be called from inside a progress callback: the \
             computation that called it holds the worker threads; do the work after the \
             call returns",
        ));
    }
    Ok(())
}

/// The pool a core call is to run on (`pool.install(work)`), or the refusal
/// of a re-entrant call.
pub fn get() -> PyResult<Arc<ThreadPool>> {
    refuse_reentry()?;
    pool()
}

/// Runs `f` on this process's pool with the GIL released.
pub fn detach<R: Send>(py: Python<'_>, f: impl FnOnce() -> R + Send) -> PyResult<R> {
    let pool = get()?;
    Ok(py.detach(|| pool.install(f)))
}

/// Calls `f` with this thread marked as running a progress callable.
pub fn as_callback<R>(f: impl FnOnce() -> R) -> R {
    struct Reset(bool);
    impl Drop for Reset {
        fn drop(&mut self) {
            IN_CALLBACK.with(|c| c.set(self.0));
        }
    }
    let _reset = Reset(IN_CALLBACK.with(|c| c.replace(true)));
    f()
}
