//! The equilibrium and the error system assembled from a [`limbs`](crate::limbs)
//! description, for any number of limbs n (docs/model.md §4–6), and solved per pose.
//!
//! **Equilibrium** `A·w = b`, `(6n + 6) × Σ unknowns`, square for these joints. Limb i's
//! unknowns, in order: the force `f_B` of the base on the leg at `B` (world x, y, z), the
//! couple the base joint transmits in its own basis (`μ_1·d_1 + μ_2·d_2 ⟂` the revolute
//! axis; `μ·n` with `n = a1 × a2` for the universal joint), and the force `f_S` of the
//! leg on the platform at `A`. Rows: leg i's forces (`6i..6i+3`),
//!
//! ```text
//! f_B − f_S = Σ_b m_b·(a_b − g),
//! ```
//!
//! its moments about `B` (`6i+3..6i+6`), where `f_B` has no arm,
//!
//! ```text
//! m_B − (A − B)×f_S = Σ_b I_b·ω̇_b + ω_b×(I_b·ω_b) + (G_b − B)×m_b·(a_b − g),
//! ```
//!
//! then the platform's forces and moments about its composite centre of mass `C`
//! (`6n..6n+6`), `Σ f_S = m·(a_C − g) − f_ext`, `Σ (A − C)×f_S = I_C·ω̇ + ω×(I_C·ω) −
//! (E − C)×f_ext − m_ext`.
//!
//! **Error system** `J_P·Δq_P = J_Cl·Δq_Cl`, `6(n − 1)` square. Limb i's passive screws
//! `[axis; (point − P)×axis]`: the revolute's one or the universal joint's two rotations
//! through `B`, then the spherical joint's rotations about world x, y, z through `A`
//! (a locked prismatic joint adds none). Rows `6(l−1)..6l` close limb l against limb 1:
//! `Σ $_l·Δq_l + t_l = Σ $_1·Δq_1 + t_1`, `t` the limb's clearance twist. One right-hand
//! side per clearance kind; the kind's pose error is limb 1's twist.
//!
//! Both are factored by faer's partial-pivoting LU ([`LuSolver`]) with Higham's estimate
//! of `κ₁` ([`LuSolver::cond_one_estimate`]); [`Assembly::solve`] allocates nothing.

use faer::{Mat, MatMut, MatRef};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3, Vector6};

use clearance_kinematics::euler_rates_matrix;

use crate::error_system::PoseError;
use crate::limbs::{ClearanceSite, LimbModel, MAX_KINDS, MAX_LIMBS, Posed, Rule, Site};
use crate::linalg::LuSolver;
use crate::pose::Status;

/// A mechanism's limbs and clearances: built once, shared by every worker.
#[derive(Clone, Debug, PartialEq)]
pub struct Assembly {
    /// Fixed at construction: the scratch and the column offsets are sized for them.
    limbs: Vec<LimbModel>,
    kinds: Vec<ClearanceSite>,
    pub gravity: Vector3<f64>,
    /// Loads at or below this leave a take-up indeterminate (N or N·m).
    pub floor: f64,
    /// Above this `κ₁` of `A` or `J_P` a pose is near-singular.
    pub singular_cond: f64,
    /// First column of limb i's reactions in `w`, and of its passive motions in `Δq_P`.
    w_col: Vec<usize>,
    dq_col: Vec<usize>,
}

