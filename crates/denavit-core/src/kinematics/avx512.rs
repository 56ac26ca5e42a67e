//! The batch kernels' transposes in AVX-512 registers, where the build enables `avx512f` (`target-cpu=native`
//! on such a CPU; `.cargo/config.toml`): a block's frames, held lane by lane (structure of arrays), go out
//! as the caller's row-major 4x4 matrices in whole 64-byte cache lines, each line one aligned store (a
//! streaming one for an output bigger than the cache, [`crate::stream`]).
//!
//! A numpy array's data is 16-byte aligned, so a matrix (128 bytes) starts 16 bytes into a cache line (a
//! large array's, 16 bytes after the page its allocation starts on) or 32 or 48 or none: the 256-bit stores
//! of the AVX path split every other line in two. Where a matrix starts 0, 2 or 4 values into a line, each
//! of its two lines holds its own values and constants of the bottom row (of the matrix before: 0, 1 or
//! 0, 0, 0, 1), so the lines of eight matrices are two 8x8 transposes of their values, the transposes of
//! constants folded ([`own_lines`]). At other offsets (a view into an array) the matrices' values are built
//! in order and each line is cut from two consecutive registers by one two-source permute.
//!
//! `safe_arch` has no AVX-512; `core::arch`'s intrinsics are safe to call only inside a function compiled
//! for the feature, which [`Lines`] enters once per eight matrices (the crate's other `unsafe` is in
//! [`crate::stream`]).

#![allow(unsafe_code)]

use core::arch::x86_64::*;

/// The writer of a chunk's matrices (`out`: rows x 16, row-major 4x4) in whole cache lines, fed eight
/// configurations at a time in order ([`Lines::put`]), then [`Lines::finish`]ed.
pub(super) struct Lines {
    /// `out` starts `s` values into a cache line (an f64 slice is 8-byte aligned).
    s: usize,
    /// For `s` other than 0, 2, 4, lane i of a line: value i + 8 - s of the pair (previous register, this
    /// register).
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
        // instructions of the functions it enters (here and in `put`).
        let (shift, previous) = unsafe { (shift(s), _mm512_setzero_pd()) };
        Self { s, shift, previous, fed: 0, stream }
    }

    /// The matrices of the first `m` (<= 8) lanes of `frame` (columns x, y, z, origin; rows of lanes), as
    /// rows `row..row + m` of `out` (the rows fed so far are `..row`).
    #[inline(always)]
    pub(super) fn put(&mut self, out: &mut [f64], row: usize, frame: &[[[f64; 8]; 3]; 4], m: usize) {
        debug_assert_eq!(16 * row, self.fed);
        // SAFETY: as in `new`
        unsafe {
            match self.s {
                0 => self.put_own::<0>(out, frame, m),
                2 => self.put_own::<2>(out, frame, m),
                4 => self.put_own::<4>(out, frame, m),
                _ => self.put_cut(out, frame, m),
            }
        }
    }

    /// Store the values fed after the last whole line: the bottom row's constants (`s` = 2, 4), or the end
    /// of the last register.
    #[inline(always)]
    pub(super) fn finish(self, out: &mut [f64]) {
        let (s, e) = (self.s, self.fed);
        match s {
            _ if e == 0 => {}
            0 => {}
            2 | 4 => out[e - s..e].copy_from_slice(&BOTTOM[4 - s..]),
            _ => store(&mut out[e - 8..e], self.previous),
        }
    }

    /// [`Lines::put`] where `out` starts `S` = 0, 2 or 4 values into a line ([`own_lines`]).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn put_own<const S: usize>(&mut self, out: &mut [f64], frame: &[[[f64; 8]; 3]; 4], m: usize) {
        let (v, e0, stream) = (own_lines::<S>(frame), self.fed, self.stream);
        self.fed += 16 * m;
        if m == 8 && e0 > 0 {
            // eight whole matrices: 16 lines from value e0 - S on, one bounds check
            out[e0 - S..e0 - S + 128].chunks_exact_mut(8).zip(v).for_each(|(d, vk)| line(d, vk, stream));
            return;
        }
        // the chunk's first line begins before `out`: the first matrix's values up to its second line
        let first = usize::from(e0 == 0 && S > 0);
        if first == 1 {
            for (t, o) in out[..8 - S].iter_mut().enumerate() {
                *o = frame[t % 4][t / 4][0];
            }
        }
        for (k, vk) in v.into_iter().enumerate().take(2 * m).skip(first) {
            let e = e0 + 8 * k - S;
            line(&mut out[e..e + 8], vk, stream);
        }
    }

    /// [`Lines::put`] at other offsets: each line cut from two consecutive registers of the matrices' values.
    #[target_feature(enable = "avx512f")]
    fn put_cut(&mut self, out: &mut [f64], frame: &[[[f64; 8]; 3]; 4], m: usize) {
        let (v, s, stream) = (own_lines::<0>(frame), self.s, self.stream);
        for vk in v.into_iter().take(2 * m) {
            let e = self.fed;
            if e == 0 {
                store(&mut out[..8], vk);
            } else {
                line(&mut out[e - s..e - s + 8], _mm512_permutex2var_pd(self.previous, self.shift, vk), stream);
            }
            self.previous = vk;
            self.fed += 8;
        }
    }
}

