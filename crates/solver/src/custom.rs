//! Reactions, take-up and errors of a mechanism described by its joints
//! (docs/model.md §12.4–12.7), from the systems its description implies.
//!
//! Every limb reduces to its constraint wrenches on the platform. With `Ξ_i` the
//! passive columns of limb i (spatial screws at the pose) and `S` the swap of a
//! six-vector's halves, the wrenches `W = [f; m_O]` that do no work on them span the
//! null space of `(S·Ξ_i)ᵀ`; `N_i`, an orthonormal basis of it, has `6 − p_i` columns,
//! and `G = [N_1 … N_L]` is 6 × 6 when the counts of §12.3 hold.
//!
//! - Reactions: a joint transmits (proximal on distal) `W_J = W_i + C_J`, `W_i` the
//!   limb's wrench on the platform and `C_J` the inertial-minus-gravity wrenches of the
//!   bodies beyond J. A passive column does no work: `(S·ξ)ᵀ·W_J = 0`, which fixes
//!   `W_i = W0_i + N_i·λ_i`; the platform's balance `Σ W_i = D_platform` is `G·λ = …`.
//! - Errors: `ΔΓ = Ξ_i·δq_i + ζ_i` per limb; `N_iᵀ·S` eliminates `δq_i`, so
//!   `(Gᵀ·S)·ΔΓ = [N_iᵀ·S·ζ_i]`: the transpose of the same 6 × 6.
//!
//! `cond_a` and `cond_jp` are both `κ₂(G)` (the two systems share it; an orthonormal
//! basis of each limb's wrenches makes it independent of the basis chosen).

use std::sync::atomic::{AtomicU64, Ordering};

use nalgebra::{DMatrix, Matrix3, Matrix6, SMatrix, Vector3, Vector6};

use clearance_kinematics::custom::{
    Configuration, CustomGeometry, CustomPosture, Few, JointState, Reflectors, Rigid, Unsolved, custom_posture,
    custom_posture_near, exp_so3, householder, placement,
};
use clearance_model::custom::{Group, JointType};
use clearance_model::{JobError, JobSpec, Mode};

use crate::fast::Points;
use crate::pose::{PoseResult, Status, Workspace, solve_pose};

type V3 = Vector3<f64>;
type V6 = Vector6<f64>;

fn w(s: &V6) -> V3 {
    s.fixed_rows::<3>(0).into_owned()
}

fn v(s: &V6) -> V3 {
    s.fixed_rows::<3>(3).into_owned()
}

fn six(a: V3, b: V3) -> V6 {
    V6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

/// `S·x`: the halves swapped (a screw's pairing with a wrench is `Wᵀ·S·ξ`).
fn swap(s: &V6) -> V6 {
    six(v(s), w(s))
}

/// A group of one joint of one limb that has play (docs/model.md §12.5).
#[derive(Clone, Debug)]
pub struct GroupDef {
    pub limb: usize,
    pub joint: usize,
    pub group: Group,
    /// Index of its kind (`<name>_<group>`) in [`CustomModel::kinds`].
    pub kind: usize,
    pub magnitude: f64,
    /// `<name><limb>_<group>`.
    pub label: String,
}

impl GroupDef {
    /// Whether its deciding load is a scalar (a sign decides) or a vector.
    pub fn scalar(&self, joint: JointType) -> bool {
        matches!(
            (joint, self.group),
            (_, Group::Backlash) | (JointType::R, Group::Axial) | (JointType::U, Group::Angular)
        )
    }
}

/// A custom mechanism with its masses, loads and clearances, ready to solve.
#[derive(Clone, Debug)]
pub struct CustomModel {
    pub geom: CustomGeometry,
    pub gravity: V3,
    pub platform_mass: f64,
    /// About P in platform axes.
    pub platform_inertia: Matrix3<f64>,
    /// Point masses on the platform: mass and offset in platform axes.
    pub points: Vec<(f64, V3)>,
    pub force: V3,
    pub moment: V3,
    /// Where the force acts, platform axes.
    pub force_at: V3,
    /// The kinds `<name>_<group>` of the job, in canonical order.
    pub kinds: Vec<String>,
    /// Every (limb, joint, group) of a kind of the job, kind by kind, then limb by limb.
    pub groups: Vec<GroupDef>,
    /// `W = m_total·|g|`.
    pub weight: f64,
    /// Deciding loads at or below it are indeterminate.
    pub floor: f64,
    pub singular_cond: f64,
    pub exact: bool,
    /// Where the description is a built-in kind's, that kind's kernel, which then
    /// solves its poses ([`Preset`]); `None` (as [`CustomModel::from_job`] leaves it):
    /// the general path for every pose.
    pub preset: Option<std::sync::Arc<Preset>>,
    /// The groups in the order that breaks a tie for the dominant joint (joint type S,
    /// U, R, P; place in the limb; group; limb), from [`CustomModel::groups`] and the
    /// joints, which a sweep's variants do not change.
    tie_order: Vec<usize>,
}

/// A group's unit response below this `|Δp|` (m per m, or per rad times 1 m) cannot
/// move the platform (docs/model.md §12.5).
pub const IMMOBILE: f64 = 1e-9;

impl CustomModel {
    /// The model of a custom job; `Err` if it is not one, or its description is refused,
    /// or its systems are singular at home (docs/model.md §12.3).
    pub fn from_job(job: &JobSpec, file: &str) -> Result<Self, JobError> {
        let d = job.description(file).ok_or_else(|| JobError::new(file, "mechanism.kind", "is not \"custom\""))??;
        let geom = CustomGeometry::new(&d.inputs, d.home, &d.limbs);
        let mut groups = Vec::new();
        let mut kinds = Vec::new();
        for (k, (kind, magnitude)) in d.kinds.iter().enumerate() {
            kinds.push(kind.key.clone());
            let with = clearance_model::custom::limbs_with(&d.limbs, &kind.joint, kind.group);
            for (n, &limb) in with.iter().enumerate() {
                let joint = d.limbs[limb].joints.iter().position(|j| j.name() == kind.joint).expect("the limb has it");
                groups.push(GroupDef {
                    limb,
                    joint,
                    group: kind.group,
                    kind: k,
                    magnitude: magnitude.of(n),
                    label: format!("{}{}_{}", kind.joint, limb + 1, kind.group.name()),
                });
            }
        }
        let m = &job.mass;
        let radius = geom.platform_radius();
        let platform_inertia = match m.platform_inertia {
            Some(i) => Matrix3::from_diagonal(&V3::new(i[0], i[1], i[2])),
            None => Matrix3::from_diagonal(&V3::new(
                m.platform * radius * radius / 4.0,
                m.platform * radius * radius / 4.0,
                m.platform * radius * radius / 2.0,
            )),
        };
        let weight = job.weight();
        let mut tie_order: Vec<usize> = (0..groups.len()).collect();
        tie_order.sort_by_key(|&i| {
            let g: &GroupDef = &groups[i];
            (geom.limbs[g.limb].joints[g.joint].joint.tie_rank(), g.joint, g.group, g.limb)
        });
        let model = Self {
            gravity: V3::from(job.mechanism.gravity),
            platform_mass: m.platform,
            platform_inertia,
            points: m.points.iter().map(|p| (p.mass, V3::from(p.at))).collect(),
            force: V3::from(job.load.force),
            moment: V3::from(job.load.moment),
            force_at: V3::from(job.load.at),
            kinds,
            groups,
            weight,
            floor: job.analysis.indeterminate_load_fraction * weight,
            singular_cond: job.analysis.singular_cond,
            exact: job.analysis.exact,
            preset: None,
            tie_order,
            geom,
        };
        // Rigid at home: the limbs' constraint wrenches span every wrench.
        let home: Vec<f64> = model.geom.inputs.iter().map(|&k| model.geom.home[k]).collect();
        // Ranges bound the poses, not home: the closure there is checked without them.
        let mut free = model.geom.clone();
        for j in free.limbs.iter_mut().flat_map(|l| l.joints.iter_mut()) {
            j.range = None;
        }
        let p = custom_posture(&free, &home, None).map_err(|_| {
            JobError::new(
                file,
                "mechanism.home",
                "the joints do not close at home: check the limbs' last joints against the platform's home pose",
            )
        })?;
        if !clearance_kinematics::custom::determined_at_home(&model.geom) {
            return Err(JobError::new(
                file,
                "mechanism.inputs",
                "the inputs do not determine the pose at home: with them fixed and the actuators free, the closure is singular there (choose other inputs, or check the joints)",
            ));
        }
        let closure = p
            .joints
            .iter()
            .zip(&model.geom.limbs)
            .map(|(pj, l)| (pj.last().expect("joints").centre - l.joints.last().expect("joints").centre).norm())
            .fold(0.0, f64::max);
        if closure > 1e-9 * model.geom.length {
            return Err(JobError::new(file, "mechanism.home", "the joints do not close at home"));
        }
        match Basis::new(&p, &model.geom).map(|b| b.cond()) {
            Some(cond) if cond.is_finite() && cond < 1e12 => Ok(model),
            _ => Err(JobError::new(
                file,
                "mechanism.limb",
                "the mechanism is not rigid at home although its counts are right (its constraint wrenches are linearly dependent: a rank deficiency); check the joints' axes",
            )),
        }
    }

    /// The kinds' count.
    pub fn kind_count(&self) -> usize {
        self.kinds.len()
    }

    fn joint_type(&self, g: &GroupDef) -> JointType {
        self.geom.limbs[g.limb].joints[g.joint].joint
    }

    /// Whether a group's deciding load is a scalar.
    pub fn scalar_group(&self, g: &GroupDef) -> bool {
        g.scalar(self.joint_type(g))
    }

    /// Whether group `g`'s deciding load is a scalar.
    pub fn scalar(&self, g: usize) -> bool {
        self.groups[g].scalar(self.joint_type(&self.groups[g]))
    }

    /// The actuated joints: (limb, joint), in limb order.
    pub fn actuators(&self) -> Vec<(usize, usize)> {
        let mut out = Vec::new();
        for (l, limb) in self.geom.limbs.iter().enumerate() {
            for (j, joint) in limb.joints.iter().enumerate() {
                if joint.actuated {
                    out.push((l, j));
                }
            }
        }
        out
    }
}

/// Each limb's orthonormal basis of the wrenches its passive freedoms let through.
struct Basis {
    /// `[N_1 … N_L]`.
    g: Matrix6<f64>,
    /// Per limb: its passive columns and their QR.
    limbs: Vec<LimbBasis>,
}

/// One limb's passive columns `Ξ_i` and the Householder QR of `S·Ξ_i`.
struct LimbBasis {
    cols: [V6; 6],
    n: usize,
    q: Reflectors,
    /// `R` of the QR (upper triangle of the first `n` columns).
    r: Matrix6<f64>,
    /// The column of `G` where the limb's block `N_i` starts, and its width `6 − n`.
    start: usize,
    width: usize,
}

impl LimbBasis {
    /// The passive columns.
    fn passive(&self) -> &[V6] {
        &self.cols[..self.n]
    }

    /// The wrench `W0` in the span of `S·Ξ_i` with `(S·ξ_k)ᵀ·W0 = r_k` for each column:
    /// `Q·[R⁻ᵀ·r; 0]`.
    fn particular(&self, r: &[f64; 6]) -> V6 {
        let mut y = V6::zeros();
        for i in 0..self.n {
            let mut t = r[i];
            for j in 0..i {
                t -= self.r[(j, i)] * y[j];
            }
            y[i] = t / self.r[(i, i)];
        }
        self.q.apply_q(&y)
    }
}

impl Basis {
    fn new(p: &CustomPosture, geom: &CustomGeometry) -> Option<Basis> {
        let mut g = Matrix6::zeros();
        let mut limbs = Vec::with_capacity(geom.limbs.len());
        let mut at = 0;
        for (limb, pj) in geom.limbs.iter().zip(&p.joints) {
            let mut cols = [V6::zeros(); 6];
            let mut n = 0;
            for c in limb.joints.iter().zip(pj).filter(|(j, _)| !j.actuated).flat_map(|(_, pj)| &pj.columns) {
                if n == 6 {
                    return None;
                }
                cols[n] = *c;
                n += 1;
            }
            if at + 6 - n > 6 {
                return None;
            }
            // Householder QR of the swapped columns: the last 6 − n rows of Qᵀ are an
            // orthonormal basis of the wrenches that do no work on them.
            let mut m = Matrix6::zeros();
            for (k, c) in cols[..n].iter().enumerate() {
                m.set_column(k, &swap(c));
            }
            let q = householder(&mut m, n)?;
            let largest = (0..n).map(|k| m[(k, k)].abs()).fold(1.0, f64::max);
            if (0..n).any(|k| m[(k, k)].abs() <= 1e-12 * largest) {
                return None; // the limb's own freedoms are dependent: a limb singularity
            }
            for k in 0..6 - n {
                g.set_column(at + k, &q.qt_row(n + k));
            }
            limbs.push(LimbBasis { cols, n, q, r: m, start: at, width: 6 - n });
            at += 6 - n;
        }
        if at != 6 {
            return None;
        }
        Some(Basis { g, limbs })
    }

    /// Limb `l`'s columns of `G`: where they start, and how many.
    fn block(&self, l: usize) -> (usize, usize) {
        (self.limbs[l].start, self.limbs[l].width)
    }

    /// The 2-norm condition number of `G` (from its singular values).
    fn cond(&self) -> f64 {
        cond_of(&self.g)
    }
}

/// The take-up of one group at a pose.
#[derive(Clone, Copy, Debug, Default)]
pub struct GroupTake {
    /// The deciding load (a scalar in `[0]` for scalar loads).
    pub load: [f64; 3],
    /// Its magnitude: the margin.
    pub margin: f64,
    /// The displacement as a spatial twist (magnitude included).
    pub twist: V6,
    pub indeterminate: bool,
    /// Whether its unit response moves P at all; `false` where the group has no play
    /// (its take-up is nothing, and nothing reads whether it could move P: the switch
    /// search reads a member of a sweep that has the play), except on a described
    /// 3-PRS's kernel.
    pub mobile: bool,
    /// Its own contribution to `|Δp|` (for the dominant joint).
    pub dp: f64,
}

/// One pose of a custom mechanism, solved.
#[derive(Clone, Debug, Default)]
pub struct CustomResult {
    pub status: Status,
    /// `x, y, z, φ, ψ, θ`; the parasitic ones NaN when unreachable.
    pub coords: [f64; 6],
    pub q: Vec<f64>,
    pub tau: Vec<f64>,
    /// Per limb, per joint: force and couple (about the joint's centre), proximal on distal.
    pub reactions: Reactions,
    pub takes: Vec<GroupTake>,
    /// Per kind `[Δp; Δα]` then Euler errors: 9 components (`None`: indeterminate).
    pub kind_errors: Vec<Option<[f64; 9]>>,
    pub total: Option<[f64; 9]>,
    /// Per kind, then the total: `x, y, z, rx, ry, rz, p, alpha`.
    pub envelope: Vec<[f64; 8]>,
    pub env_total: [f64; 8],
    /// Index into [`CustomModel::groups`].
    pub dominant: Option<usize>,
    pub cond: f64,
    pub exact: Option<[f64; 6]>,
}

/// A pose's joint reactions, `reactions[limb][joint]`: force and couple (about the
/// joint's centre), proximal on distal. The limbs' joints one after another in one
/// buffer: a pose is solved millions of times, and a buffer a limb was most of a
/// 6-UPS pose's allocations.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reactions {
    values: Vec<(V3, V3)>,
    /// Where each limb's joints end in `values`.
    ends: Vec<u32>,
}

impl Reactions {
    /// Room for `limbs` limbs of `joints` joints in all.
    pub fn with_capacity(limbs: usize, joints: usize) -> Self {
        Self { values: Vec::with_capacity(joints), ends: Vec::with_capacity(limbs) }
    }

    /// The limbs of `limbs`, each its joints' reactions in order.
    pub fn of<L: AsRef<[(V3, V3)]>>(limbs: &[L]) -> Self {
        Self::with_capacity(limbs.len(), limbs.iter().map(|l| l.as_ref().len()).sum()).refill(limbs)
    }