/// Everything solved at one pose. Arrays are indexed by limb (then kind) up to
/// [`MAX_LIMBS`] and [`MAX_KINDS`]; entries past the mechanism's are zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbsSolution {
    pub status: Status,
    /// Force of the base on the leg at `B`, the couple (world) and its components in the
    /// joint's basis, the force of the leg on the platform at `A`.
    pub f_b: [Vector3<f64>; MAX_LIMBS],
    pub m_b: [Vector3<f64>; MAX_LIMBS],
    pub mu: [[f64; 2]; MAX_LIMBS],
    pub f_s: [Vector3<f64>; MAX_LIMBS],
    /// Per kind and limb: the take-up (translation or rotation vector) and its margin.
    pub take: [[Vector3<f64>; MAX_LIMBS]; MAX_KINDS],
    pub margins: [[f64; MAX_LIMBS]; MAX_KINDS],
    /// Per kind: its take-up is determinate (or its clearance is zero).
    pub kind_ok: [bool; MAX_KINDS],
    pub errors: [PoseError; MAX_KINDS],
    pub total: PoseError,
    /// `κ₁` of `A` and of `J_P`, estimated (NaN where not reached, or with no
    /// `singular_cond` to test).
    pub cond_a: f64,
    pub cond_jp: f64,
}

impl Default for LimbsSolution {
    fn default() -> Self {
        let z = [Vector3::zeros(); MAX_LIMBS];
        Self {
            status: Status::NearSingular,
            f_b: z,
            m_b: z,
            mu: [[0.0; 2]; MAX_LIMBS],
            f_s: z,
            take: [z; MAX_KINDS],
            margins: [[0.0; MAX_LIMBS]; MAX_KINDS],
            kind_ok: [false; MAX_KINDS],
            errors: [PoseError::default(); MAX_KINDS],
            total: PoseError::default(),
            cond_a: f64::NAN,
            cond_jp: f64::NAN,
        }
    }
}

/// Scratch for one worker: sized once for an [`Assembly`], reused for every pose.
pub struct AssemblyData {
    a: Mat<f64>,
    w: Mat<f64>,
    lu_a: LuSolver,
    jp: Mat<f64>,
    dq: Mat<f64>,
    lu_jp: LuSolver,
}

impl AssemblyData {
    pub fn new(assembly: &Assembly) -> Self {
        let (n, m) = (assembly.unknowns(), assembly.passive());
        let k = assembly.kinds.len();
        Self {
            a: Mat::zeros(n, n),
            w: Mat::zeros(n, 1),
            lu_a: LuSolver::new(n, n),
            jp: Mat::zeros(m, m),
            dq: Mat::zeros(m, k),
            lu_jp: LuSolver::new(m, m.max(k)),
        }
    }

    /// The last assembled `A` and `J_P` (for tests and diagnostics).
    pub fn a(&self) -> MatRef<'_, f64> {
        self.a.as_ref()
    }
    pub fn jp(&self) -> MatRef<'_, f64> {
        self.jp.as_ref()
    }
}

fn put3(a: &mut MatMut<'_, f64>, row: usize, col: usize, m: &Matrix3<f64>) {
    for i in 0..3 {
        for k in 0..3 {
            a[(row + i, col + k)] = m[(i, k)];
        }
    }
}

fn twist(w: Vector3<f64>, v: Vector3<f64>) -> Vector6<f64> {
    Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z)
}

/// `−mag·v/|v|` when `|v|` is above the floor, else zero (direction undefined).
fn against(v: Vector3<f64>, norm: f64, mag: f64, floor: f64) -> Vector3<f64> {
    if norm > floor && norm > 0.0 { v * -(mag / norm) } else { Vector3::zeros() }
}

/// `[Δα; Δp]` with the Euler-angle form `(ΔΦ, ΔΨ, ΔΘ)` of docs/model.md §6.
pub fn pose_error(t: &Vector6<f64>, (psi, theta): (f64, f64)) -> PoseError {
    let dalpha = Vector3::new(t[0], t[1], t[2]);
    let e = euler_rates_matrix(psi, theta).try_inverse().map_or(Vector3::repeat(f64::NAN), |m| m * dalpha);
    PoseError { dalpha, dp: Vector3::new(t[3], t[4], t[5]), euler: [e[2], e[1], e[0]] }
}