/// The bottom row of a matrix.
const BOTTOM: [f64; 4] = [0.0, 0.0, 0.0, 1.0];

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

/// The cache lines of eight matrices (the lanes of `frame`; columns x, y, z, origin) that start `S` (0, 2 or
/// 4) values before each matrix and before its 9th value, in the order they are stored (the first matrix's
/// two lines, the second's, ...): line j of a matrix holds its values 8j - S .. 8j + 8 - S, those before its
/// first being the bottom row's constants of the matrix before. Two 8x8 transposes (40 shuffles for `S` = 0,
/// 44 for 2 and 4, those of constants folded at compile time).
#[target_feature(enable = "avx512f")]
fn own_lines<const S: usize>(frame: &[[[f64; 8]; 3]; 4]) -> [__m512d; 16] {
    // value t (0..16) of the row-major matrices, t < 0 the matrix before's 16 + t
    let value = |t: usize| -> __m512d {
        let t = (t + 16 - S) % 16;
        if t < 12 { load(&frame[t % 4][t / 4]) } else { _mm512_set1_pd(BOTTOM[t - 12]) }
    };
    let a = transpose(std::array::from_fn(value));
    let b = transpose(std::array::from_fn(|e| value(8 + e)));
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
        #[cfg(not(miri))]
        unsafe {
            _mm512_stream_pd(d.as_mut_ptr(), v)
        }
        // Miri cannot run the streaming store (inline assembly); the aligned store it runs and checks needs the
        // same 64-byte alignment and writes the same bytes. SAFETY: as above.
        #[cfg(miri)]
        unsafe {
            _mm512_store_pd(d.as_mut_ptr(), v)
        }
    } else {
        store(d, v);
    }
}

#[cfg(test)]
mod tests {
    use super::Lines;

    /// The writer at every offset from a cache line, streamed and plain, for 1 to 17 matrices: each row-major
    /// 4x4 where it belongs, nothing written outside the output. Also run under Miri (`.ci/run`), which checks
    /// the alignment and bounds of every store.
    #[test]
    fn lines_at_every_offset_write_the_matrices_and_nothing_else() {
        for stream in [false, true] {
            // (Miri has no two-source permute: the offsets whose lines are cut (1, 3, 5, 6, 7) run natively only;
            // their stores are the same `line` and `store` as those of 0, 2 and 4)
            let offsets: &[usize] = if cfg!(miri) { &[0, 2, 4] } else { &[0, 1, 2, 3, 4, 5, 6, 7] };
            for &offset in offsets {
                for rows in [1, 7, 8, 9, 17] {
                    let mut buf = vec![-1.0; 16 * rows + 24];
                    let start = buf.as_ptr().align_offset(64) + offset;
                    let out = &mut buf[start..start + 16 * rows];
                    let mut lines = Lines::new(out, stream);
                    // frame[column][row][lane]: configuration r's value (row, column) = 100 r + 10 row + column
                    for first in (0..rows).step_by(8) {
                        let m = (rows - first).min(8);
                        let frame: [[[f64; 8]; 3]; 4] =
                            std::array::from_fn(|c| std::array::from_fn(|r| std::array::from_fn(|l| (100 * (first + l) + 10 * r + c) as f64)));
                        lines.put(out, first, &frame, m);
                    }
                    lines.finish(out);
                    crate::stream::fence();
                    for (r, mat) in out.chunks_exact(16).enumerate() {
                        let want: Vec<f64> =
                            (0..16).map(|t| if t < 12 { (100 * r + 10 * (t / 4) + t % 4) as f64 } else { [0.0, 0.0, 0.0, 1.0][t - 12] }).collect();
                        assert_eq!(mat, &want[..], "stream {stream}, offset {offset}, rows {rows}, matrix {r}");
                    }
                    assert!(buf[..start].iter().chain(&buf[start + 16 * rows..]).all(|&v| v == -1.0));
                }
            }
        }
    }
}
