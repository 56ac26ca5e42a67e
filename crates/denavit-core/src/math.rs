//! The one sine/cosine kernel of the crate, used by kinematics, dynamics and the calibration chain, so
//! every algorithm computes bit-for-bit the same joint frames.

/// Arguments from this magnitude on (and NaN) go to `f64::sin_cos`; below it the Cody-Waite reduction
/// with a two-part pi/2 is exact enough (`k * PIO2_1` is exact for |k| < 2^20).
const REDUCED_MAX: f64 = 1.0e5;

/// `sin x, cos x` (rad) to within 1 ulp of `f64::sin_cos` (matches it bit for bit on about 97 % of
/// angles): Cody-Waite reduction by pi/2 as in fdlibm's `__ieee754_rem_pio2` (the reduced argument kept as
/// a double-double) and the FreeBSD/musl minimax kernels `__sin`, `__cos` on [-pi/4, pi/4], evaluated
/// with fused multiply-adds (about 43 operations instead of 65); `f64::sin_cos` from |x| = 1e5 on and for
/// NaN. About 15x as fast as libm's `sincos` here (no call, no branch), and it is on every link of every
/// algorithm.
///
/// ```
/// use denavit_core::math::sin_cos;
/// let (s, c) = sin_cos(0.5);
/// assert!((s - 0.5f64.sin()).abs() <= f64::EPSILON * s && (c - 0.5f64.cos()).abs() <= f64::EPSILON * c);
/// assert_eq!(sin_cos(0.0), (0.0, 1.0));
/// ```
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() >= REDUCED_MAX || x.is_nan() {
        return x.sin_cos();
    }
    sin_cos_reduced(x)
}

/// [`sin_cos`] of `N` angles at once: the arguments are checked once, then the branch-free kernel runs
/// over the lanes (which the compiler maps to SIMD registers). Bit for bit the values of [`sin_cos`].
#[inline(always)]
pub(crate) fn sin_cos_lanes<const N: usize>(x: &[f64; N]) -> ([f64; N], [f64; N]) {
    let (mut sn, mut cs) = ([0.0; N], [0.0; N]);
    if x.iter().all(|v| v.abs() < REDUCED_MAX) {
        let done = avx::sin_cos_reduced_slices(x, &mut sn, &mut cs);
        for l in done..N {
            (sn[l], cs[l]) = sin_cos_reduced(x[l]);
        }
    } else {
        for l in 0..N {
            (sn[l], cs[l]) = sin_cos(x[l]);
        }
    }
    (sn, cs)
}

/// [`sin_cos`] of every `x[i]` into `sn[i]`, `cs[i]` (slices of one length, e.g. a block of a batch): the
/// branch-free kernel over all, then `f64::sin_cos` over all if an argument was out of its range. Bit for bit
/// the values of [`sin_cos`]. Returns whether every `|x|` was below 1e5 (false for a NaN or an infinity).
#[inline(always)]
pub(crate) fn sin_cos_slices(x: &[f64], sn: &mut [f64], cs: &mut [f64]) -> bool {
    let (sn, cs) = (&mut sn[..x.len()], &mut cs[..x.len()]);
    let in_range = sin_cos_reduced_checked(x, sn, cs);
    if !in_range {
        for i in 0..x.len() {
            (sn[i], cs[i]) = sin_cos(x[i]);
        }
    }
    in_range
}

/// [`sin_cos_reduced`] of the slices if every argument is in its range (returns whether they are). With
/// AVX-512, the compiler's loop on eight lanes with the range check folded in (a compare and a mask `and` per
/// eight angles instead of a pass of its own; docs/speed.md).
#[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
#[inline(always)]
fn sin_cos_reduced_checked(x: &[f64], sn: &mut [f64], cs: &mut [f64]) -> bool {
    let mut in_range = true;
    for ((xi, si), ci) in x.iter().zip(sn).zip(cs) {
        (*si, *ci) = sin_cos_reduced(*xi);
        in_range &= xi.abs() < REDUCED_MAX;
    }
    in_range
}