impl Assembly {
    #[track_caller]
    pub fn new(
        limbs: Vec<LimbModel>,
        kinds: Vec<ClearanceSite>,
        gravity: Vector3<f64>,
        floor: f64,
        singular_cond: f64,
    ) -> Self {
        assert!((2..=MAX_LIMBS).contains(&limbs.len()), "2 to {MAX_LIMBS} limbs, not {}", limbs.len());
        assert!(kinds.len() <= MAX_KINDS, "at most {MAX_KINDS} clearance kinds, not {}", kinds.len());
        let (mut w_col, mut dq_col) = (Vec::new(), Vec::new());
        let (mut w, mut dq) = (0, 0);
        for l in &limbs {
            w_col.push(w);
            dq_col.push(dq);
            w += 6 + l.base.moments();
            dq += 3 + l.base.freedoms();
        }
        let out = Self { limbs, kinds, gravity, floor, singular_cond, w_col, dq_col };
        assert_eq!(out.unknowns(), w, "the equilibrium must be square: 6 unknowns per limb + its couple's");
        assert_eq!(out.passive(), dq, "the error system must be square: 6 passive freedoms per limb");
        out
    }

    /// Whether the matrix `m` just factored in `lu` is within `singular_cond`, its
    /// estimated `κ₁` put in `cond`. With no limit (infinite, as the 6-UPS, whose
    /// reduced systems decide) any factored matrix is, and nothing is estimated: the
    /// estimate costs as much as the factorisation.
    fn within_limit(&self, lu: &mut LuSolver, m: MatRef<'_, f64>, cond: &mut f64) -> bool {
        if self.singular_cond == f64::INFINITY {
            return true;
        }
        *cond = lu.cond_one_estimate(m);
        self.conditioned(*cond)
    }

