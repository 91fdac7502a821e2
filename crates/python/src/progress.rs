//! Progress callbacks and Ctrl-C for long core calls.
//!
//! The core reports progress through `Fn(done, total) -> bool` closures called
//! from rayon worker threads (STYLE 17); returning `false` asks it to stop.
//! [`run`] turns an optional Python callable into such a closure:
//!
//! * the callable is called at most about 100 times (each time `done` passes
//!   another hundredth of `total`, and once at `done == total`), with `done`
//!   increasing, each call re-attaching the worker thread to the interpreter;
//! * if it raises, the exception is kept, the closure returns `false` from then
//!   on, and [`run`] raises that exception once the core call has returned;
//! * the work runs on its own thread while the calling thread waits with the
//!   GIL released, waking every 100 ms to let Python handle signals: Ctrl-C
//!   stops the work the same way (worker threads never see signals);
//! * the core polls the closure from its long loops at a bounded interval;
//!   `progress(0, 0)` is such a poll: it reports nothing (the callable is not
//!   called) and only answers whether to go on;
//! * the work runs on this process's pool ([`crate::pool`]: safe after
//!   `fork`), and a core call from inside the callable is refused;
//! * [`run_detachable`] (used by `embed`) does not wait for work that is
//!   inside a step that cannot poll (one sparse factorisation): after a stop
//!   it returns within a few hundred milliseconds and the work ends on its
//!   own thread at its next poll.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use pyo3::prelude::*;

use crate::errors::mesh_error;
use crate::mesh::CoreMesh;
use spherify_mesh::Mesh;

/// Most calls of the Python callable per run (plus the final one).
const MAX_CALLS: usize = 100;

struct State {
    callback: Option<Py<PyAny>>,
    /// The last `done` passed to the callable.
    last: Mutex<usize>,
    error: Mutex<Option<PyErr>>,
    stop: AtomicBool,
}

/// A poisoned lock only means another thread panicked while holding it; the
/// data (a counter, an optional error) is still meaningful.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Where the work leaves its result, and the condition the caller waits on.
struct Slot<R> {
    value: Mutex<Option<R>>,
    ready: Condvar,
}

impl<R> Slot<R> {
    fn new() -> Slot<R> {
        Slot { value: Mutex::new(None), ready: Condvar::new() }
    }

    fn put(&self, result: R) {
        *lock(&self.value) = Some(result);
        self.ready.notify_all();
    }

    /// The result, waiting at most [`WAKE_EVERY`] for it (call without the GIL).
    fn take_within_a_wake(&self) -> Option<R> {
        let (mut value, _) = self
            .ready
            .wait_timeout_while(lock(&self.value), WAKE_EVERY, |r| r.is_none())
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        value.take()
    }

    fn take(&self) -> Option<R> {
        lock(&self.value).take()
    }
}

/// How often the waiting caller wakes to let Python handle signals.
const WAKE_EVERY: Duration = Duration::from_millis(100);

impl State {
    /// The state of one run, after refusing a progress argument that is
    /// neither None nor callable.
    fn new(callback: Option<&Bound<'_, PyAny>>) -> PyResult<State> {
        if let Some(c) = callback.filter(|c| !c.is_callable()) {
            return Err(mesh_error(format!(
                "progress must be None or a callable taking (done, total), got {}",
                c.get_type().name()?
            )));
        }
        Ok(State {
            callback: callback.map(|c| c.clone().unbind()),
            last: Mutex::new(0),
            error: Mutex::new(None),
            stop: AtomicBool::new(false),
        })
    }

    /// What the run gives back: the error the callable or a signal handler
    /// raised, else the work's result.
    fn finish<R>(&self, result: Option<R>) -> PyResult<R> {
        match (lock(&self.error).take(), result) {
            (Some(err), _) => Err(err),
            (None, Some(result)) => Ok(result),
            (None, None) => {
                Err(mesh_error("internal error: the computation ended without a result"))
            }
        }
    }

    fn fail(&self, err: PyErr) {
        let mut slot = lock(&self.error);
        if slot.is_none() {
            *slot = Some(err);
        }
        self.stop.store(true, Ordering::SeqCst);
    }

    fn report(&self, done: usize, total: usize) -> bool {
        if self.stop.load(Ordering::SeqCst) {
            return false;
        }
        let Some(callback) = &self.callback else {
            return true;
        };
        let step = total.div_ceil(MAX_CALLS).max(1);
        // Held across the call, so that calls happen one at a time and in
        // increasing order of `done`: workers finish sources out of order.
        let mut last = lock(&self.last);
        // A worker that waited for the lock while the callable raised must
        // not call it again: the stop is set before the lock is let go.
        if self.stop.load(Ordering::SeqCst) {
            return false;
        }
        if done <= *last || (done < total && done / step == *last / step) {
            return true;
        }
        *last = done;
        let called = crate::pool::as_callback(|| {
            Python::attach(|py| callback.call1(py, (done, total)).map(drop))
        });
        let going_on = match called {
            Ok(()) => true,
            Err(err) => {
                self.fail(err);
                false
            }
        };
        drop(last);
        going_on
    }
}