    /// [`Reactions::of`] in this value's memory (emptied first).
    pub fn refill<L: AsRef<[(V3, V3)]>>(mut self, limbs: &[L]) -> Self {
        self.values.clear();
        self.ends.clear();
        // Room for all at once: grown limb by limb, a fresh value was reallocated at
        // each of its first limbs.
        self.values.reserve(limbs.iter().map(|l| l.as_ref().len()).sum());
        self.ends.reserve(limbs.len());
        for l in limbs {
            self.push_limb(l.as_ref().iter().copied());
        }
        self
    }

    /// Adds the next limb, its joints' reactions in order.
    pub fn push_limb(&mut self, joints: impl IntoIterator<Item = (V3, V3)>) {
        self.values.extend(joints);
        self.ends.push(u32::try_from(self.values.len()).expect("fewer than 2³² joints"));
    }

    /// The number of limbs.
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    /// Whether there is no limb.
    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }

    /// Each limb's joints' reactions, in order.
    pub fn iter(&self) -> impl Iterator<Item = &[(V3, V3)]> {
        (0..self.len()).map(|l| &self[l])
    }
}

impl std::ops::Index<usize> for Reactions {
    type Output = [(V3, V3)];

    fn index(&self, limb: usize) -> &[(V3, V3)] {
        let start = if limb == 0 { 0 } else { self.ends[limb - 1] as usize };
        &self.values[start..self.ends[limb] as usize]
    }
}

impl CustomResult {
    /// Whether the pose has reactions (and loads).
    pub fn loaded(&self) -> bool {
        matches!(self.status, Status::Ok | Status::IndeterminateContact)
    }
}

thread_local! {
    /// Results let go of on this thread ([`recycle`]), whose vectors the presets'
    /// results built here next reuse ([`spare_result`]).
    static SPARE: std::cell::RefCell<Vec<CustomResult>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Lets go of `r`, keeping its vectors for a result built next on this thread, up to
/// `most` results a thread (the rest are freed). A preset's pose allocates seven
/// vectors; allocated and freed for every pose, glibc's thread caches (seven blocks of
/// a size) ran dry, and its allocator was a tenth of a described 3-PRS's CPU (`perf`).
pub fn recycle(r: CustomResult, most: usize) {
    SPARE.with_borrow_mut(|spare| {
        if spare.len() < most {
            spare.push(r);
        }
    });
}

/// Frees the results this thread keeps for reuse ([`recycle`]).
pub fn drop_spare_results() {
    SPARE.take();
}

/// A result let go of on this thread, or a new one: only its vectors' memory is
/// meant to be reused (every field is set again by its caller).
fn spare_result() -> CustomResult {
    SPARE.with_borrow_mut(Vec::pop).unwrap_or_default()
}

/// `v` emptied, then filled from `items`: its memory reused.
fn refill<T>(mut v: Vec<T>, items: impl IntoIterator<Item = T>) -> Vec<T> {
    v.clear();
    v.extend(items);
    v
}

fn skew_axial(r: &Matrix3<f64>) -> V3 {
    V3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]) / 2.0
}

/// The rotation vector of `r`, accurate at small angles (atan2 of sine and cosine).
pub fn log_so3(r: &Matrix3<f64>) -> V3 {
    let a = skew_axial(r);
    let s = a.norm();
    let c = (r.trace() - 1.0) / 2.0;
    if s == 0.0 {
        return V3::zeros();
    }
    a * (s.atan2(c) / s)
}

/// The nine components of an error `[Δp; Δα]` at the pose `coords`: the six, then
/// `[ΔΦ, ΔΨ, ΔΘ]` from `Δα = ΔΘ·ŷ + ΔΨ·R_y x̂ + ΔΦ·R_y R_x ẑ` (docs/model.md §6), NaN
/// where the angles are singular. The 3 × 3 map is factored once for the pose's kinds
/// and total; the last angles' factors are kept on each thread (a grid at one
/// orientation, or a line of one angle, meets the same angles pose after pose).
fn nine_at(coords: &[f64; 6]) -> impl Fn(&[f64; 6]) -> [f64; 9] {
    type Factored = ([u64; 2], Lu3);
    thread_local! {
        static LAST: std::cell::Cell<Option<Factored>> = const { std::cell::Cell::new(None) };
    }
    let key = [coords[4].to_bits(), coords[5].to_bits()];
    let lu = LAST.with(|last| match last.get() {
        Some((k, lu)) if k == key => lu,
        _ => {
            let ry = nalgebra::Rotation3::from_axis_angle(&V3::y_axis(), coords[5]).into_inner();
            let rx = nalgebra::Rotation3::from_axis_angle(&V3::x_axis(), coords[4]).into_inner();
            let lu = Lu3::new(&Matrix3::from_columns(&[ry * rx * V3::z(), ry * V3::x(), V3::y()]));
            last.set(Some((key, lu)));
            lu
        }
    });
    move |e| {
        let eu = lu.solve([e[3], e[4], e[5]]).unwrap_or([f64::NAN; 3]);
        [e[0], e[1], e[2], e[3], e[4], e[5], eu[0], eu[1], eu[2]]
    }
}

/// nalgebra's LU of a 3 × 3 matrix (partial pivoting) and its `solve`: the same
/// operations in the same order (so the same bits), without its generic loops.
#[derive(Clone, Copy, Debug)]
struct Lu3 {
    /// Row `k` of the permuted right-hand side is row `perm[k]` of the given one.
    perm: [usize; 3],
    /// `L` (unit diagonal) below the diagonal, `U` on and above it.
    lu: [[f64; 3]; 3],
}

impl Lu3 {
    /// nalgebra's `LU::new`: at each column the first row of largest `|a|` at or below
    /// the diagonal is the pivot (a zero pivot skips the column), the rows swapped, the
    /// column below scaled by the pivot's reciprocal and the rows below updated.
    fn new(m: &Matrix3<f64>) -> Self {
        let mut a: [[f64; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]));
        let mut perm = [0, 1, 2];
        for i in 0..3 {
            let mut piv = i;
            for r in i + 1..3 {
                if a[r][i].abs() > a[piv][i].abs() {
                    piv = r;
                }
            }
            let diag = a[piv][i];
            if diag == 0.0 {
                continue;
            }
            a.swap(i, piv);
            perm.swap(i, piv);
            let inv = 1.0 / diag;
            for row in a.iter_mut().skip(i + 1) {
                row[i] *= inv;
            }
            for k in i + 1..3 {
                let p = a[i][k];
                for row in a.iter_mut().skip(i + 1) {
                    row[k] += (-p) * row[i];
                }
            }
        }
        Self { perm, lu: a }
    }

    /// `x` with `M·x = b`; `None` where a pivot is zero (as nalgebra's `solve`). Each
    /// update adds `(−c)·a`, as nalgebra's `axpy` (addition commutes, bit for bit).
    fn solve(&self, b: [f64; 3]) -> Option<[f64; 3]> {
        let a = &self.lu;
        let mut x = self.perm.map(|k| b[k]);
        // L·y = P·b, unit diagonal.
        x[1] += (-x[0]) * a[1][0];
        x[2] += (-x[0]) * a[2][0];
        x[2] += (-x[1]) * a[2][1];
        // U·x = y, from the last row.
        for i in (0..3).rev() {
            if a[i][i] == 0.0 {
                return None;
            }
            let c = x[i] / a[i][i];
            x[i] = c;
            for j in 0..i {
                x[j] += (-c) * a[j][i];
            }
        }
        Some(x)
    }
}

/// A spatial twist's error at P: `[Δp; Δα]` (Δp the velocity of P).
fn at_p(t: &V6, p: &V3) -> [f64; 6] {
    let (a, vo) = (w(t), v(t));
    let dp = vo + a.cross(p);
    [dp.x, dp.y, dp.z, a.x, a.y, a.z]
}

/// Solves one pose: `inputs` in canonical order, `rates = (velocities, accelerations)`
/// of the inputs (dynamics).
pub fn solve_custom(model: &CustomModel, inputs: &[f64], rates: Option<(&[f64], &[f64])>, mode: Mode) -> CustomResult {
    solve_custom_near(model, inputs, rates, mode, None).0
}

/// [`solve_custom`] with the configuration continued from `near`, a solved pose close by
/// (to round-off the same result, see [`custom_posture_near`]); also returns the pose's
/// configuration, where it has one, for the next.
pub fn solve_custom_near(
    model: &CustomModel,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    near: Option<&Configuration>,
) -> (CustomResult, Option<Configuration>) {
    let (mut all, configuration) = solve_members_near(&[model], inputs, rates, mode, near, Wanted::Whole);
    (all.pop().expect("one model, one result"), configuration)
}

/// What a solve gives of a pose ([`solve_members_near`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wanted {
    /// Every field, with `κ₂(G)` (`cond`).
    Whole,
    /// Every field the same bits, but `κ₂(G)` only where it decides (the switch
    /// search, which writes no condition number): `‖G‖_F·‖G⁻¹‖_F` bounds it from above,
    /// and a bound within `singular_cond` accepts the pose as `κ₂` would (its `cond` is
    /// then NaN).
    WithoutCond,
    /// What the switch search reads of a pose for the switches and jumps of one kind,
    /// [`Wanted::WithoutCond`]'s bits: the coordinates, whether the pose has loads, the
    /// take-up of each group of that kind and the kind's error. Every other group's
    /// take-up is left default (so the status is `ok` where only another kind's
    /// take-up is indeterminate), every other kind's error `None`, the total and the
    /// dominant joint `None`, the envelope the kind's alone. The take-up of the other
    /// kinds' groups (their unit responses and envelope) is most of a whole solve
    /// where the kernel does not give it.
    Kind(usize),
    /// What the switch search reads of a switch's own point: the coordinates and
    /// whether the pose has loads, [`Wanted::WithoutCond`]'s bits. No group's take-up
    /// (each left default, so the status is `ok` where the pose has loads), no error,
    /// no envelope, no total, no dominant joint.
    Posed,
}

/// `only` of a solve that reads no kind's take-up ([`Wanted::Posed`]): a kind no group has.
const NO_KIND: usize = usize::MAX;

/// [`solve_custom_near`] for the members of a clearance sweep: models equal but for
/// their clearances (with the same kinds), giving what `wanted` asks. The kinematics
/// and the reactions are solved once; each member takes up its own clearances. Each
/// result is, bit for bit, the member's solved alone.
pub fn solve_members_near(
    models: &[&CustomModel],
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    near: Option<&Configuration>,
    wanted: Wanted,
) -> (Vec<CustomResult>, Option<Configuration>) {
    let (cond_of, only) = match wanted {
        Wanted::Whole => (CondOf::Each, None),
        Wanted::WithoutCond => (CondOf::Verdict, None),
        Wanted::Kind(k) => (CondOf::Verdict, Some(k)),
        Wanted::Posed => (CondOf::Verdict, Some(NO_KIND)),
    };
    let model = models[0];
    let rates = if mode == Mode::Dynamic { rates } else { None };
    if models.iter().all(|m| m.preset.is_some()) {
        let fast: Option<Vec<CustomResult>> = models
            .iter()
            .map(|m| m.preset.as_deref().and_then(|p| preset_result(m, p, inputs, rates, mode, cond_of, only)))
            .collect();
        if let Some(fast) = fast {
            return (fast, None);
        }
    }
    let mut out = CustomResult {
        coords: [f64::NAN; 6],
        cond: f64::NAN,
        kind_errors: vec![None; model.kinds.len()],
        envelope: vec![[f64::NAN; 8]; model.kinds.len()],
        env_total: [f64::NAN; 8],
        ..Default::default()
    };
    for (i, &k) in model.geom.inputs.iter().enumerate() {
        out.coords[k] = inputs[i];
    }
    let posture = match custom_posture_near(&model.geom, inputs, rates, near) {
        Ok(p) => p,
        Err(unsolved) => {
            if let Unsolved::OutOfRange(coords) = unsolved {
                out.coords = coords;
            }
            out.status = Status::Unreachable;
            return (vec![out; models.len()], None);
        }
    };
    let solved = solve_posture(models, &posture, out, cond_of, only);
    (solved, Some((posture.coords, posture.states)))
}

/// Group `group`'s deciding load at a pose where the pose has loads and the group can
/// move P, else `None` (what the switch search reads): the value [`solve_custom_near`]
/// gives, bit for bit, without the other groups' take-up, the errors or the envelope.
/// Also returns the pose's configuration, where it has one.
pub fn group_load_near(
    model: &CustomModel,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    near: Option<&Configuration>,
    group: usize,
) -> (Option<[f64; 3]>, Option<Configuration>) {
    let rates = if mode == Mode::Dynamic { rates } else { None };
    if let Some(load) = model.preset.as_deref().and_then(|p| preset_load(model, p, inputs, rates, mode, group)) {
        return (load, None);
    }
    let Ok(posture) = custom_posture_near(&model.geom, inputs, rates, near) else { return (None, None) };
    let mut out = CustomResult::default();
    let load = statics(model, &posture, &mut out, CondOf::Verdict).and_then(|(basis, gi)| {
        let g = &model.groups[group];
        let pj = &posture.joints[g.limb][g.joint];
        let at = (&pj.centre, &pj.axis, &pj.normal);
        let system = Blocks { g: &basis.g, block: |l| basis.block(l), gi: &gi, pos: posture.platform.t };
        mobile_load(model, g, out.reactions[g.limb][g.joint], at, &system)
    });
    (load, Some((posture.coords, posture.states)))
}

/// Group `def`'s deciding load from its joint's reaction `(f, m)` and its centre, axis
/// and normal (`at`), where the group can move P (its unit reach in the pose's error
/// system at least [`IMMOBILE`]); else `None`.
fn mobile_load(
    model: &CustomModel,
    def: &GroupDef,
    (f, m): (V3, V3),
    at: (&V3, &V3, &V3),
    system: &impl Responder,
) -> Option<[f64; 3]> {
    let joint = model.joint_type(def);
    let (load, ..) = deciding_load(joint, def.group, at.1, at.2, &f, &m);
    let (.., unit_p, _) = system.reach(def.limb, (joint, def.group), at);
    (unit_p >= IMMOBILE).then_some([load.x, load.y, load.z])
}

/// Whether a preset's pose is within `singular_cond` as [`statics`] decides it without
/// the condition number: by the bound `‖G‖_F·‖G⁻¹‖_F` where that suffices, else `κ₂(G)`.
fn bounded(model: &CustomModel, g: &Matrix6<f64>, gi: &Matrix6<f64>) -> bool {
    frobenius_bounded(model, g, gi) || within_limit(model, cond_of(g))
}

/// Whether `‖G‖_F·‖G⁻¹‖_F`, which bounds `κ₂(G)` from above, is within `singular_cond`.
fn frobenius_bounded(model: &CustomModel, g: &Matrix6<f64>, gi: &Matrix6<f64>) -> bool {
    within_limit(model, g.norm() * gi.norm())
}

/// Whether a condition number is within `singular_cond` (NaN is not).
fn within_limit(model: &CustomModel, cond: f64) -> bool {
    cond.is_finite() && cond <= model.singular_cond
}

/// A pose's `cond` and whether the pose is within `singular_cond`: NaN and within where
/// `G⁻¹` is given and [`frobenius_bounded`] accepts the pose without `κ₂(G)`; else
/// `κ₂(G)`, within where it is at most the limit (NaN is not).
fn decided_cond(model: &CustomModel, g: &Matrix6<f64>, gi: Option<&Matrix6<f64>>) -> (f64, bool) {
    if gi.is_some_and(|gi| frobenius_bounded(model, g, gi)) {
        return (f64::NAN, true);
    }
    let cond = cond_of(g);
    (cond, !cond.is_nan() && cond <= model.singular_cond)
}

/// A preset pose's `cond` ([`decided_cond`]), `None` where the pose is beyond the limit.
fn accepted_cond(model: &CustomModel, g: &Matrix6<f64>, gi: Option<&Matrix6<f64>>) -> Option<f64> {
    let (cond, within) = decided_cond(model, g, gi);
    within.then_some(cond)
}

