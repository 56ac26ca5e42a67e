//! The arithmetic of the batch kernels on a block's configurations, lane by lane: the one-pass chains of
//! revolute about-x chains ([`revolute_about_x`], [`jacobian_about_x`]), the joint-by-joint [`step`]s of other
//! chains, and the writers of Jacobian blocks.

use super::*;

/// Configurations per group of the one-pass chains: the lanes of one vector register.
#[cfg(target_feature = "avx512f")]
pub(super) const LANES: usize = 8;
#[cfg(not(target_feature = "avx512f"))]
pub(super) const LANES: usize = 4;

/// One quantity of a group of configurations (a vector register).
pub(super) type G = [f64; LANES];

/// The lanes of group `g` of a block's quantity.
#[inline(always)]
pub(super) fn lanes(v: &V, g: usize) -> G {
    std::array::from_fn(|i| v[g * LANES + i])
}

/// `a * b + c` lane by lane, fused.
#[inline(always)]
pub(super) fn fma<const L: usize>(a: &[f64; L], b: &[f64; L], c: &[f64; L]) -> [f64; L] {
    std::array::from_fn(|i| a[i].mul_add(b[i], c[i]))
}

/// `a * b + c` lane by lane with a constant `b`, fused.
#[inline(always)]
pub(super) fn fma_by<const L: usize>(a: &[f64; L], b: f64, c: &[f64; L]) -> [f64; L] {
    std::array::from_fn(|i| a[i].mul_add(b, c[i]))
}

/// A vector of groups negated.
#[inline(always)]
pub(super) fn negated<const L: usize>(a: &[[f64; L]; 3]) -> [[f64; L]; 3] {
    a.map(|v| v.map(|x| -x))
}

/// The tool frames of a block for a chain of `N` revolute joints whose placements 2..N rotate about x only
/// (`factors`: those placements; `tool`: the tool's factor; `sn`, `cs`: the sines and cosines of the joint
/// angles, per joint), the whole chain in one pass over the configurations, a group of [`LANES`] at a time,
/// the frame in registers (the joint-by-joint [`step`]s store and reload it at every joint), each group's
/// frames handed to `put(group, frames)`.
#[inline(always)]
pub(super) fn revolute_about_x<const N: usize>(first: &Frame, factors: &[Factor], tool: &Factor, sn: &[V], cs: &[V], mut put: impl FnMut(usize, &[[G; 3]; 4])) {
    let (factors, sn, cs) = (&factors[..N - 1], &sn[..N], &cs[..N]);
    for g in 0..BLOCK / LANES {
        let frame = chain_about_x(first, factors, |i| (lanes(&sn[i], g), lanes(&cs[i], g)), |_, _, _| {});
        put(g, &times_factor(frame, tool));
    }
}

/// `frame · f` for a constant factor (the tool) in registers, for both batch chains: the arithmetic of
/// [`step`] with `MOTION_NONE`, the terms the factor's exact zeros and ones make vanish left out.
#[inline(always)]
pub(super) fn times_factor<const L: usize>(frame: [[[f64; L]; 3]; 4], f: &Factor) -> [[[f64; L]; 3]; 4] {
    let [x, y, z, mut p] = frame;
    let (a, b) = ([x, y, z], &f.b);
    let scaled = |v: &[f64; L], k: f64| v.map(|x| x * k);
    let dense = |j: usize| -> [[f64; L]; 3] { std::array::from_fn(|r| fma_by(&a[2][r], b[j][2], &fma_by(&a[1][r], b[j][1], &scaled(&a[0][r], b[j][0])))) };
    let yz = |j: usize| -> [[f64; L]; 3] { std::array::from_fn(|r| fma_by(&a[2][r], b[j][2], &scaled(&a[1][r], b[j][1]))) };
    let [x, y, z] = match f.rot {
        ROT_IDENTITY => a,
        ROT_ABOUT_X | ROT_QUARTER_X => [a[0], yz(1), yz(2)],
        _ => [dense(0), dense(1), dense(2)],
    };
    for k in 0..3 {
        if f.origin & (1 << k) != 0 {
            p = std::array::from_fn(|r| fma_by(&a[k][r], b[3][k], &p[r]));
        }
    }
    [x, y, z, p]
}

