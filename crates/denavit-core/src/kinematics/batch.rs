//! The batch kernels ([`fk_batch`], [`jacobian_batch`]): rows in blocks of [`BLOCK`] configurations
//! in structure-of-arrays form, chunks of [`CHUNK`] rows in parallel ([`crate::parallel`]), the last rows and
//! small batches through the single-configuration path.

use super::*;

/// Configurations per structure-of-arrays block of the batch kernels: every step of the chain is a loop over
/// the block's configurations with a straight-line body, which the compiler vectorises at the machine's full
/// width (4 or 8 lanes) with fused multiply-adds; a block's frames (6 KB) stay in the L1 cache.
pub(super) const BLOCK: usize = 64;

/// Rows of a batch per parallel work item (a multiple of [`BLOCK`]).
pub(super) const CHUNK: usize = 1024;

/// One quantity of a block's configurations.
pub(super) type V = [f64; BLOCK];

/// The last rows of a batch up to this many go through the single-configuration path one by one (the same
/// values bit for bit) instead of a block padded to [`BLOCK`] rows: a one-row batch had cost a whole block.
pub(super) const TAIL_ROWS: usize = 16;

/// What [`block_of`] made of a block's joint values.
pub(super) enum Rows<'a> {
    /// The block to compute (`BLOCK` rows of joint values).
    Block(&'a [f64]),
    /// Each row written by the single-configuration path.
    Written,
    /// A joint value is not finite.
    NotFinite,
}

/// The block of joint values `qb` (`BLOCK` rows of `n`, or the batch's last rows): `qb` itself when whole;
/// the last rows padded with zeros into `padded`; or, up to [`TAIL_ROWS`] rows, each row of `out` written
/// by `one(q_row, out_row)`.
#[inline(always)]
pub(super) fn block_of<'a>(qb: &'a [f64], n: usize, padded: &'a mut Vec<f64>, out: &mut [f64], one: impl Fn(&[f64], &mut [f64])) -> Rows<'a> {
    let rows = qb.len() / n;
    if rows == BLOCK {
        return Rows::Block(qb);
    }
    if rows > TAIL_ROWS {
        padded.resize(BLOCK * n, 0.0);
        padded[..qb.len()].copy_from_slice(qb);
        return Rows::Block(padded);
    }
    // (the batch's error names the first non-finite value of all rows: this block's own is dropped)
    match small_batch(qb, n, out, out.len() / rows, one) {
        Ok(()) => Rows::Written,
        Err(_) => Rows::NotFinite,
    }
}

/// Rows through the single-configuration path (`qs`: rows of `n`; `out`: rows of `per_row`), each row of
/// `out` written by `one(q_row, out_row)` once all are known finite: a whole batch of up to [`TAIL_ROWS`]
/// rows, without a block's workspace or the chain's factors (a one-row batch had spent half its time
/// allocating them), and the last rows of a bigger one ([`block_of`]).
pub(super) fn small_batch(qs: &[f64], n: usize, out: &mut [f64], per_row: usize, one: impl Fn(&[f64], &mut [f64])) -> Result<()> {
    crate::error::check_finite_rows("q", qs, n)?;
    for (q, o) in qs.chunks_exact(n).zip(out.chunks_exact_mut(per_row)) {
        one(q, o);
    }
    Ok(())
}

/// The workspace of a block: its frames, the joint values and their sines and cosines, and (for the
/// Jacobian, `per_row` values per configuration) the block's results, written here (in the L1 cache) and
/// then copied to the caller's array at once: element by element into memory that is not in the cache, the
/// Jacobian's scattered stores would wait on the memory, 8 bytes at a time.
pub(super) struct Block {
    pub(super) c: Frames,
    /// `s[joint][configuration]`: the joint values plus the offsets; `sn`, `cs` their sines and cosines.
    pub(super) s: Vec<V>,
    pub(super) sn: Vec<V>,
    pub(super) cs: Vec<V>,
    pub(super) stage: Vec<f64>,
    /// Whether the block's results go out with streaming stores ([`crate::stream::wanted`] of the batch's output).
    pub(super) stream: bool,
}

impl Block {
    fn new(n: usize, per_row: usize, stream: bool) -> Box<Self> {
        let v = || vec![[0.0; BLOCK]; n.max(1)];
        Box::new(Self { c: [[[0.0; BLOCK]; 3]; 4], s: v(), sn: v(), cs: v(), stage: vec![0.0; per_row * BLOCK], stream })
    }
}