/// Without AVX-512: the arguments counted first (a compare and a subtraction per four angles; NaN is out of
/// range), then the interleaved AVX2 kernel ([`avx`]) or the compiler's loop.
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
#[inline(always)]
fn sin_cos_reduced_checked(x: &[f64], sn: &mut [f64], cs: &mut [f64]) -> bool {
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    let out_of_range = x.iter().filter(|v| !(v.abs() < REDUCED_MAX)).count();
    if out_of_range == 0 {
        let done = avx::sin_cos_reduced_slices(x, sn, cs);
        for i in done..x.len() {
            (sn[i], cs[i]) = sin_cos_reduced(x[i]);
        }
    }
    out_of_range == 0
}

// The kernels' constants exactly as published: fdlibm's two-part pi/2 and the FreeBSD/musl minimax
// coefficients of `__sin` (S1..S6) and `__cos` (C1..C6).
const INV_PIO2: f64 = std::f64::consts::FRAC_2_PI;
#[allow(clippy::excessive_precision)]
const PIO2_1: f64 = 1.57079632673412561417e+00; // first 33 bits of pi/2
#[allow(clippy::excessive_precision)]
const PIO2_1T: f64 = 6.07710050650619224932e-11; // pi/2 - PIO2_1
#[allow(clippy::excessive_precision)]
const S: [f64; 6] = [
    -1.66666666666666324348e-01,
    8.33333333332248946124e-03,
    -1.98412698298579493134e-04,
    2.75573137070700676789e-06,
    -2.50507602534068634195e-08,
    1.58969099521155010221e-10,
];
#[allow(clippy::excessive_precision)]
const C: [f64; 6] = [
    4.16666666666666019037e-02,
    -1.38888888888741095749e-03,
    2.48015872894767294178e-05,
    -2.75573143513906633035e-07,
    2.08757232129817482790e-09,
    -1.13596475577881948265e-11,
];
/// Round to nearest by adding and subtracting 1.5 * 2^52 (no libm call without SSE4.1; exact for |x| < 2^51).
const SHIFT: f64 = 6755399441055744.0;

/// [`sin_cos`] without the range check (|x| < 1e5, not NaN): branch-free, so a loop over lanes vectorises.
#[inline(always)]
fn sin_cos_reduced(x: f64) -> (f64, f64) {
    let shifted = x.mul_add(INV_PIO2, SHIFT);
    let k = shifted - SHIFT;
    // the quadrant k mod 4 sits in the low mantissa bits of `shifted` (two's complement)
    let quadrant = shifted.to_bits();
    // k * PIO2_1 is exact for |k| < 2^20, so the fused r is fdlibm's; (y0, y1) is the reduced argument as a
    // double-double, its tail from the exact difference r - y0 and one rounding of the product k * PIO2_1T
    let r = (-k).mul_add(PIO2_1, x);
    let y0 = (-k).mul_add(PIO2_1T, r);
    let y1 = (-k).mul_add(PIO2_1T, r - y0);
    let z = y0 * y0;
    // __sin(y0, y1, 1) and __cos(y0, y1), the polynomials by Horner's rule in fused multiply-adds
    let rs = z.mul_add(z.mul_add(z.mul_add(z.mul_add(S[5], S[4]), S[3]), S[2]), S[1]);
    let v = z * y0;
    let sn = y0 - (-v).mul_add(S[0], z.mul_add((-v).mul_add(rs, 0.5 * y1), -y1));
    let rc = z * z.mul_add(z.mul_add(z.mul_add(z.mul_add(z.mul_add(C[5], C[4]), C[3]), C[2]), C[1]), C[0]);
    let hz = 0.5 * z;
    let wc = 1.0 - hz;
    let cs = wc + (((1.0 - wc) - hz) + z.mul_add(rc, -(y0 * y1)));
    // branch-free quadrant (random angles would mispredict a branch; a select is a blend): swap on odd k,
    // then signs: sin + + - - for k = 0, 1, 2, 3 (bit 1 of k), cos + - - + (bit 1 of k + 1)
    let (s0, c0) = if quadrant & 1 != 0 { (cs, sn) } else { (sn, cs) };
    let s_sign = (quadrant << 62) & (1 << 63);
    let c_sign = (quadrant.wrapping_add(1) << 62) & (1 << 63);
    (f64::from_bits(s0.to_bits() ^ s_sign), f64::from_bits(c0.to_bits() ^ c_sign))
}

