//! Long calls without the GIL that Ctrl-C stops.
//!
//! Python runs its signal handlers (KeyboardInterrupt on SIGINT) on the main thread, between bytecodes: a
//! call that runs for seconds in Rust without the GIL would ignore Ctrl-C until it ended. A long call
//! ([`without_gil`] with `long`) therefore runs on a helper thread while the calling thread waits for it,
//! taking the GIL back every [`POLL`] to run the handlers (`PyErr_CheckSignals`). When a handler raises,
//! the core is asked to stop (`denavit_core::parallel::interrupt`: every batch and solve checks at each
//! chunk or iteration), the helper is joined, and the handler's exception (KeyboardInterrupt) is raised.
//! A short call runs on the calling thread as before: a thread start would cost more than the call itself.

use pyo3::prelude::*;
use std::sync::mpsc::{sync_channel, RecvTimeoutError};
use std::time::Duration;

/// How often a long call's calling thread runs Python's signal handlers.
const POLL: Duration = Duration::from_millis(50);

/// A call expected to take this long on one core (ns) or more is a long call: the helper thread then costs
/// at most about 1 % of it.
const LONG_NS: f64 = 2e6;

/// Whether a call of about `ns` ns of work on one core is a long call.
pub fn long(ns: f64) -> bool {
    ns >= LONG_NS
}

/// Run `work` without the GIL, on a helper thread that Ctrl-C interrupts when `long` (module docs), else on
/// this thread. `Err` is the exception a signal handler raised; the work's own result is `Ok`.
pub fn without_gil<R: Send>(py: Python<'_>, long: bool, work: impl FnOnce() -> R + Send) -> PyResult<R> {
    if !long {
        return Ok(py.allow_threads(work));
    }
    py.allow_threads(|| {
        std::thread::scope(|s| {
            let (tx, rx) = sync_channel(1);
            let worker = s.spawn(move || {
                // the receiver outlives the worker (joined before the scope ends): sending cannot fail
                let _ = tx.send(work());
            });
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(r) => return Ok(r),
                    Err(RecvTimeoutError::Timeout) => {
                        if let Err(e) = Python::with_gil(|py| py.check_signals()) {
                            denavit_core::parallel::interrupt();
                            // the work stops at its next check (a chunk of a batch, an IK iteration)
                            let _ = worker.join();
                            denavit_core::parallel::clear_interrupt();
                            return Err(e);
                        }
                    }
                    Err(RecvTimeoutError::Disconnected) => {
                        // the worker ended without a result: it panicked; re-raise its panic here
                        if let Err(p) = worker.join() {
                            std::panic::resume_unwind(p);
                        }
                        return Err(pyo3::exceptions::PyRuntimeError::new_err("a worker thread ended without a result"));
                    }
                }
            }
        })
    })
}