    /// `κ₁` within the limit (NaN is not).
    fn conditioned(&self, cond: f64) -> bool {
        matches!(cond.partial_cmp(&self.singular_cond), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal))
    }

    pub fn limbs(&self) -> &[LimbModel] {
        &self.limbs
    }

    /// The clearance kinds, in the order of every per-kind array of a solution.
    pub fn kinds(&self) -> &[ClearanceSite] {
        &self.kinds
    }

    /// Sets each kind's magnitude (m or rad), in the order of [`Assembly::kinds`].
    #[track_caller]
    pub fn set_magnitudes(&mut self, magnitudes: &[f64]) {
        assert_eq!(magnitudes.len(), self.kinds.len(), "one magnitude per kind");
        for (kind, &c) in self.kinds.iter_mut().zip(magnitudes) {
            kind.magnitude = c;
        }
    }

    /// Rows (and unknowns) of `A`: `6n + 6`.
    pub fn unknowns(&self) -> usize {
        6 * self.limbs.len() + 6
    }

    /// Rows (and unknowns) of `J_P`: `6(n − 1)`.
    pub fn passive(&self) -> usize {
        6 * (self.limbs.len() - 1)
    }

    /// Writes `A` and `b` (docs/model.md §4) for the pose; both are overwritten whole.
    pub fn assemble_equilibrium(&self, posed: &Posed, mut a: MatMut<'_, f64>, mut b: MatMut<'_, f64>) {
        a.fill(0.0);
        let g = &self.gravity;
        let eye = Matrix3::identity();
        let n = self.limbs.len();
        let plat = &posed.platform;
        for (i, limb) in self.limbs.iter().enumerate() {
            let lp = &posed.limbs[i];
            let (r, c) = (6 * i, self.w_col[i]);
            let k = limb.base.moments();
            let s = c + 3 + k;
            put3(&mut a, r, c, &eye);
            put3(&mut a, r, s, &(-eye));
            let basis = lp.moment_basis(limb.base);
            for (m, d) in basis.iter().take(k).enumerate() {
                for q in 0..3 {
                    a[(r + 3 + q, c + 3 + m)] = d[q];
                }
            }
            put3(&mut a, r + 3, s, &(-(lp.a - lp.b).cross_matrix()));
            let (mut f_rhs, mut m_rhs) = (Vector3::zeros(), Vector3::zeros());
            for body in &lp.bodies {
                let f = body.demand(g);
                f_rhs += f;
                m_rhs += body.spin() + (body.centre - lp.b).cross(&f);
            }
            put3(&mut a, 6 * n, s, &eye);
            put3(&mut a, 6 * n + 3, s, &(lp.a - plat.centre).cross_matrix());
            for q in 0..3 {
                b[(r + q, 0)] = f_rhs[q];
                b[(r + 3 + q, 0)] = m_rhs[q];
            }
        }
        let f_rhs = plat.demand(g) - posed.force;
        let m_rhs = plat.spin() - (posed.force_at - plat.centre).cross(&posed.force) - posed.moment;
        for q in 0..3 {
            b[(6 * n + q, 0)] = f_rhs[q];
            b[(6 * n + 3 + q, 0)] = m_rhs[q];
        }
    }

    /// Reads the reactions out of `w` into `out`.
    fn reactions_into(&self, posed: &Posed, w: &Mat<f64>, out: &mut LimbsSolution) {
        let v = |k: usize| Vector3::new(w[(k, 0)], w[(k + 1, 0)], w[(k + 2, 0)]);
        for (i, limb) in self.limbs.iter().enumerate() {
            let c = self.w_col[i];
            let k = limb.base.moments();
            let basis = posed.limbs[i].moment_basis(limb.base);
            out.f_b[i] = v(c);
            out.m_b[i] = Vector3::zeros();
            for m in 0..k {
                out.mu[i][m] = w[(c + 3 + m, 0)];
                out.m_b[i] += out.mu[i][m] * basis[m];
            }
            out.f_s[i] = v(c + 3 + k);
        }
    }

    /// Take-ups, margins and which kinds are determinate, from the reactions in `out`.
    pub fn take_up(&self, posed: &Posed, out: &mut LimbsSolution) {
        let floor = self.floor;
        for (k, kind) in self.kinds.iter().enumerate() {
            let mut ok = true;
            for (i, limb) in self.limbs.iter().enumerate() {
                let lp = &posed.limbs[i];
                let f = match kind.site {
                    Site::Base => out.f_b[i],
                    Site::Platform => out.f_s[i],
                };
                let (m, c, u) = (out.m_b[i], kind.magnitude, lp.axes[0]);
                let (take, margin) = match kind.rule {
                    Rule::AgainstForce => {
                        let n = f.norm();
                        (against(f, n, c, floor), n)
                    }
                    Rule::AgainstForceAcrossAxis => {
                        let perp = f - u * f.dot(&u);
                        let n = perp.norm();
                        (against(perp, n, c, floor), n)
                    }
                    Rule::AlongAxis => {
                        let axial = f.dot(&u);
                        let t = if axial.abs() > floor { u * (-c * axial.signum()) } else { Vector3::zeros() };
                        (t, axial.abs())
                    }
                    Rule::AgainstMoment => {
                        let n = m.norm();
                        (against(m, n, c, floor), n)
                    }
                    Rule::AboutForbidden => (c * lp.moment_basis(limb.base)[0], m.norm()),
                };
                out.take[k][i] = take;
                out.margins[k][i] = margin;
                ok &= kind.rule == Rule::AboutForbidden || margin > floor;
            }
            out.kind_ok[k] = ok || kind.magnitude == 0.0;
        }
    }

    /// Limb i's passive screws, in the order of its columns of `J_P`.
    fn screws(&self, posed: &Posed, i: usize) -> ([Vector6<f64>; 5], usize) {
        let lp = &posed.limbs[i];
        let (rb, ra) = (lp.b - posed.p, lp.a - posed.p);
        let s = |axis: Vector3<f64>, r: Vector3<f64>| twist(axis, r.cross(&axis));
        let f = self.limbs[i].base.freedoms();
        let mut out = [Vector6::zeros(); 5];
        for u in 0..f {
            out[u] = s(lp.axes[u], rb);
        }
        for k in 0..3 {
            out[f + k] = s(Vector3::ith(k, 1.0), ra);
        }
        (out, f + 3)
    }

    /// Limb i's clearance twist for kind k: `[θ; (B − P)×θ]` for a rotation about the
    /// joint's centre, `[0; t]` for a translation.
    fn clearance_twist(&self, posed: &Posed, sol: &LimbsSolution, k: usize, i: usize) -> Vector6<f64> {
        let t = sol.take[k][i];
        let kind = &self.kinds[k];
        if !kind.rule.rotation() {
            return twist(Vector3::zeros(), t);
        }
        let centre = match kind.site {
            Site::Base => posed.limbs[i].b,
            Site::Platform => posed.limbs[i].a,
        };
        twist(t, (centre - posed.p).cross(&t))
    }

    /// Writes `J_P` and the right-hand sides (one column per kind) for the take-ups in
    /// `sol` (docs/model.md §6); both are overwritten whole.
    pub fn assemble_error(
        &self,
        posed: &Posed,
        sol: &LimbsSolution,
        mut jp: MatMut<'_, f64>,
        mut rhs: MatMut<'_, f64>,
    ) {
        jp.fill(0.0);
        let (first, m0) = self.screws(posed, 0);
        for l in 1..self.limbs.len() {
            let row = 6 * (l - 1);
            let (other, ml) = self.screws(posed, l);
            for q in 0..6 {
                for u in 0..ml {
                    jp[(row + q, self.dq_col[l] + u)] = other[u][q];
                }
                for u in 0..m0 {
                    jp[(row + q, u)] = -first[u][q];
                }
            }
            for k in 0..self.kinds.len() {
                let d = self.clearance_twist(posed, sol, k, 0) - self.clearance_twist(posed, sol, k, l);
                for q in 0..6 {
                    rhs[(row + q, k)] = d[q];
                }
            }
        }
    }

    /// Reactions, take-up, per-kind and total errors of one pose. A singular or
    /// ill-conditioned `A` or `J_P` gives `near_singular` with what was reached.
    pub fn solve(&self, posed: &Posed, data: &mut AssemblyData) -> LimbsSolution {
        let mut out = LimbsSolution::default();
        if self.solve_reactions(posed, data, &mut out) && self.solve_errors(posed, &mut out, data) {
            out.status = self.determinacy(&out);
        }
        out
    }

    /// Reactions and take-up of one pose, without the error system: what a search for
    /// switches evaluates between samples. The status is [`Assembly::solve`]'s except
    /// where only `J_P` fails to factor (an exact singularity of the passive joints).
    pub fn solve_loads(&self, posed: &Posed, data: &mut AssemblyData) -> LimbsSolution {
        let mut out = LimbsSolution::default();
        if self.solve_reactions(posed, data, &mut out) {
            out.status = self.determinacy(&out);
        }
        out
    }

    /// [`Assembly::solve_loads`] for limbs whose base joint transmits one couple (the
    /// universal joint), with each leg eliminated in closed form instead of factoring
    /// `A`: with `r = A − B`, `ê = r/|r|`, a leg's moments about `B` give along `ê`
    /// its couple `μ = ê·M/(ê·n)` and across it `f_S⊥ = −r×(μ·n − M)/|r|²`, so
    /// `f_S = t·ê + f_S⊥` with one unknown `t` a leg, which the platform's six
    /// equations give (the 6 × 6 system of the legs' screws `[ê; (A − C)×ê]`); then
    /// `f_B = F + f_S`. The same reactions as the 42 × 42 factorisation to round-off,
    /// in about a twentieth of its work: what a search evaluates between samples.
    /// `None` (for the caller to factor `A`) where there are not six limbs whose base
    /// joints transmit one couple, a leg's couple axis lies across the leg, or the
    /// legs' screws are singular.
    ///
    /// `legs_inverse`, where the caller has it, is the inverse of the legs' screws
    /// reduced to P (`[ê; (A − P)×ê]`): the platform's moments are then taken about P
    /// and multiplied by it instead of factoring the screws about C.
    pub fn solve_loads_reduced(
        &self,
        posed: &Posed,
        legs_inverse: Option<&SMatrix<f64, 6, 6>>,
    ) -> Option<LimbsSolution> {
        let mut out = LimbsSolution::default();
        self.solve_loads_reduced_into(posed, legs_inverse, &mut out).then_some(out)
    }

    /// [`Assembly::solve_loads_reduced`] into `out` (a worker's, reused: a solution is
    /// some 2 kB), false where it does not apply. Writes the status, the reactions,
    /// take-ups, margins and determinacy; leaves the errors and condition numbers.
    pub fn solve_loads_reduced_into(
        &self,
        posed: &Posed,
        legs_inverse: Option<&SMatrix<f64, 6, 6>>,
        out: &mut LimbsSolution,
    ) -> bool {
        if !self.reduced_reactions_into(posed, legs_inverse, out) {
            return false;
        }
        self.take_up(posed, out);
        out.status = self.determinacy(out);
        true
    }

    /// The reactions of [`Assembly::solve_loads_reduced_into`] alone (`f_s`, `f_b`,
    /// `mu`, `m_b`), bit for bit, without the take-up: what the switch search needs
    /// between samples. Leaves the status. False where the reduced form does not apply.
    pub fn reduced_reactions_into(
        &self,
        posed: &Posed,
        legs_inverse: Option<&SMatrix<f64, 6, 6>>,
        out: &mut LimbsSolution,
    ) -> bool {
        let n = self.limbs.len();
        if n != 6 || self.limbs.iter().any(|l| l.base.moments() != 1) {
            return false;
        }
        let g = &self.gravity;
        let plat = &posed.platform;
        let mut forces = [Vector3::zeros(); MAX_LIMBS];
        let mut across = [Vector3::zeros(); MAX_LIMBS];
        let mut axis = [Vector3::zeros(); MAX_LIMBS];
        let mut screws = SMatrix::<f64, 6, 6>::zeros();
        let mut rhs = SVector::<f64, 6>::zeros();
        rhs.fixed_rows_mut::<3>(0).copy_from(&(plat.demand(g) - posed.force));
        rhs.fixed_rows_mut::<3>(3)
            .copy_from(&(plat.spin() - (posed.force_at - plat.centre).cross(&posed.force) - posed.moment));
        for (i, limb) in self.limbs.iter().enumerate() {
            let lp = &posed.limbs[i];
            let (mut f, mut m) = (Vector3::zeros(), Vector3::zeros());
            for body in &lp.bodies {
                let d = body.demand(g);
                f += d;
                m += body.spin() + (body.centre - lp.b).cross(&d);
            }
            let r = lp.a - lp.b;
            let (len2, d) = (r.norm_squared(), lp.moment_basis(limb.base)[0]);
            let e = r / len2.sqrt();
            let along = e.dot(&d);
            if along.abs() <= 1e-12 * d.norm() || len2 == 0.0 {
                return false;
            }
            let mu = e.dot(&m) / along;
            let perp = -r.cross(&(mu * d - m)) / len2;
            let arm = lp.a - plat.centre;
            screws.fixed_view_mut::<3, 1>(0, i).copy_from(&e);
            screws.fixed_view_mut::<3, 1>(3, i).copy_from(&arm.cross(&e));
            let mut moment = rhs.fixed_rows_mut::<3>(3);
            moment -= arm.cross(&perp);
            let mut force = rhs.fixed_rows_mut::<3>(0);
            force -= perp;
            (forces[i], across[i], axis[i]) = (f, perp, e);
            out.mu[i][0] = mu;
            out.m_b[i] = mu * d;
        }
        let t = match legs_inverse {
            Some(inverse) => {
                // Σ (A − C)×f = Σ (A − P)×f + (P − C)×Σ f.
                let force = rhs.fixed_rows::<3>(0).into_owned();
                let about_p = rhs.fixed_rows::<3>(3) - (posed.p - plat.centre).cross(&force);
                rhs.fixed_rows_mut::<3>(3).copy_from(&about_p);
                inverse * rhs
            }
            None => match screws.lu().solve(&rhs) {
                Some(t) => t,
                None => return false,
            },
        };
        for i in 0..n {
            out.f_s[i] = t[i] * axis[i] + across[i];
            out.f_b[i] = forces[i] + out.f_s[i];
        }
        true
    }

    /// `ok` when every kind's take-up is determinate, else `indeterminate_contact`.
    fn determinacy(&self, out: &LimbsSolution) -> Status {
        let determinate = out.kind_ok.iter().take(self.kinds.len()).all(|&ok| ok);
        if determinate { Status::Ok } else { Status::IndeterminateContact }
    }

    /// Factors and solves `A·w = b`, then the reactions and take-up into `out`; false
    /// (status `near_singular`) where `A` is singular or ill-conditioned.
    fn solve_reactions(&self, posed: &Posed, data: &mut AssemblyData, out: &mut LimbsSolution) -> bool {
        self.assemble_equilibrium(posed, data.a.as_mut(), data.w.as_mut());
        if !data.lu_a.factor(data.a.as_ref()) {
            out.cond_a = f64::INFINITY;
            return false;
        }
        if !self.within_limit(&mut data.lu_a, data.a.as_ref(), &mut out.cond_a) {
            return false;
        }
        data.lu_a.solve_factored(data.w.as_mut());
        self.reactions_into(posed, &data.w, out);
        self.take_up(posed, out);
        true
    }

    /// The per-kind and total errors of the take-ups in `out.take` (docs/model.md §6),
    /// and `out.cond_jp`; false (errors untouched) where `J_P` is singular or
    /// ill-conditioned. [`Assembly::solve`] calls it after the take-up; alone, it gives
    /// the response to any displacements of the joints.
    pub fn solve_errors(&self, posed: &Posed, out: &mut LimbsSolution, data: &mut AssemblyData) -> bool {
        self.assemble_error(posed, out, data.jp.as_mut(), data.dq.as_mut());
        if !data.lu_jp.factor(data.jp.as_ref()) {
            out.cond_jp = f64::INFINITY;
            return false;
        }
        if !self.within_limit(&mut data.lu_jp, data.jp.as_ref(), &mut out.cond_jp) {
            return false;
        }
        data.lu_jp.solve_factored(data.dq.as_mut());
        let (first, m0) = self.screws(posed, 0);
        out.total = PoseError::default();
        for k in 0..self.kinds.len() {
            let mut t = self.clearance_twist(posed, out, k, 0);
            for u in 0..m0 {
                t += first[u] * data.dq[(u, k)];
            }
            out.errors[k] = pose_error(&t, posed.psi_theta);
            out.total.dalpha += out.errors[k].dalpha;
            out.total.dp += out.errors[k].dp;
            for q in 0..3 {
                out.total.euler[q] += out.errors[k].euler[q];
            }
        }
        true
    }

    /// [`Assembly::solve`] for each pose of a batch, into `out` (same length).
    #[track_caller]
    pub fn solve_batch(&self, posed: &[Posed], data: &mut AssemblyData, out: &mut [LimbsSolution]) {
        assert_eq!(posed.len(), out.len(), "one result per pose");
        for (p, o) in posed.iter().zip(out) {
            *o = self.solve(p, data);
        }
    }
}