/// What a pose gives of `κ₂(G)` (its `cond`).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum CondOf {
    /// Every pose's.
    Each,
    /// Only where it may be the largest of the poses solved at once
    /// ([`preset_members`], [`LargestCond`]): all that the statistics read of it where
    /// no column holds it. A pose whose [`cond_bound`] is within `singular_cond` is
    /// accepted by it, its `cond` left NaN and its bound and `G` kept ([`Open`]) for
    /// [`settle_largest`].
    Largest,
    /// None where `‖G‖_F·‖G⁻¹‖_F` decides the pose within `singular_cond` (the switch
    /// search, [`decided_cond`]).
    Verdict,
}

/// A pose whose `cond` is left NaN under [`CondOf::Largest`]: its [`cond_bound`] and
/// its `G`.
type Open = (f64, Matrix6<f64>);

/// A preset pose's `cond` as `cond_of` asks it ([`accepted_cond`], or with
/// [`cond_bound`] under [`CondOf::Largest`], the pose then [`Open`]; `known` a `cond`
/// that some pose of the solve has), `None` where the pose is beyond the limit.
fn given_cond(
    model: &CustomModel,
    g: &Matrix6<f64>,
    gi: Option<&Matrix6<f64>>,
    (cond_of, known): (CondOf, f64),
    open: &mut Option<Open>,
) -> Option<f64> {
    match cond_of {
        CondOf::Each => accepted_cond(model, g, None),
        CondOf::Verdict => accepted_cond(model, g, gi),
        CondOf::Largest => {
            if let Some((bound, _)) = open {
                // Another member's, at the same `G`.
                return within_limit(model, *bound).then_some(f64::NAN);
            }
            if let Some(bound) = near_bound(g).filter(|b| *b < known && within_limit(model, *b)) {
                *open = Some((bound, *g));
                return Some(f64::NAN);
            }
            let (bound, sigmas) = cond_bound(g, gi, known);
            if let Some((hi, lo)) = sigmas {
                NEAR.set(Some(Near { g: *g, hi, lo }));
            }
            if within_limit(model, bound) {
                *open = Some((bound, *g));
                Some(f64::NAN)
            } else {
                accepted_cond(model, g, None)
            }
        }
    }
}

/// A pose whose singular values of `G` are bounded, `σ_max ≤ hi` and `σ_min ≥ lo`
/// (by the bounds of [`cond_bound`] that need `G⁻¹`, where it vouches for them).
#[derive(Clone, Copy)]
struct Near {
    g: Matrix6<f64>,
    hi: f64,
    lo: f64,
}

thread_local! {
    /// The last pose on this thread whose singular values [`cond_bound`] bounded:
    /// the poses of a run are neighbours on a grid line or a trajectory.
    static NEAR: std::cell::Cell<Option<Near>> = const { std::cell::Cell::new(None) };
}

/// An upper bound of `κ₂(G)` from the last pose this thread bounded ([`NEAR`]), about
/// a twentieth of [`cond_bound`]'s arithmetic: each singular value moves by at most
/// `‖G − G'‖₂ ≤ ‖G − G'‖_F = d` (Weyl), so `κ₂(G) ≤ (hi + d)/(lo − d)`. `None` where
/// `d` exceeds half of `lo` (the bound would be loose, and its round-off no longer
/// that of `hi` and `lo`). Its margin is [`cond_bound`]'s.
fn near_bound(g: &Matrix6<f64>) -> Option<f64> {
    let near = NEAR.get()?;
    let mut d2 = 0.0;
    for (a, b) in g.as_slice().iter().zip(near.g.as_slice()) {
        d2 += (a - b) * (a - b);
    }
    let d = d2.sqrt();
    (d <= 0.5 * near.lo).then(|| (near.hi + d) / (near.lo - d) * (1.0 + 1e-6))
}

/// Above this, [`cond_bound`] does not vouch for its bound: the round-off of `(GᵀG)⁻¹`
/// grows with `κ₂(G)²`.
const BOUND_VOUCHED: f64 = 1e3;

/// An upper bound of `κ₂(G)` (as [`cond_of`] computes it), within a few per cent of
/// it where `GᵀG`'s two largest eigenvalues, and its two smallest, are apart; infinite
/// where it cannot vouch for one. `κ₂(G)² = λ_max(M)·λ_max(M⁻¹)` for `M = GᵀG`, and for
/// a symmetric positive definite `A`, `λ_max(A)⁸ ≤ Σλ⁸ = ‖A⁴‖_F²` ([`eighth_powers`]),
/// within `6^{1/8}` of it and nearer as the largest eigenvalue stands out. `M⁻¹` is
/// `G⁻¹·G⁻ᵀ` where `G⁻¹` is given, else `L⁻ᵀL⁻¹` from the Cholesky factor `L` of `M`.
/// A margin of 1e-6 covers the round-off, which below [`BOUND_VOUCHED`] is under 1e-8
/// relative. About a third of the SVD's arithmetic.
///
/// Where a looser bound, by `λ_max(A)² ≤ Σλ² = ‖A‖_F²` or `λ_max(A)⁴ ≤ Σλ⁴ = ‖A²‖_F²`
/// (on the way to `A⁴`), is already below `below` (a `cond` some pose of the solve
/// has), that bound is given instead: such a pose cannot be the largest, whichever bound
/// it has ([`settle_largest`]), and the eighth powers were most of the arithmetic.
///
/// With the bound, the bounds `(hi, lo)` of `σ_max(G)` and `σ_min(G)` found on the way,
/// where they are vouched for and come from `Σλ⁴` or `Σλ⁸` (`hi/lo` is then the bound
/// before its margin; a bound by `Σλ²` gives none): [`near_bound`] starts from them.
fn cond_bound(g: &Matrix6<f64>, gi: Option<&Matrix6<f64>>, below: f64) -> (f64, Option<(f64, f64)>) {
    let col = |m: &Matrix6<f64>, j: usize| -> [f64; 6] { std::array::from_fn(|i| m[(i, j)]) };
    let cols: [[f64; 6]; 6] = std::array::from_fn(|j| col(g, j));
    let m = gram(|i, j| dot(&cols[i], &cols[j]));
    let inverse = match gi {
        Some(gi) => {
            let rows: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| gi[(i, j)]));
            gram(|i, j| dot(&rows[i], &rows[j]))
        }
        None => {
            // M = L·Lᵀ, then W = L⁻¹ (both lower triangular) and M⁻¹ = Wᵀ·W.
            let mut l = [[0.0; 6]; 6];
            for j in 0..6 {
                for i in j..6 {
                    let v = m[i][j] - dot(&l[i][..j], &l[j][..j]);
                    if i == j {
                        // Not positive (or NaN): `M` is not numerically definite.
                        if v.is_nan() || v <= 0.0 {
                            return (f64::INFINITY, None);
                        }
                        l[j][j] = v.sqrt();
                    } else {
                        l[i][j] = v / l[j][j];
                    }
                }
            }
            let mut w = [[0.0; 6]; 6];
            for i in 0..6 {
                w[i][i] = 1.0 / l[i][i];
                for j in 0..i {
                    let v: f64 = (j..i).map(|k| l[i][k] * w[k][j]).sum();
                    w[i][j] = -v * w[i][i];
                }
            }
            gram(|i, j| (i.max(j)..6).map(|k| w[k][i] * w[k][j]).sum())
        }
    };
    let vouched = |bound: f64| bound.is_finite() && bound <= BOUND_VOUCHED;
    // `Σλ²` and `Σλ⁴` on the way to `Σλ⁸`: the bound by each, given where it suffices
    // (compared as powers, the root taken only for the bound given).
    let squares = |a: &[[f64; 6]; 6]| a.iter().flatten().map(|x| x * x).sum::<f64>();
    let limit = below.min(BOUND_VOUCHED) / (1.0 + 1e-6);
    let limit4 = (limit * limit) * (limit * limit);
    let given = |power: f64, root: f64| Some(power.powf(root) * (1.0 + 1e-6)).filter(|b| *b < below);
    let power = squares(&m) * squares(&inverse);
    if let Some(bound) = (power < limit4).then(|| given(power, 1.0 / 4.0)).flatten() {
        return (bound, None);
    }
    // `σ_max² = λ_max(M) ≤ (Σλ^k)^{1/k}`, `σ_min⁻² = λ_max(M⁻¹)` likewise.
    let sigmas = |a: f64, b: f64, k: f64| {
        let (hi, lo) = (a.powf(0.5 / k), b.powf(-0.5 / k));
        (hi.is_finite() && lo.is_finite() && lo > 0.0 && vouched(hi / lo)).then_some((hi, lo))
    };
    let (m2, inverse2) = (squared(&m), squared(&inverse));
    let (a, b) = (squares(&m2), squares(&inverse2));
    let power = a * b;
    if let Some(bound) = (power < limit4 * limit4).then(|| given(power, 1.0 / 8.0)).flatten() {
        return (bound, sigmas(a, b, 4.0));
    }
    let (a, b) = (eighth_powers(&m2), eighth_powers(&inverse2));
    let bound = (a * b).powf(1.0 / 16.0);
    if vouched(bound) { (bound * (1.0 + 1e-6), sigmas(a, b, 8.0)) } else { (f64::INFINITY, None) }
}

/// `a·b`, summed in order.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The symmetric 6 × 6 matrix whose entry `(i, j)`, `i ≥ j`, is `at(i, j)`.
fn gram(at: impl Fn(usize, usize) -> f64) -> [[f64; 6]; 6] {
    let mut m = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..=i {
            m[i][j] = at(i, j);
            m[j][i] = m[i][j];
        }
    }
    m
}

/// `a²` of a symmetric `a`, as the Gram matrix of its rows.
fn squared(a: &[[f64; 6]; 6]) -> [[f64; 6]; 6] {
    gram(|i, j| dot(&a[i], &a[j]))
}

/// `Σλ⁸` of a symmetric `A` from `b` = `A²` ([`squared`]): `‖b²‖_F²`, `Σ_ij (b_i·b_j)²`
/// over its rows.
fn eighth_powers(b: &[[f64; 6]; 6]) -> f64 {
    let mut sum = 0.0;
    for i in 0..6 {
        let d = dot(&b[i], &b[i]);
        sum += d * d;
        for j in 0..i {
            let d = dot(&b[i], &b[j]);
            sum += 2.0 * d * d;
        }
    }
    sum
}

/// Under [`CondOf::Largest`], the largest `cond` of a run's poses that every member
/// solved (`results`) where it may exceed `known`, the largest found so far in the
/// other runs of the same solve: `κ₂(G)` of the open poses in the order of their
/// bounds, from the largest, until a bound falls below the largest `cond` known. A pose
/// left open has a bound, and so a `κ₂`, below a `cond` that some pose of the solve
/// has; the statistics' maximum is the same as with every pose's `cond`, whatever the
/// runs and the order they are settled in.
fn settle_largest(solved: &mut MembersSolved, open: &[Option<Open>], known: &LargestCond) {
    let MembersSolved { answered, results } = solved;
    let mut largest = known.get();
    for (k, _) in answered.iter().enumerate().filter(|(_, a)| **a) {
        for r in results.iter().map(|rs| &rs[k]) {
            if r.status != Status::Unreachable && r.cond.is_finite() {
                largest = largest.max(r.cond);
            }
        }
    }
    let mut order: Vec<(f64, usize)> =
        open.iter().enumerate().filter(|(k, _)| answered[*k]).filter_map(|(k, o)| Some((o.as_ref()?.0, k))).collect();
    order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    for (bound, k) in order {
        if bound < largest {
            break;
        }
        let cond = open[k].as_ref().map_or(f64::NAN, |(_, g)| cond_of(g));
        for rs in results.iter_mut() {
            rs[k].cond = cond;
        }
        if cond.is_finite() {
            largest = largest.max(cond);
        }
    }
    known.raise(largest);
}

/// The largest finite `cond` found so far among the poses of one solve, shared by the
/// threads settling its runs of [`preset_members`] (as each run settles, its open poses
/// need their `κ₂` only where their bound reaches it). A solve of a described 3-PRS took
/// the SVD of a third of its poses when each run of 64 settled on its own largest alone,
/// of one in ninety with this.
#[derive(Debug)]
pub struct LargestCond(AtomicU64);

impl Default for LargestCond {
    fn default() -> Self {
        Self(AtomicU64::new(0.0f64.to_bits()))
    }
}

impl LargestCond {
    /// The largest so far (0 before any).
    fn get(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Relaxed))
    }

    /// Raises it to `cond` if that is larger. Condition numbers are at least 1, and the
    /// bits of non-negative doubles order as the doubles do.
    fn raise(&self, cond: f64) {
        if cond.is_finite() && cond > 0.0 {
            self.0.fetch_max(cond.to_bits(), Ordering::Relaxed);
        }
    }
}

/// A description that is a built-in kind's, with that kind's kernel (docs/model.md
/// §12.10): the 3-PRS's or the 6-UPS's.
#[derive(Clone, Debug)]
pub enum Preset {
    Prs3(Box<PrsPreset>),
    Ups6(Box<UpsPreset>),
}

/// A description that is a built-in 3-PRS (as `clearance describe` writes one, docs/model.md
/// §12.9), with what its kernel needs: the poses that kernel solves cleanly are solved
/// there and given as the general path gives them, to round-off (docs/model.md §12.10).
///
/// The kernel answers a pose only where its answer is the general path's, to
/// round-off, by the general path's own rules: the kernel solves it (status ok or
/// indeterminate contact), `κ₂` of the description's wrench basis `G` is within
/// `singular_cond`, and each kind's determinacy is the description's. Each group's
/// mobility is proved by its own contribution to `|Δp|` (at least [`IMMOBILE`] per
/// unit of its magnitude, a lower bound of its unit reach) where the pose is ok and
/// every group has play, else computed from `G⁻¹` as the general path does. Any other
/// pose goes the general way.
#[derive(Clone, Debug)]
pub struct PrsPreset {
    /// The built-in kind's model: the fast solver, with the envelope.
    pub model: crate::Model,
    /// The actuators' positions at home: a custom `q` is measured from there.
    pub q_home: [f64; 3],
    /// Per kind of the description, its place in `clearance_model::KINDS`.
    pub kinds: Vec<usize>,
    /// Whether some group's magnitude is zero.
    pub without_play: bool,
}

impl PrsPreset {
    /// The preset for a description whose built-in kind's model is `model`, its joints
    /// in each limb `P, R, S` (the 3-PRS's), at `home`; `None` unless every kind of
    /// `custom` is one of the built-in kind's, on the joints that kind names, and the
    /// exact error is off.
    pub fn new(custom: &CustomModel, mut model: crate::Model, home: &[f64; 6]) -> Option<Self> {
        use clearance_model::MechanismKind;
        if model.geometry.kind != MechanismKind::Prs3 || custom.exact || custom.geom.inputs != [2, 4, 5] {
            return None;
        }
        let limbs_ok = limbs_are(custom, 3, [JointType::P, JointType::R, JointType::S]);
        let kinds: Option<Vec<usize>> =
            custom.kinds.iter().map(|k| clearance_model::KINDS.iter().position(|b| b.name() == k.as_str())).collect();
        let kinds = kinds?;
        // s_radial is the S joint's radial play; the other three are the R joint's.
        let groups_ok = custom.groups.iter().all(|g| {
            let expected = match kinds[g.kind] {
                0 => (2, Group::Radial),
                1 => (1, Group::Radial),
                2 => (1, Group::Axial),
                _ => (1, Group::Angular),
            };
            (g.joint, g.group) == expected && g.magnitude >= 0.0
        });
        if !limbs_ok || !groups_ok {
            return None;
        }
        model.solver = crate::SolverKind::Fast;
        model.envelope = true;
        model.totals_only = false;
        model.exact = false;
        model.singular_cond = custom.singular_cond;
        let at_home = crate::fast::Pose::<f64>::new(&model.geometry, home[2], home[4], home[5]);
        if !at_home.reachable {
            return None;
        }
        let without_play = custom.groups.iter().any(|g| g.magnitude == 0.0);
        Some(Self { q_home: at_home.q, kinds, model, without_play })
    }
}