/// [`sin_cos_reduced`] in AVX2 registers, several groups of four angles at a time, their operations
/// interleaved so that the groups' chains of dependent fused multiply-adds overlap (the compiler's loop
/// over one group at a time waits on each chain's latency; docs/speed.md). The same operations in the same
/// order: bit for bit the scalar kernel's values.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma", not(target_feature = "avx512f")))]
mod avx {
    use safe_arch::*;

    /// The kernel's constants ([`super::S`], [`super::C`], ...), each in four lanes: read through an opaque
    /// reference, so that the compiler folds them into the operations as memory operands instead of keeping
    /// (and spilling) them in registers or broadcasting them anew at every use.
    struct Constants {
        inv_pio2: [f64; 4],
        shift: [f64; 4],
        pio2_1: [f64; 4],
        pio2_1t: [f64; 4],
        s: [[f64; 4]; 6],
        c: [[f64; 4]; 6],
        half: [f64; 4],
        one: [f64; 4],
    }

    const fn four(v: f64) -> [f64; 4] {
        [v; 4]
    }

    const fn six(v: [f64; 6]) -> [[f64; 4]; 6] {
        [four(v[0]), four(v[1]), four(v[2]), four(v[3]), four(v[4]), four(v[5])]
    }

    static CONSTANTS: Constants = Constants {
        inv_pio2: four(super::INV_PIO2),
        shift: four(super::SHIFT),
        pio2_1: four(super::PIO2_1),
        pio2_1t: four(super::PIO2_1T),
        s: six(super::S),
        c: six(super::C),
        half: four(0.5),
        one: four(1.0),
    };

    #[inline(always)]
    fn kernel<const K: usize>(x: [m256d; K], k: &Constants) -> [[m256d; 2]; K] {
        let c = load_unaligned_m256d;
        let shifted = x.map(|x| fused_mul_add_m256d(x, c(&k.inv_pio2), c(&k.shift)));
        let n = shifted.map(|s| sub_m256d(s, c(&k.shift)));
        let r: [m256d; K] = std::array::from_fn(|i| fused_mul_neg_add_m256d(n[i], c(&k.pio2_1), x[i]));
        let y0: [m256d; K] = std::array::from_fn(|i| fused_mul_neg_add_m256d(n[i], c(&k.pio2_1t), r[i]));
        let y1: [m256d; K] = std::array::from_fn(|i| fused_mul_neg_add_m256d(n[i], c(&k.pio2_1t), sub_m256d(r[i], y0[i])));
        let z = y0.map(|y| mul_m256d(y, y));
        // Horner's rule from the highest coefficient down to `p[low]`
        let horner = |z: m256d, p: &[[f64; 4]; 6], low: usize| p[low..5].iter().rev().fold(c(&p[5]), |acc, pi| fused_mul_add_m256d(z, acc, c(pi)));
        let rs = z.map(|z| horner(z, &k.s, 1));
        let v: [m256d; K] = std::array::from_fn(|i| mul_m256d(z[i], y0[i]));
        let sn: [m256d; K] = std::array::from_fn(|i| {
            let inner = fused_mul_neg_add_m256d(v[i], rs[i], mul_m256d(c(&k.half), y1[i]));
            let inner = fused_mul_sub_m256d(z[i], inner, y1[i]);
            sub_m256d(y0[i], fused_mul_neg_add_m256d(v[i], c(&k.s[0]), inner))
        });
        let rc = z.map(|z| mul_m256d(z, horner(z, &k.c, 0)));
        let cs: [m256d; K] = std::array::from_fn(|i| {
            let hz = mul_m256d(c(&k.half), z[i]);
            let wc = sub_m256d(c(&k.one), hz);
            let tail = fused_mul_sub_m256d(z[i], rc[i], mul_m256d(y0[i], y1[i]));
            add_m256d(wc, add_m256d(sub_m256d(sub_m256d(c(&k.one), wc), hz), tail))
        });
        std::array::from_fn(|i| {
            let q = cast_to_m256i_from_m256d(shifted[i]);
            let even = cast_to_m256d_from_m256i(cmp_eq_mask_i64_m256i(bitand_m256i(q, set_splat_i64_m256i(1)), zeroed_m256i()));
            let (s0, c0) = (blend_varying_m256d(cs[i], sn[i], even), blend_varying_m256d(sn[i], cs[i], even));
            let sign = set_splat_i64_m256i(i64::MIN);
            let s_sign = bitand_m256i(shl_imm_u64_m256i::<62>(q), sign);
            let c_sign = bitand_m256i(shl_imm_u64_m256i::<62>(add_i64_m256i(q, set_splat_i64_m256i(1))), sign);
            [bitxor_m256d(s0, cast_to_m256d_from_m256i(s_sign)), bitxor_m256d(c0, cast_to_m256d_from_m256i(c_sign))]
        })
    }

