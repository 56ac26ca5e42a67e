//! Streaming (non-temporal) stores for batch outputs larger than the cache.
//!
//! A plain store into memory that is not in the cache first reads the line in (read-for-ownership), so a
//! write-only output costs twice its size in memory traffic and evicts the inputs from the cache. A streaming
//! store sends the values to memory through write-combining buffers instead, at up to twice the speed
//! (docs/speed.md). For an output that fits in the cache, plain
//! stores are better (the caller reads the values back from the cache), so a batch streams only from
//! [`threshold`] bytes on, as glibc's `memcpy` decides.
//!
//! The instruction takes a raw pointer and needs 16-byte alignment, which [`pairs`] checks before its stores
//! (the AVX-512 writer of whole cache lines, `kinematics/avx512.rs`, has its own). The checks test the low
//! bits of an address the compiler knows to be 8-byte aligned, because it comes from a `&mut [f64]`: safe
//! Rust cannot make one that is not, and the binding never makes one over numpy data that is not
//! (`denavit-py/src/convert.rs`: an unaligned `out=` is refused, an unaligned input copied). A slice made
//! unsafely over unaligned memory would already be undefined behaviour before any store here.

use std::cell::Cell;
use std::sync::OnceLock;

thread_local! {
    /// Set while [`with_plain_stores`] runs on this thread.
    static PLAIN: Cell<bool> = const { Cell::new(false) };
}

/// Run `f` with the batch kernels it calls on this thread writing their outputs with plain stores whatever
/// their size: for an output just allocated (Python's `fk_batch(model, qs)` without `out=`), whose pages
/// the operating system zeroes at their first touch, leaving their lines in the cache, where a streaming
/// store costs more than a plain one (`fk_batch` into a new array, one core, ns per configuration streamed /
/// plain: 100,000 configurations 28.6 / 16.9, 10^6 45.0 / 33.5).
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk_batch, stream::with_plain_stores};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs = vec![0.3; 2 * 1000];
/// let mut out = vec![0.0; 16 * 1000];
/// with_plain_stores(|| fk_batch(&m, &qs, &mut out)).unwrap();
/// ```
pub fn with_plain_stores<R>(f: impl FnOnce() -> R) -> R {
    crate::parallel::with_flag(&PLAIN, f)
}

/// A batch output of this many bytes or more is streamed: 3/4 of the last-level cache (`/sys` on Linux,
/// else 8 MiB assumed), at most [`THRESHOLD_MAX`], read once.
pub(crate) fn threshold() -> usize {
    static BYTES: OnceLock<usize> = OnceLock::new();
    *BYTES.get_or_init(|| (last_level_cache().unwrap_or(8 << 20) / 4 * 3).min(THRESHOLD_MAX))
}

/// The most [`threshold`] may be: a virtual machine reports its host's whole last-level cache, of which it
/// gets far less (a 2-core guest here reports 480 MiB; batch FK one core with AVX-512's whole-line stores,
/// plain against streaming, ns per configuration: 1.3 MB of output 11.5 / 12.3, 8 MB 13.0 / 13.3, 13 MB
/// 12.9 / 12.6, 26 MB 13.5 / 12.7, 51 MB 26.8 / 17.0, 128 MB 26.7 / 17.3). 8 MiB is also where the 2-core
/// EPYC of the first measurements streamed (3/4 of its 8 MiB).
const THRESHOLD_MAX: usize = 8 << 20;

/// The size of cpu0's highest-level cache in bytes, from Linux's `/sys/devices/system/cpu/cpu0/cache`.
fn last_level_cache() -> Option<usize> {
    let dir = std::fs::read_dir("/sys/devices/system/cpu/cpu0/cache").ok()?;
    let read = |p: std::path::PathBuf| std::fs::read_to_string(p).ok().map(|s| s.trim().to_owned());
    dir.flatten()
        .filter_map(|e| {
            let level: u32 = read(e.path().join("level"))?.parse().ok()?;
            let size = read(e.path().join("size"))?;
            let (digits, scale) = match size.strip_suffix('K') {
                Some(d) => (d, 1 << 10),
                None => size.strip_suffix('M').map_or((size.as_str(), 1), |d| (d, 1 << 20)),
            };
            Some((level, digits.parse::<usize>().ok()? * scale))
        })
        .max()
        .map(|(_, bytes)| bytes)
}