/// Whether `custom` has `limbs` limbs, each of the joints `order` with its P joint, and
/// only it, actuated: the built-in kinds' limbs (3-PRS `P*–R–S`, 6-UPS `U–P*–S`).
fn limbs_are(custom: &CustomModel, limbs: usize, order: [JointType; 3]) -> bool {
    custom.geom.limbs.len() == limbs
        && custom.geom.limbs.iter().all(|l| {
            l.joints.len() == 3
                && l.joints.iter().zip(order).all(|(j, t)| j.joint == t && j.actuated == (t == JointType::P))
        })
}

/// The posture of a preset's pose and the description's wrench basis `G` there, limb
/// `j`'s block in columns `2j, 2j + 1`. The wrenches that do no work on the passive R
/// (axis `y_j` at `B_j`) and S (at `A_j`) are the forces through `A_j` in the plane of
/// `y_j` and the leg: `[f; A_j × f]` for `f` in span(`y_j`, `e_j`), made orthonormal.
/// It is the general path's `G` but for an orthogonal change of basis within each
/// limb's block, to which `κ₂(G)` and every response are blind.
fn preset_frame(preset: &PrsPreset, pose: &Points) -> Matrix6<f64> {
    let geometry = &preset.model.geometry;
    let mut g = Matrix6::zeros();
    for j in 0..3 {
        let a = pose.a[j];
        let force = |f: &V3| six(*f, a.cross(f));
        let u = force(&geometry.y[j]).normalize();
        let w = force(&pose.e[j]);
        let w = (w - u * u.dot(&w)).normalize();
        g.set_column(2 * j, &u);
        g.set_column(2 * j + 1, &w);
    }
    g
}

/// A 3-PRS preset's points at `inputs` (`z`, `ψ`, `θ`), as its kernel's
/// [`solve_poses_posed`](crate::pose::solve_poses_posed) gives them.
fn preset_points(preset: &PrsPreset, inputs: &[f64]) -> Points {
    crate::fast::Pose::<f64>::new(&preset.model.geometry, inputs[0], inputs[1], inputs[2]).points(0)
}

/// The 2-norm condition number of `g` (from its singular values).
fn cond_of(g: &Matrix6<f64>) -> f64 {
    let s = g.singular_values();
    let (hi, lo) = (s.max(), s.min());
    if lo > 0.0 { hi / lo } else { f64::INFINITY }
}

/// [`preset_load`] for a 3-PRS preset.
fn prs_load(
    model: &CustomModel,
    preset: &PrsPreset,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    group: usize,
) -> Option<Option<[f64; 3]>> {
    let sample = kernel_sample(inputs, rates);
    let mut posed = None;
    let r = KERNEL.with(|ws| {
        crate::pose::solve_reactions_posed(&preset.model, &sample, mode, &mut ws.borrow_mut(), &mut posed)
    })?;
    let pose = posed.unwrap_or_else(|| preset_points(preset, inputs));
    let g = preset_frame(preset, &pose);
    // `G⁻¹` only decides here (the conditioning and whether the group moves P, each
    // against its limit): by the 6-UPS kernel's elimination, a third of nalgebra's cost.
    let gi = crate::ups::inverse6(&g)?;
    if !bounded(model, &g, &gi) {
        return None;
    }
    let def = &model.groups[group];
    let l = def.limb;
    let (reaction, centre, axis) = match model.joint_type(def) {
        JointType::S => ((r.f_s[l], V3::zeros()), pose.a[l], V3::zeros()),
        _ => ((r.f_r[l], r.m_r[l]), pose.b[l], preset.model.geometry.y[l]),
    };
    let at = (&centre, &axis, &V3::zeros());
    let system = Blocks { g: &g, block: |l| (2 * l, 2), gi: &gi, pos: pose.p };
    Some(mobile_load(model, def, reaction, at, &system))
}

/// The kernel's sample of a preset's inputs (`z`, `ψ`, `θ`) and their rates.
fn kernel_sample(inputs: &[f64], rates: Option<(&[f64], &[f64])>) -> clearance_grid::Sample {
    kernel_sample_of(|i| [inputs[i], rates.map_or(0.0, |r| r.0[i]), rates.map_or(0.0, |r| r.1[i])])
}

/// The kernel's sample whose input `i` (`z`, `ψ`, `θ`) has value, rate and
/// acceleration `at(i)`.
fn kernel_sample_of(at: impl Fn(usize) -> [f64; 3]) -> clearance_grid::Sample {
    clearance_grid::Sample { index: 0, t: None, z: at(0), psi: at(1), theta: at(2) }
}

thread_local! {
    /// The kernel's scratch, per thread (unused by its fast solver, which is the one a
    /// preset uses, but its signature asks for one).
    static KERNEL: std::cell::RefCell<Workspace> = std::cell::RefCell::new(Workspace::new());
}

/// [`preset_result`] for a 3-PRS preset.
fn prs_result(
    model: &CustomModel,
    preset: &PrsPreset,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    cond_of: CondOf,
) -> Option<CustomResult> {
    let sample = kernel_sample(inputs, rates);
    let r = KERNEL.with(|ws| solve_pose(&preset.model, &sample, mode, &mut ws.borrow_mut()));
    preset_result_of(model, preset, (inputs, &preset_points(preset, inputs)), &r, (cond_of, 0.0), &mut None)
}

/// [`solve_members_near`] for a run of poses of a description that is a preset, every
/// member's kernel solving the run at once (in statics, the lanes of its batched fast
/// solver): per pose (`inputs`: each input's value, rate and acceleration, in canonical
/// order), every member's result, unless some member's kernel answer is not the
/// general path's (the caller then solves that pose with [`solve_members_near`]).
/// `None` unless every member is a preset.
///
/// With `each_cond`, every result has its `cond`; without, only those that may be the
/// largest of the solve whose runs share `largest` (all that its statistics read of it).
pub fn preset_members<P: std::ops::Deref<Target = [[f64; 3]]>>(
    models: &[&CustomModel],
    poses: &[P],
    mode: Mode,
    each_cond: bool,
    largest: &LargestCond,
) -> Option<MembersSolved> {
    let cond_of = if each_cond { CondOf::Each } else { CondOf::Largest };
    let presets: Vec<&Preset> = models.iter().map(|m| m.preset.as_deref()).collect::<Option<_>>()?;
    let presets: Vec<&PrsPreset> = match presets.as_slice() {
        [Preset::Ups6(_), ..] => return Some(ups_members(models, poses, mode, cond_of, largest)),
        _ => presets.iter().map(|p| if let Preset::Prs3(p) = p { Some(&**p) } else { None }).collect::<Option<_>>()?,
    };
    let dynamic = mode == Mode::Dynamic;
    // Statics has no rates, as `solve_members_near` has none there.
    let samples: Vec<clearance_grid::Sample> =
        poses.iter().map(|p| kernel_sample_of(|i| if dynamic { p[i] } else { [p[i][0], 0.0, 0.0] })).collect();
    let mut kernel = vec![PoseResult::default(); samples.len()];
    let mut out = MembersSolved::new(models.len(), poses.len());
    // The members share `G` (they differ only in their clearances), so its bound too.
    let mut open: Vec<Option<Open>> = vec![None; poses.len()];
    let known = largest.get();
    // The members' postures are the same (so are their geometries): the first
    // member's kernel gives their points.
    let mut points = vec![Points::default(); samples.len()];
    for (m, (model, preset)) in models.iter().zip(presets).enumerate() {
        KERNEL.with(|ws| {
            let ws = &mut ws.borrow_mut();
            match m {
                0 => crate::pose::solve_poses_posed(&preset.model, &samples, mode, ws, &mut kernel, &mut points),
                _ => crate::pose::solve_poses(&preset.model, &samples, mode, ws, &mut kernel),
            }
        });
        let results = &mut out.results[m];
        for (k, (((pose, at), r), open)) in poses.iter().zip(&points).zip(&kernel).zip(&mut open).enumerate() {
            let inputs: [f64; 3] = std::array::from_fn(|i| pose[i][0]);
            let solved =
                out.answered[k].then(|| preset_result_of(model, preset, (&inputs, at), r, (cond_of, known), open));
            match solved.flatten() {
                Some(r) => results.push(r),
                None => {
                    out.answered[k] = false;
                    results.push(CustomResult::default());
                }
            }
        }
    }
    settle_largest(&mut out, &open, largest);
    Some(out)
}

/// A run of poses solved for the members of a sweep at once ([`preset_members`]):
/// per member, one result a pose, a pose's results meant only where it is `answered`
/// (elsewhere, placeholders for the caller's own solve).
#[derive(Debug, Default)]
pub struct MembersSolved {
    pub answered: Vec<bool>,
    /// Per member, per pose.
    pub results: Vec<Vec<CustomResult>>,
}

impl MembersSolved {
    /// Every pose answered until shown otherwise, no result yet.
    fn new(members: usize, poses: usize) -> Self {
        Self { answered: vec![true; poses], results: (0..members).map(|_| Vec::with_capacity(poses)).collect() }
    }

    /// No pose answered: a placeholder result for each, for the caller's own solve.
    pub fn unanswered(members: usize, poses: usize) -> Self {
        Self {
            answered: vec![false; poses],
            results: (0..members).map(|_| vec![CustomResult::default(); poses]).collect(),
        }
    }
}

/// [`preset_result`] from the kernel's result `r` at `inputs`, whose posture's points are `pose`.
fn preset_result_of(
    model: &CustomModel,
    preset: &PrsPreset,
    (inputs, pose): (&[f64], &Points),
    r: &PoseResult,
    (cond_of, known): (CondOf, f64),
    open: &mut Option<Open>,
) -> Option<CustomResult> {
    // Where a take-up is indeterminate, the kernel gives no joint contributions: each
    // group's own response is then computed here, as `take_up` does.
    let indeterminate = match r.status {
        Status::Ok => false,
        Status::IndeterminateContact => true,
        _ => return None,
    };
    let geometry = &preset.model.geometry;
    let g = preset_frame(preset, pose);
    let inverse = if cond_of == CondOf::Verdict { g.try_inverse() } else { None };
    let cond = given_cond(model, &g, inverse.as_ref(), (cond_of, known), open)?;
    // A group without play is not proved mobile by its (zero) error: then too.
    let gi = if indeterminate || preset.without_play { Some(inverse.or_else(|| g.try_inverse())?) } else { None };
    let coords = [r.x, r.y, inputs[0], r.phi, inputs[1], inputs[2]];
    let CustomResult { q, tau, reactions, takes, kind_errors, envelope, .. } = spare_result();
    let mut out = CustomResult {
        status: Status::Ok,
        coords,
        q: refill(q, (0..3).map(|j| r.q[j] - preset.q_home[j])),
        tau: refill(tau, (0..3).map(|j| r.reactions.f_r[j].dot(&geometry.rail(j)))),
        // P (on the massless slider: the R joint's reaction, about the same point),
        // R and S; the S joint transmits no couple.
        reactions: reactions.refill(&std::array::from_fn::<_, 3, _>(|j| {
            let (f_r, m_r) = (r.reactions.f_r[j], r.reactions.m_r[j]);
            [(f_r, m_r), (f_r, m_r), (r.reactions.f_s[j], V3::zeros())]
        })),
        takes: refill(takes, []),
        kind_errors: refill(kind_errors, []),
        envelope: refill(envelope, []),
        cond,
        ..Default::default()
    };
    // A preset's kinds are distinct built-in kinds: at most `KINDS.len()` (on the stack,
    // not an allocation a pose).
    let mut undetermined = [false; clearance_model::KINDS.len()];
    let undetermined = &mut undetermined[..model.kinds.len()];
    out.takes.reserve_exact(model.groups.len());
    for def in &model.groups {
        let (l, joint) = (def.limb, model.joint_type(def));
        let (axis, centre) = if joint == JointType::R { (geometry.y[l], pose.b[l]) } else { (V3::zeros(), pose.a[l]) };
        let at = (&centre, &axis, &V3::zeros());
        let mut take = group_take(model, def, joint, at, out.reactions[l][def.joint]);
        if let Some(gi) = &gi {
            let system = Blocks { g: &g, block: |l| (2 * l, 2), gi, pos: pose.p };
            let reach = system.reach(l, (joint, def.group), at);
            settle(model, def, &reach, &system, &mut take);
            undetermined[def.kind] |= take.indeterminate;
        } else {
            // A group's own |Δp| bounds its unit reach from below: at least IMMOBILE
            // per unit of magnitude proves that it moves P.
            take.dp = r.contribution[preset.kinds[def.kind]][l];
            if !(take.margin > model.floor && take.dp >= IMMOBILE * def.magnitude) {
                return None;
            }
            take.mobile = true;
        }
        out.takes.push(take);
    }
    // The kernel's verdict on each kind must be the description's.
    if preset.kinds.iter().zip(undetermined.iter()).any(|(&kb, &u)| r.kind_ok[kb] == u) {
        return None;
    }
    let nine = nine_at(&coords);
    let mut sum = [0.0; 6];
    let mut env_total = [0.0; 8];
    out.kind_errors.reserve_exact(preset.kinds.len());
    out.envelope.reserve_exact(preset.kinds.len());
    for (&kb, &u) in preset.kinds.iter().zip(undetermined.iter()) {
        let e = &r.errors[kb];
        let six = [e.dp.x, e.dp.y, e.dp.z, e.dalpha.x, e.dalpha.y, e.dalpha.z];
        out.kind_errors.push((!u).then(|| nine(&six)));
        for c in 0..6 {
            sum[c] += six[c];
        }
        out.envelope.push(r.envelope[kb]);
        for c in 0..8 {
            env_total[c] += r.envelope[kb][c];
        }
    }
    if indeterminate {
        out.status = Status::IndeterminateContact;
    } else {
        out.total = Some(nine(&sum));
    }
    out.env_total = env_total;
    out.dominant = dominant(model, &out.takes);
    Some(out)
}

/// A pose of a description that is a preset, solved by its kernel and given as
/// [`solve_posture`] gives it; `None` where the kernel's answer is not the general
/// path's (see [`PrsPreset`], [`UpsPreset`]): the caller then solves the pose the
/// general way.
fn preset_result(
    model: &CustomModel,
    preset: &Preset,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    cond_of: CondOf,
    only: Option<usize>,
) -> Option<CustomResult> {
    match preset {
        // The 3-PRS's kernel gives every kind's error at once, and whether its answer
        // is the description's is judged on every group: it solves the whole pose.
        Preset::Prs3(p) => prs_result(model, p, inputs, rates, mode, cond_of),
        Preset::Ups6(p) => UPS_KERNEL.with(|k| {
            let mut k = k.borrow_mut();
            let pose = k.recalled(p, &ups_sample(inputs, rates), mode)?;
            ups_result(model, p, inputs, pose, (cond_of, 0.0), &mut None, only)
        }),
    }
}

/// Group `group`'s deciding load at a pose of a preset, as [`group_load_near`] reads
/// it (`Some(None)` where the group cannot move P); `None` where the kernel does not
/// solve the pose, which the general path then decides.
fn preset_load(
    model: &CustomModel,
    preset: &Preset,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    group: usize,
) -> Option<Option<[f64; 3]>> {
    match preset {
        Preset::Prs3(p) => prs_load(model, p, inputs, rates, mode, group),
        Preset::Ups6(p) => ups_load(model, p, inputs, rates, mode, group),
    }
}