    /// The angles of `x` in groups of `4 K` (the first multiple of `4 K`); returns how many it did.
    #[inline(always)]
    fn groups<const K: usize>(x: &[f64], sn: &mut [f64], cs: &mut [f64], constants: &Constants) -> usize {
        let whole = x.len() / (4 * K) * (4 * K);
        for ((xc, sc), cc) in x[..whole].chunks_exact(4 * K).zip(sn[..whole].chunks_exact_mut(4 * K)).zip(cs[..whole].chunks_exact_mut(4 * K)) {
            let four = |v: &[f64], i: usize| *v[4 * i..].first_chunk::<4>().expect("4 K values");
            let r = kernel::<K>(std::array::from_fn(|i| load_unaligned_m256d(&four(xc, i))), constants);
            for (i, [s, c]) in r.into_iter().enumerate() {
                store_unaligned_m256d(sc[4 * i..].first_chunk_mut::<4>().expect("4 K values"), s);
                store_unaligned_m256d(cc[4 * i..].first_chunk_mut::<4>().expect("4 K values"), c);
            }
        }
        whole
    }

    /// The first multiple of 4 of the angles (|x| < [`super::REDUCED_MAX`]), 16 at a time (four
    /// interleaved groups: fastest here, fewer leave the pipeline waiting, more spill registers), then 4;
    /// returns how many it did.
    #[inline(always)]
    pub(super) fn sin_cos_reduced_slices(x: &[f64], sn: &mut [f64], cs: &mut [f64]) -> usize {
        let constants = std::hint::black_box(&CONSTANTS);
        let done = groups::<4>(x, sn, cs, constants);
        done + groups::<1>(&x[done..], &mut sn[done..], &mut cs[done..], constants)
    }
}

/// Without AVX2 (or with AVX-512, where the compiler's loop runs on eight lanes), the compiler's loop.
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2", target_feature = "fma", not(target_feature = "avx512f"))))]
mod avx {
    #[inline(always)]
    pub(super) fn sin_cos_reduced_slices(_: &[f64], _: &mut [f64], _: &mut [f64]) -> usize {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::{sin_cos, sin_cos_lanes, sin_cos_slices};

    /// Distance in units in the last place of two values of the same sign.
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        (a.to_bits() as i64).abs_diff(b.to_bits() as i64)
    }

