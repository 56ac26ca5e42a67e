//! The batch kernels' transposes in AVX-512 registers, where the build enables `avx512f` (`target-cpu=native`
//! on such a CPU; `.cargo/config.toml`): a block's frames, held lane by lane (structure of arrays), go out
//! as the caller's row-major 4x4 matrices in whole 64-byte cache lines, each line one aligned store (a
//! streaming one for an output bigger than the cache, [`crate::stream`]).
//!
//! A numpy array's data is 16-byte aligned, so a matrix (128 bytes) starts 16 bytes into a cache line: the
//! 256-bit stores of the AVX path split every other line in two, and the values of a line come from two
//! matrices. Here the matrices' values are built in order, eight at a time (sixteen registers of eight
//! values), and each aligned line is cut from two consecutive registers (one two-source permute).
//!
//! `safe_arch` has no AVX-512; `core::arch`'s intrinsics are safe to call only inside a function compiled
//! for the feature, which [`Lines`] enters once per eight matrices (the crate's other `unsafe` is in
//! [`crate::stream`]).

#![allow(unsafe_code)]

use core::arch::x86_64::*;

/// The writer of a chunk's matrices (`out`: rows x 16, row-major 4x4) in whole cache lines, fed eight
/// configurations at a time in order ([`Lines::put`]), then [`Lines::finish`]ed.
pub(super) struct Lines {
    /// `out` starts `s` values into a cache line (an f64 slice is 8-byte aligned): each aligned line is the
    /// last `s` values of one register and the first `8 - s` of the next; the first and last partial lines
    /// are plain unaligned stores.
    s: usize,
    /// Lane i of a line: value i + 8 - s of the pair (previous register, this register).
    shift: __m512i,
    previous: __m512d,
    /// Values fed so far.
    fed: usize,
    stream: bool,
}

impl Lines {
    pub(super) fn new(out: &[f64], stream: bool) -> Self {
        let s = (out.as_ptr() as usize / 8) % 8;
        // SAFETY: the module is compiled only when the build enables avx512f (the CPU that runs the extension
        // is the one it was built for, or one named by RUSTFLAGS with the feature), so the CPU has the
        // instructions of the functions it enters (here and in `put`, `finish`).
        let (shift, previous) = unsafe { (shift(s), _mm512_setzero_pd()) };
        Self { s, shift, previous, fed: 0, stream }
    }

    /// The matrices of the first `m` (<= 8) lanes of `frame` (columns x, y, z, origin; rows of lanes), as
    /// rows `row..row + m` of `out` (the rows fed so far are `..row`).
    #[inline(always)]
    pub(super) fn put(&mut self, out: &mut [f64], row: usize, frame: &[[[f64; 8]; 3]; 4], m: usize) {
        debug_assert_eq!(16 * row, self.fed);
        // SAFETY: as in `new`
        unsafe { self.put_avx512(out, frame, m) }
    }

    /// Store the last values fed (the part of a line after the last whole one).
    #[inline(always)]
    pub(super) fn finish(self, out: &mut [f64]) {
        if self.s != 0 && self.fed >= 8 {
            store(&mut out[self.fed - 8..self.fed], self.previous);
        }
    }

    #[target_feature(enable = "avx512f")]
    fn put_avx512(&mut self, out: &mut [f64], frame: &[[[f64; 8]; 3]; 4], m: usize) {
        let v = matrices(frame);
        let (e0, s, stream) = (self.fed, self.s, self.stream);
        if m == 8 && (s == 0 || e0 > 0) {
            // eight whole matrices after the first line: 16 lines from value e0 - s on, one bounds check
            let d = out[e0 - s..e0 - s + 128].chunks_exact_mut(8);
            if s == 0 {
                d.zip(v).for_each(|(d, vk)| line(d, vk, stream));
            } else {
                let previous = std::iter::once(self.previous).chain(v.into_iter().take(15));
                d.zip(previous.zip(v)).for_each(|(d, (p, vk))| line(d, _mm512_permutex2var_pd(p, self.shift, vk), stream));
            }
            self.previous = v[15];
            self.fed += 128;
            return;
        }
        for vk in v.into_iter().take(2 * m) {
            let e = self.fed;
            if s == 0 {
                line(&mut out[e..e + 8], vk, stream);
            } else if e == 0 {
                store(&mut out[..8], vk);
            } else {
                line(&mut out[e - s..e - s + 8], _mm512_permutex2var_pd(self.previous, self.shift, vk), stream);
            }
            self.previous = vk;
            self.fed += 8;
        }
    }
}