/// A description that is a built-in 6-UPS (as `clearance describe` writes one,
/// docs/model.md §12.9), with what its kernel needs: the 6-UPS's posture in closed form
/// and its legs' reactions with the legs eliminated (a 6 × 6 solve). Only these come
/// from the kernel; the take-up, the errors, the envelope and the dominant joint are
/// the general path's own code, from the description's wrench basis `G` in
/// closed form: per leg the one wrench its U and S joints let through, the force along
/// the leg through `A_i`, `[e_i; A_i × e_i]` made unit. The kernel answers a pose only
/// where it solves it (`ok`, within its own conditioning limit) and `κ₂(G)` is within
/// `singular_cond`; any other pose goes the general way.
#[derive(Clone, Debug)]
pub struct UpsPreset {
    /// The built-in kind's model.
    model: crate::ups::UpsModel,
    /// The legs' lengths at home: a custom `q` is measured from there.
    q_home: [f64; 6],
    /// Per leg, the P joint's centre at home as its distance from the U joint's
    /// along the leg (it travels with the piston).
    p_from_b: [f64; 6],
    /// This preset among those the process made ([`UpsKernel::recalled`]): its fields
    /// are fixed once made, and a clone is the same preset.
    id: u64,
}

impl UpsPreset {
    /// The preset for a description whose built-in kind's model is `model`, its joints
    /// in each limb `U, P*, S` (the 6-UPS's), its inputs the six coordinates, at
    /// `home`; `None` unless every kind of `custom` is one of the built-in kind's on the
    /// joint that kind names, and the exact error is off.
    pub fn new(custom: &CustomModel, mut model: crate::ups::UpsModel, home: &[f64; 6]) -> Option<Self> {
        if custom.exact || custom.geom.inputs != [0, 1, 2, 3, 4, 5] {
            return None;
        }
        let limbs_ok = limbs_are(custom, 6, [JointType::U, JointType::P, JointType::S]);
        let groups_ok = custom.groups.iter().all(|g| {
            let expected = match custom.kinds[g.kind].as_str() {
                "s_radial" => (2, Group::Radial),
                "u_radial" => (0, Group::Radial),
                "u_angular" => (0, Group::Angular),
                _ => return false,
            };
            (g.joint, g.group) == expected && g.magnitude >= 0.0
        });
        if !limbs_ok || !groups_ok {
            return None;
        }
        model.exact = false;
        model.singular_cond = custom.singular_cond;
        let at_home = clearance_kinematics::ups_inverse_kinematics(&model.geometry, *home).ok()?;
        let p_from_b = std::array::from_fn(|l| {
            let j = &custom.geom.limbs[l].joints;
            (j[1].centre - j[0].centre).norm()
        });
        static MADE: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let id = MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Some(Self { q_home: at_home.q, p_from_b, model, id })
    }
}

/// The 6-UPS kernel's sample of a preset's inputs (the six coordinates) and their rates.
fn ups_sample(inputs: &[f64], rates: Option<(&[f64], &[f64])>) -> crate::ups::UpsSample {
    std::array::from_fn(|i| [inputs[i], rates.map_or(0.0, |r| r.0[i]), rates.map_or(0.0, |r| r.1[i])])
}

/// The 6-UPS kernel's scratch and the pose it gives, per thread (its sizes are the
/// kind's, whatever the model), with the poses the switch search solved last.
struct UpsKernel {
    ws: crate::ups::UpsWorkspace,
    pose: UpsPose,
    /// The last [`RECALLED`] poses [`UpsKernel::recalled`] solved, each key's hash in
    /// `hashes` at its index; the oldest at `next` once full.
    recent: Vec<Recalled>,
    hashes: Vec<u64>,
    next: usize,
    /// By the low byte of a key's hash, 1 + the index of the pose kept last with it (0:
    /// none). Comparing the hashes of all the poses kept was 4 % of a described 6-UPS's
    /// search; a pose whose bucket a later one took is solved again, to the same bits.
    bucket: [u8; 256],
}

/// Poses a thread's [`UpsKernel`] keeps (fewer than 256: [`UpsKernel::bucket`] holds
/// their indices in bytes). The search reads a group's load at a point (the kernel's
/// pose, for one joint's reaction), and later solves the whole pose at points among
/// those: the switch at a polished minimum, the readings where the load rose to twice
/// it. On a described 6-UPS those were a sixth of the kernel's poses, each solved a few
/// dozen poses before.
const RECALLED: usize = 64;
const _: () = assert!(RECALLED < 256);

/// What a kept pose was solved for: the preset's id, the mode, the sample's bits.
type RecallKey = (u64, Mode, [[u64; 3]; 6]);

/// A pose kept by [`UpsKernel::recalled`], and whether the kernel solved it.
struct Recalled {
    key: RecallKey,
    solved: bool,
    pose: UpsPose,
}

/// A hash of a [`RecallKey`] (a multiply–rotate mix of its words), to find a kept
/// pose without comparing the keys of all.
fn recall_hash((id, mode, bits): &RecallKey) -> u64 {
    let mix = |h: u64, w: u64| (h ^ w).wrapping_mul(0x9e37_79b9_7f4a_7c15).rotate_left(23);
    bits.iter().flatten().fold(mix(*id, *mode as u64), |h, &w| mix(h, w))
}

impl UpsKernel {
    /// The kernel's pose of `sample` ([`ups_pose`]), or `None`.
    fn pose(&mut self, preset: &UpsPreset, sample: &crate::ups::UpsSample, mode: Mode) -> Option<&mut UpsPose> {
        ups_pose(preset, sample, mode, &mut self.ws, &mut self.pose).then_some(&mut self.pose)
    }

    /// [`UpsKernel::pose`], the same bits, from the poses kept where one was solved for
    /// the same preset, mode and sample; else solved and kept. For the switch search's
    /// points: the pass's poses are never solved twice.
    fn recalled(&mut self, preset: &UpsPreset, sample: &crate::ups::UpsSample, mode: Mode) -> Option<&mut UpsPose> {
        let key = (preset.id, mode, sample.map(|s| s.map(f64::to_bits)));
        let hash = recall_hash(&key);
        let bucket = (hash & 0xff) as usize;
        let found = (self.bucket[bucket] as usize)
            .checked_sub(1)
            .filter(|&i| self.hashes[i] == hash && self.recent[i].key == key);
        let slot = match found {
            Some(i) => i,
            None => {
                let slot = if self.recent.len() < RECALLED {
                    self.recent.push(Recalled { key, solved: false, pose: UpsPose::default() });
                    self.hashes.push(hash);
                    self.recent.len() - 1
                } else {
                    let oldest = self.next;
                    self.next = (self.next + 1) % RECALLED;
                    let gone = (self.hashes[oldest] & 0xff) as usize;
                    if self.bucket[gone] as usize == oldest + 1 {
                        self.bucket[gone] = 0;
                    }
                    oldest
                };
                let kept = &mut self.recent[slot];
                kept.key = key;
                kept.solved = ups_pose(preset, sample, mode, &mut self.ws, &mut kept.pose);
                self.hashes[slot] = hash;
                self.bucket[bucket] = (slot + 1) as u8;
                slot
            }
        };
        let kept = &mut self.recent[slot];
        kept.solved.then_some(&mut kept.pose)
    }
}

thread_local! {
    static UPS_KERNEL: std::cell::RefCell<UpsKernel> = std::cell::RefCell::new(UpsKernel {
        ws: crate::ups::UpsWorkspace::new(&crate::ups::UpsModel::default()),
        pose: UpsPose::default(),
        recent: Vec::new(),
        hashes: Vec::new(),
        next: 0,
        bucket: [0; 256],
    });
}

/// What the 6-UPS kernel gives of a pose: per leg its U and S centres, the U's fixed
/// axis and normal, the leg's direction, `q` and the kernel's reactions; P; `G_P⁻¹`.
/// The description's `G`, `G⁻¹` and reactions are made from these leg by leg
/// ([`UpsPose::leg`]): the switch search reads one leg of most poses it solves, and
/// making all six was a fifth of its load.
#[derive(Default)]
struct UpsPose {
    p: V3,
    b: [V3; 6],
    a: [V3; 6],
    e: [V3; 6],
    a1: [V3; 6],
    n: [V3; 6],
    q: [f64; 6],
    /// `G_P⁻¹`, the inverse of the legs' screws about P (column i `[e_i; (A_i − P)×e_i]`),
    /// and `(κ₁(G_P), κ∞(G_P))`.
    legs_inverse: Matrix6<f64>,
    kappa: (f64, f64),
    /// Per leg the kernel's reactions: the U joint's force and couple, the S joint's force.
    f_b: [V3; 6],
    m_b: [V3; 6],
    f_s: [V3; 6],
    /// Per leg the piston's centre, and the force and the couple its weight and inertia ask.
    piston: [(V3, V3, V3); 6],
    /// Whether the fields below hold every leg's ([`UpsPose::complete`]).
    whole: bool,
    /// Per leg the P joint's centre, and each joint's reaction (U, P, S: `(f, m)`
    /// proximal on distal, `m` about the joint's centre).
    c_p: [V3; 6],
    reactions: [[(V3, V3); 3]; 6],
    /// The description's wrench basis `G` (column i: the unit force along leg i through
    /// `A_i`, `[e_i; A_i × e_i]` made unit; limb i's block) and `G⁻¹`.
    g: Matrix6<f64>,
    gi: Matrix6<f64>,
}

/// One leg of a [`UpsPose`] as the description reads it.
struct UpsLeg {
    c_p: V3,
    reactions: [(V3, V3); 3],
    /// Its column of `G` and its row of `G⁻¹`.
    column: V6,
    row: [f64; 6],
}

impl UpsPose {
    /// Leg `i` as the description reads it. The P joint's reaction is the piston's
    /// balance: the S joint's force, which transmits no couple, plus what the piston's
    /// weight and inertia ask (`W_P = W_S + C_piston`, as [`reactions`] carries the bodies
    /// beyond a joint). `G⁻¹` from the kernel's: column i of `G` is leg i's screw about P
    /// moved to O (`T = [I 0; [P]ₓ I]`) and made unit (`D`), so `G⁻¹ = D⁻¹·G_P⁻¹·T⁻¹`.
    fn leg(&self, preset: &UpsPreset, i: usize) -> UpsLeg {
        let c_p = self.b[i] + self.e[i] * (preset.p_from_b[i] + self.q[i] - preset.q_home[i]);
        let (centre, demand, spin) = self.piston[i];
        let f_s = self.f_s[i];
        let f_p = f_s + demand;
        let m_p = (self.a[i] - c_p).cross(&f_s) + (centre - c_p).cross(&demand) + spin;
        let column = six(self.e[i], self.a[i].cross(&self.e[i]));
        let norm = column.norm();
        let row = self.legs_inverse.row(i);
        let (force, moment) = (row.fixed_columns::<3>(0), row.fixed_columns::<3>(3));
        let shifted = force - moment * self.p.cross_matrix();
        UpsLeg {
            c_p,
            reactions: [(self.f_b[i], self.m_b[i]), (f_p, m_p), (f_s, V3::zeros())],
            column: column / norm,
            row: std::array::from_fn(|c| if c < 3 { norm * shifted[c] } else { norm * moment[c - 3] }),
        }
    }

    /// Every leg's [`UpsPose::leg`] into `c_p`, `reactions`, `g` and `gi`, once a pose.
    fn complete(&mut self, preset: &UpsPreset) {
        if self.whole {
            return;
        }
        for i in 0..6 {
            let leg = self.leg(preset, i);
            self.c_p[i] = leg.c_p;
            self.reactions[i] = leg.reactions;
            self.g.set_column(i, &leg.column);
            for c in 0..6 {
                self.gi[(i, c)] = leg.row[c];
            }
        }
        self.whole = true;
    }
}

/// Below this fraction of `singular_cond`, [`certified`]'s bound vouches for `κ₂(G)`
/// whatever the round-off of the kernel's condition numbers.
const CERTIFIED: f64 = 0.5;

/// Whether `κ₂(G)` is within `singular_cond` by [`certificate`], without `G` or `G⁻¹`.
/// `false` decides nothing: [`bounded`] then does.
fn certified(model: &CustomModel, pose: &UpsPose) -> bool {
    let bound = certificate(pose);
    bound.is_finite() && bound <= CERTIFIED * model.singular_cond
}

/// An upper bound of `κ₂(G)` from what the kernel gave: `G = T·G_P·D⁻¹` (see
/// [`UpsPose::leg`]), so `κ₂(G) ≤ κ₂(T)·κ₂(G_P)·κ₂(D)`, with `κ₂(T) ≤ (1 + |P|)²`,
/// `κ₂(G_P) ≤ √(κ₁·κ∞)` (as `‖X‖₂² ≤ ‖X‖₁·‖X‖∞`) and `κ₂(D) ≤ √(1 + max |A_i|²)` (each
/// column's length is `√(1 + |A_i × e_i|²)`, `e_i` a unit vector).
fn certificate(pose: &UpsPose) -> f64 {
    let (cond_1, cond_inf) = pose.kappa;
    let farthest = pose.a.iter().map(|a| a.norm_squared()).fold(0.0, f64::max);
    let moved = 1.0 + pose.p.norm();
    moved * moved * (1.0 + farthest).sqrt() * (cond_1 * cond_inf).sqrt()
}

/// The kernel's posture and reactions of a pose of a 6-UPS preset, into `out` (its
/// description's legs not yet made: [`UpsPose::complete`]); `false` where the kernel
/// does not solve it.
fn ups_pose(
    preset: &UpsPreset,
    sample: &crate::ups::UpsSample,
    mode: Mode,
    ws: &mut crate::ups::UpsWorkspace,
    out: &mut UpsPose,
) -> bool {
    let model = &preset.model;
    let Ok((legs_inverse, kappa)) = crate::ups::ups_reactions_into(model, sample, mode, ws) else { return false };
    let gravity = model.assembly.gravity;
    let (pose, sol, posed) = (&ws.pose, &ws.sol, &ws.posed);
    for i in 0..6 {
        let piston = &posed.limbs[i].bodies[1];
        out.piston[i] = (piston.centre, piston.demand(&gravity), piston.spin());
        (out.f_b[i], out.m_b[i], out.f_s[i]) = (sol.f_b[i], sol.m_b[i], sol.f_s[i]);
    }
    (out.legs_inverse, out.kappa, out.whole) = (legs_inverse, kappa, false);
    (out.p, out.b, out.a, out.e, out.a1, out.n, out.q) = (pose.p, pose.b, pose.a, pose.e, pose.a1, pose.n, pose.q);
    true
}

/// Each joint's centre, axis and normal at a 6-UPS preset's pose, as the general path
/// poses them (`l` the limb, `j` the joint: U, P, S; `c_p` the leg's P centre).
fn ups_joint_at(pose: &UpsPose, c_p: &V3, l: usize, j: usize) -> (V3, V3, V3) {
    match j {
        0 => (pose.b[l], pose.a1[l], pose.n[l]),
        1 => (*c_p, pose.e[l], V3::zeros()),
        _ => (pose.a[l], V3::zeros(), V3::zeros()),
    }
}

/// A pose of a 6-UPS preset from the kernel's `pose`, as [`solve_posture`] gives it;
/// `None` where `κ₂(G)` is not within `singular_cond` (the general path decides).
fn ups_result(
    model: &CustomModel,
    preset: &UpsPreset,
    inputs: &[f64],
    pose: &mut UpsPose,
    cond_of: (CondOf, f64),
    open: &mut Option<Open>,
    only: Option<usize>,
) -> Option<CustomResult> {
    pose.complete(preset);
    let pose = &*pose;
    let (g, gi) = (&pose.g, &pose.gi);
    let cond = given_cond(model, g, Some(gi), cond_of, open)?;
    let coords: [f64; 6] = std::array::from_fn(|i| inputs[i]);
    let CustomResult { q, tau, reactions, takes, kind_errors, envelope, .. } = spare_result();
    let mut out = CustomResult {
        status: Status::Ok,
        coords,
        q: refill(q, (0..6).map(|i| pose.q[i] - preset.q_home[i])),
        tau: refill(tau, (0..6).map(|i| pose.reactions[i][1].0.dot(&pose.e[i]))),
        reactions: reactions.refill(&pose.reactions),
        // Set anew by `take_up_at`.
        takes,
        kind_errors,
        envelope,
        cond,
        ..Default::default()
    };
    let joint_at = |l, j| ups_joint_at(pose, &pose.c_p[l], l, j);
    take_up_at(model, joint_at, &Legs::new(g, gi, &pose.p), &coords, &mut out, only);
    Some(out)
}

