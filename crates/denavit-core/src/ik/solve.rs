//! The solver ([`IkSolver`]): closed-form seeds, the LM and Newton attempts and the restarts.

use super::*;

/// Iterations after which an LM attempt must have halved its squared error, else it gives way to the next
/// What trying one seed of attempt 0 gave ([`IkSolver::try_seed`]): met as it is (the measured position and
/// rotation errors), or polished (whether the polish met the tolerance).
pub(super) enum Seeded {
    Met(f64, f64),
    Polished(bool),
}

/// restart (never in the last attempt, which uses its whole budget).
pub(super) const STALL_EVERY: usize = 10;

/// Newton steps without a new best error after which an attempt gives way to the next restart (never in the
/// last attempt).
pub(super) const STALL_NEWTON: usize = 8;

/// A closed-form seed that meets the tolerance as it is: the configuration (its first `n` values) and its
/// measured position and rotation errors.
pub(super) type MetSeed = ([f64; 7], f64, f64);

/// Step between the first samples of q7 of a 7R arm's semi-analytic seeds (rad; [`IkSolver::attempt_seeds7`]).
pub(super) const STEP7: f64 = 1.6;

/// Times the samples of q7 are refined (the values halfway between the previous ones) when no branch of the coarser
/// ones meets the tolerance: down to 0.1 rad apart, which solves as many goals as sampling every 0.1 rad from the
/// start at a small part of its cost (docs/speed.md).
pub(super) const REFINE7: u32 = 4;

/// Most branches of a 7R arm's samples held at once, ranked by their distance from `q0`.
const KEEP7: usize = 48;

/// The samples of q7 in `[lo, hi]`, nearest to `centre` first: `centre + k step` (level 0), then at each finer
/// level the values halfway between the previous levels' ones.
struct Samples7 {
    centre: f64,
    lo: f64,
    hi: f64,
    step: f64,
    level: u32,
    /// The next offset's index `m` and sign (offsets `± (m step)` at level 0, `± ((m + 1/2) step)` after).
    m: u32,
    negative: bool,
}

impl Samples7 {
    fn new(centre: f64, lo: f64, hi: f64) -> Self {
        Self { centre, lo, hi, step: STEP7, level: 0, m: 0, negative: false }
    }

    fn next(&mut self) -> Option<f64> {
        let reach = (self.centre - self.lo).max(self.hi - self.centre);
        loop {
            let o = if self.level == 0 { self.m as f64 } else { self.m as f64 + 0.5 } * self.step;
            if o > reach {
                return None;
            }
            let v = if self.negative { self.centre - o } else { self.centre + o };
            // +o then -o (o = 0 once)
            if self.negative || (self.level == 0 && self.m == 0) {
                (self.m, self.negative) = (self.m + 1, false);
            } else {
                self.negative = true;
            }
            if v >= self.lo && v <= self.hi {
                return Some(v);
            }
        }
    }

    /// The next finer level (`false` after [`REFINE7`] of them).
    fn refine(&mut self) -> bool {
        if self.level == REFINE7 {
            return false;
        }
        if self.level > 0 {
            self.step *= 0.5;
        }
        (self.level, self.m, self.negative) = (self.level + 1, 0, false);
        true
    }
}

/// Jacobian evaluations of the Newton polish of one closed-form seed (within attempt 0's `max_iterations`): an
/// exact seed needs none (it is met as it is, checked by forward kinematics), a seed of an identified robot (axes
/// 0.5 mm / 0.5 mrad off the ideal structure) 3 (the median).
pub(super) const POLISH: usize = 10;

/// Step lengths 1, 1/2, 1/4 tried by Newton's backtracking.
pub(super) const BACKTRACK: usize = 3;

/// How far from success a measured error is (< = 1 means within the tolerance).
#[inline]
pub(super) fn score(pos: f64, rot: f64, o: &IkOptions) -> f64 {
    (pos / o.tol_position.max(1e-300)).max(rot / o.tol_rotation.max(1e-300))
}