/// The body of [`revolute_about_x`] for group `g` of a block: the frame of the last joint (x, y, z axes
/// and origin, rows of groups), each joint's z axis and origin handed to `each(joint, z, p)` on the way.
/// The arithmetic of [`step`] with `ROT_ABOUT_X` without the terms a placement's exact zeros and ones
/// make vanish, chosen joint by joint (its rotation class and origin components): the same values up to
/// the sign of zeros. The choices are the same for every group, so their branches are predicted.
#[inline(always)]
pub(super) fn chain_about_x<const L: usize>(
    first: &Frame,
    factors: &[Factor],
    sin_cos: impl Fn(usize) -> ([f64; L], [f64; L]),
    mut each: impl FnMut(usize, &[[f64; L]; 3], &[[f64; L]; 3]),
) -> [[[f64; L]; 3]; 4] {
    let f = &first.c;
    // joint 1: the first frame, the same for every configuration, turned
    let (s, k) = sin_cos(0);
    let mut x: [[f64; L]; 3] = std::array::from_fn(|r| fma_by(&k, f[0][r], &s.map(|v| v * f[1][r])));
    let mut y: [[f64; L]; 3] = std::array::from_fn(|r| fma_by(&k, f[1][r], &s.map(|v| -(v * f[0][r]))));
    let mut z: [[f64; L]; 3] = std::array::from_fn(|r| [f[2][r]; L]);
    let mut p: [[f64; L]; 3] = std::array::from_fn(|r| [f[3][r]; L]);
    each(0, &z, &p);
    for (i, fi) in factors.iter().enumerate() {
        let b = &fi.b;
        let a = [x, y, z];
        for k in 0..3 {
            if fi.origin & (1 << k) != 0 {
                p = std::array::from_fn(|r| fma_by(&a[k][r], b[3][k], &p[r]));
            }
        }
        // the y axis turned about x; z in place
        let y1 = match fi.rot {
            ROT_IDENTITY => y,
            // (y, z) -> (z, -y) for +90 deg, (-z, y) for -90 deg
            ROT_QUARTER_X if b[1][2] > 0.0 => {
                z = negated(&a[1]);
                a[2]
            }
            ROT_QUARTER_X => {
                z = a[1];
                negated(&a[2])
            }
            _ => {
                z = std::array::from_fn(|r| fma_by(&a[2][r], b[2][2], &a[1][r].map(|v| v * b[2][1])));
                std::array::from_fn(|r| fma_by(&a[2][r], b[1][2], &a[1][r].map(|v| v * b[1][1])))
            }
        };
        let (s, k) = sin_cos(i + 1);
        y = std::array::from_fn(|r| fma(&k, &y1[r], &std::array::from_fn(|l| -(s[l] * x[r][l]))));
        x = std::array::from_fn(|r| fma(&k, &x[r], &std::array::from_fn(|l| s[l] * y1[r][l])));
        each(i + 1, &z, &p);
    }
    [x, y, z, p]
}

/// The frames of [`jacobian_about_x`]'s const parameter, as [`JacobianFrame`].
pub(super) const FRAME_LWA: u8 = 0;
pub(super) const FRAME_WORLD: u8 = 1;
pub(super) const FRAME_BASE: u8 = 2;
pub(super) const FRAME_LOCAL: u8 = 3;

pub(super) const fn frame_of(f: u8) -> JacobianFrame {
    match f {
        FRAME_WORLD => JacobianFrame::World,
        FRAME_BASE => JacobianFrame::Base,
        FRAME_LOCAL => JacobianFrame::Local,
        _ => JacobianFrame::LocalWorldAligned,
    }
}

/// The tool Jacobians of a block (into `jac[r * N + k]`: row r, column k; the frame `FRAME`) for the chains
/// of [`revolute_about_x`], in one pass over the configurations: the chain of a group in registers, each
/// joint's origin and z axis kept as the chain passes it, then per configuration of the group the tool
/// (`tool`, as [`Frame::mul`]) and the columns (as [`column`]: the values of
/// [`jacobian_row_major_unchecked`] up to the sign of zeros), stored lane by lane. `base`: the base frame's axes (for `FRAME_BASE`).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(super) fn jacobian_about_x<const N: usize, const FRAME: u8>(
    first: &Frame,
    factors: &[Factor],
    tool: &Factor,
    base: &[[f64; 3]; 3],
    sn: &[V],
    cs: &[V],
    jac: &mut [V],
) {
    let (factors, sn, cs, jac, b) = (&factors[..N - 1], &sn[..N], &cs[..N], &mut jac[..6 * N], &tool.b);
    let frame = frame_of(FRAME);
    for g in 0..BLOCK / LANES {
        let (mut og, mut zg) = ([[[0.0; LANES]; 3]; N], [[[0.0; LANES]; 3]; N]);
        let frame_g = chain_about_x(
            first,
            factors,
            |i| (lanes(&sn[i], g), lanes(&cs[i], g)),
            |i, zi, pi| {
                zg[i] = *zi;
                og[i] = *pi;
            },
        );
        for m in 0..LANES {
            let l = g * LANES + m;
            let lane = |v: &[G; 3]| -> [f64; 3] { std::array::from_fn(|r| v[r][m]) };
            let (o, zs): ([[f64; 3]; N], [[f64; 3]; N]) = (std::array::from_fn(|i| lane(&og[i])), std::array::from_fn(|i| lane(&zg[i])));
            let [x, y, z, p] = frame_g.each_ref().map(lane);
            let a = [x, y, z];
            let tp: [f64; 3] = std::array::from_fn(|r| a[2][r].mul_add(b[3][2], a[1][r].mul_add(b[3][1], a[0][r].mul_add(b[3][0], p[r]))));
            let axes: Option<[[f64; 3]; 3]> = match FRAME {
                FRAME_LOCAL => Some(std::array::from_fn(|j| std::array::from_fn(|r| a[2][r].mul_add(b[j][2], a[1][r].mul_add(b[j][1], a[0][r] * b[j][0]))))),
                FRAME_BASE => Some(*base),
                _ => None,
            };
            for k in 0..N {
                let col = column(JointKind::Revolute, o[k], zs[k], tp, frame, axes.as_ref());
                for r in 0..6 {
                    jac[r * N + k][l] = col[r];
                }
            }
        }
    }
}