/// Group `group`'s deciding load at a pose of a 6-UPS preset, as [`group_load_near`]
/// reads it; `None` where the kernel does not solve the pose.
fn ups_load(
    model: &CustomModel,
    preset: &UpsPreset,
    inputs: &[f64],
    rates: Option<(&[f64], &[f64])>,
    mode: Mode,
    group: usize,
) -> Option<Option<[f64; 3]>> {
    UPS_KERNEL.with(|k| {
        let mut k = k.borrow_mut();
        let pose = k.recalled(preset, &ups_sample(inputs, rates), mode)?;
        ups_load_at(model, preset, pose, group)
    })
}

/// [`ups_load`] from the kernel's pose: its group's leg alone where [`certified`]
/// settles the conditioning, as [`bounded`] would.
fn ups_load_at(model: &CustomModel, preset: &UpsPreset, pose: &mut UpsPose, group: usize) -> Option<Option<[f64; 3]>> {
    if !certified(model, pose) {
        pose.complete(preset);
        if !bounded(model, &pose.g, &pose.gi) {
            return None;
        }
    }
    let def = &model.groups[group];
    let leg = pose.leg(preset, def.limb);
    let (centre, axis, normal) = ups_joint_at(pose, &leg.c_p, def.limb, def.joint);
    let at = (&centre, &axis, &normal);
    let system = Legs::leg(def.limb, leg.column.into(), leg.row, &pose.p);
    Some(mobile_load(model, def, leg.reactions[def.joint], at, &system))
}

/// [`preset_members`] for 6-UPS presets: per pose, the kernel once (the members differ
/// only in their clearances), then each member's take-up.
fn ups_members<P: std::ops::Deref<Target = [[f64; 3]]>>(
    models: &[&CustomModel],
    poses: &[P],
    mode: Mode,
    cond_of: CondOf,
    largest: &LargestCond,
) -> MembersSolved {
    let Some(Preset::Ups6(first)) = models[0].preset.as_deref() else {
        return MembersSolved::unanswered(models.len(), poses.len());
    };
    let mut out = MembersSolved::new(models.len(), poses.len());
    let dynamic = mode == Mode::Dynamic;
    let mut open: Vec<Option<Open>> = vec![None; poses.len()];
    let known = largest.get();
    UPS_KERNEL.with(|k| {
        let k = &mut k.borrow_mut();
        for (i, (p, open)) in poses.iter().zip(&mut open).enumerate() {
            // Statics has no rates, as `solve_members_near` has none there.
            let sample: crate::ups::UpsSample =
                std::array::from_fn(|i| if dynamic { p[i] } else { [p[i][0], 0.0, 0.0] });
            let inputs: [f64; 6] = std::array::from_fn(|i| p[i][0]);
            let mut pose = k.pose(first, &sample, mode);
            for (m, results) in models.iter().zip(&mut out.results) {
                let solved = match (m.preset.as_deref(), pose.as_deref_mut(), out.answered[i]) {
                    (Some(Preset::Ups6(preset)), Some(pose), true) => {
                        ups_result(m, preset, &inputs, pose, (cond_of, known), open, None)
                    }
                    _ => None,
                };
                if solved.is_none() {
                    out.answered[i] = false;
                }
                results.push(solved.unwrap_or_default());
            }
        }
    });
    settle_largest(&mut out, &open, largest);
    out
}

/// The reactions (once: the models differ only in their clearances), then each
/// model's take-up and errors, at a solved posture.
fn solve_posture(
    models: &[&CustomModel],
    posture: &CustomPosture,
    mut out: CustomResult,
    cond_of: CondOf,
    only: Option<usize>,
) -> Vec<CustomResult> {
    out.coords = posture.coords;
    out.q = posture.actuators(&models[0].geom);
    let statics = statics(models[0], posture, &mut out, cond_of);
    let mut all = vec![out; models.len()];
    if let Some((basis, gi)) = statics {
        for (model, out) in models.iter().zip(&mut all) {
            take_up(model, posture, &basis, &gi, out, only);
            if model.exact && out.status == Status::Ok && only.is_none() {
                out.exact = exact_error(model, posture, &basis, &gi, out);
            }
        }
    }
    all
}

/// The wrench basis, `G⁻¹` and the reactions (into `out`, with `cond` as `cond_of` asks)
/// at a posture; `None` where the pose is near-singular (`out.status` says so).
///
/// Under [`CondOf::Verdict`] (the switch search, which writes no condition number) the
/// singular values are computed only where they could decide: `‖G‖_F·‖G⁻¹‖_F` bounds
/// the 2-norm condition number from above, so a bound within `singular_cond` accepts
/// the pose as the condition number would, with the same `G⁻¹`; `out.cond` is then
/// NaN. Otherwise every pose's (only a preset's kernel leaves poses open,
/// [`CondOf::Largest`]).
fn statics(
    model: &CustomModel,
    posture: &CustomPosture,
    out: &mut CustomResult,
    cond_of: CondOf,
) -> Option<(Basis, Matrix6<f64>)> {
    let Some(basis) = Basis::new(posture, &model.geom) else {
        out.status = Status::NearSingular;
        out.cond = f64::INFINITY;
        return None;
    };
    let inverse = (cond_of == CondOf::Verdict).then(|| basis.g.try_inverse()).flatten();
    let (cond, within) = decided_cond(model, &basis.g, inverse.as_ref());
    out.cond = cond;
    let Some(gi) = within.then(|| inverse.or_else(|| basis.g.try_inverse())).flatten() else {
        out.status = Status::NearSingular;
        return None;
    };
    reactions(model, posture, &basis, &gi, out);
    Some((basis, gi))
}

/// The wrench `[m(a_G − g); G × m(a_G − g) + Iα + ω × Iω]` at the origin of a body
/// with spatial twist `tw` and acceleration `ac`.
fn body_wrench(mass: f64, com: &V3, inertia: &Matrix3<f64>, tw: &V6, ac: &V6, gravity: &V3) -> V6 {
    let (om, vo) = (w(tw), v(tw));
    let vel = vo + om.cross(com);
    let acc = v(ac) + w(ac).cross(com) + om.cross(&vel);
    let f = (acc - gravity) * mass;
    let m = com.cross(&f) + inertia * w(ac) + om.cross(&(inertia * om));
    six(f, m)
}

fn reactions(model: &CustomModel, p: &CustomPosture, basis: &Basis, gi: &Matrix6<f64>, out: &mut CustomResult) {
    let geom = &model.geom;
    // The platform: composite with its point masses, less the external wrench.
    let r = p.platform.r;
    let pos = p.platform.t;
    let mut d_platform = body_wrench(
        model.platform_mass,
        &pos,
        &(r * model.platform_inertia * r.transpose()),
        &p.twist,
        &p.accel,
        &model.gravity,
    );
    for (m, at) in &model.points {
        d_platform += body_wrench(*m, &(pos + r * at), &Matrix3::zeros(), &p.twist, &p.accel, &model.gravity);
    }
    let e = pos + r * model.force_at;
    d_platform -= six(model.force, e.cross(&model.force) + model.moment);
    // Per limb: C_J for each joint, the particular wrench W0 and the block of G.
    let mut carried: Vec<Vec<V6>> = Vec::with_capacity(geom.limbs.len());
    let mut rhs = d_platform;
    let mut w0s = Vec::with_capacity(geom.limbs.len());
    for (l, limb) in geom.limbs.iter().enumerate() {
        let n = limb.joints.len();
        let mut c = vec![V6::zeros(); n];
        for j in (0..n).rev() {
            let beyond = if j + 1 < n { c[j + 1] } else { V6::zeros() };
            let body = limb.bodies.get(j).map_or(V6::zeros(), |b| {
                let pb = &p.bodies[l][j];
                body_wrench(b.mass, &pb.com, &pb.inertia, &pb.twist, &pb.accel, &model.gravity)
            });
            c[j] = beyond + body;
        }
        // (S ξ_k)ᵀ (W0 + C_J(k)) = 0 for each passive column k.
        let mut r = [0.0; 6];
        let mut k = 0;
        for (j, (joint, pj)) in limb.joints.iter().zip(&p.joints[l]).enumerate() {
            if joint.actuated {
                continue;
            }
            for s in &pj.columns {
                r[k] = -swap(s).dot(&c[j]);
                k += 1;
            }
        }
        let w0 = basis.limbs[l].particular(&r);
        rhs -= w0;
        w0s.push(w0);
        carried.push(c);
    }
    let lambda = gi * rhs;
    out.reactions = Reactions::with_capacity(geom.limbs.len(), geom.limbs.iter().map(|l| l.joints.len()).sum());
    out.tau.clear();
    for (l, limb) in geom.limbs.iter().enumerate() {
        let LimbBasis { start, width, .. } = basis.limbs[l];
        let mut wl = w0s[l];
        for k in 0..width {
            wl += basis.g.column(start + k) * lambda[start + k];
        }
        let (tau, carried) = (&mut out.tau, &carried[l]);
        out.reactions.push_limb(limb.joints.iter().enumerate().map(|(j, joint)| {
            // W_J = W_limb + the bodies beyond J (`carried[l][j]` holds them from body j on).
            let wj = wl + carried[j];
            let pj = &p.joints[l][j];
            let f = w(&wj);
            let m = v(&wj) - pj.centre.cross(&f);
            if joint.actuated {
                tau.push(match joint.joint {
                    JointType::R => m.dot(&pj.axis),
                    _ => f.dot(&pj.axis),
                });
            }
            (f, m)
        }));
    }
}

/// Unit displacement twists spanning a group's admissible set at the pose (at most
/// three, held in place), whether they are rotations, and the set's shape (for the
/// envelope).
// Inlined into each error system's reach: called, it cost its result's copy (a per cent
// of a general 6-PUS's instructions).
#[inline(always)]
fn unit_set(joint: JointType, group: Group, centre: &V3, axis: &V3, normal: &V3) -> (Few<V6>, Shape) {
    let trans = |d: V3| six(V3::zeros(), d);
    let rot = |d: V3| six(d, centre.cross(&d));
    let perp = |a: &V3| {
        let t = if a.x.abs() < 0.9 { V3::x() } else { V3::y() };
        let u = a.cross(&t).normalize();
        (u, a.cross(&u))
    };
    let axes = [V3::x(), V3::y(), V3::z()];
    match (joint, group) {
        (JointType::R | JointType::P, Group::Radial) => {
            let (u, w) = perp(axis);
            (Few::of(&[trans(u), trans(w)]), Shape::Disc)
        }
        (JointType::R, Group::Axial) => (Few::of(&[trans(*axis)]), Shape::Segment),
        (JointType::R, Group::Angular) => {
            let (u, w) = perp(axis);
            (Few::of(&[rot(u), rot(w)]), Shape::Disc)
        }
        (JointType::P, Group::Angular) => (Few::of(&axes.map(rot)), Shape::Ball),
        (JointType::U | JointType::S, Group::Radial) => (Few::of(&axes.map(trans)), Shape::Ball),
        (JointType::U, Group::Angular) => (Few::of(&[rot(*normal)]), Shape::Segment),
        (JointType::R, Group::Backlash) => (Few::of(&[rot(*axis)]), Shape::Segment),
        (JointType::P, Group::Backlash) => (Few::of(&[trans(*axis)]), Shape::Segment),
        _ => (Few::of(&[]), Shape::Segment),
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Shape {
    Disc,
    Ball,
    Segment,
}

/// `ΔΓ` at P of a displacement twist `zeta` of the limb whose columns of `G` are
/// `block` (start, width): `S·G⁻ᵀ·[N_lᵀ·S·ζ]`.
fn response(g: &Matrix6<f64>, (start, width): (usize, usize), gi: &Matrix6<f64>, zeta: &V6, pos: &V3) -> [f64; 6] {
    let sz = swap(zeta);
    // `G⁻ᵀ·b` where `b` is zero but in the block: the block's rows of `G⁻¹`, each times
    // its entry of `b`, in the order of the whole product (whose other terms are zero).
    let mut y = V6::zeros();
    for k in start..start + width {
        let b = g.column(k).dot(&sz);
        for i in 0..6 {
            y[i] += gi[(k, i)] * b;
        }
    }
    at_p(&swap(&y), pos)
}

/// A group's deciding load from its joint's reaction `(f, m)`, the direction its
/// distal body is pushed (unit for a scalar load, the load's opposite for a vector),
/// and whether the take-up is a rotation.
fn deciding_load(joint: JointType, group: Group, a: &V3, normal: &V3, f: &V3, m: &V3) -> (V3, V3, bool) {
    match (joint, group) {
        (JointType::R | JointType::P, Group::Radial) => {
            let fp = f - a * f.dot(a);
            (fp, -fp, false)
        }
        (JointType::R, Group::Axial) => {
            let s = f.dot(a);
            (V3::new(s, 0.0, 0.0), -a * s.signum(), false)
        }
        (JointType::R, Group::Angular) => {
            let mp = m - a * m.dot(a);
            (mp, -mp, true)
        }
        (JointType::P, Group::Angular) => (*m, -m, true),
        (JointType::U | JointType::S, Group::Radial) => (*f, -f, false),
        (JointType::U, Group::Angular) => {
            let mu = m.dot(normal);
            (V3::new(mu, 0.0, 0.0), -normal * mu.signum(), true)
        }
        (JointType::R, Group::Backlash) => {
            let tau = m.dot(a);
            (V3::new(tau, 0.0, 0.0), -a * tau.signum(), true)
        }
        (JointType::P, Group::Backlash) => {
            let tau = f.dot(a);
            (V3::new(tau, 0.0, 0.0), -a * tau.signum(), false)
        }
        _ => (V3::zeros(), V3::zeros(), false),
    }
}

/// The largest singular value of a 3 × 3 matrix: the square root of the largest
/// eigenvalue of `MᵀM` (well conditioned: to round-off of `‖M‖`), in closed form.
fn largest_singular_value(m: &Matrix3<f64>) -> f64 {
    let a = m.transpose() * m;
    // The trigonometric solution of the symmetric 3 × 3 eigenproblem (Smith, 1961).
    let off = a[(0, 1)].powi(2) + a[(0, 2)].powi(2) + a[(1, 2)].powi(2);
    let q = a.trace() / 3.0;
    let d = [a[(0, 0)] - q, a[(1, 1)] - q, a[(2, 2)] - q];
    let p2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] + 2.0 * off;
    let largest = if p2 <= 0.0 {
        q
    } else {
        let p = (p2 / 6.0).sqrt();
        let b = (a - Matrix3::identity() * q) / p;
        let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
        q + 2.0 * p * (r.acos() / 3.0).cos()
    };
    largest.max(0.0).sqrt()
}

/// A group's admissible set's unit responses at P, its shape, and the largest `|Δp|`
/// and `|Δα|` a unit take-up in it can cause ([`unit_reach`]).
type Reach = (Few<[f64; 6]>, Shape, f64, f64);

/// The unit responses at P of a group's admissible set (its joint's centre, axis and
/// normal in `at`; `(G, the limb's block of it, G⁻¹)` in `system`), the set's shape,
/// and the largest `|Δp|` and `|Δα|` a unit take-up in it can cause.
fn unit_reach(
    (g, block, gi): (&Matrix6<f64>, (usize, usize), &Matrix6<f64>),
    (joint, group): (JointType, Group),
    (centre, axis, normal): (&V3, &V3, &V3),
    pos: &V3,
) -> Reach {
    let (set, shape) = unit_set(joint, group, centre, axis, normal);
    let responses = set.map(|z| response(g, block, gi, z, pos));
    let block = |rows: std::ops::Range<usize>| -> f64 {
        let m = SMatrix::<f64, 3, 3>::from_fn(|r, c| responses.get(c).map_or(0.0, |x| x[rows.start + r]));
        match shape {
            Shape::Segment => m.column(0).norm(),
            _ => largest_singular_value(&m),
        }
    };
    let (unit_p, unit_a) = (block(0..3), block(3..6));
    (responses, shape, unit_p, unit_a)
}

/// A pose's error system as the take-up reads it (docs/model.md §12.7): the response at
/// P of a limb's displacement twist, and a group's unit reach.
trait Responder {
    /// `ΔΓ` at P of a displacement twist `zeta` of limb `limb` ([`response`]).
    fn response(&self, limb: usize, zeta: &V6) -> [f64; 6];

    /// The unit reach of a group of limb `limb` ([`unit_reach`]): its joint and group,
    /// and its joint's centre, axis and normal in `at`.
    fn reach(&self, limb: usize, kind: (JointType, Group), at: (&V3, &V3, &V3)) -> Reach;
}

/// Any mechanism's error system: `G`, each limb's block of its columns (start, width) by
/// `block`, `G⁻¹` and P.
struct Blocks<'a, B> {
    g: &'a Matrix6<f64>,
    block: B,
    gi: &'a Matrix6<f64>,
    pos: V3,
}

