//! The joints' ranges as the solvers use them ([`Bounds`]: projection, restarts' samples, wrist flips) and the
//! restarts' seeded generator.

use super::*;

/// SplitMix64 (Steele, Lea & Flood 2014): a small deterministic generator for restarts.
#[derive(Debug, Clone)]
pub(super) struct SplitMix64(pub(super) u64);

impl SplitMix64 {
    pub(super) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub(super) fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Seed of goal `index` of a batch or path.
pub(crate) fn mix_seed(seed: u64, index: u64) -> u64 {
    SplitMix64(seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03)).next_u64()
}

/// Per-joint data used by the projection and the restarts, and the model's wrist flips; derived from the
/// joints once per model (`Model::derived`).
#[derive(Debug, Clone)]
pub(crate) struct Bounds {
    pub(super) lower: Vec<f64>,
    pub(super) upper: Vec<f64>,
    pub(super) revolute: Vec<bool>,
    pub(super) offset: Vec<f64>,
    pub(super) sample_lo: Vec<f64>,
    pub(super) sample_hi: Vec<f64>,
    /// The first joints of the wrist flips ([`wrist_flips`]).
    pub(super) flips: Vec<usize>,
    /// The closed form of a recognised 6R structure (the seeds of the first attempt).
    pub(super) closed_form: Option<ClosedForm>,
    /// The semi-analytic form of a recognised 7R structure (the seeds of the first attempt).
    pub(super) redundant: Option<Redundant>,
}

impl crate::model::Derive for Bounds {
    const SLOT: usize = 1;
    fn derive(model: &Model) -> Self {
        Self::new(model)
    }
}

impl Bounds {
    pub(crate) fn new(model: &Model) -> Self {
        let n = model.nq();
        let mut b = Self {
            lower: Vec::with_capacity(n),
            upper: Vec::with_capacity(n),
            revolute: Vec::with_capacity(n),
            offset: Vec::with_capacity(n),
            sample_lo: Vec::with_capacity(n),
            sample_hi: Vec::with_capacity(n),
            flips: wrist_flips(model),
            closed_form: ClosedForm::new(model),
            redundant: Redundant::new(model),
        };
        for j in model.joints() {
            let (lo, hi, rev) = (j.lower, j.upper, j.kind == JointKind::Revolute);
            let w = if rev { PI } else { 1.0 };
            let (a, bb) = (lo.max(-w), hi.min(w));
            let (a, bb) = if a <= bb {
                (a, bb)
            } else if lo > w {
                (lo, hi.min(lo + 2.0 * w))
            } else {
                (lo.max(hi - 2.0 * w), hi)
            };
            b.lower.push(lo);
            b.upper.push(hi);
            b.revolute.push(rev);
            b.offset.push(j.offset);
            b.sample_lo.push(a);
            b.sample_hi.push(bb);
        }
        b
    }

    #[inline]
    pub(super) fn fits(&self, i: usize, v: f64) -> bool {
        v >= self.lower[i] && v <= self.upper[i]
    }

    /// `v`, or `v` shifted by a multiple of 2π into the range of revolute joint `i` when that exists.
    #[inline]
    pub(super) fn wrap(&self, i: usize, v: f64) -> f64 {
        if self.fits(i, v) || !self.revolute[i] || !self.lower[i].is_finite() {
            return v;
        }
        let shifted = v - TAU * ((v - self.lower[i]) / TAU).floor();
        if self.fits(i, shifted) { shifted } else { v }
    }