/// Whether a batch writes `out` with streaming stores: it is at least [`threshold`] bytes and 16-byte
/// aligned (a numpy array's data is; a view at an odd offset is not and gets plain stores), outside
/// [`with_plain_stores`].
pub(crate) fn wanted(out: &[f64]) -> bool {
    cfg!(target_arch = "x86_64") && std::mem::size_of_val(out) >= threshold() && (out.as_ptr() as usize).is_multiple_of(16) && !PLAIN.with(|p| p.get())
}

/// Store `count` pairs into `d[..2 * count]`, pair `k` (`v(k)`) at `d[2k..2k + 2]`, with streaming stores
/// (`movntpd`), or plain ones if `d` is not 16-byte aligned: one alignment and one length check for all
/// (per store, they had cost as much as the kinematics' arithmetic).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
pub(crate) fn pairs(d: &mut [f64], count: usize, mut v: impl FnMut(usize) -> safe_arch::m128d) {
    let d = &mut d[..2 * count];
    if (d.as_ptr() as usize).is_multiple_of(16) {
        let p = d.as_mut_ptr();
        for k in 0..count {
            // SAFETY: `d` is `2 * count` writable, initialised f64 (a unique borrow of that length, checked
            // by the slicing above), so `p + 2k .. p + 2k + 2` is inside it; 16-byte aligned as `movntpd`
            // requires (`d` is, checked above, and 2k f64 are 16k bytes).
            #[cfg(not(miri))]
            unsafe {
                core::arch::x86_64::_mm_stream_pd(p.add(2 * k), v(k).0)
            }
            // Miri cannot run the streaming store (inline assembly); the aligned store it runs and checks
            // needs the same 16-byte alignment and writes the same bytes. SAFETY: as above.
            #[cfg(miri)]
            unsafe {
                core::arch::x86_64::_mm_store_pd(p.add(2 * k), v(k).0)
            }
        }
    } else {
        for (k, d) in d.chunks_exact_mut(2).enumerate() {
            if let Some(d) = d.first_chunk_mut::<2>() {
                safe_arch::store_unaligned_m128d(d, v(k));
            }
        }
    }
}

/// Order the streaming stores before every later store (`sfence`): call before a batch's output is handed
/// back (streamed values sit in write-combining buffers, outside the usual ordering of x86 stores).
#[inline]
#[allow(unsafe_code)]
pub(crate) fn fence() {
    // SAFETY: `sfence` is part of SSE, which every x86_64 processor has; it reads and writes no memory.
    // (Miri, which runs the unsafe paths' tests in CI, has no write-combining buffers to order nor the
    // instruction.)
    #[cfg(all(target_arch = "x86_64", not(miri)))]
    unsafe {
        core::arch::x86_64::_mm_sfence()
    };
}

#[cfg(test)]
mod tests {
    /// [`pairs`] at every 8-byte offset from a 16-byte boundary (streamed when aligned to 16, plain stores
    /// otherwise): every pair where it belongs, nothing written outside `d[..2 * count]`. Also run under
    /// Miri (`.ci/run`), which checks each store's alignment and bounds.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn pairs_at_every_offset_write_their_values_and_nothing_else() {
        for offset in 0..4 {
            for count in [0, 1, 2, 5] {
                let mut buf = vec![-1.0; 2 * count + 8];
                let start = buf.as_ptr().align_offset(16) + offset;
                let d = &mut buf[start..start + 2 * count + 1];
                super::pairs(d, count, |k| safe_arch::m128d::from_array([k as f64, 0.5 + k as f64]));
                super::fence();
                for k in 0..count {
                    assert_eq!((d[2 * k], d[2 * k + 1]), (k as f64, 0.5 + k as f64));
                }
                assert_eq!(d[2 * count], -1.0);
                assert!(buf[..start].iter().all(|&v| v == -1.0));
            }
        }
    }
}