impl<B: Fn(usize) -> (usize, usize)> Responder for Blocks<'_, B> {
    fn response(&self, limb: usize, zeta: &V6) -> [f64; 6] {
        response(self.g, (self.block)(limb), self.gi, zeta, &self.pos)
    }

    fn reach(&self, limb: usize, kind: (JointType, Group), at: (&V3, &V3, &V3)) -> Reach {
        unit_reach((self.g, (self.block)(limb), self.gi), kind, at, &self.pos)
    }
}

/// A 6-UPS preset's error system (docs/model.md §12.10): each leg lets one wrench
/// through, so its block of `G` is one column `g_l` and the response of a twist `ζ` of
/// the leg is `(g_lᵀ·S·ζ)·r_l`, where `r_l` is row `l` of `G⁻¹` as a twist, at P. A
/// group's unit responses are then multiples of one vector, and its unit reach is
/// `|r_l|` (its translation or rotation half) times the length of the multiples.
/// The same values as [`Blocks`] gives to round-off.
struct Legs {
    /// `g_l`, leg by leg.
    columns: [[f64; 6]; 6],
    /// `r_l` at P, leg by leg.
    rows: [[f64; 6]; 6],
    /// `(|Δp|, |Δα|)` of each `r_l`.
    norms: [(f64, f64); 6],
}

impl Legs {
    const NONE: Self = Self { columns: [[0.0; 6]; 6], rows: [[0.0; 6]; 6], norms: [(0.0, 0.0); 6] };

    fn new(g: &Matrix6<f64>, gi: &Matrix6<f64>, pos: &V3) -> Self {
        let mut out = Self::NONE;
        for l in 0..6 {
            out.set(l, std::array::from_fn(|i| g[(i, l)]), std::array::from_fn(|i| gi[(l, i)]), pos);
        }
        out
    }

    /// The system of leg `l` alone (the others' entries zero), from its column of `G`
    /// and its row of `G⁻¹`: what the switch search reads one group with.
    fn leg(l: usize, column: [f64; 6], row: [f64; 6], pos: &V3) -> Self {
        let mut out = Self::NONE;
        out.set(l, column, row, pos);
        out
    }

    fn set(&mut self, l: usize, column: [f64; 6], row: [f64; 6], pos: &V3) {
        self.columns[l] = column;
        let r = at_p(&swap(&V6::from(row)), pos);
        let half = |h: &[f64]| (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        self.norms[l] = (half(&r[..3]), half(&r[3..]));
        self.rows[l] = r;
    }

    /// `g_lᵀ·S·ζ`: the leg's one wrench paired with the twist.
    fn pairing(&self, limb: usize, zeta: &V6) -> f64 {
        let c = &self.columns[limb];
        c[0] * zeta[3] + c[1] * zeta[4] + c[2] * zeta[5] + c[3] * zeta[0] + c[4] * zeta[1] + c[5] * zeta[2]
    }
}

impl Responder for Legs {
    fn response(&self, limb: usize, zeta: &V6) -> [f64; 6] {
        let b = self.pairing(limb, zeta);
        self.rows[limb].map(|r| r * b)
    }

    fn reach(&self, limb: usize, (joint, group): (JointType, Group), (centre, axis, normal): (&V3, &V3, &V3)) -> Reach {
        let (set, shape) = unit_set(joint, group, centre, axis, normal);
        let pairings = set.map(|z| self.pairing(limb, z));
        let responses = pairings.map(|b| self.rows[limb].map(|r| r * b));
        // The largest singular value of the rank-one `r·bᵀ` is `|r|·|b|`.
        let length = pairings.iter().map(|b| b * b).sum::<f64>().sqrt();
        let (unit_p, unit_a) = self.norms[limb];
        (responses, shape, unit_p * length, unit_a * length)
    }
}

/// A group's deciding load, margin and displacement twist at a pose (docs/model.md
/// §12.5), from its joint's reaction `(f, m)` and its centre, axis and normal there;
/// whether it moves P, its determinacy and its own error are [`settle`]'s.
fn group_take(
    model: &CustomModel,
    def: &GroupDef,
    joint: JointType,
    (centre, axis, normal): (&V3, &V3, &V3),
    (f, m): (V3, V3),
) -> GroupTake {
    let (load, dir, rotation) = deciding_load(joint, def.group, axis, normal, &f, &m);
    let scalar = def.scalar(joint);
    let margin = if scalar { load.x.abs() } else { load.norm() };
    // A scalar load at or below the floor decides nothing: the take-up is then along
    // +axis (the 6-UPS's convention for its U tilt play, whose load is round-off).
    // `dir` is −axis·signum(load), signum never 0.
    let unit = if scalar && margin <= model.floor {
        -dir * load.x.signum()
    } else if scalar {
        dir
    } else if margin > 0.0 {
        dir / margin
    } else {
        V3::zeros()
    };
    let disp = unit * def.magnitude;
    let twist = if rotation { six(disp, centre.cross(&disp)) } else { six(V3::zeros(), disp) };
    GroupTake { load: [load.x, load.y, load.z], margin, twist, ..Default::default() }
}

/// Whether `take`'s group moves P, whether its take-up is indeterminate, and its own
/// `|Δp|`, from its admissible set's unit reach (`reach`, [`Responder::reach`]) and the
/// pose's error system; returns its error at P.
fn settle(
    model: &CustomModel,
    def: &GroupDef,
    reach: &Reach,
    system: &impl Responder,
    take: &mut GroupTake,
) -> [f64; 6] {
    take.mobile = reach.2 >= IMMOBILE;
    take.indeterminate = def.magnitude > 0.0 && take.mobile && take.margin <= model.floor;
    let e = system.response(def.limb, &take.twist);
    take.dp = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    e
}

/// Whether a group's admissible set is the ball of translations (the radial play of a U
/// or S joint), whose unit reach depends on its limb alone, not on the joint's place.
fn translation_ball(joint: JointType, group: Group) -> bool {
    matches!((joint, group), (JointType::U | JointType::S, Group::Radial))
}

/// The limbs whose translation balls' reach [`take_up_at`] keeps, computed once a limb:
/// a 6-UPS or 6-PUS leg's U and S joints have the same, which was a fifth of a pose.
const KEPT_BALLS: usize = 8;

fn take_up(
    model: &CustomModel,
    p: &CustomPosture,
    basis: &Basis,
    gi: &Matrix6<f64>,
    out: &mut CustomResult,
    only: Option<usize>,
) {
    let joint_at = |l: usize, j: usize| {
        let pj = &p.joints[l][j];
        (pj.centre, pj.axis, pj.normal)
    };
    let system = Blocks { g: &basis.g, block: |l| basis.block(l), gi, pos: p.platform.t };
    take_up_at(model, joint_at, &system, &p.coords, out, only);
}

/// [`take_up`] from what it reads of a pose: each joint's centre, axis and normal
/// (`joint_at(limb, joint)`), its error system and the coordinates; the reactions are
/// `out`'s. Sets the status: `ok`, or `indeterminate_contact` where a take-up is. With
/// `only`, that kind's groups alone ([`Wanted::Kind`]).
fn take_up_at(
    model: &CustomModel,
    joint_at: impl Fn(usize, usize) -> (V3, V3, V3),
    system: &impl Responder,
    coords: &[f64; 6],
    out: &mut CustomResult,
    only: Option<usize>,
) {
    let nk = model.kinds.len();
    // Each kind's error `[Δp; Δα]` summed in the first six entries of its slot of
    // `kind_errors` (`None` once a group of it is indeterminate), then made the nine.
    out.kind_errors.clear();
    out.kind_errors.resize(nk, Some([0.0; 9]));
    let mut envelope = std::mem::take(&mut out.envelope);
    envelope.clear();
    envelope.resize(nk, [0.0f64; 8]);
    out.takes.clear();
    out.takes.reserve_exact(model.groups.len());
    let read = |k: usize| only.is_none_or(|o| o == k);
    let mut balls: [Option<(Reach, [f64; 6])>; KEPT_BALLS] = [None; KEPT_BALLS];
    for g in &model.groups {
        if !read(g.kind) {
            out.takes.push(GroupTake::default());
            continue;
        }
        let joint = model.joint_type(g);
        let (centre, axis, normal) = joint_at(g.limb, g.joint);
        let at = (&centre, &axis, &normal);
        let mut t = group_take(model, g, joint, at, out.reactions[g.limb][g.joint]);
        if g.magnitude == 0.0 {
            // No play: its take-up (a zero twist) adds ±0 to its kind's error, which
            // from +0 never holds −0, and 0·reach to the envelope: nothing. Its unit
            // reach, a sixth of a described 6-UPS's pose where its U joints' tilt play
            // is zero, is not solved (`mobile` stays false, `dp` 0 as solved).
            out.takes.push(t);
            continue;
        }
        // The admissible set's unit responses: the envelope, and whether it moves P;
        // with the largest of each component of `ΔΓ` a unit take-up in it can cause.
        let reach_here = || {
            let reach = system.reach(g.limb, (joint, g.group), at);
            let (responses, shape) = (&reach.0, reach.1);
            let components: [f64; 6] = std::array::from_fn(|c| match shape {
                Shape::Segment => responses[0][c].abs(),
                _ => responses.iter().map(|x| x[c] * x[c]).sum::<f64>().sqrt(),
            });
            (reach, components)
        };
        let computed;
        let (reach, components) = match translation_ball(joint, g.group).then(|| balls.get_mut(g.limb)).flatten() {
            Some(kept) => kept.get_or_insert_with(reach_here),
            None => {
                computed = reach_here();
                &computed
            }
        };
        let e = settle(model, g, reach, system, &mut t);
        let (unit_p, unit_a) = (reach.2, reach.3);
        for c in 0..6 {
            envelope[g.kind][c] += g.magnitude * components[c];
        }
        envelope[g.kind][6] += g.magnitude * unit_p;
        envelope[g.kind][7] += g.magnitude * unit_a;
        let slot = &mut out.kind_errors[g.kind];
        if t.indeterminate {
            *slot = None;
        } else if let Some(sum) = slot {
            for c in 0..6 {
                sum[c] += e[c];
            }
        }
        out.takes.push(t);
    }
    let six = |e: &[f64; 9]| -> [f64; 6] { std::array::from_fn(|c| e[c]) };
    let nine = nine_at(coords);
    out.total = (only.is_none() && out.kind_errors.iter().all(Option::is_some)).then(|| {
        let mut s = [0.0; 6];
        for e in out.kind_errors.iter().flatten() {
            for c in 0..6 {
                s[c] += e[c];
            }
        }
        nine(&s)
    });
    for (k, slot) in out.kind_errors.iter_mut().enumerate() {
        *slot = slot.filter(|_| read(k)).map(|e| nine(&six(&e)));
    }
    let mut total = [0.0; 8];
    for e in &envelope {
        for c in 0..8 {
            total[c] += e[c];
        }
    }
    out.envelope = envelope;
    out.env_total = total;
    out.dominant = if only.is_none() { dominant(model, &out.takes) } else { None };
    out.status = if out.takes.iter().any(|t| t.indeterminate) { Status::IndeterminateContact } else { Status::Ok };
}

/// Relative tolerance of a tie between two joints' contributions (docs/model.md §12.7).
pub const DOMINANT_TIE: f64 = 1e-9;

/// The group whose own take-up moves P most; ties go to the first in the canonical
/// order (joint type S, U, R, P; place in the limb; group; limb).
fn dominant(model: &CustomModel, takes: &[GroupTake]) -> Option<usize> {
    let candidate = |i: usize| model.groups[i].magnitude > 0.0 && takes[i].mobile;
    let best = (0..model.groups.len()).filter(|&i| candidate(i)).map(|i| takes[i].dp).fold(f64::NEG_INFINITY, f64::max);
    if best.is_nan() || best <= 0.0 {
        return None;
    }
    model.tie_order.iter().copied().find(|&i| candidate(i) && takes[i].dp >= best * (1.0 - DOMINANT_TIE))
}

/// Chord iterations of [`exact_error`] that run whatever their progress. The chord
/// converges linearly, the slower the larger the take-up: a 3-PRS with 0.04 rad of
/// error contracted by 0.47 an iteration and reached round-off at the 41st, so it was
/// left null where the reference's Newton converged (cross-check seed 2611, job 121).
const CHORD_SURE: usize = 40;

/// Beyond [`CHORD_SURE`], the iterations go on while each shrinks the residual by this
/// factor at least, up to [`CHORD_MOST`] in all.
const CHORD_CONTRACTS: f64 = 0.9;
const CHORD_MOST: usize = 200;

/// The exact error (docs/model.md §12.7): the take-ups as finite rigid motions, the
/// closure solved for the platform's displacement and the passive joints' motions by
/// chord iterations on the linear error system's matrix.
fn exact_error(
    model: &CustomModel,
    p: &CustomPosture,
    basis: &Basis,
    gi: &Matrix6<f64>,
    out: &CustomResult,
) -> Option<[f64; 6]> {
    let geom = &model.geom;
    // Each joint's take-up as a rotation vector and a translation about its centre.
    let mut play: Vec<Vec<(V3, V3)>> =
        geom.limbs.iter().map(|l| vec![(V3::zeros(), V3::zeros()); l.joints.len()]).collect();
    for (g, t) in model.groups.iter().zip(&out.takes) {
        // On an ok pose a vector load at or below the floor is that of a group that
        // cannot move P: its direction is round-off, so it is not displaced (its
        // second-order effect would be noise). A scalar one is along +axis (`take_up`).
        if t.margin <= model.floor && !model.scalar_group(g) {
            continue;
        }
        let e = &mut play[g.limb][g.joint];
        e.0 += w(&t.twist);
        // A rotation's twist carries c × δ in its second half; the translation is the rest.
        let c = p.joints[g.limb][g.joint].centre;
        e.1 += v(&t.twist) - c.cross(&w(&t.twist));
    }
    let mut delta = Rigid::IDENTITY;
    let mut q: Vec<Vec<f64>> = basis.limbs.iter().map(|b| vec![0.0; b.n]).collect();
    let scale = geom.length;
    let pinv: Vec<Option<DMatrix<f64>>> = basis
        .limbs
        .iter()
        .map(|b| {
            let cols = b.passive();
            let x = DMatrix::from_fn(6, cols.len(), |r, c| cols[c][r]);
            (x.transpose() * &x).try_inverse().map(|gram| gram * x.transpose())
        })
        .collect();
    let mut previous = f64::INFINITY;
    for iteration in 0..CHORD_MOST {
        let mut b = V6::zeros();
        let mut res = Vec::with_capacity(geom.limbs.len());
        let mut size = 0.0f64;
        for (l, limb) in geom.limbs.iter().enumerate() {
            let mut g = Rigid::IDENTITY;
            let mut k = 0;
            for (j, joint) in limb.joints.iter().enumerate() {
                let pj = &p.joints[l][j];
                let c = pj.centre;
                if !joint.actuated {
                    let m = match joint.joint {
                        JointType::R => Rigid::about(&c, exp_so3(&(pj.axis * q[l][k]))),
                        JointType::P => Rigid { r: Matrix3::identity(), t: pj.axis * q[l][k] },
                        JointType::U => Rigid::about(&c, exp_so3(&(pj.axis * q[l][k])))
                            .then(&Rigid::about(&c, exp_so3(&(pj.axis2 * q[l][k + 1])))),
                        JointType::S => Rigid::about(&c, exp_so3(&V3::new(q[l][k], q[l][k + 1], q[l][k + 2]))),
                    };
                    k += match joint.joint {
                        JointType::R | JointType::P => 1,
                        JointType::U => 2,
                        JointType::S => 3,
                    };
                    g = g.then(&m);
                }
                let (rv, u) = play[l][j];
                if rv != V3::zeros() || u != V3::zeros() {
                    let cj = Rigid { r: exp_so3(&rv), t: c - exp_so3(&rv) * c + u };
                    g = cj.then(&g);
                }
            }
            let e = g.then(&delta.inverse());
            let r = six(skew_axial(&e.r), e.t);
            size = size.max(w(&r).amax()).max(v(&r).amax() / scale);
            let LimbBasis { start, width, .. } = basis.limbs[l];
            let sr = swap(&r);
            for kk in 0..width {
                b[start + kk] = basis.g.column(start + kk).dot(&sr);
            }
            res.push(r);
        }
        // Converged: at round-off, where the chord iterations stop gaining.
        let converged = size < 1e-16 || (size < 1e-12 && size > 0.5 * previous);
        if !converged && iteration >= CHORD_SURE && size >= CHORD_CONTRACTS * previous {
            return None;
        }
        previous = size;
        if converged {
            let rot = log_so3(&delta.r);
            let pos = p.platform.t;
            let dp = delta.apply(&pos) - pos;
            let exact = [dp.x, dp.y, dp.z, rot.x, rot.y, rot.z];
            // Another branch near a singularity is not the pose the clearances make.
            let lin = out.total?;
            let diff = (0..6).map(|i| (exact[i] - lin[i]).powi(2)).sum::<f64>().sqrt();
            let size = (0..6).map(|i| lin[i] * lin[i]).sum::<f64>().sqrt();
            return (diff <= size.max(1e-300)).then_some(exact);
        }
        let d = swap(&(gi.transpose() * b));
        delta = Rigid { r: exp_so3(&w(&d)), t: v(&d) }.then(&delta);
        for (l, r) in res.iter().enumerate() {
            let Some(pi) = &pinv[l] else { return None };
            let dq = pi * nalgebra::DVector::from_iterator(6, (d - r).iter().copied());
            for (x, y) in q[l].iter_mut().zip(dq.iter()) {
                *x += y;
            }
        }
    }
    None
}

/// The nominal posture's placement of the platform, for callers that need P.
pub fn platform_of(coords: &[f64; 6]) -> Rigid {
    placement(coords)
}

/// The states of a solved configuration (for tests).
pub fn states_of(p: &CustomPosture) -> &[Vec<JointState>] {
    &p.states
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// [`Reactions`] gives back each limb's joints as they were given, limbs of any
    /// length (none too), built whole or limb by limb.
    #[test]
    fn reactions_are_read_limb_by_limb_as_they_were_given() {
        let v = |x: f64| (V3::new(x, 0.0, -x), V3::new(0.0, x, 2.0 * x));
        let limbs: Vec<Vec<(V3, V3)>> = vec![vec![v(1.0), v(2.0)], vec![], vec![v(3.0), v(4.0), v(5.0)], vec![v(6.0)]];
        let whole = Reactions::of(&limbs);
        assert_eq!(whole.len(), limbs.len());
        for (l, limb) in limbs.iter().enumerate() {
            assert_eq!(&whole[l], limb.as_slice(), "limb {l}");
        }
        assert_eq!(whole.iter().map(<[_]>::len).collect::<Vec<_>>(), [2, 0, 3, 1]);
        let mut pushed = Reactions::with_capacity(limbs.len(), 6);
        for limb in &limbs {
            pushed.push_limb(limb.iter().copied());
        }
        assert_eq!(pushed, whole);
        assert!(Reactions::default().is_empty());
    }

    /// [`cond_bound`] is above `κ₂(G)` as [`cond_of`] computes it and within `6^{1/8}`
    /// of it (and its margin), from `G` alone and with `G⁻¹`, on matrices of unit
    /// columns (as a wrench basis's) from well to badly conditioned; below a third of
    /// [`BOUND_VOUCHED`] it always vouches for one, three times in four within 1 %.
    #[test]
    fn the_bound_of_the_condition_number_is_above_it_and_near() {
        let mut rng = ChaCha8Rng::seed_from_u64(38);
        let (mut vouched, mut near, mut beyond) = (0, 0, 0);
        for k in 0..20_000 {
            let mut g = Matrix6::from_fn(|_, _| rng.random_range(-1.0..1.0));
            if k % 2 == 0 {
                // Two columns nearly dependent.
                let e = 10f64.powf(rng.random_range(-5.0..0.0));
                let c = g.column(0) + g.column(1) * e;
                g.set_column(1, &c);
            }
            for mut c in g.column_iter_mut() {
                let n = c.norm();
                c /= n;
            }
            let cond = cond_of(&g);
            for gi in [None, g.try_inverse()] {
                let bound = cond_bound(&g, gi.as_ref(), 0.0).0;
                if bound.is_finite() {
                    assert!(cond < bound && bound <= cond * 6f64.powf(0.125) * (1.0 + 2e-6), "{cond} {bound}\n{g}");
                    vouched += 1;
                    near += usize::from(bound < 1.01 * cond);
                    // Below any known value, the loosest bound (by `Σλ²`) is given: still
                    // above `κ₂`, within `√6`; and below a value between the two, the
                    // bound given is below that value.
                    let loose = cond_bound(&g, gi.as_ref(), f64::INFINITY).0;
                    assert!(bound <= loose && loose <= cond * 6f64.sqrt() * (1.0 + 2e-6), "{cond} {bound} {loose}");
                    let between = (bound + loose) / 2.0;
                    let given = cond_bound(&g, gi.as_ref(), between).0;
                    assert!(cond < given && (given < between || given == bound), "{cond} {given} {between}");
                } else {
                    assert!(cond > BOUND_VOUCHED / 3.0, "{cond}\n{g}");
                    beyond += 1;
                }
            }
        }
        assert!(vouched > 20_000 && near > vouched * 3 / 4 && beyond > 5_000, "{vouched} {near} {beyond}");
    }

    /// [`Lu3`] factors and solves as nalgebra's LU does, bit for bit: on random matrices, on ones
    /// with a zero column or repeated rows (no solution: `None` from both), on the Euler
    /// maps of [`nine_at`] (singular at `cos Ψ = 0`), and with NaN and infinite entries.
    #[test]
    fn the_3_by_3_lu_solves_as_nalgebras() {
        let mut rng = ChaCha8Rng::seed_from_u64(3933);
        let mut some = 0;
        for k in 0..20_000 {
            let mut m = Matrix3::from_fn(|_, _| rng.random_range(-2.0..2.0));
            match k % 8 {
                0 => m.set_column(rng.random_range(0..3), &V3::zeros()),
                1 => {
                    let r = m.row(0).into_owned();
                    m.set_row(2, &r);
                }
                2 => {
                    let (psi, theta) = (
                        if k % 16 == 2 { std::f64::consts::FRAC_PI_2 } else { rng.random_range(-1.5..1.5) },
                        rng.random_range(-3.0..3.0),
                    );
                    let ry = nalgebra::Rotation3::from_axis_angle(&V3::y_axis(), theta).into_inner();
                    let rx = nalgebra::Rotation3::from_axis_angle(&V3::x_axis(), psi).into_inner();
                    m = Matrix3::from_columns(&[ry * rx * V3::z(), ry * V3::x(), V3::y()]);
                }
                3 => m[(rng.random_range(0..3), rng.random_range(0..3))] = [f64::NAN, f64::INFINITY, 0.0][k % 3],
                _ => {}
            }
            let b = [rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)];
            let lu = m.lu();
            let theirs = lu.solve(&V3::from(b)).map(|x| [x[0], x[1], x[2]]);
            let ours = Lu3::new(&m);
            assert_eq!(format!("{:?}", ours.solve(b)), format!("{theirs:?}"), "{m}");
            // The factors themselves, and where each row comes from.
            let (l, u) = (lu.l(), lu.u());
            let factors: [[f64; 3]; 3] =
                std::array::from_fn(|r| std::array::from_fn(|c| if c < r { l[(r, c)] } else { u[(r, c)] }));
            assert_eq!(format!("{:?}", ours.lu), format!("{factors:?}"), "{m}");
            let mut order = V3::new(0.0, 1.0, 2.0);
            lu.p().permute_rows(&mut order);
            assert_eq!(ours.perm.map(|k| k as f64), [order[0], order[1], order[2]], "{m}");
            let ours = ours.solve(b);
            some += usize::from(ours.is_some());
        }
        assert!(some > 10_000 && some < 19_000, "{some}");
    }