/// A reusable IK workspace for one model (no allocation in the iterations).
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk, ik::{IkSolver, IkOptions}};
/// let m = builtin_planar2(1.0, 1.0);
/// let goal = fk(&m, &[0.4, 0.9]).unwrap();
/// // a planar arm cannot meet an arbitrary orientation, but this goal is reachable
/// let mut s = IkSolver::new(&m, IkOptions::default()).unwrap();
/// let r = s.solve(&goal, &[0.0, 0.5]).unwrap();
/// assert!(r.success && r.position_error <= 1e-10 && r.rotation_error <= 1e-10);
/// ```
#[derive(Debug, Clone)]
pub struct IkSolver<'m> {
    pub(super) model: &'m Model,
    pub(super) opts: IkOptions,
    pub(super) bounds: &'m Bounds,
    /// Whether the workspace below is allocated ([`Self::workspace`]).
    pub(super) ready: bool,
    pub(super) jac_eval: Vec<f64>,
    pub(super) q: Vec<f64>,
    pub(super) q_trial: Vec<f64>,
    pub(super) q_best: Vec<f64>,
    pub(super) q_cur: Vec<f64>,
    pub(super) q_jump: Vec<f64>,
    pub(super) jac: Vec<f64>,
    pub(super) jac_jump: Vec<f64>,
    pub(super) a: Vec<f64>,
    pub(super) g: Vec<f64>,
}

impl<'m> IkSolver<'m> {
    /// A workspace for `model` with checked options.
    pub fn new(model: &'m Model, opts: IkOptions) -> Result<Self> {
        opts.check()?;
        Ok(Self {
            model,
            opts,
            bounds: model.derived::<Bounds>(),
            ready: false,
            jac_eval: Vec::new(),
            q: Vec::new(),
            q_trial: Vec::new(),
            q_best: Vec::new(),
            q_cur: Vec::new(),
            q_jump: Vec::new(),
            jac: Vec::new(),
            jac_jump: Vec::new(),
            a: Vec::new(),
            g: Vec::new(),
        })
    }

    /// Allocate the iterations' workspace on first use (a single solve met by an exact closed-form seed needs
    /// none: ten allocations were a third of its time).
    #[inline]
    pub(super) fn workspace(&mut self) {
        if self.ready {
            return;
        }
        let n = self.model.nq();
        let m = n.max(6);
        for v in [&mut self.q, &mut self.q_trial, &mut self.q_best, &mut self.q_cur, &mut self.q_jump] {
            *v = vec![0.0; n];
        }
        for v in [&mut self.jac_eval, &mut self.jac, &mut self.jac_jump] {
            *v = vec![0.0; 6 * n];
        }
        self.a = vec![0.0; m * m];
        self.g = vec![0.0; m];
        self.ready = true;
    }

    /// The options in use.
    pub fn options(&self) -> &IkOptions {
        &self.opts
    }

    /// Solve for `goal` (`T_world_tool`) from `q0`; `Err` only for bad input (size, NaN, non-SE(3)).
    pub fn solve(&mut self, goal: &Pose, q0: &[f64]) -> Result<IkResult> {
        check_pose("IK goal", goal)?;
        self.model.check_q(q0).map_err(|e| rename(e, "q0"))?;
        let r = self.solve_unchecked(goal, q0, mix_seed(self.opts.seed, 0));
        crate::parallel::check_interrupt()?;
        Ok(r)
    }

    /// Jacobian and error at `q`.
    #[inline]
    pub(super) fn evaluate(&mut self, which_trial: bool, goal: &Pose, e: &mut [f64; 6]) -> (f64, f64) {
        let q = if which_trial { &self.q_trial } else { &self.q };
        let tool = fk_and_jacobian(self.model, q, &mut self.jac_eval);
        twist(&tool, goal, e)
    }