/// The joint values of a block of configurations (`qb`: BLOCK x n row-major; `N` > 0 promises n == N, so
/// that the transposition of `qb` has a constant stride) plus the offsets into `s[joint][configuration]`.
/// False if a value of `qb` is not finite.
#[inline(always)]
#[must_use]
pub(super) fn load_block<const N: usize>(model: &Model, qb: &[f64], s: &mut [V]) -> bool {
    let n = if N > 0 { N } else { model.nq() };
    let (qb, joints, s) = (&qb[..BLOCK * n], &model.joints()[..n], &mut s[..n]);
    // the transposition, once per block, and the finiteness check in the same pass (`x * 0` is NaN
    // exactly for an infinite or NaN `x`)
    let mut bad = [0.0f64; BLOCK];
    for l in 0..BLOCK {
        for i in 0..n {
            let v = qb[l * n + i];
            bad[l] += v * 0.0;
            s[i][l] = v + joints[i].offset;
        }
    }
    bad.iter().all(|b| *b == 0.0)
}

/// The joint angles of a block (as [`load_block`]) and their sines and cosines, every joint's in one pass (no
/// short remainder per joint), for the one-pass chains of revolute joints. False if a value of `qb` is not
/// finite: looked for only when an angle falls out of the sine kernel's reduced range, as a non-finite one does
/// (no check in the transposition; docs/speed.md).
#[inline(always)]
#[must_use]
pub(super) fn load_angles<const N: usize>(model: &Model, qb: &[f64], w: &mut Block) -> bool {
    let n = if N > 0 { N } else { model.nq() };
    let (qb, joints, s) = (&qb[..BLOCK * n], &model.joints()[..n], &mut w.s[..n]);
    for l in 0..BLOCK {
        for i in 0..n {
            s[i][l] = qb[l * n + i] + joints[i].offset;
        }
    }
    sin_cos_slices(s.as_flattened(), w.sn[..n].as_flattened_mut(), w.cs[..n].as_flattened_mut()) || qb.iter().all(|v| v.is_finite())
}

/// The joint frames of a block of configurations (`qb`: BLOCK x n row-major; `N` > 0 promises n == N, so
/// that the transposition of `qb` has a constant stride), joints 1..=`cols`, each handed to
/// `each(i, frames)`; `w.c` ends as the frame of joint `cols`. False (and nothing computed) if a value of
/// `qb` is not finite.
#[inline(always)]
#[must_use]
pub(super) fn walk_block<const N: usize>(model: &Model, chain: &Chain, qb: &[f64], cols: usize, w: &mut Block, mut each: impl FnMut(usize, &Frames)) -> bool {
    if !load_block::<N>(model, qb, &mut w.s) {
        return false;
    }
    for (i, j) in model.joints().iter().enumerate().take(cols) {
        let s = &w.s[i];
        let motion = if j.kind == JointKind::Revolute {
            sin_cos_slices(s, &mut w.sn[0], &mut w.cs[0]);
            MOTION_RZ
        } else {
            MOTION_TZ
        };
        if i == 0 {
            // the first joint's frame before its motion is the same for every configuration
            for (ck, fk) in w.c.iter_mut().zip(&chain.first.c) {
                for (ckr, v) in ck.iter_mut().zip(fk) {
                    ckr.fill(*v);
                }
            }
            step_factor(&mut w.c, &IDENTITY, motion, s, &w.sn[0], &w.cs[0]);
        } else {
            step_factor(&mut w.c, &chain.factors[i - 1], motion, s, &w.sn[0], &w.cs[0]);
        }
        each(i, &w.c);
    }
    true
}

/// The identity as a [`Factor`].
pub(super) const IDENTITY: Factor = Factor { b: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0; 3]], rot: ROT_IDENTITY, origin: 0 };