    /// Project `q` into the limits, first by moves that keep the tool pose: a revolute joint outside its range
    /// is shifted by a multiple of 2π when that brings it in; a wrist ([`wrist_flips`]) with a joint still
    /// outside is flipped when the flipped wrist is within its limits. What is still outside is clamped,
    /// after `reflect` has mirrored it at the limit it crossed (`2 upper - q`, `2 lower - q`, as in reflective
    /// Newton methods for bounds: Coleman & Li 1996).
    #[inline]
    pub(super) fn project(&self, q: &mut [f64], reflect: bool) {
        let mut inside = true;
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = self.wrap(i, *qi);
            inside &= self.fits(i, *qi);
        }
        if inside {
            return;
        }
        for &i in &self.flips {
            if (i..i + 3).all(|k| self.fits(k, q[k])) {
                continue;
            }
            let f = [self.wrap(i, q[i] + PI), self.wrap(i + 1, -q[i + 1] - 2.0 * self.offset[i + 1]), self.wrap(i + 2, q[i + 2] + PI)];
            if (0..3).all(|k| self.fits(i + k, f[k])) {
                q[i..i + 3].copy_from_slice(&f);
            }
        }
        for (i, qi) in q.iter_mut().enumerate() {
            let (lo, hi) = (self.lower[i], self.upper[i]);
            if self.fits(i, *qi) {
                continue;
            }
            if reflect {
                *qi = if *qi > hi { 2.0 * hi - *qi } else { 2.0 * lo - *qi };
            }
            *qi = qi.clamp(lo, hi);
        }
    }

    /// Place angle `v` of revolute joint `i` near `q0_i`: shifted by the multiple of 2π nearest to `q0_i` and,
    /// when `respect_limits`, then by ±2π if that brings it within its range; `None` if it is still outside
    /// (with `respect_limits`).
    #[inline]
    pub(super) fn place_joint(&self, i: usize, v: f64, q0_i: f64, respect_limits: bool) -> Option<f64> {
        let d = v - q0_i;
        let v = q0_i + (d - TAU * (d / TAU).round()); // the nearest to q0_i (fmod is slow)
        if !respect_limits || self.fits(i, v) {
            return Some(v);
        }
        // the other side of q0 first (the nearer of v ± 2π to q0)
        let (a, b) = if v > q0_i { (v - TAU, v + TAU) } else { (v + TAU, v - TAU) };
        [a, b].into_iter().find(|&x| self.fits(i, x))
    }

    pub(super) fn within(&self, q: &[f64]) -> bool {
        q.iter().enumerate().all(|(i, &v)| v >= self.lower[i] && v <= self.upper[i])
    }

    pub(super) fn sample(&self, rng: &mut SplitMix64, q: &mut [f64]) {
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = self.sample_lo[i] + (self.sample_hi[i] - self.sample_lo[i]) * rng.uniform();
        }
    }
}

/// The wrists of `model`: the joints `i` such that revolute joints `i, i+1, i+2` reach every pose of theirs twice,
/// `θ_i + π, -θ_(i+1), θ_(i+2) + π` (θ = q + offset) giving the tool pose of `θ_i, θ_(i+1), θ_(i+2)`: a spherical
/// wrist (three axes through one point, the middle one perpendicular to the others; Paul 1981, ch. 3, the
/// "flip" of the wrist). Found numerically: the flip moves the tool by less than 1e-12 (m and rad, relative to
/// the chain's size) at two pseudo-random configurations (an identity of the chain holds at every configuration;
/// a chain without it fails at almost every one).
pub(super) fn wrist_flips(model: &Model) -> Vec<usize> {
    let n = model.nq();
    let joints = model.joints();
    let size = 1.0 + joints.iter().map(|j| j.placement.translation.vector.norm()).sum::<f64>() + model.t_last_tool().translation.vector.norm();
    let mut rng = SplitMix64(0x5EED_F11B);
    let mut q = vec![0.0; n];
    (0..n.saturating_sub(2))
        .filter(|&i| {
            joints[i..i + 3].iter().all(|j| j.kind == JointKind::Revolute)
                && (0..2).all(|_| {
                    for v in q.iter_mut() {
                        *v = PI * (2.0 * rng.uniform() - 1.0);
                    }
                    let before = fk_unchecked(model, &q);
                    q[i] += PI;
                    q[i + 1] = -q[i + 1] - 2.0 * joints[i + 1].offset;
                    q[i + 2] += PI;
                    let (dp, dr) = pose_error(&fk_unchecked(model, &q), &before);
                    dp <= 1e-12 * size && dr <= 1e-12
                })
        })
        .collect()
}