    /// One attempt from `self.q`; leaves the attempt's best configuration in `self.q`.
    /// `last`: no attempt follows, so this one uses its whole iteration budget (a stalled attempt is
    /// abandoned early only when a restart can take over).
    /// `budget`: the Jacobian evaluations it may use (`max_iterations`, less what the seeds used in attempt 0).
    pub(super) fn attempt(&mut self, goal: &Pose, last: bool, budget: usize) -> (usize, f64, f64) {
        match self.opts.method {
            IkMethod::Lm => self.attempt_lm(goal, last, budget),
            IkMethod::Newton => self.attempt_newton(goal, last, budget),
        }
    }

    pub(super) fn attempt_lm(&mut self, goal: &Pose, last: bool, budget: usize) -> (usize, f64, f64) {
        let n = self.model.nq();
        let mut e = [0.0; 6];
        let (mut pos, mut rot) = self.evaluate(false, goal, &mut e);
        let mut it = 1;
        if score(pos, rot, &self.opts) <= 1.0 || n == 0 {
            return (it, pos, rot);
        }
        self.jac.copy_from_slice(&self.jac_eval);
        let mut cost: f64 = e.iter().map(|v| v * v).sum();
        // damping lambda = mu |e|^2 (Fan & Yuan 2005: quadratic convergence to a zero residual), mu updated by
        // the gain ratio rho = (F(q) - F(q + h)) / (L(0) - L(h)) of the actual to the predicted decrease
        // (Nielsen 1999; Madsen, Nielsen & Tingleff 2004, eq. 3.15 and Algorithm 3.16): accepted (rho > 0):
        // mu *= max(1/3, 1 - (2 rho - 1)^3), nu = 2; rejected: mu *= nu, nu *= 2.
        let mut mu = self.opts.damping;
        let mut nu = 2.0;
        let mut checkpoint = cost;
        let mut jte = vec![0.0; n]; // J^T e (n <= 6 stays on the stack in practice: a small allocation per attempt)
        // (an interrupt ends the attempt: the caller reports Error::Interrupted)
        while it < budget && !crate::parallel::interrupted() {
            if !last && it % STALL_EVERY == 0 {
                // a local minimum or a crawl: leave it to the next restart
                if cost > 0.5 * checkpoint {
                    break;
                }
                checkpoint = cost;
            }
            for (i, c) in self.jac.chunks_exact(6).enumerate() {
                jte[i] = c.iter().zip(&e).map(|(x, y)| x * y).sum();
            }
            let lambda = (mu * cost).max(f64::MIN_POSITIVE);
            let mut ok = self.lm_solve(&e, lambda);
            if ok && self.blocked_by_limits() {
                // joints held at a limit that the step pushes outwards: solve again without them
                self.without_blocked(|s| ok = s.lm_solve(&e, lambda));
            }
            if !ok {
                mu *= nu;
                nu *= 2.0;
                if !(mu * cost).is_finite() || mu * cost > 1e30 {
                    break;
                }
                continue;
            }
            for i in 0..n {
                self.q_trial[i] = self.q[i] + self.g[i];
            }
            if self.opts.respect_limits {
                self.bounds.project(&mut self.q_trial, false);
            }
            let mut et = [0.0; 6];
            let (p, r) = self.evaluate(true, goal, &mut et);
            it += 1;
            let cost_t: f64 = et.iter().map(|v| v * v).sum();
            // predicted decrease of |e|^2: 2 L(0) - 2 L(h) = h^T (lambda h + J^T e)
            let predicted: f64 = (0..n).map(|i| self.g[i] * (lambda * self.g[i] + jte[i])).sum();
            if cost_t < cost {
                let rho = (cost - cost_t) / predicted.max(f64::MIN_POSITIVE);
                std::mem::swap(&mut self.q, &mut self.q_trial);
                self.jac.copy_from_slice(&self.jac_eval);
                (e, cost, pos, rot) = (et, cost_t, p, r);
                if score(pos, rot, &self.opts) <= 1.0 {
                    break;
                }
                mu = (mu * (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0)).max(1e-12);
                nu = 2.0;
            } else {
                mu *= nu;
                nu *= 2.0;
                if !(mu * cost).is_finite() || mu * cost > 1e30 {
                    break;
                }
            }
        }
        (it, pos, rot)
    }

