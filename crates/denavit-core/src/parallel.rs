//! Where the batch kernels run: [`with_threads`] picks the default pool, the calling thread, or a pool of k
//! threads (built once per k and kept for the life of the process, so a call costs no thread start).
//!
//! The batch functions `kinematics::fk_batch`, `kinematics::jacobian_batch`, the `dynamics::*_batch`,
//! `ik::ik_batch`, compensation and the calibration chain iterate through [`try_for_each_chunk_init`] or
//! [`in_pool`], so one call of [`with_threads`] around them decides. Results never depend on the number of
//! threads (each row is computed alone).
//!
//! **Fork.** The crate never uses rayon's global pool: its pools belong to the process that built them. A
//! child made by `fork` (Python's `multiprocessing` default on Linux before 3.14) has none of its parent's
//! threads, so a pool inherited from the parent would wait forever for them; the child builds its own at its
//! first parallel call (the process id is compared at every pool look-up), and the parent's are left as they
//! are (never dropped: their state may hold locks of threads that do not exist in the child).
//!
//! **Interruption.** [`interrupt`] asks every batch and solve running in the process to stop at its next
//! check (a chunk of a batch, an IK iteration): they return [`Error::Interrupted`]. The binding calls it when
//! a signal handler raised (Ctrl-C) and [`clear_interrupt`] once the call has stopped.

use crate::error::{Error, Result};
use rayon::prelude::*;
use std::cell::Cell;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// Set by [`interrupt`], cleared by [`clear_interrupt`].
static INTERRUPT: AtomicBool = AtomicBool::new(false);

/// Ask every batch and solve running in this process to stop at its next check with [`Error::Interrupted`]
/// (about every 0.1-1 ms of work). Stays set until [`clear_interrupt`]. Process-wide: a test of it
/// (`tests/interrupt.rs`) runs alone in its own process.
///
/// ```
/// assert!(!denavit_core::parallel::interrupted());
/// ```
pub fn interrupt() {
    INTERRUPT.store(true, Ordering::Relaxed);
}

/// Let batches and solves run again after [`interrupt`].
pub fn clear_interrupt() {
    INTERRUPT.store(false, Ordering::Relaxed);
}

/// Whether [`interrupt`] was called (and not cleared).
#[inline]
pub fn interrupted() -> bool {
    INTERRUPT.load(Ordering::Relaxed)
}

/// `Err(Error::Interrupted)` after [`interrupt`].
#[inline]
pub(crate) fn check_interrupt() -> Result<()> {
    if interrupted() { Err(Error::Interrupted) } else { Ok(()) }
}

thread_local! {
    /// Set while [`with_threads`]`(Some(1), ..)` runs on this thread.
    static SERIAL: Cell<bool> = const { Cell::new(false) };
}

/// Run `f` with a thread-local flag of the crate set on this thread (restored when `f` ends, also on
/// unwinding): [`with_threads`]`(Some(1), ..)`'s serial flag, `stream::with_plain_stores`'.
pub(crate) fn with_flag<R>(flag: &'static std::thread::LocalKey<Cell<bool>>, f: impl FnOnce() -> R) -> R {
    struct Restore(&'static std::thread::LocalKey<Cell<bool>>, bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            self.0.with(|s| s.set(self.1));
        }
    }
    let _restore = Restore(flag, flag.with(|s| s.replace(true)));
    f()
}