/// Write a block's Jacobians (`jac[i][configuration]`, `i` the index in the row-major 6 x n matrix) as
/// row-major matrices (`out`: up to BLOCK x 6n): four configurations at a time by transposes in AVX
/// shuffles where the build has AVX, the rest value by value.
#[inline(always)]
pub(super) fn write_jacobians<const N: usize>(jac: &[V], out: &mut [f64]) {
    let per = 6 * N;
    let done = write_jacobians_avx::<N>(jac, out);
    for (l, o) in out.chunks_exact_mut(per).enumerate().skip(done) {
        for (i, v) in o.iter_mut().enumerate() {
            *v = jac[i][l];
        }
    }
}

/// [`write_jacobians`] with streaming stores ([`crate::stream`]): two configurations at a time, each
/// configuration's 6n values (an even count) stored in order as pairs, from 2x2 transposes in 128-bit
/// registers.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn write_jacobians_streamed<const N: usize>(jac: &[V], out: &mut [f64]) {
    use safe_arch::{load_unaligned_m128d as load, unpack_high_m128d as hi, unpack_low_m128d as lo};
    let (per, jac) = (6 * N, &jac[..6 * N]);
    let done = 2 * (out.len() / (2 * per));
    let mut pairs = out.chunks_exact_mut(2 * per);
    for (g, o) in (&mut pairs).enumerate() {
        let l0 = 2 * g;
        let load2 = |i: usize| jac[i][l0..].first_chunk::<2>().map_or(safe_arch::zeroed_m128d(), load);
        let (first, second) = o.split_at_mut(per);
        crate::stream::pairs(first, per / 2, |i| lo(load2(2 * i), load2(2 * i + 1)));
        crate::stream::pairs(second, per / 2, |i| hi(load2(2 * i), load2(2 * i + 1)));
    }
    for (l, o) in pairs.into_remainder().chunks_exact_mut(per).enumerate() {
        for (i, v) in o.iter_mut().enumerate() {
            *v = jac[i][done + l];
        }
    }
}

/// The groups of four configurations of [`write_jacobians`]; returns the number of configurations written.
#[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx"))]
#[inline(always)]
pub(super) fn write_jacobians_avx<const N: usize>(jac: &[V], out: &mut [f64]) -> usize {
    use safe_arch::{cast_to_m128d_from_m256d as low, extract_m128d_from_m256d as high, store_unaligned_m128d as store2};
    use safe_arch::{load_unaligned_m256d as load, permute2z_m256d as join, store_unaligned_m256d as store};
    use safe_arch::{unpack_hi_m256d as hi, unpack_lo_m256d as lo};
    let (per, jac) = (6 * N, &jac[..6 * N]);
    let mut groups = out.chunks_exact_mut(4 * per);
    for (g, o) in (&mut groups).enumerate() {
        let l0 = 4 * g;
        let load4 = |i: usize| jac[i][l0..].first_chunk::<4>().map_or(safe_arch::zeroed_m256d(), load);
        for r in 0..6 {
            let i0 = N * r;
            let mut k = 0;
            // columns k..k+4 of row r of the four configurations: a 4x4 transpose
            while k + 4 <= N {
                let (a, b, c, d) = (load4(i0 + k), load4(i0 + k + 1), load4(i0 + k + 2), load4(i0 + k + 3));
                let (ab0, ab1, cd0, cd1) = (lo(a, b), hi(a, b), lo(c, d), hi(c, d));
                let rows = [join::<0x20>(ab0, cd0), join::<0x20>(ab1, cd1), join::<0x31>(ab0, cd0), join::<0x31>(ab1, cd1)];
                for (i, v) in rows.into_iter().enumerate() {
                    if let Some(d) = o[per * i + i0 + k..].first_chunk_mut::<4>() {
                        store(d, v);
                    }
                }
                k += 4;
            }
            // two columns: the unpacks' halves
            while k + 2 <= N {
                let (a, b) = (load4(i0 + k), load4(i0 + k + 1));
                let (ab0, ab1) = (lo(a, b), hi(a, b));
                let pairs = [low(ab0), low(ab1), high::<1>(ab0), high::<1>(ab1)];
                for (i, v) in pairs.into_iter().enumerate() {
                    if let Some(d) = o[per * i + i0 + k..].first_chunk_mut::<2>() {
                        store2(d, v);
                    }
                }
                k += 2;
            }
            if k < N {
                for i in 0..4 {
                    o[per * i + i0 + k] = jac[i0 + k][l0 + i];
                }
            }
        }
    }
    4 * (out.len() / (4 * per))
}