    /// The damped step `(J^T J + lambda I) g = J^T e` into `self.g[..n]` from `self.jac`.
    pub(super) fn lm_solve(&mut self, e: &[f64; 6], lambda: f64) -> bool {
        let n = self.model.nq();
        if n == 6 {
            lm_step6(&self.jac, e, lambda, &mut self.g)
        } else {
            normal_equations(&self.jac, e, lambda, &mut self.a[..n * n], &mut self.g[..n], n);
            cholesky_solve(&mut self.a, &mut self.g, n)
        }
    }

    /// Whether joint `i` sits at a limit (where the projection clamped it) and the LM step `self.g` pushes it
    /// further out.
    #[inline]
    pub(super) fn blocked(&self, i: usize) -> bool {
        let (q, b) = (&self.q, &self.bounds);
        (q[i] <= b.lower[i] && self.g[i] < 0.0) || (q[i] >= b.upper[i] && self.g[i] > 0.0)
    }

    /// Whether any joint is [`Self::blocked`] (only when limits are respected).
    pub(super) fn blocked_by_limits(&self) -> bool {
        self.opts.respect_limits && (0..self.model.nq()).any(|i| self.blocked(i))
    }

    /// Recompute the LM step with `solve` on the Jacobian whose columns of the blocked joints are zero (an
    /// active set, as in projected Newton methods for bound constraints: Bertsekas 1982), then hold those
    /// joints: the other joints do the work instead of a step the projection would cancel. (Tried for
    /// Newton too: it lowered the 7-joint success rate, so Newton keeps the plain projection.)
    pub(super) fn without_blocked(&mut self, solve: impl FnOnce(&mut Self)) {
        let n = self.model.nq();
        let blocked: Vec<bool> = (0..n).map(|i| self.blocked(i)).collect();
        self.jac_jump.copy_from_slice(&self.jac);
        for (i, c) in self.jac.chunks_exact_mut(6).enumerate() {
            if blocked[i] {
                c.fill(0.0);
            }
        }
        solve(self);
        std::mem::swap(&mut self.jac, &mut self.jac_jump);
        for i in 0..n {
            if blocked[i] {
                self.g[i] = 0.0;
            }
        }
    }

    /// The Newton step into `self.g[..n]` from the last evaluated Jacobian and `e`.
    pub(super) fn newton_step(&mut self, e: &[f64; 6]) {
        let n = self.model.nq();
        let jac = &self.jac[..]; // column-major 6 x n, at the current iterate
        let solved = if n == 6 {
            newton_step6(jac, e, &mut self.g)
        } else if n < 6 {
            normal_equations(jac, e, 0.0, &mut self.a[..n * n], &mut self.g[..n], n);
            cholesky_solve(&mut self.a, &mut self.g, n)
        } else {
            // minimum-norm step: dq = J^T y, (J J^T) y = e
            let a = &mut self.a[..36];
            for r in 0..6 {
                for c in 0..=r {
                    let v: f64 = (0..n).map(|k| jac[6 * k + r] * jac[6 * k + c]).sum();
                    a[r * 6 + c] = v;
                    a[c * 6 + r] = v;
                }
            }
            let mut y = *e;
            let ok = cholesky_solve(&mut self.a, &mut y, 6);
            for k in 0..n {
                self.g[k] = (0..6).map(|r| jac[6 * k + r] * y[r]).sum();
            }
            ok
        };
        if !solved {
            // singular: a slightly damped least-squares step
            let lambda = 1e-8 * (1.0 + jac.iter().map(|v| v * v).sum::<f64>());
            normal_equations(jac, e, lambda, &mut self.a[..n * n], &mut self.g[..n], n);
            if !cholesky_solve(&mut self.a, &mut self.g, n) {
                self.g[..n].fill(0.0);
            }
        }
    }