/// The permute index of [`Lines::shift`].
#[target_feature(enable = "avx512f")]
fn shift(s: usize) -> __m512i {
    _mm512_add_epi64(_mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0), _mm512_set1_epi64(8 - s as i64))
}

/// Eight values into a register.
#[inline(always)]
fn load(a: &[f64; 8]) -> __m512d {
    // SAFETY: `a` is 8 readable f64 (64 bytes); the load has no alignment requirement.
    unsafe { _mm512_loadu_pd(a.as_ptr()) }
}

/// The 16 values of each of eight matrices (the lanes of `frame`), in the order they are
/// stored: rows 0-1 of the first matrix, rows 2-3 of it, rows 0-1 of the second, ...: two 8x8 transposes
/// (the second's last four inputs are the bottom row's constants 0, 0, 0, 1).
#[target_feature(enable = "avx512f")]
fn matrices(frame: &[[[f64; 8]; 3]; 4]) -> [__m512d; 16] {
    // top[k]: entry k of the first two rows (x, y, z, p of row 0, then of row 1) of the 8 configurations
    let top: [__m512d; 8] = std::array::from_fn(|k| load(&frame[k % 4][k / 4]));
    let bottom: [__m512d; 4] = std::array::from_fn(|j| load(&frame[j][2]));
    let (zero, one) = (_mm512_setzero_pd(), _mm512_set1_pd(1.0));
    let a = transpose(top);
    let b = transpose([bottom[0], bottom[1], bottom[2], bottom[3], zero, zero, zero, one]);
    std::array::from_fn(|k| if k % 2 == 0 { a[k / 2] } else { b[k / 2] })
}

/// The 8x8 transpose of `r` (`r[k]` lane `i` -> result `i` lane `k`): pairs, then 128-bit lanes, then
/// 256-bit halves (24 shuffles; those of constant inputs fold).
#[target_feature(enable = "avx512f")]
fn transpose(r: [__m512d; 8]) -> [__m512d; 8] {
    // t[2j], t[2j+1]: lanes (0, 2, 4, 6) and (1, 3, 5, 7) of r[2j], r[2j+1] interleaved
    let t: [__m512d; 8] = std::array::from_fn(|k| if k % 2 == 0 { _mm512_unpacklo_pd(r[k], r[k + 1]) } else { _mm512_unpackhi_pd(r[k - 1], r[k]) });
    // u[4h + m]: the 128-bit lanes of t, so that u[4h + m] holds configurations m and m + 4 of rows
    // 4h..4h + 4 (m = 0, 1 from lanes 0 and 2 of the t, m = 2, 3 from lanes 1 and 3)
    const EVEN: i32 = 0b10_00_10_00;
    const ODD: i32 = 0b11_01_11_01;
    let halves = |a: __m512d, b: __m512d, odd: bool| if odd { _mm512_shuffle_f64x2::<ODD>(a, b) } else { _mm512_shuffle_f64x2::<EVEN>(a, b) };
    let u: [__m512d; 8] = std::array::from_fn(|k| {
        let (h, m) = (k / 4, k % 4);
        let (a, b) = (t[4 * h + m % 2], t[4 * h + 2 + m % 2]);
        halves(a, b, m >= 2)
    });
    // configuration i: the halves of u[i mod 4] and u[4 + i mod 4] that hold it
    std::array::from_fn(|i| halves(u[i % 4], u[4 + i % 4], i >= 4))
}

/// An unaligned store of 8 values.
#[inline(always)]
fn store(d: &mut [f64], v: __m512d) {
    let d = d.first_chunk_mut::<8>().expect("8 values");
    // SAFETY: `d` is 8 writable f64 (64 bytes); the store has no alignment requirement.
    unsafe { _mm512_storeu_pd(d.as_mut_ptr(), v) }
}

/// One whole cache line (`d`: 8 values, 64-byte aligned), with a streaming store if `stream`.
#[inline(always)]
fn line(d: &mut [f64], v: __m512d, stream: bool) {
    let d = d.first_chunk_mut::<8>().expect("8 values");
    debug_assert_eq!(d.as_ptr() as usize % 64, 0);
    if stream && (d.as_ptr() as usize).is_multiple_of(64) {
        // SAFETY: `d` is 8 writable f64 (64 bytes), 64-byte aligned as the streaming store requires (checked).
        unsafe { _mm512_stream_pd(d.as_mut_ptr(), v) }
    } else {
        store(d, v);
    }
}