/// Without AVX: none (the caller writes every configuration value by value).
#[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx")))]
#[inline(always)]
pub(super) fn write_jacobians_avx<const N: usize>(_: &[V], _: &mut [f64]) -> usize {
    0
}

/// `c <- c · b · M(s)` for a block (`sn`, `cs`: the sines and cosines of `s` for `MOTION_RZ`): the
/// arithmetic of [`Frame::mul`] without the terms `ROT` and `ORIGIN` say are exact zeros or ones, then of
/// [`Frame::motion`].
#[inline(never)]
pub(super) fn step<const ROT: u8, const ORIGIN: u8, const MOTION: u8>(c: &mut Frames, b: &[[f64; 3]; 4], s: &V, sn: &V, cs: &V) {
    for l in 0..BLOCK {
        let a: [[f64; 3]; 4] = std::array::from_fn(|j| std::array::from_fn(|r| c[j][r][l]));
        let dense = |j: usize| -> [f64; 3] { std::array::from_fn(|r| a[2][r].mul_add(b[j][2], a[1][r].mul_add(b[j][1], a[0][r] * b[j][0]))) };
        let yz = |j: usize| -> [f64; 3] { std::array::from_fn(|r| a[2][r].mul_add(b[j][2], a[1][r] * b[j][1])) };
        let (mut x, mut y, z) = match ROT {
            ROT_IDENTITY => (a[0], a[1], a[2]),
            ROT_ABOUT_X => (a[0], yz(1), yz(2)),
            _ => (dense(0), dense(1), dense(2)),
        };
        let mut p = a[3];
        for k in 0..3 {
            if ORIGIN & (1 << k) != 0 {
                p = std::array::from_fn(|r| a[k][r].mul_add(b[3][k], p[r]));
            }
        }
        match MOTION {
            MOTION_RZ => {
                let (x0, y0) = (x, y);
                x = std::array::from_fn(|r| cs[l].mul_add(x0[r], sn[l] * y0[r]));
                y = std::array::from_fn(|r| cs[l].mul_add(y0[r], -(sn[l] * x0[r])));
            }
            MOTION_TZ => p = std::array::from_fn(|r| z[r].mul_add(s[l], p[r])),
            _ => {}
        }
        for r in 0..3 {
            c[0][r][l] = x[r];
            c[1][r][l] = y[r];
            c[2][r][l] = z[r];
            c[3][r][l] = p[r];
        }
    }
}

/// [`step`] for a factor known only at run time.
pub(super) fn step_factor(c: &mut Frames, f: &Factor, motion: u8, s: &V, sn: &V, cs: &V) {
    macro_rules! by_origin {
        ($rot:expr, $motion:expr) => {
            match f.origin {
                0 => step::<$rot, 0, $motion>(c, &f.b, s, sn, cs),
                1 => step::<$rot, 1, $motion>(c, &f.b, s, sn, cs),
                2 => step::<$rot, 2, $motion>(c, &f.b, s, sn, cs),
                3 => step::<$rot, 3, $motion>(c, &f.b, s, sn, cs),
                4 => step::<$rot, 4, $motion>(c, &f.b, s, sn, cs),
                5 => step::<$rot, 5, $motion>(c, &f.b, s, sn, cs),
                6 => step::<$rot, 6, $motion>(c, &f.b, s, sn, cs),
                _ => step::<$rot, 7, $motion>(c, &f.b, s, sn, cs),
            }
        };
    }
    macro_rules! by_rot {
        ($motion:expr) => {
            match f.rot {
                ROT_IDENTITY => by_origin!(ROT_IDENTITY, $motion),
                ROT_ABOUT_X | ROT_QUARTER_X => by_origin!(ROT_ABOUT_X, $motion),
                _ => by_origin!(ROT_GENERAL, $motion),
            }
        };
    }
    match motion {
        MOTION_RZ => by_rot!(MOTION_RZ),
        MOTION_TZ => by_rot!(MOTION_TZ),
        _ => by_rot!(MOTION_NONE),
    }
}