    pub(super) fn attempt_newton(&mut self, goal: &Pose, last: bool, budget: usize) -> (usize, f64, f64) {
        let n = self.model.nq();
        let mut e = [0.0; 6];
        let (mut pos, mut rot) = self.evaluate(false, goal, &mut e);
        let mut it = 1;
        let mut best = (score(pos, rot, &self.opts), pos, rot);
        if best.0 <= 1.0 || n == 0 {
            return (it, pos, rot);
        }
        // the iterate (q_cur, its Jacobian in jac, its error e); self.q keeps the attempt's best configuration
        self.jac.copy_from_slice(&self.jac_eval);
        self.q_cur.copy_from_slice(&self.q);
        let mut cost: f64 = e.iter().map(|v| v * v).sum();
        let mut stalled = 0;
        'attempt: while it < budget && !crate::parallel::interrupted() {
            self.newton_step(&e);
            // backtracking on |e|^2 (Nocedal & Wright 2006, Algorithm 3.1, halving): steps 1, 1/2, 1/4; when
            // none lowers the error the full step is taken anyway (Newton's jump out of a basin)
            let mut alpha = 1.0;
            let mut moved = false;
            let mut jump = None;
            for k in 0..BACKTRACK {
                for i in 0..n {
                    self.q_trial[i] = self.q_cur[i] + alpha * self.g[i];
                }
                if self.opts.respect_limits {
                    self.bounds.project(&mut self.q_trial, true);
                }
                if self.q_trial.iter().any(|v| !v.is_finite()) {
                    break 'attempt;
                }
                let mut et = [0.0; 6];
                let (p, r) = self.evaluate(true, goal, &mut et);
                it += 1;
                let cost_t: f64 = et.iter().map(|v| v * v).sum();
                if cost_t < cost {
                    std::mem::swap(&mut self.q_cur, &mut self.q_trial);
                    self.jac.copy_from_slice(&self.jac_eval);
                    (e, cost, pos, rot) = (et, cost_t, p, r);
                    moved = true;
                    break;
                }
                if k == 0 {
                    self.q_jump.copy_from_slice(&self.q_trial);
                    self.jac_jump.copy_from_slice(&self.jac_eval);
                    jump = Some((et, cost_t, p, r));
                }
                if it >= budget {
                    break;
                }
                alpha *= 0.5;
            }
            if !moved {
                let Some(j) = jump else { break };
                std::mem::swap(&mut self.q_cur, &mut self.q_jump);
                std::mem::swap(&mut self.jac, &mut self.jac_jump);
                (e, cost, pos, rot) = j;
            }
            let s = score(pos, rot, &self.opts);
            if s < best.0 {
                best = (s, pos, rot);
                self.q.copy_from_slice(&self.q_cur);
                stalled = 0;
                if s <= 1.0 {
                    break;
                }
            } else {
                stalled += 1;
                if !last && stalled >= STALL_NEWTON {
                    break;
                }
            }
        }
        (it, best.1, best.2)
    }

    /// The closed-form seeds of a recognised structure ([`Structure`]): the branches placed near `q0` (each
    /// joint by [`Bounds::place_joint`]; those outside the limits dropped when `respect_limits`), nearest to
    /// `q0` first, each checked by FK and, if not within the tolerance as it is, polished by a Newton attempt on
    /// the model, until one meets the tolerance. Returns the Jacobian evaluations, the best score (its
    /// configuration in `self.q_best`) and, for a seed met as it is, its measured errors; `None` without a
    /// closed form.
    ///
    /// The order is found best-first on the closed form's two levels ([`ClosedForm::levels`]): a first level
    /// (three joints) is completed to its branches only when its own distance from `q0`, a lower bound of its
    /// branches', is below that of every branch found so far, so the branches of arms far from `q0` are not
    /// computed. Distances come from the angles to 3e-7 rad ([`closed_form::Cs::angle_approx`]: `atan2` costs
    /// about as much as the closed form of a branch); a branch is tried with its exact angles.
    pub(super) fn attempt_seeds(&mut self, goal: &Pose, q0: &[f64]) -> Option<(usize, f64, Option<MetSeed>)> {
        let bounds: &'m Bounds = self.bounds;
        let cf = bounds.closed_form.as_ref()?;
        let respect = self.opts.respect_limits;
        let (first, second) = cf.levels();
        // the first levels within the limits, by their distance from q0
        let mut parts = [Partial::EMPTY; MAX_PARTIALS];
        let np = cf.partials(goal, q0, &mut parts);
        let mut part_order = [(0.0f64, 0); MAX_PARTIALS];
        let mut kept = 0;
        'parts: for (k, part) in parts[..np].iter().enumerate() {
            let mut d = 0.0;
            for &i in &first {
                let Some(v) = bounds.place_joint(i, part.q[i].angle_approx(), q0[i], respect) else { continue 'parts };
                d += (v - q0[i]) * (v - q0[i]);
            }
            if !d.is_finite() {
                continue;
            }
            let mut j = kept;
            while j > 0 && part_order[j - 1].0 > d {
                part_order[j] = part_order[j - 1];
                j -= 1;
            }
            part_order[j] = (d, k);
            kept += 1;
        }
        // the branches found, their distances, and whether tried
        let mut found = [(0.0f64, [Cs::ZERO; 6], false); MAX_BRANCHES];
        let (mut nf, mut next) = (0, 0);
        let mut total = 0;
        let mut best = f64::INFINITY;
        loop {
            let nearest = (0..nf).filter(|&c| !found[c].2).min_by(|&a, &b| found[a].0.total_cmp(&found[b].0));
            if next < kept && nearest.is_none_or(|c| part_order[next].0 < found[c].0) {
                // a first level that may hold a nearer branch: complete it
                let (pd, k) = part_order[next];
                next += 1;
                let mut leaves = [[Cs::ZERO; 6]; 2];
                let nl = cf.complete(&parts[k], q0, &mut leaves);
                'leaves: for leaf in &leaves[..nl] {
                    let mut d = pd;
                    for &i in &second {
                        let Some(v) = bounds.place_joint(i, leaf[i].angle_approx(), q0[i], respect) else { continue 'leaves };
                        d += (v - q0[i]) * (v - q0[i]);
                    }
                    if d.is_finite() {
                        found[nf] = (d, *leaf, false);
                        nf += 1;
                    }
                }
                continue;
            }
            let Some(c) = nearest else { break };
            found[c].2 = true;
            let budget = POLISH.min(self.opts.max_iterations - total);
            if budget == 0 {
                break;
            }
            // the exact angles, placed again (a joint at a limit may fall outside by them)
            let mut q = [0.0; 6];
            let mut placed = true;
            for i in 0..6 {
                match bounds.place_joint(i, found[c].1[i].angle(), q0[i], respect) {
                    Some(v) => q[i] = v,
                    None => placed = false,
                }
            }
            if !placed {
                continue;
            }
            // an exact seed is checked by the verdict's own measurement (forward kinematics alone, counted as one
            // evaluation), which then stands as the verdict
            match self.try_seed(goal, &q, budget, &mut total, &mut best) {
                Seeded::Met(pos, rot) => {
                    let mut met = [0.0; 7];
                    met[..6].copy_from_slice(&q);
                    return Some((total + 1, 1.0, Some((met, pos, rot))));
                }
                Seeded::Polished(true) => break,
                Seeded::Polished(false) => {}
            }
        }
        Some((total, best, None))
    }

    /// The semi-analytic seeds of a recognised 7R arm ([`Redundant`]): q7 sampled every [`STEP7`] rad from
    /// `q0_7` outwards (within its limits when `respect_limits`, else within ±π of `q0_7`), each sample's 6R
    /// branches in closed form, placed near `q0` (those outside the limits dropped when `respect_limits`) and tried
    /// nearest to `q0` first, as [`Self::attempt_seeds`] tries a 6R arm's: checked by FK, polished by Newton if not
    /// within the tolerance as they are, each try counted in attempt 0's `max_iterations`. Best-first: a sample
    /// is solved only while its distance from `q0_7` is below that of every untried branch found so far. When
    /// every branch of the samples has been tried (none within the limits, or none met), the samples halfway
    /// between are solved, [`REFINE7`] times at most (a goal whose q7 must lie in a narrow interval).
    pub(super) fn attempt_seeds7(&mut self, goal: &Pose, q0: &[f64]) -> Option<(usize, f64, Option<MetSeed>)> {
        let bounds: &'m Bounds = self.bounds;
        let rf = bounds.redundant.as_ref()?;
        let respect = self.opts.respect_limits;
        let g = rf.goal(goal);
        let (mut lo, mut hi) = (q0[6] - PI, q0[6] + PI);
        let mut centre = q0[6];
        if respect {
            centre = centre.clamp(bounds.lower[6], bounds.upper[6]);
            (lo, hi) = ((centre - PI).max(bounds.lower[6]), (centre + PI).min(bounds.upper[6]));
        }
        let mut samples = Samples7::new(centre, lo, hi);
        let mut pending = samples.next();
        let mut found = [(0.0f64, [Cs::ZERO; 7], false, 0.0f64); KEEP7]; // (distance, branch, tried, q7)
        let mut nf = 0;
        let mut total = 0;
        let mut best = f64::INFINITY;
        loop {
            let nearest = (0..nf).filter(|&c| !found[c].2).min_by(|&a, &b| found[a].0.total_cmp(&found[b].0));
            if let Some(q7) = pending
                && nearest.is_none_or(|c| (q7 - centre) * (q7 - centre) < found[c].0)
            {
                pending = samples.next();
                let mut leaves = [[Cs::ZERO; 7]; MAX_BRANCHES7];
                let nl = rf.branches(&g, q7, q0, &mut leaves);
                'leaves: for leaf in &leaves[..nl] {
                    let mut d = (q7 - q0[6]) * (q7 - q0[6]);
                    for i in 0..6 {
                        let Some(v) = bounds.place_joint(i, leaf[i].angle_approx(), q0[i], respect) else { continue 'leaves };
                        d += (v - q0[i]) * (v - q0[i]);
                    }
                    if !d.is_finite() {
                        continue;
                    }
                    // keep it: in a free slot, a tried one's, or the farthest one's if it is nearer
                    let slot = if nf < KEEP7 {
                        nf += 1;
                        nf - 1
                    } else if let Some(t) = (0..KEEP7).find(|&c| found[c].2) {
                        t
                    } else {
                        let far = (0..KEEP7).max_by(|&a, &b| found[a].0.total_cmp(&found[b].0)).unwrap_or(0);
                        if found[far].0 <= d {
                            continue;
                        }
                        far
                    };
                    found[slot] = (d, *leaf, false, q7);
                }
                continue;
            }
            let Some(c) = nearest else {
                // every branch of this level's samples tried: the samples halfway between them
                if samples.refine() {
                    pending = samples.next();
                    continue;
                }
                break;
            };
            found[c].2 = true;
            let budget = POLISH.min(self.opts.max_iterations - total);
            if budget == 0 {
                break;
            }
            let mut q = [0.0; 7];
            let mut placed = true;
            for i in 0..6 {
                match bounds.place_joint(i, found[c].1[i].angle(), q0[i], respect) {
                    Some(v) => q[i] = v,
                    None => placed = false,
                }
            }
            q[6] = found[c].3; // the sample itself, exact
            if !placed {
                continue;
            }
            match self.try_seed(goal, &q, budget, &mut total, &mut best) {
                Seeded::Met(pos, rot) => return Some((total + 1, 1.0, Some((q, pos, rot)))),
                Seeded::Polished(true) => break,
                Seeded::Polished(false) => {}
            }
        }
        Some((total, best, None))
    }

    /// One seed of attempt 0 (a 6R arm's closed-form branch, a 7R arm's semi-analytic one; `q`: all n joints)
    /// tried: checked by forward kinematics (one evaluation, which stands as the verdict when it meets the
    /// tolerance: `Met`), else polished by Newton within `budget`, its evaluations added to `total` and a better
    /// score kept in `best` and `q_best` (`Polished(true)`: the polish met the tolerance, the search stops).
    #[inline]
    fn try_seed(&mut self, goal: &Pose, q: &[f64], budget: usize, total: &mut usize, best: &mut f64) -> Seeded {
        let (pos, rot) = pose_error(&fk_unchecked(self.model, q), goal);
        if score(pos, rot, &self.opts) <= 1.0 {
            return Seeded::Met(pos, rot);
        }
        self.workspace();
        self.q.copy_from_slice(q);
        let (it, pos, rot) = self.attempt_newton(goal, false, budget);
        *total += it;
        let s = score(pos, rot, &self.opts);
        if s < *best {
            *best = s;
            self.q_best.copy_from_slice(&self.q);
            return Seeded::Polished(s <= 1.0);
        }
        Seeded::Polished(false)
    }

    /// Solve without checking the input; `seed` drives the restarts.
    pub(crate) fn solve_unchecked(&mut self, goal: &Pose, q0: &[f64], seed: u64) -> IkResult {
        let n = self.model.nq();
        let mut total = 0;
        let mut best_score = f64::INFINITY;
        let mut restarts = 0;
        let mut seeded = false;
        let seeds = match self.attempt_seeds(goal, q0) {
            None => self.attempt_seeds7(goal, q0),
            some => some,
        };
        if let Some((it, s, exact)) = seeds {
            if let Some((q, position_error, rotation_error)) = exact {
                // met by a seed as it is (within the limits by construction): its measurement is the verdict
                let q = &q[..n];
                let within = !self.opts.respect_limits || self.bounds.within(q);
                let success = position_error <= self.opts.tol_position && rotation_error <= self.opts.tol_rotation && within;
                return IkResult { q: q.to_vec(), success, iterations: it, restarts: 0, position_error, rotation_error };
            }
            (total, best_score, seeded) = (it, s, s.is_finite());
        }
        self.workspace();
        for attempt in 0..=self.opts.restarts {
            if best_score <= 1.0 || crate::parallel::interrupted() {
                break;
            }
            if attempt == 0 {
                self.q.copy_from_slice(q0);
            } else {
                let mut rng = SplitMix64(mix_seed(seed, attempt as u64));
                self.bounds.sample(&mut rng, &mut self.q);
            }
            if self.opts.respect_limits {
                self.bounds.project(&mut self.q, false);
            }
            let budget = if attempt == 0 { self.opts.max_iterations - total } else { self.opts.max_iterations };
            if budget == 0 {
                continue; // the seeds used attempt 0's budget
            }
            let (it, pos, rot) = self.attempt(goal, attempt == self.opts.restarts, budget);
            total += it;
            restarts = attempt;
            let s = score(pos, rot, &self.opts);
            if s < best_score || (attempt == 0 && !seeded) {
                best_score = s;
                self.q_best.copy_from_slice(&self.q);
            }
            if s <= 1.0 {
                break;
            }
        }
        // the honest verdict: measure the returned configuration with the public FK and error functions
        let q = self.q_best[..n].to_vec();
        let (position_error, rotation_error) = pose_error(&fk_unchecked(self.model, &q), goal);
        let within = !self.opts.respect_limits || self.bounds.within(&q);
        let success = position_error <= self.opts.tol_position && rotation_error <= self.opts.tol_rotation && within;
        IkResult { q, success, iterations: total, restarts, position_error, rotation_error }
    }
}