    #[test]
    fn sin_cos_matches_libm_to_an_ulp() {
        let mut worst_abs: f64 = 0.0;
        let mut worst_ulp = 0;
        let mut check = |y: f64| {
            let ((s, c), (s0, c0)) = (sin_cos(y), y.sin_cos());
            worst_abs = worst_abs.max((s - s0).abs()).max((c - c0).abs());
            // in ulp of the value where it is not small (near a zero, the absolute bound above is the measure)
            for (v, v0) in [(s, s0), (c, c0)] {
                if v0.abs() >= 1e-3 {
                    worst_ulp = worst_ulp.max(ulps(v, v0));
                }
            }
        };
        let mut x = -2.0e5;
        while x < 2.0e5 {
            for y in [x, x * 1e-3, x * 1e-6, x * 1e-9] {
                check(y);
            }
            x += 0.987654321;
        }
        for k in -1000..1000 {
            // near multiples of pi/2, where the reduction cancels
            check(k as f64 * std::f64::consts::FRAC_PI_2);
        }
        assert!(worst_abs <= 2.3e-16, "worst absolute difference {worst_abs:e}");
        assert!(worst_ulp <= 1, "worst difference {worst_ulp} ulp");
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!(sin_cos(f64::NAN).0.is_nan() && sin_cos(f64::INFINITY).1.is_nan());
    }

    #[test]
    fn lanes_equal_the_scalar_kernel_bit_for_bit() {
        for big in [false, true] {
            let mut x = [0.0; 8];
            for (l, v) in x.iter_mut().enumerate() {
                *v = (l as f64 - 3.5) * 0.917;
            }
            if big {
                x[5] = 3.0e5;
            }
            let (s, c) = sin_cos_lanes(&x);
            for l in 0..8 {
                assert_eq!((s[l].to_bits(), c[l].to_bits()), (sin_cos(x[l]).0.to_bits(), sin_cos(x[l]).1.to_bits()));
            }
        }
    }

    #[test]
    fn slices_equal_the_scalar_kernel_bit_for_bit() {
        // every length up to 40 (the interleaved groups of 16, the groups of 4 and the rest), then a long
        // slice of angles spread over the reduced range and angles near multiples of pi/2
        let mut angles: Vec<f64> = (0..4000).map(|k| (k as f64 * 0.7548776662466927).fract() * 2.0e5 - 1.0e5).collect();
        angles.extend((-500..500).flat_map(|k| [-1e-9, 0.0, 3e-16].map(|d| k as f64 * std::f64::consts::FRAC_PI_2 + d)));
        angles.extend((0..400).map(|k| (k as f64 - 200.0) * 0.0173));
        for len in (0..=40).chain([angles.len()]) {
            let x = &angles[angles.len() - len..];
            let (mut sn, mut cs) = (vec![0.0; len], vec![0.0; len]);
            sin_cos_slices(x, &mut sn, &mut cs);
            for (i, &xi) in x.iter().enumerate() {
                let (s, c) = sin_cos(xi);
                assert_eq!((sn[i].to_bits(), cs[i].to_bits()), (s.to_bits(), c.to_bits()), "x = {xi:e}, length {len}");
            }
        }
    }

    #[test]
    fn sin_cos_matches_libm() {
        let mut worst: f64 = 0.0;
        let mut x = -50.0;
        while x < 50.0 {
            let (s, c) = sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
            x += 0.000_731;
        }
        for k in -20..=20 {
            for d in [-1e-12, 0.0, 1e-12] {
                let x = k as f64 * std::f64::consts::FRAC_PI_2 + d;
                let (s, c) = sin_cos(x);
                worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
            }
        }
        assert!(worst < 2.3e-16, "worst {worst:e}");
        for x in [1e6, -3e7, f64::INFINITY, f64::NAN] {
            let (s, c) = sin_cos(x);
            let (s0, c0) = x.sin_cos();
            assert!(s.to_bits() == s0.to_bits() && c.to_bits() == c0.to_bits());
        }
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        // the lanes are the scalar function, bit for bit
        let x: [f64; 8] = std::array::from_fn(|l| -7.3 + 2.1 * l as f64);
        let (s, c) = sin_cos_lanes(&x);
        for l in 0..8 {
            assert_eq!((s[l].to_bits(), c[l].to_bits()), (sin_cos(x[l]).0.to_bits(), sin_cos(x[l]).1.to_bits()));
        }
    }
}