/// Write a block's frames as row-major 4x4 matrices (`out`: up to BLOCK x 16), four configurations at a
/// time by 4x4 transposes.
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
#[inline(always)]
pub(super) fn write_block(c: &Frames, out: &mut [f64]) {
    let base = 4 * (out.len() / 64);
    let mut groups = out.chunks_exact_mut(64);
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx"))]
    for (g, o) in (&mut groups).enumerate() {
        // the transposes in AVX shuffles (the compiler's own code moved the values one by one): per row r
        // of four configurations, the unpacks pair (x, y) and (z, p) of configurations 0/2 and 1/3, the
        // 128-bit permutes join the pairs into the four rows, each stored whole
        use safe_arch::{load_unaligned_m256d as load, permute2z_m256d as join, store_unaligned_m256d as store};
        use safe_arch::{unpack_hi_m256d as hi, unpack_lo_m256d as lo};
        let l0 = 4 * g;
        let load4 = |j: usize, r: usize| c[j][r][l0..].first_chunk::<4>().map_or(safe_arch::zeroed_m256d(), load);
        for r in 0..3 {
            let (x, y, z, p) = (load4(0, r), load4(1, r), load4(2, r), load4(3, r));
            let (xy0, xy1, zp0, zp1) = (lo(x, y), hi(x, y), lo(z, p), hi(z, p));
            let rows = [join::<0x20>(xy0, zp0), join::<0x20>(xy1, zp1), join::<0x31>(xy0, zp0), join::<0x31>(xy1, zp1)];
            for (i, row) in rows.into_iter().enumerate() {
                if let Some(d) = o[16 * i + 4 * r..].first_chunk_mut::<4>() {
                    store(d, row);
                }
            }
        }
        for i in 0..4 {
            o[16 * i + 12..16 * i + 16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        }
    }
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx")))]
    for (g, o) in (&mut groups).enumerate() {
        let l0 = 4 * g;
        for r in 0..3 {
            // m[j][i]: column j, row r of configuration l0 + i
            let m: [[f64; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| c[j][r][l0 + i]));
            for i in 0..4 {
                o[16 * i + 4 * r..16 * i + 4 * r + 4].copy_from_slice(&[m[0][i], m[1][i], m[2][i], m[3][i]]);
            }
        }
        for i in 0..4 {
            o[16 * i + 12..16 * i + 16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        }
    }
    for (i, o) in groups.into_remainder().chunks_exact_mut(16).enumerate() {
        for r in 0..3 {
            for j in 0..4 {
                o[4 * r + j] = c[j][r][base + i];
            }
        }
        o[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
}

/// [`write_block`] with streaming stores ([`crate::stream`]), two configurations at a time by 2x2
/// transposes in 128-bit registers (no lane-crossing shuffles), each configuration's 16 values stored in
/// order so that its cache lines fill whole in the write-combining buffers.
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx512f")))]
#[inline(always)]
pub(super) fn write_block_streamed(c: &Frames, out: &mut [f64]) {
    use safe_arch::{load_unaligned_m128d as load, m128d, set_m128d as set, unpack_high_m128d as hi, unpack_low_m128d as lo};
    let base = 2 * (out.len() / 32);
    let mut pairs = out.chunks_exact_mut(32);
    for (g, o) in (&mut pairs).enumerate() {
        let l0 = 2 * g;
        let load2 = |j: usize, r: usize| c[j][r][l0..].first_chunk::<2>().map_or(safe_arch::zeroed_m128d(), load);
        // rows[i][r]: row r of configuration l0 + i as two halves, then the bottom row
        let mut rows = [[(safe_arch::zeroed_m128d(), safe_arch::zeroed_m128d()); 4]; 2];
        for r in 0..3 {
            let (x, y, z, p) = (load2(0, r), load2(1, r), load2(2, r), load2(3, r));
            rows[0][r] = (lo(x, y), lo(z, p));
            rows[1][r] = (hi(x, y), hi(z, p));
        }
        let bottom: (m128d, m128d) = (safe_arch::zeroed_m128d(), set(1.0, 0.0));
        rows[0][3] = bottom;
        rows[1][3] = bottom;
        // configuration k / 8, row (k % 8) / 2, its first or second half
        crate::stream::pairs(o, 16, |k| {
            let (a, b) = rows[k / 8][(k % 8) / 2];
            if k % 2 == 0 { a } else { b }
        });
    }
    for (i, o) in pairs.into_remainder().chunks_exact_mut(16).enumerate() {
        for r in 0..3 {
            for j in 0..4 {
                o[4 * r + j] = c[j][r][base + i];
            }
        }
        o[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
}

/// Tool poses of the rows of one chunk (`q`: rows x n, `out`: rows x 16), a block at a time, the last
/// block padded.
#[inline(never)]
pub(super) fn fk_chunk<const N: usize>(model: &Model, chain: &Chain, q: &[f64], w: &mut Block, out: &mut [f64]) -> bool {
    let n = model.nq();
    let tool = &chain.factors[n - 1];
    let mut padded = Vec::new();
    let mut writer = Writer::new(out, w.stream);
    for (k, qb) in q.chunks(BLOCK * n).enumerate() {
        let (row, rows) = (k * BLOCK, qb.len() / n);
        let qb = match block_of(qb, n, &mut padded, &mut out[16 * row..16 * (row + rows)], |qr, o| write_pose(&fk_unchecked(model, qr), o)) {
            Rows::Block(qb) => qb,
            Rows::Written => continue,
            Rows::NotFinite => return false,
        };
        match chain.about_x {
            true if N > 0 => {
                if !load_angles::<N>(model, qb, w) {
                    return false;
                }
                let (first, f, sn, cs) = (&chain.first, &chain.factors, &w.sn, &w.cs);
                revolute_about_x::<N>(first, f, tool, sn, cs, |g, frame| writer.put(&mut w.c, out, row, rows, g, frame));
                writer.block_done(&w.c, out, row, rows);
            }
            _ => {
                if !walk_block::<N>(model, chain, qb, n, w, |_, _| {}) {
                    return false;
                }
                // the tool group by group, as in the one-pass chain
                for g in 0..BLOCK / LANES {
                    let frame: [[G; 3]; 4] = std::array::from_fn(|j| std::array::from_fn(|r| lanes(&w.c[j][r], g)));
                    writer.put(&mut w.c, out, row, rows, g, &times_factor(frame, tool));
                }
                writer.block_done(&w.c, out, row, rows);
            }
        }
    }
    writer.finish(out);
    true
}

/// Where a chunk's tool poses go, straight into the caller's array as whole rows in order (a copy through
/// an L1 stage cost a fifth of the time): with AVX-512, eight at a time in whole cache lines
/// ([`avx512::Lines`]); else a block's frames are gathered in the block's workspace and written four at a
/// time ([`write_block`], or [`write_block_streamed`] for an output bigger than the cache).
pub(super) struct Writer {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    pub(super) lines: avx512::Lines,
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
    pub(super) stream: bool,
}

impl Writer {
    fn new(out: &[f64], stream: bool) -> Self {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        return Self { lines: avx512::Lines::new(out, stream) };
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
        {
            let _ = out;
            Self { stream }
        }
    }

    /// The frames of group `g` of the block of rows `row..row + rows` (the group's lanes past the block's
    /// rows are padding); `c`: the block's frames.
    #[inline(always)]
    #[allow(unused_variables)]
    fn put(&mut self, c: &mut Frames, out: &mut [f64], row: usize, rows: usize, g: usize, frame: &[[G; 3]; 4]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        if LANES * g < rows {
            self.lines.put(out, row + LANES * g, frame, (rows - LANES * g).min(LANES));
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
        for (cj, fj) in c.iter_mut().zip(frame) {
            for (cr, fr) in cj.iter_mut().zip(fj) {
                cr[g * LANES..(g + 1) * LANES].copy_from_slice(fr);
            }
        }
    }

    /// The block of rows `row..row + rows` is computed (its frames in `c` where [`Writer::put`] keeps them).
    #[inline(always)]
    #[allow(unused_variables)]
    fn block_done(&mut self, c: &Frames, out: &mut [f64], row: usize, rows: usize) {
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
        {
            let ob = &mut out[16 * row..16 * (row + rows)];
            #[cfg(target_arch = "x86_64")]
            if self.stream {
                write_block_streamed(c, ob);
                return;
            }
            write_block(c, ob);
        }
    }

    #[inline(always)]
    #[allow(unused_variables)]
    fn finish(self, out: &mut [f64]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        self.lines.finish(out);
    }
}

/// The first non-finite value of a batch of rows of `n` (after a chunk found one: the error names the first
/// of all, by its row and its index in the row).
pub(super) fn non_finite(qs: &[f64], n: usize) -> Error {
    match crate::error::check_finite_rows("q", qs, n) {
        Err(e) => e,
        Ok(()) => Error::InvalidArgument { what: "q batch".into(), expected: "finite values".into(), got: "a non-finite value".into() },
    }
}

/// Batch tool poses: `qs` holds N configurations row-major (N x n), `out` N row-major 4x4 matrices (N x 16).
/// Runs on rayon's pool (or as [`crate::parallel::with_threads`] says), [`BLOCK`] configurations at a time
/// in structure-of-arrays form so that every operation is a SIMD one, with fused multiply-adds. Values must
/// be finite (checked block by block in the pass that reads them; after an error `out` is partly written).
/// Same values as [`fk`] up to the sign of zeros.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::{fk, fk_batch}};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs: Vec<f64> = (0..40).map(|k| 0.1 * k as f64).collect(); // 20 configurations
/// let mut out = vec![0.0; 20 * 16];
/// fk_batch(&m, &qs, &mut out).unwrap();
/// assert_eq!(out[16 * 7 + 3], fk(&m, &qs[14..16]).unwrap().translation.x);
/// ```
pub fn fk_batch(model: &Model, qs: &[f64], out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    let count = qs.len().checked_div(n).unwrap_or(out.len() / 16);
    check_len("q batch (N*n values)", count * n, qs.len())?;
    check_len("output (N*16 values)", count * 16, out.len())?;
    if n == 0 {
        let t = fk_unchecked(model, &[]);
        out.chunks_exact_mut(16).for_each(|o| write_pose(&t, o));
        return Ok(());
    }
    if count <= TAIL_ROWS {
        return small_batch(qs, n, out, 16, |q, o| write_pose(&fk_unchecked(model, q), o));
    }
    let chain = model.derived::<Chain>();
    let stream = crate::stream::wanted(out);
    crate::parallel::try_for_each_chunk_init(
        out,
        16 * CHUNK,
        || Block::new(n, 0, stream),
        |w, k, o| {
            let q = &qs[k * CHUNK * n..(k * CHUNK + o.len() / 16) * n];
            let finite = match n {
                6 => fk_chunk::<6>(model, chain, q, w, o),
                7 => fk_chunk::<7>(model, chain, q, w, o),
                _ => fk_chunk::<0>(model, chain, q, w, o),
            };
            if stream {
                crate::stream::fence();
            }
            if finite { Ok(()) } else { Err(non_finite(qs, n)) }
        },
    )
}

/// The workspace of the batch Jacobian: a block's frames and its joints' origins and z axes (`oz[joint]`:
/// `[o_x, o_y, o_z, z_x, z_y, z_z][configuration]`).
pub(super) struct JacobianWork {
    pub(super) block: Box<Block>,
    pub(super) oz: Vec<[V; 6]>,
    /// The block's Jacobians of [`jacobian_about_x`] (`jac[row * n + column][configuration]`).
    pub(super) jac: Vec<V>,
}

/// Jacobians (as [`jacobian_row_major_unchecked`]) of the rows of one chunk (`q`: rows x n, `out`: rows x 6n).
#[inline(never)]
pub(super) fn jacobian_chunk<const N: usize>(
    model: &Model,
    chain: &Chain,
    q: &[f64],
    frame: JacobianFrame,
    joint: Option<usize>,
    w: &mut JacobianWork,
    out: &mut [f64],
) -> bool {
    let n = model.nq();
    let cols = joint.map_or(n, |j| j + 1);
    let b = Frame::of(model.t_world_base());
    let base = [b.col(0), b.col(1), b.col(2)];
    let mut padded = Vec::new();
    for (qb, ob) in q.chunks(BLOCK * n).zip(out.chunks_mut(6 * n * BLOCK)) {
        let qb = match block_of(qb, n, &mut padded, ob, |qr, o| jacobian_row_major_unchecked(model, qr, frame, joint, o)) {
            Rows::Block(qb) => qb,
            Rows::Written => continue,
            Rows::NotFinite => return false,
        };
        if let (true, true, None) = (chain.about_x, N > 0, joint) {
            let b = &mut *w.block;
            if !load_angles::<N>(model, qb, b) {
                return false;
            }
            let (first, f, tool, sn, cs, jac) = (&chain.first, &chain.factors, &chain.factors[n - 1], &b.sn, &b.cs, &mut w.jac);
            match frame {
                JacobianFrame::LocalWorldAligned => jacobian_about_x::<N, FRAME_LWA>(first, f, tool, &base, sn, cs, jac),
                JacobianFrame::World => jacobian_about_x::<N, FRAME_WORLD>(first, f, tool, &base, sn, cs, jac),
                JacobianFrame::Base => jacobian_about_x::<N, FRAME_BASE>(first, f, tool, &base, sn, cs, jac),
                JacobianFrame::Local => jacobian_about_x::<N, FRAME_LOCAL>(first, f, tool, &base, sn, cs, jac),
            }
            #[cfg(target_arch = "x86_64")]
            if b.stream {
                write_jacobians_streamed::<N>(jac, ob);
                continue;
            }
            write_jacobians::<N>(jac, ob);
            continue;
        }
        let (b, oz) = (&mut *w.block, &mut w.oz);
        if !walk_block::<N>(model, chain, qb, cols, b, |i, c| oz[i] = [c[3][0], c[3][1], c[3][2], c[2][0], c[2][1], c[2][2]]) {
            return false;
        }
        if joint.is_none() {
            step_factor(&mut b.c, &chain.factors[n - 1], MOTION_NONE, &b.sn[0], &b.sn[0], &b.cs[0]);
        }
        let (c, stage) = (&b.c, &mut b.stage[..ob.len()]);
        let rows = ob.len() / (6 * n);
        for (k, j) in model.joints().iter().enumerate() {
            let ozk = &oz[k.min(cols - 1)];
            for l in 0..rows {
                let col = if k < cols {
                    let (o, z) = ([ozk[0][l], ozk[1][l], ozk[2][l]], [ozk[3][l], ozk[4][l], ozk[5][l]]);
                    let p = [c[3][0][l], c[3][1][l], c[3][2][l]];
                    let (v, w) = match j.kind {
                        JointKind::Revolute if frame == JacobianFrame::World => (cross(o, z), z),
                        JointKind::Revolute => (cross(z, [p[0] - o[0], p[1] - o[1], p[2] - o[2]]), z),
                        JointKind::Prismatic => (z, [0.0; 3]),
                    };
                    let axes = match frame {
                        JacobianFrame::Local => {
                            Some([[c[0][0][l], c[0][1][l], c[0][2][l]], [c[1][0][l], c[1][1][l], c[1][2][l]], [c[2][0][l], c[2][1][l], c[2][2][l]]])
                        }
                        JacobianFrame::Base => Some(base),
                        _ => None,
                    };
                    match axes {
                        None => [v[0], v[1], v[2], w[0], w[1], w[2]],
                        // R^T v: the rows of R^T are the columns of R
                        Some(a) => [dot(a[0], v), dot(a[1], v), dot(a[2], v), dot(a[0], w), dot(a[1], w), dot(a[2], w)],
                    }
                } else {
                    [0.0; 6]
                };
                for (r, v) in col.iter().enumerate() {
                    stage[6 * n * l + r * n + k] = *v;
                }
            }
        }
        ob.copy_from_slice(stage);
    }
    true
}

/// Batch Jacobians of the tool (`joint = None`) or of joint frame `joint` (0-based): `out` holds N row-major
/// 6 x n matrices (N x 6n), in `frame`; the values of [`jacobian_row_major_unchecked`] (up to the sign of
/// zeros), [`BLOCK`] configurations at a time as in [`fk_batch`].
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::{jacobian_batch, jacobian_row_major_unchecked, JacobianFrame}};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs: Vec<f64> = (0..22).map(|k| 0.1 * k as f64).collect(); // 11 configurations
/// let mut out = vec![0.0; 11 * 12];
/// jacobian_batch(&m, &qs, JacobianFrame::World, None, &mut out).unwrap();
/// let mut one = [0.0; 12];
/// jacobian_row_major_unchecked(&m, &qs[20..22], JacobianFrame::World, None, &mut one);
/// assert_eq!(&out[120..], &one);
/// ```
pub fn jacobian_batch(model: &Model, qs: &[f64], frame: JacobianFrame, joint: Option<usize>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    check_joint(model, joint)?;
    if n == 0 {
        return Ok(());
    }
    let count = qs.len() / n;
    check_len("q batch (N*n values)", count * n, qs.len())?;
    check_len("output (N*6n values)", count * 6 * n, out.len())?;
    if count <= TAIL_ROWS {
        return small_batch(qs, n, out, 6 * n, |q, o| jacobian_row_major_unchecked(model, q, frame, joint, o));
    }
    let chain = model.derived::<Chain>();
    let stream = crate::stream::wanted(out);
    crate::parallel::try_for_each_chunk_init(
        out,
        6 * n * CHUNK,
        || JacobianWork { block: Block::new(n, 6 * n, stream), oz: vec![[[0.0; BLOCK]; 6]; n], jac: vec![[0.0; BLOCK]; 6 * n] },
        |w, k, o| {
            let q = &qs[k * CHUNK * n..(k * CHUNK + o.len() / (6 * n)) * n];
            let finite = match n {
                6 => jacobian_chunk::<6>(model, chain, q, frame, joint, w, o),
                7 => jacobian_chunk::<7>(model, chain, q, frame, joint, w, o),
                _ => jacobian_chunk::<0>(model, chain, q, frame, joint, w, o),
            };
            if stream {
                crate::stream::fence();
            }
            if finite { Ok(()) } else { Err(non_finite(qs, n)) }
        },
    )
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    /// Outputs from the streaming threshold on are written with streaming stores (an aligned output) and
    /// equal, bit for bit, the plain stores' values (the same output one value off the alignment).
    #[test]
    fn streamed_outputs_equal_plain_ones() {
        use crate::spatial::Pose;
        use crate::{Convention, JointKind, Table};
        const H: f64 = std::f64::consts::FRAC_PI_2;
        // the KR5 of Hayat et al. (d, theta, a, alpha), and a 7th joint repeating the last row
        let kr5 = [0.4, 0.0, 0.18, -H, 0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 0.12, -H, 0.62, 0.0, 0.0, H, 0.0, 0.0, 0.0, -H, 0.115, 0.0, 0.0, 0.0];
        for n in [6, 7] {
            let p: Vec<f64> = (0..4 * n).map(|k| kr5[k.min(4 * 6 - 1 - (3 - k % 4))]).collect();
            let table = nalgebra::DMatrix::from_row_slice(n, 4, &p);
            let m = Table::new(Convention::Dh, table, vec![JointKind::Revolute; n], Pose::identity(), Pose::identity()).unwrap().to_model("m").unwrap();
            // an odd count past the threshold: the last block partial (more rows than the single path takes),
            // an unpaired last configuration
            let count = crate::stream::threshold() / (16 * 8) + 2 * super::BLOCK + super::TAIL_ROWS + 17;
            let qs: Vec<f64> = (0..count * n).map(|k| ((k as f64) * 0.618).sin() * 3.0).collect();
            for per in [16, 6 * n] {
                let buf = vec![0.0; per * count + 2];
                let start = buf.as_ptr().align_offset(16);
                let (mut streamed, mut plain) = (buf.clone(), buf);
                let (streamed, plain) = (&mut streamed[start..start + per * count], &mut plain[start + 1..start + 1 + per * count]);
                assert_eq!(crate::stream::wanted(streamed), cfg!(target_arch = "x86_64"));
                assert!(!crate::stream::wanted(plain));
                assert!(!crate::stream::with_plain_stores(|| crate::stream::wanted(streamed)));
                let run = |out: &mut [f64]| {
                    if per == 16 { super::fk_batch(&m, &qs, out) } else { super::jacobian_batch(&m, &qs, super::JacobianFrame::LocalWorldAligned, None, out) }
                };
                crate::parallel::with_threads(Some(2), || run(streamed)).unwrap().unwrap();
                crate::parallel::with_threads(Some(1), || run(plain)).unwrap().unwrap();
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert!(bits(streamed) == bits(plain), "n = {n}, {per} values per configuration");
            }
        }
    }

    /// The one-pass kernel of DH-like chains (6 and 7 joints, offsets in x and z only or in all three
    /// components), the identity tool skipped, and the joint-by-joint kernel of a chain with a prismatic
    /// joint: every row of a batch (whole blocks, then a padded block or last rows through the single path)
    /// equal to the single-configuration path (`==`: up to the sign of zeros), including a row beyond the
    /// fast sine's range.
    #[test]
    fn batch_kernels_equal_the_single_path() {
        use crate::spatial::{Pose, rx, ry, trans};
        use crate::{Convention, JointKind, Table};
        const H: f64 = std::f64::consts::FRAC_PI_2;
        let r = JointKind::Revolute;
        let base = trans(0.1, -0.2, 0.3) * rx(0.2);
        let cases = [
            // d, theta, a, alpha: offsets in x and z; a tool turned about a general axis
            (Convention::Dh, vec![0.4, 0.0, 0.18, -H, 0.0, 0.0, 0.6, 0.0, 0.0, -H, 0.12, -H], trans(0.01, 0.02, 0.1) * rx(0.3) * ry(-0.4)),
            (Convention::Dh, vec![0.4, 0.0, 0.18, -H, 0.0, 0.0, 0.6, 0.0, 0.0, -H, 0.12, -H], Pose::identity()),
            // alpha, a, theta, d: Rx(alpha) Tx(a) Tz(d) has an offset in y as well
            (Convention::Mdh, vec![0.0, 0.0, 0.0, 0.3, H, 0.1, -H, 0.15, 0.0, -0.4, 0.0, 0.0, 0.3, -0.39, 0.5, 0.1], trans(0.0, 0.0, 0.1)),
        ];
        let mut state = 7u64;
        let mut rand = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.0
        };
        for (convention, params, tool) in cases {
            let rows = params.len() / 4;
            for n in [6, 7] {
                // repeat the rows to n joints
                let p: Vec<f64> = (0..n).flat_map(|i| params[4 * (i % rows)..4 * (i % rows) + 4].to_vec()).collect();
                let table = nalgebra::DMatrix::from_row_slice(n, 4, &p);
                let mut kinds = vec![r; n];
                for prismatic in [false, true] {
                    if prismatic {
                        kinds[2] = JointKind::Prismatic;
                    }
                    let m = Table::new(convention, table.clone(), kinds.clone(), base, tool).unwrap().to_model("m").unwrap();
                    // the last rows: a padded block, or few enough for the single path (a one-row batch too)
                    for count in [2 * super::BLOCK + super::TAIL_ROWS + 9, 3 * super::BLOCK + 5, 1] {
                        let mut qs: Vec<f64> = (0..count * n).map(|_| rand()).collect();
                        if count > 70 {
                            qs[n * 70 + 1] = 3.0e5;
                        }
                        let mut out = vec![0.0; 16 * count];
                        crate::parallel::with_threads(Some(1), || super::fk_batch(&m, &qs, &mut out)).unwrap().unwrap();
                        // the same values at every offset from a cache line (whole lines cut from two matrices' values)
                        let mut shifted = vec![f64::NAN; 16 * count + 8];
                        for offset in 0..8 {
                            let o = &mut shifted[offset..offset + 16 * count];
                            crate::parallel::with_threads(Some(1), || super::fk_batch(&m, &qs, o)).unwrap().unwrap();
                            assert_eq!(o, &out, "{convention:?} n = {n} prismatic {prismatic}: the output {offset} values into the buffer");
                        }
                        for (q, o) in qs.chunks(n).zip(out.chunks(16)) {
                            let mut one = [0.0; 16];
                            // the joint-by-joint path (every product of every placement), and the single call
                            super::write_pose(&super::fk_walk(&m, q), &mut one);
                            assert_eq!(o, &one, "{convention:?} n = {n} prismatic {prismatic} q = {q:?}");
                            let mut single = [0.0; 16];
                            super::write_pose(&super::fk(&m, q).unwrap(), &mut single);
                            assert_eq!(single, one, "{convention:?} n = {n} prismatic {prismatic} q = {q:?}");
                        }
                        // the Jacobians (the one-pass kernel for the tool of a revolute chain, the joint-by-joint
                        // one for a joint frame), in every frame
                        for frame in
                            [super::JacobianFrame::LocalWorldAligned, super::JacobianFrame::World, super::JacobianFrame::Base, super::JacobianFrame::Local]
                        {
                            for joint in [None, Some(n - 3)] {
                                let mut jac = vec![0.0; 6 * n * count];
                                let run = || super::jacobian_batch(&m, &qs, frame, joint, &mut jac);
                                crate::parallel::with_threads(Some(1), run).unwrap().unwrap();
                                for (q, o) in qs.chunks(n).zip(jac.chunks(6 * n)) {
                                    let mut one = vec![0.0; 6 * n];
                                    super::jacobian_row_major_unchecked(&m, q, frame, joint, &mut one);
                                    assert_eq!(o, &one, "{convention:?} n = {n} prismatic {prismatic} {frame:?} {joint:?} q = {q:?}");
                                }
                            }
                        }
                    }
                    assert_eq!(super::Chain::of(&m).about_x, !prismatic);
                }
            }
        }
    }

    #[test]
    fn fused_jacobian_matches_data_jacobian() {
        use crate::spatial::{rx, trans};
        use crate::{Data, Joint, JointKind, Model};
        let joints = vec![
            Joint::new("a", JointKind::Revolute, rx(0.3) * trans(0.1, 0.2, 0.3)),
            Joint::new("b", JointKind::Prismatic, rx(-1.1) * trans(0.0, 0.4, 0.1)),
            Joint::new("c", JointKind::Revolute, rx(0.7) * trans(0.3, 0.0, -0.2)),
        ];
        let m = Model::new("m", trans(0.1, 0.0, 0.2) * rx(0.2), joints, trans(0.0, 0.1, 0.2), rx(0.4)).unwrap();
        let q = [0.4, 0.2, -0.9];
        let mut d = Data::new(&m);
        super::jacobian(&m, &mut d, &q, super::JacobianFrame::LocalWorldAligned).unwrap();
        let mut jac = vec![0.0; 18];
        let t = super::fk_and_jacobian(&m, &q, &mut jac);
        assert_eq!(jac.as_slice(), d.jacobian.as_slice());
        assert_eq!(t, d.t_world_tool);
        // the row-major form of the bindings, in both frames
        for frame in [super::JacobianFrame::World, super::JacobianFrame::LocalWorldAligned, super::JacobianFrame::Base, super::JacobianFrame::Local] {
            super::jacobian(&m, &mut d, &q, frame).unwrap();
            let mut rm = vec![0.0; 18];
            super::jacobian_row_major_unchecked(&m, &q, frame, None, &mut rm);
            for r in 0..6 {
                for c in 0..3 {
                    assert!((rm[r * 3 + c] - d.jacobian[(r, c)]).abs() < 1e-15, "{r} {c}");
                }
            }
        }
    }
}