/// The most threads a call may ask for: 4 per core of this machine (more only adds threads waiting for a core;
/// every count asked for keeps its pool for the life of the process). The core count is read once: on Linux
/// `available_parallelism` reads the cgroup files at every call.
pub fn max_threads() -> usize {
    static MAX: OnceLock<usize> = OnceLock::new();
    *MAX.get_or_init(|| 4 * std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Run `f` with the crate's batch kernels on `threads` threads: `None` the default pool of this process
/// ([`default_threads`]: `RAYON_NUM_THREADS` threads if that variable is set, else one per core), `Some(1)` serially on the
/// calling thread (no pool involved), `Some(k)` a pool of k threads (k <= [`max_threads`]), built at its
/// first use and cached.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk_batch, parallel::with_threads};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs = vec![0.3; 2 * 1000];
/// let (mut a, mut b) = (vec![0.0; 16 * 1000], vec![0.0; 16 * 1000]);
/// with_threads(Some(1), || fk_batch(&m, &qs, &mut a)).unwrap().unwrap();
/// with_threads(Some(2), || fk_batch(&m, &qs, &mut b)).unwrap().unwrap();
/// assert_eq!(a, b);
/// assert!(with_threads(Some(0), || ()).is_err());
/// assert!(with_threads(Some(denavit_core::parallel::max_threads() + 1), || ()).is_err());
/// ```
pub fn with_threads<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R> {
    match threads {
        None => Ok(f()),
        Some(k) if k == 0 || k > max_threads() => Err(Error::InvalidArgument {
            what: "threads".into(),
            expected: format!("None (RAYON_NUM_THREADS, else every core) or a count 1..={} (4 per core)", max_threads()),
            got: k.to_string(),
        }),
        Some(1) => Ok(with_flag(&SERIAL, f)),
        Some(k) => Ok(pool(k)?.install(f)),
    }
}

/// The threads of the default pool: `RAYON_NUM_THREADS` when it is set to a positive count (as rayon's
/// global pool would), else one per core; at most [`max_threads`].
pub fn default_threads() -> usize {
    static N: OnceLock<usize> = OnceLock::new();
    *N.get_or_init(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.trim().parse::<usize>().ok()).filter(|&k| k > 0).unwrap_or(cores).min(max_threads())
    })
}

/// The pools of this process, by thread count.
#[derive(Default)]
struct Pools {
    /// The process that built them (a forked child has another).
    pid: u32,
    by_count: HashMap<usize, Arc<rayon::ThreadPool>>,
}

/// The cached pool of `k` threads of this process.
fn pool(k: usize) -> Result<Arc<rayon::ThreadPool>> {
    static POOLS: OnceLock<Mutex<Pools>> = OnceLock::new();
    let mut pools = POOLS.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
    let pid = std::process::id();
    if pools.pid != pid {
        // a forked child (or the first call): the parent's pools have no threads here; left as they are
        std::mem::forget(std::mem::take(&mut pools.by_count));
        pools.pid = pid;
    }
    if let Some(p) = pools.by_count.get(&k) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new().num_threads(k).thread_name(move |i| format!("denavit-{k}-{i}")).build().map_err(|e| Error::InvalidArgument {
        what: "threads".into(),
        expected: "a thread pool the system can start".into(),
        got: format!("{k} ({e})"),
    })?;
    let p = Arc::new(p);
    pools.by_count.insert(k, p.clone());
    Ok(p)
}

/// Run `f` (which uses rayon's parallel iterators) in a pool of this process: the current one inside
/// [`with_threads`]`(Some(k), ..)`, else the default pool (never rayon's global pool: see the module's note on
/// fork).
pub(crate) fn in_pool<R: Send>(f: impl FnOnce() -> R + Send) -> Result<R> {
    if rayon::current_thread_index().is_some() { Ok(f()) } else { Ok(pool(default_threads())?.install(f)) }
}

/// Whether the current thread runs batch kernels serially (inside `with_threads(Some(1), ..)`).
#[inline]
pub(crate) fn serial() -> bool {
    SERIAL.with(|s| s.get())
}

/// `f(workspace, chunk_index, chunk)` over `out.chunks_mut(size)`, with a workspace per worker (`init`) and
/// early exit on the first error or [`interrupt`]: in parallel ([`in_pool`]), or in order on this thread when
/// [`serial`] or when there is only one chunk (a small batch pays no worker wake-up).
pub(crate) fn try_for_each_chunk_init<T: Send, W>(
    out: &mut [T],
    size: usize,
    init: impl Fn() -> W + Sync + Send,
    f: impl Fn(&mut W, usize, &mut [T]) -> Result<()> + Sync + Send,
) -> Result<()> {
    if serial() || out.len() <= size {
        let mut w = init();
        out.chunks_mut(size).enumerate().try_for_each(|(c, o)| {
            check_interrupt()?;
            f(&mut w, c, o)
        })
    } else {
        in_pool(|| {
            out.par_chunks_mut(size).enumerate().try_for_each_init(init, |w, (c, o)| {
                check_interrupt()?;
                f(w, c, o)
            })
        })?
    }
}