    /// The bounds of `σ_max(G)` and `σ_min(G)` that [`cond_bound`] gives are around the
    /// singular values as the SVD computes them (to 1e-9), and [`near_bound`] from them is above
    /// `κ₂` of every matrix within its reach, on matrices of unit columns perturbed by
    /// up to a tenth of `σ_min` (in Frobenius norm), which it answers.
    #[test]
    fn the_neighbours_bound_of_the_condition_number_is_above_it() {
        let mut rng = ChaCha8Rng::seed_from_u64(3838);
        let unit = |mut g: Matrix6<f64>| {
            for mut c in g.column_iter_mut() {
                let n = c.norm();
                c /= n;
            }
            g
        };
        let (mut bounded, mut answered, mut asked) = (0, 0, 0);
        for k in 0..4_000 {
            let g = unit(Matrix6::from_fn(|_, _| rng.random_range(-1.0..1.0)));
            let gi = g.try_inverse();
            let below = if k % 2 == 0 { 0.0 } else { f64::INFINITY };
            let Some((hi, lo)) = cond_bound(&g, gi.as_ref(), below).1 else { continue };
            bounded += 1;
            let s = g.singular_values();
            // To their round-off, which the bound's margin covers: where one eigenvalue
            // dominates, they are the singular values.
            assert!(hi >= s.max() * (1.0 - 1e-9) && lo <= s.min() * (1.0 + 1e-9) && lo > 0.0, "{hi} {lo} {s}");
            NEAR.set(Some(Near { g, hi, lo }));
            for _ in 0..10 {
                let e = Matrix6::from_fn(|_, _| rng.random_range(-1.0..1.0));
                let near = g + e * (rng.random_range(0.0..0.1) * lo / e.norm());
                asked += 1;
                if let Some(bound) = near_bound(&near) {
                    answered += 1;
                    assert!(cond_of(&near) < bound, "{} {bound}", cond_of(&near));
                }
            }
            // Beyond half of `σ_min`, none.
            let e = Matrix6::from_fn(|_, _| rng.random_range(-1.0..1.0));
            assert!(near_bound(&(g + e * (0.6 * lo / e.norm()))).is_none());
        }
        NEAR.set(None);
        assert!(bounded > 1_500 && answered == asked, "{bounded} {answered} {asked}");
    }

    /// The 6-UPS kernel's rank-one error system ([`Legs`]) gives what the general one
    /// ([`Blocks`], each limb a block of one column) gives, to 1e-12 of each quantity's
    /// scale: every group's unit responses, shape and unit reach (the general one's
    /// largest singular value in closed form), and the response of any twist; for every
    /// joint and group, at random joints, on random bases of unit columns, and for one
    /// leg alone ([`Legs::leg`]).
    #[test]
    fn the_legs_rank_one_system_is_the_general_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(47);
        let v3 = |rng: &mut ChaCha8Rng| V3::from_fn(|_, _| rng.random_range(-1.0..1.0));
        let kinds = [
            (JointType::R, Group::Radial),
            (JointType::R, Group::Axial),
            (JointType::R, Group::Angular),
            (JointType::R, Group::Backlash),
            (JointType::P, Group::Radial),
            (JointType::P, Group::Angular),
            (JointType::P, Group::Backlash),
            (JointType::U, Group::Radial),
            (JointType::U, Group::Angular),
            (JointType::S, Group::Radial),
        ];
        let close = |a: f64, b: f64, scale: f64| (a - b).abs() <= 1e-12 * scale.max(f64::MIN_POSITIVE);
        let mut compared = 0;
        for _ in 0..200 {
            let mut g = Matrix6::from_fn(|_, _| rng.random_range(-1.0..1.0));
            for mut c in g.column_iter_mut() {
                let n = c.norm();
                c /= n;
            }
            let Some(gi) = g.try_inverse() else { continue };
            let pos = v3(&mut rng);
            let general = Blocks { g: &g, block: |l| (l, 1), gi: &gi, pos };
            let legs = Legs::new(&g, &gi, &pos);
            for l in 0..6 {
                let column = std::array::from_fn(|i| g[(i, l)]);
                let alone = Legs::leg(l, column, std::array::from_fn(|i| gi[(l, i)]), &pos);
                let zeta = V6::from_fn(|_, _| rng.random_range(-1.0..1.0));
                let want = general.response(l, &zeta);
                let scale = want.iter().fold(0.0f64, |m, x| m.max(x.abs()));
                for got in [legs.response(l, &zeta), alone.response(l, &zeta)] {
                    assert!(want.iter().zip(&got).all(|(a, b)| close(*a, *b, scale)), "{want:?} {got:?}");
                }
                for kind in kinds {
                    let (centre, axis, normal) = (v3(&mut rng), v3(&mut rng).normalize(), v3(&mut rng).normalize());
                    let at = (&centre, &axis, &normal);
                    let want = general.reach(l, kind, at);
                    let scale = want.0.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
                    for got in [legs.reach(l, kind, at), alone.reach(l, kind, at)] {
                        assert_eq!((got.0.len(), got.1), (want.0.len(), want.1), "{kind:?}");
                        for (w, r) in want.0.iter().zip(got.0.iter()) {
                            assert!(w.iter().zip(r).all(|(a, b)| close(*a, *b, scale)), "{kind:?}: {w:?} {r:?}");
                        }
                        assert!(
                            close(got.2, want.2, want.2) && close(got.3, want.3, want.3),
                            "{kind:?}: {got:?} {want:?}"
                        );
                        compared += 1;
                    }
                }
            }
        }
        assert!(compared > 20_000, "{compared}");
    }

    /// [`certificate`] is above `κ₂(G)` (as [`cond_of`] computes it from the description's
    /// `G`, [`UpsPose::complete`]) at poses the built-in 6-UPS's kernel solves, across its
    /// workspace, and within 50 times it (5 to 13 times on this seed); so [`certified`]
    /// accepts a pose only where [`bounded`] does, and accepts the poses of a workspace.
    #[test]
    fn the_6_ups_certificate_is_above_the_condition_number() {
        let model = crate::ups::UpsModel::default();
        let mut ws = crate::ups::UpsWorkspace::new(&model);
        let preset = UpsPreset { model, q_home: [0.0; 6], p_from_b: [0.0; 6], id: u64::MAX };
        let mut rng = ChaCha8Rng::seed_from_u64(48);
        let (mut solved, mut tight) = (0, 0);
        for _ in 0..5_000 {
            let inputs = [
                rng.random_range(-0.3..0.3),
                rng.random_range(-0.3..0.3),
                rng.random_range(0.4..1.1),
                rng.random_range(-0.8..0.8),
                rng.random_range(-0.8..0.8),
                rng.random_range(-0.8..0.8),
            ];
            let sample: crate::ups::UpsSample = inputs.map(|v| [v, 0.0, 0.0]);
            let mut pose = UpsPose::default();
            if !ups_pose(&preset, &sample, Mode::Kinetostatic, &mut ws, &mut pose) {
                continue;
            }
            pose.complete(&preset);
            let (cond, bound) = (cond_of(&pose.g), certificate(&pose));
            assert!(cond <= bound, "{inputs:?}: κ₂ {cond}, certificate {bound}");
            solved += 1;
            tight += usize::from(bound < 50.0 * cond);
        }
        assert!(solved > 500 && tight == solved, "{solved} {tight}");
    }
}