/// Runs `work` with a progress closure backed by `callback` (a Python callable
/// taking `(done, total)`, or `None`), with the GIL released. Raises what the
/// callable raised, or what a signal handler raised (KeyboardInterrupt), even
/// when `work` finished; otherwise returns its result.
pub fn run<R: Send>(
    py: Python<'_>,
    callback: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&(dyn Fn(usize, usize) -> bool + Sync)) -> R + Send,
) -> PyResult<R> {
    let state = State::new(callback)?;
    let pool = crate::pool::get()?;
    let finished = Slot::new();
    let result = std::thread::scope(|scope| {
        let (state, finished, pool) = (&state, &finished, &pool);
        let worker = scope.spawn(move || {
            finished.put(pool.install(|| work(&|done, total| state.report(done, total))));
        });
        loop {
            if let Some(result) = py.detach(|| finished.take_within_a_wake()) {
                return Some(result);
            }
            if worker.is_finished() {
                // Finished without a result: the work panicked (a bug). Let the
                // panic reach Python as it would have without this thread.
                if let Err(payload) = worker.join() {
                    std::panic::resume_unwind(payload);
                }
                return finished.take();
            }
            if let Err(err) = py.check_signals() {
                state.fail(err);
            }
        }
    });
    state.finish(result)
}

/// Input size (vertices or faces) from which a linear-time call without
/// polls can take a second: from here on [`run_sized`] makes it detachable.
const DETACH_FROM: usize = 1 << 20;

/// A call that cannot poll and whose time grows with `size`: below
/// [`DETACH_FROM`] it runs as [`crate::pool::detach`] does (milliseconds; a
/// thread of its own per call would cost more than the work), from there on
/// through [`run_detachable`], so that Ctrl-C is answered at once.
pub fn run_sized<R: Send + 'static>(
    py: Python<'_>,
    size: usize,
    work: impl FnOnce() -> R + Send + 'static,
) -> PyResult<R> {
    if size < DETACH_FROM {
        crate::pool::detach(py, work)
    } else {
        run_detachable(py, None, move |_| work())
    }
}

/// [`run_sized`] for a call on one mesh, sized by its faces: at 10^7 faces a
/// check, a search or the measures take seconds and cannot poll, and Ctrl-C
/// leaves them to finish in the background. The work gets its own handle on
/// the mesh, since a detached call may outlive this one.
pub fn run_on_mesh<R: Send + 'static>(
    py: Python<'_>,
    mesh: &CoreMesh,
    work: impl FnOnce(&Mesh) -> R + Send + 'static,
) -> PyResult<R> {
    let shared = Arc::clone(&mesh.mesh);
    run_sized(py, shared.n_faces(), move || work(&shared))
}

/// How long [`run_detachable`] waits for stopped work before it returns.
const ABANDON_AFTER: Duration = Duration::from_millis(300);

/// [`run`] for work that owns everything it uses (`'static`), so that a stop
/// need not wait for it: a poll cannot happen inside one sparse factorisation
/// or solve, which takes seconds at a million vertices. On Ctrl-C (or an
/// exception from the callable) the work is asked to stop; if it has not
/// ended within [`ABANDON_AFTER`], the call raises at once and the work runs
/// on, in the background, until its next poll (the end of that step), and
/// its result is dropped. Issue 13, item 2.
pub fn run_detachable<R: Send + 'static>(
    py: Python<'_>,
    callback: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&(dyn Fn(usize, usize) -> bool + Sync)) -> R + Send + 'static,
) -> PyResult<R> {
    let state = Arc::new(State::new(callback)?);
    let pool = crate::pool::get()?;
    let finished: Arc<Slot<R>> = Arc::new(Slot::new());
    let worker = {
        let (state, finished) = (Arc::clone(&state), Arc::clone(&finished));
        std::thread::Builder::new()
            .name("spherify-call".to_string())
            .spawn(move || {
                finished.put(pool.install(|| work(&|done, total| state.report(done, total))));
            })
            .map_err(|e| mesh_error(format!("cannot start a worker thread: {e}")))?
    };
    let mut stopping: Option<Instant> = None;
    let result = loop {
        let result = py.detach(|| finished.take_within_a_wake());
        if result.is_some() {
            break result;
        }
        if worker.is_finished() {
            // Finished without a result: the work panicked (a bug). Let the
            // panic reach Python as it would have without this thread.
            let joined = py.detach(|| worker.join());
            if let Err(payload) = joined {
                std::panic::resume_unwind(payload);
            }
            break finished.take();
        }
        if let Err(err) = py.check_signals() {
            state.fail(err);
        }
        if state.stop.load(Ordering::SeqCst) {
            let since = *stopping.get_or_insert_with(Instant::now);
            if since.elapsed() >= ABANDON_AFTER {
                // The work is inside a step that cannot poll: leave it.
                break None;
            }
        }
    };
    state.finish(result)
}
