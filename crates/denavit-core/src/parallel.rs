//! Where the batch kernels run: [`with_threads`] picks rayon's global pool, the calling thread, or a pool
//! of k threads (built once per k and kept for the life of the process, so a call costs no thread start).
//!
//! The batch functions `kinematics::tool_pose_batch`, `kinematics::jacobian_batch`, the `dynamics::*_batch`
//! and `ik::ik_batch` iterate through [`try_for_each_chunk_init`] or ask [`serial`], so
//! one call of [`with_threads`] around them decides. (Other parallel code, e.g. the calibration chain, uses
//! rayon's pool directly: inside `with_threads(Some(k), ..)` that is the k-thread pool.)
//! Results never depend on the number of threads (each row is computed alone).

use crate::error::{Error, Result};
use rayon::prelude::*;
use std::cell::Cell;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

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
/// `available_parallelism` reads the cgroup files, about 25 us a call.
pub fn max_threads() -> usize {
    static MAX: OnceLock<usize> = OnceLock::new();
    *MAX.get_or_init(|| 4 * std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Run `f` with the crate's batch kernels on `threads` threads: `None` rayon's global pool
/// (`RAYON_NUM_THREADS` threads if that variable is set, else one per core), `Some(1)` serially on the
/// calling thread (no pool involved), `Some(k)` a pool of k threads (k <= [`max_threads`]), built at its
/// first use and cached.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::tool_pose_batch, parallel::with_threads};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs = vec![0.3; 2 * 1000];
/// let (mut a, mut b) = (vec![0.0; 16 * 1000], vec![0.0; 16 * 1000]);
/// with_threads(Some(1), || tool_pose_batch(&m, &qs, &mut a)).unwrap().unwrap();
/// with_threads(Some(2), || tool_pose_batch(&m, &qs, &mut b)).unwrap().unwrap();
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

/// The cached pool of `k` threads.
fn pool(k: usize) -> Result<Arc<rayon::ThreadPool>> {
    static POOLS: OnceLock<Mutex<HashMap<usize, Arc<rayon::ThreadPool>>>> = OnceLock::new();
    let mut pools = POOLS.get_or_init(Default::default).lock().unwrap_or_else(|e| e.into_inner());
    if let Some(p) = pools.get(&k) {
        return Ok(p.clone());
    }
    let p = rayon::ThreadPoolBuilder::new().num_threads(k).thread_name(move |i| format!("denavit-{k}-{i}")).build().map_err(|e| Error::InvalidArgument {
        what: "threads".into(),
        expected: "a thread pool the system can start".into(),
        got: format!("{k} ({e})"),
    })?;
    let p = Arc::new(p);
    pools.insert(k, p.clone());
    Ok(p)
}

/// Whether the current thread runs batch kernels serially (inside `with_threads(Some(1), ..)`).
#[inline]
pub(crate) fn serial() -> bool {
    SERIAL.with(|s| s.get())
}

/// `f(workspace, chunk_index, chunk)` over `out.chunks_mut(size)`, with a workspace per worker (`init`) and
/// early exit on the first error: in parallel, or in order on this thread when [`serial`] or when there is only
/// one chunk (a small batch pays no worker wake-up: one row through the pool had cost 7 us).
pub(crate) fn try_for_each_chunk_init<T: Send, W>(
    out: &mut [T],
    size: usize,
    init: impl Fn() -> W + Sync + Send,
    f: impl Fn(&mut W, usize, &mut [T]) -> Result<()> + Sync + Send,
) -> Result<()> {
    if serial() || out.len() <= size {
        let mut w = init();
        out.chunks_mut(size).enumerate().try_for_each(|(c, o)| f(&mut w, c, o))
    } else {
        out.par_chunks_mut(size).enumerate().try_for_each_init(init, |w, (c, o)| f(w, c, o))
    }
}
