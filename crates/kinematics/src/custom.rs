//! Kinematics of a mechanism described by its joints (docs/model.md §12.2).
//!
//! Screws are spatial twists `[ω; v_O]` (angular velocity, velocity of the point at
//! the world origin). Each joint is one or more *columns*, a unit screw fixed in the
//! body before it: R one rotation, P one translation, U a rotation about `a1` then
//! one about `a2`, S three rotations about the world axes at home. A body's
//! displacement from home is the product of its joints' motions from the ground
//! (`G_j = G_{j−1}·T_j`); closure asks the last body's displacement to equal the
//! platform's, `D = T(pose)·T(home)⁻¹`. Newton on every limb's closure at once
//! (unknowns: the parasitic coordinates and every joint variable) follows the branch
//! of home by continuation along the straight segment of the inputs. Rates come from
//! the same Jacobian: `J·θ̇ − V_par·ẋ_par = V_in·ẋ_in`, and with the columns' drift
//! `ξ̇_k = [V_(k−1), ξ_k]` (the Lie bracket with the twist of the body before) the
//! accelerations.

use nalgebra::{DMatrix, Matrix3, Matrix6, Rotation3, Vector3, Vector6};

use clearance_model::custom::{BodySpec, JointType, Limb};

type V3 = Vector3<f64>;

/// A rigid motion `x ↦ r·x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    pub r: Matrix3<f64>,
    pub t: V3,
}

impl Rigid {
    pub const IDENTITY: Rigid =
        Rigid { r: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), t: V3::new(0.0, 0.0, 0.0) };

    pub fn apply(&self, x: &V3) -> V3 {
        self.r * x + self.t
    }

    pub fn then(&self, other: &Rigid) -> Rigid {
        // self ∘ other: apply `other` first.
        Rigid { r: self.r * other.r, t: self.r * other.t + self.t }
    }

    pub fn inverse(&self) -> Rigid {
        let rt = self.r.transpose();
        Rigid { r: rt, t: -(rt * self.t) }
    }

    /// The rotation `r` about the point `c`.
    pub fn about(c: &V3, r: Matrix3<f64>) -> Rigid {
        Rigid { r, t: c - r * c }
    }

    /// A spatial screw `[ω; v_O]` moved by this motion (the adjoint).
    pub fn screw(&self, s: &Vector6<f64>) -> Vector6<f64> {
        let w = self.r * s.fixed_rows::<3>(0);
        let v = self.r * s.fixed_rows::<3>(3) + self.t.cross(&w);
        Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z)
    }
}

/// `R = R_y(θ)·R_x(ψ)·R_z(φ)` of docs/model.md §1.
pub fn orientation(phi: f64, psi: f64, theta: f64) -> Matrix3<f64> {
    let ry = Rotation3::from_axis_angle(&V3::y_axis(), theta);
    let rx = Rotation3::from_axis_angle(&V3::x_axis(), psi);
    let rz = Rotation3::from_axis_angle(&V3::z_axis(), phi);
    (ry * rx * rz).into_inner()
}

/// The platform's placement at pose `c = (x, y, z, φ, ψ, θ)`.
pub fn placement(c: &[f64; 6]) -> Rigid {
    Rigid { r: orientation(c[3], c[4], c[5]), t: V3::new(c[0], c[1], c[2]) }
}

/// The rotation of angle `|v|` about `v`.
pub fn exp_so3(v: &V3) -> Matrix3<f64> {
    Rotation3::new(*v).into_inner()
}

fn rotation_screw(axis: &V3, c: &V3) -> Vector6<f64> {
    let v = c.cross(axis);
    Vector6::new(axis.x, axis.y, axis.z, v.x, v.y, v.z)
}

fn translation_screw(d: &V3) -> Vector6<f64> {
    Vector6::new(0.0, 0.0, 0.0, d.x, d.y, d.z)
}

/// `[a, b]` for spatial twists: the rate of change of `b` carried by a body moving with `a`.
pub fn bracket(a: &Vector6<f64>, b: &Vector6<f64>) -> Vector6<f64> {
    let (wa, va) = (a.fixed_rows::<3>(0).into_owned(), a.fixed_rows::<3>(3).into_owned());
    let (wb, vb) = (b.fixed_rows::<3>(0).into_owned(), b.fixed_rows::<3>(3).into_owned());
    let w = wa.cross(&wb);
    let v = wa.cross(&vb) - wb.cross(&va);
    Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z)
}

/// One joint at home, with unit axes.
#[derive(Clone, Debug)]
pub struct JointGeom {
    pub joint: JointType,
    pub name: String,
    pub actuated: bool,
    pub centre: V3,
    /// R: `a`; P: `d`; U: `a1` (zero for S).
    pub axis: V3,
    /// U: `a2` (zero otherwise).
    pub axis2: V3,
    pub range: Option<(f64, f64)>,
}

impl JointGeom {
    /// Variables: R, P 1; U 2; S 3.
    pub fn dof(&self) -> usize {
        match self.joint {
            JointType::R | JointType::P => 1,
            JointType::U => 2,
            JointType::S => 3,
        }
    }
}

/// A body at home: mass, centre of mass and inertia about it in world axes.
#[derive(Clone, Debug)]
pub struct BodyGeom {
    pub mass: f64,
    pub com: V3,
    pub inertia: Matrix3<f64>,
}

/// One limb at home.
#[derive(Clone, Debug)]
pub struct LimbGeom {
    pub joints: Vec<JointGeom>,
    /// `joints − 1`: body `b` lies between joints `b` and `b + 1`.
    pub bodies: Vec<BodyGeom>,
}

impl LimbGeom {
    pub fn dof(&self) -> usize {
        self.joints.iter().map(JointGeom::dof).sum()
    }
}

/// A custom mechanism's geometry at home (docs/model.md §12.1).
#[derive(Clone, Debug)]
pub struct CustomGeometry {
    /// Indices of the inputs among `x, y, z, φ, ψ, θ`, in that order.
    pub inputs: Vec<usize>,
    /// The others, parasitic.
    pub parasitic: Vec<usize>,
    pub home: [f64; 6],
    pub limbs: Vec<LimbGeom>,
    /// A length scale (m): the largest distance of a joint from P at home.
    pub length: f64,
}

fn v3(a: [f64; 3]) -> V3 {
    V3::new(a[0], a[1], a[2])
}

fn body_geom(spec: &BodySpec, from: &V3, to: &V3) -> BodyGeom {
    let com = spec.com.map(v3).unwrap_or((from + to) / 2.0);
    let inertia = match spec.inertia {
        Some(i) => Matrix3::from_fn(|r, c| i[r][c]),
        None => {
            let seg = to - from;
            let l = seg.norm();
            if l == 0.0 {
                Matrix3::zeros()
            } else {
                let u = seg / l;
                (Matrix3::identity() - u * u.transpose()) * (spec.mass * l * l / 12.0)
            }
        }
    };
    BodyGeom { mass: spec.mass, com, inertia }
}

impl CustomGeometry {
    /// The geometry of an expanded, checked description.
    pub fn new(inputs: &[usize], home: [f64; 6], limbs: &[Limb]) -> Self {
        let limbs: Vec<LimbGeom> = limbs
            .iter()
            .map(|l| {
                let joints: Vec<JointGeom> = l
                    .joints
                    .iter()
                    .map(|j| {
                        let (axis, axis2) = match (j.axis, j.axes) {
                            (Some(a), _) => (v3(a).normalize(), V3::zeros()),
                            (None, Some([a1, a2])) => (v3(a1).normalize(), v3(a2).normalize()),
                            _ => (V3::zeros(), V3::zeros()),
                        };
                        JointGeom {
                            joint: j.joint,
                            name: j.name(),
                            actuated: j.actuated,
                            centre: v3(j.at),
                            axis,
                            axis2,
                            range: j.range.map(|[lo, hi]| (lo, hi)),
                        }
                    })
                    .collect();
                let bodies = l
                    .bodies
                    .iter()
                    .enumerate()
                    .map(|(b, spec)| body_geom(spec, &joints[b].centre, &joints[b + 1].centre))
                    .collect();
                LimbGeom { joints, bodies }
            })
            .collect();
        let p = V3::new(home[0], home[1], home[2]);
        let length = limbs.iter().flat_map(|l| &l.joints).map(|j| (j.centre - p).norm()).fold(0.0, f64::max).max(1e-3);
        let parasitic = (0..6).filter(|k| !inputs.contains(k)).collect();
        Self { inputs: inputs.to_vec(), parasitic, home, limbs, length }
    }

    /// The default platform inertia's radius: the mean distance from P, in the
    /// platform's plane at home, of the platform-side joints' centres.
    pub fn platform_radius(&self) -> f64 {
        let home = placement(&self.home);
        let w = home.r.column(2).into_owned();
        let p = home.t;
        let n = self.limbs.len().max(1) as f64;
        self.limbs
            .iter()
            .filter_map(|l| l.joints.last())
            .map(|j| {
                let d = j.centre - p;
                (d - w * w.dot(&d)).norm()
            })
            .sum::<f64>()
            / n
    }
}

/// The state of one joint: R, P one value; U two; S a rotation matrix (its motion
/// about the centre at home).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointState {
    Scalar(f64),
    Pair(f64, f64),
    Ball(Matrix3<f64>),
}

impl JointState {
    fn home(j: &JointGeom) -> Self {
        match j.joint {
            JointType::R | JointType::P => Self::Scalar(0.0),
            JointType::U => Self::Pair(0.0, 0.0),
            JointType::S => Self::Ball(Matrix3::identity()),
        }
    }

    /// Adds the increments of the joint's columns.
    fn step(&mut self, d: &[f64]) {
        match self {
            Self::Scalar(v) => *v += d[0],
            Self::Pair(a, b) => {
                *a += d[0];
                *b += d[1];
            }
            Self::Ball(r) => *r = exp_so3(&V3::new(d[0], d[1], d[2])) * *r,
        }
    }

    /// The scalar variable of an R or P joint.
    pub fn value(&self) -> f64 {
        match self {
            Self::Scalar(v) => *v,
            _ => f64::NAN,
        }
    }
}

/// One joint at a pose: its current centre and axes, and its columns' screws.
#[derive(Clone, Debug, Default)]
pub struct PosedJoint {
    pub centre: V3,
    pub axis: V3,
    pub axis2: V3,
    /// `n = a1 × a2` for a U joint (current), else zero.
    pub normal: V3,
    /// The columns' spatial screws, at the pose.
    pub columns: Screws,
}

/// A joint's columns at a pose: one to three spatial screws, held in place.
pub type Screws = Few<Vector6<f64>>;

/// At most three items held in place (a joint's columns; a joint group's admissible set
/// and its responses, `clearance_solver::custom`): a pose asks for them joint by joint
/// and group by group, without allocating.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Few<T> {
    items: [T; 3],
    n: usize,
}

impl<T: Copy + Default> Few<T> {
    /// The items of `items` (at most three).
    pub fn of(items: &[T]) -> Self {
        let mut out = Self { items: [T::default(); 3], n: items.len() };
        out.items[..items.len()].copy_from_slice(items);
        out
    }

    /// `f` of each item, in order.
    pub fn map<U: Copy + Default>(&self, f: impl Fn(&T) -> U) -> Few<U> {
        let mut out = Few { items: [U::default(); 3], n: self.n };
        for (o, i) in out.items.iter_mut().zip(self.iter()) {
            *o = f(i);
        }
        out
    }
}

impl<T> std::ops::Deref for Few<T> {
    type Target = [T];

    fn deref(&self) -> &[T] {
        &self.items[..self.n]
    }
}

impl<'a, T> IntoIterator for &'a Few<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.items[..self.n].iter()
    }
}

/// One body at a pose.
#[derive(Clone, Debug, Default)]
pub struct PosedBody {
    /// Its displacement from home.
    pub motion: Option<Rigid>,
    pub com: V3,
    pub inertia: Matrix3<f64>,
    /// Spatial twist and its time derivative (zero in statics).
    pub twist: Vector6<f64>,
    pub accel: Vector6<f64>,
}

/// The mechanism solved at one pose.
#[derive(Clone, Debug)]
pub struct CustomPosture {
    /// `x, y, z, φ, ψ, θ` (inputs and parasitic).
    pub coords: [f64; 6],
    pub platform: Rigid,
    /// Platform twist and its derivative.
    pub twist: Vector6<f64>,
    pub accel: Vector6<f64>,
    pub joints: Vec<Vec<PosedJoint>>,
    pub bodies: Vec<Vec<PosedBody>>,
    pub states: Vec<Vec<JointState>>,
}

impl CustomPosture {
    /// The actuated joints' variables, in limb order (from home).
    pub fn actuators(&self, geom: &CustomGeometry) -> Vec<f64> {
        let mut out = Vec::new();
        for (l, limb) in geom.limbs.iter().enumerate() {
            for (j, joint) in limb.joints.iter().enumerate() {
                if joint.actuated {
                    out.push(self.states[l][j].value());
                }
            }
        }
        out
    }
}

/// Why a pose has no configuration on the branch of home.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unsolved {
    /// Continuation from home failed (the branch ends, or turns back).
    Unreachable,
    /// A joint left its range; the platform's coordinates are still known.
    OutOfRange([f64; 6]),
}

/// One joint crossed at its state: its columns' screws at the pose (at most three),
/// its current centre and axes.
struct Crossed {
    columns: [Vector6<f64>; 3],
    n: usize,
    centre: V3,
    axis: V3,
    axis2: V3,
}

/// Crosses joint `j` at state `s`: `g`, the displacement of the body before it, becomes
/// that of the body after it.
fn cross(j: &JointGeom, s: &JointState, g: &mut Rigid) -> Crossed {
    let mut c = Crossed {
        columns: [Vector6::zeros(); 3],
        n: 0,
        centre: g.apply(&j.centre),
        axis: V3::zeros(),
        axis2: V3::zeros(),
    };
    match (j.joint, s) {
        (JointType::R, JointState::Scalar(v)) => {
            c.axis = g.r * j.axis;
            c.columns[0] = g.screw(&rotation_screw(&j.axis, &j.centre));
            c.n = 1;
            *g = g.then(&Rigid::about(&j.centre, exp_so3(&(j.axis * *v))));
        }
        (JointType::P, JointState::Scalar(v)) => {
            c.axis = g.r * j.axis;
            c.columns[0] = g.screw(&translation_screw(&j.axis));
            c.n = 1;
            *g = g.then(&Rigid { r: Matrix3::identity(), t: j.axis * *v });
            // The bearing's centre travels with the sliding part.
            c.centre = g.apply(&j.centre);
        }
        (JointType::U, JointState::Pair(a, b)) => {
            c.axis = g.r * j.axis;
            c.columns[0] = g.screw(&rotation_screw(&j.axis, &j.centre));
            *g = g.then(&Rigid::about(&j.centre, exp_so3(&(j.axis * *a))));
            c.axis2 = g.r * j.axis2;
            c.columns[1] = g.screw(&rotation_screw(&j.axis2, &j.centre));
            c.n = 2;
            *g = g.then(&Rigid::about(&j.centre, exp_so3(&(j.axis2 * *b))));
        }
        (JointType::S, JointState::Ball(r)) => {
            for k in 0..3 {
                c.columns[k] = g.screw(&rotation_screw(&V3::ith(k, 1.0), &j.centre));
            }
            c.n = 3;
            *g = g.then(&Rigid::about(&j.centre, *r));
        }
        _ => unreachable!("a joint's state matches its type"),
    }
    c
}

/// The displacement of each body of a limb and the columns' screws at `states`.
fn chain(limb: &LimbGeom, states: &[JointState]) -> (Vec<Rigid>, Vec<PosedJoint>) {
    let mut g = Rigid::IDENTITY;
    let mut bodies = Vec::with_capacity(limb.joints.len());
    let mut joints = Vec::with_capacity(limb.joints.len());
    for (j, s) in limb.joints.iter().zip(states) {
        let c = cross(j, s, &mut g);
        joints.push(posed(j, &c.centre, &c.axis, &c.axis2, &c.columns[..c.n]));
        bodies.push(g);
    }
    (bodies, joints)
}

/// Joint `j` at a pose, from what crossing it gave: its centre, axes and columns (a U
/// joint's normal `a1 × a2` from its two axes).
fn posed(j: &JointGeom, centre: &V3, axis: &V3, axis2: &V3, columns: &[Vector6<f64>]) -> PosedJoint {
    let normal = if j.joint == JointType::U { axis.cross(axis2) } else { V3::zeros() };
    PosedJoint { centre: *centre, axis: *axis, axis2: *axis2, normal, columns: Screws::of(columns) }
}

/// The displacement of a limb's last body and its columns (in `columns`, at most six:
/// a limb of more freedoms is idle and refused), without allocating. `None` past six.
/// What crossing each joint gave is kept in `crossed`, from which [`chain`]'s result is
/// put together without crossing the joints again ([`Crossing::chain`]).
fn closure(
    limb: &LimbGeom,
    states: &[JointState],
    columns: &mut [Vector6<f64>; 6],
    crossed: &mut [Crossing; 6],
) -> Option<(Rigid, usize)> {
    let mut g = Rigid::IDENTITY;
    let mut n = 0;
    for ((j, s), kept) in limb.joints.iter().zip(states).zip(crossed.iter_mut()) {
        let c = cross(j, s, &mut g);
        if n + c.n > 6 {
            return None;
        }
        columns[n..n + c.n].copy_from_slice(&c.columns[..c.n]);
        // Field by field: the compiler moves these in registers, where the whole
        // struct at once went through `memcpy`.
        kept.body.r = g.r;
        kept.body.t = g.t;
        kept.centre = c.centre;
        kept.axis = c.axis;
        kept.axis2 = c.axis2;
        kept.n = c.n;
        n += c.n;
    }
    // Six columns come from six joints at most, so every joint was kept.
    (limb.joints.len() <= 6).then_some((g, n))
}

/// One joint as [`closure`] crossed it: the displacement of the body after it, its
/// centre and axes at the pose, and how many columns it gave.
#[derive(Clone, Copy, Debug)]
struct Crossing {
    body: Rigid,
    centre: V3,
    axis: V3,
    axis2: V3,
    n: usize,
}

impl Default for Crossing {
    fn default() -> Self {
        Self { body: Rigid::IDENTITY, centre: V3::zeros(), axis: V3::zeros(), axis2: V3::zeros(), n: 0 }
    }
}

impl Crossing {
    /// [`chain`]'s result for a limb whose joints [`closure`] crossed (`crossed`, in
    /// order) with the columns `columns`: the same numbers, bit for bit.
    fn chain(limb: &LimbGeom, crossed: &[Crossing; 6], columns: &[Vector6<f64>; 6]) -> (Vec<Rigid>, Vec<PosedJoint>) {
        let mut bodies = Vec::with_capacity(limb.joints.len());
        let mut joints = Vec::with_capacity(limb.joints.len());
        let mut at = 0;
        for (j, c) in limb.joints.iter().zip(crossed) {
            joints.push(posed(j, &c.centre, &c.axis, &c.axis2, &columns[at..at + c.n]));
            bodies.push(c.body);
            at += c.n;
        }
        (bodies, joints)
    }
}

/// The closure's Newton matrix `[J_1 … J_L | −V_par]` (limb l's rows hold its columns
/// `J_l` and minus the parasitic coordinates' screws), factored limb by limb: with
/// `J_l = Q_l·[R_l; 0]`, the last `6 − n_l` rows of `Q_lᵀ` eliminate the limb's own
/// variables, and stacked over the limbs they leave a `k × k` system for the `k`
/// parasitic coordinates (`Σ(6 − n_l) = k` when the counts of §12.3 hold). Each solve
/// then costs a few reflections of 6-vectors instead of a dense `6L × 6L`
/// factorisation. With no parasitic coordinate the limbs are independent, each `J_l`
/// square: it is LU-factored instead (half the work of the QR).
struct Factored {
    k: usize,
    limbs: Vec<LimbFactor>,
    /// The parasitic coordinates' system, padded to 6 × 6 with the identity.
    reduced: Option<nalgebra::LU<f64, nalgebra::U6, nalgebra::U6>>,
}

/// Per limb: `Q_l` as its reflectors, `R_l` (upper triangle), `Q_lᵀ·(−V_par)`.
#[derive(Clone, Copy)]
struct LimbFactor {
    q: Reflectors,
    r: Matrix6<f64>,
    qv: Matrix6<f64>,
    /// With no parasitic coordinate: the limb's square `J_l`, LU-factored instead.
    lu: Lu6,
}

/// A 6 × 6 matrix factored by Gaussian elimination with partial pivoting, `P·A = L·U`
/// (rows, in place: `L` below the diagonal with a unit diagonal, `U` on and above).
#[derive(Clone, Copy, Debug, Default)]
struct Lu6 {
    m: [[f64; 6]; 6],
    perm: [usize; 6],
}

impl Lu6 {
    /// Factors the matrix of columns `cols`; `false` where a pivot is zero or not finite.
    fn factor(&mut self, cols: &[Vector6<f64>; 6]) -> bool {
        let m = &mut self.m;
        for (c, col) in cols.iter().enumerate() {
            for r in 0..6 {
                m[r][c] = col[r];
            }
        }
        self.perm = [0, 1, 2, 3, 4, 5];
        let perm = &mut self.perm;
        eliminate::<0>(m, perm)
            && eliminate::<1>(m, perm)
            && eliminate::<2>(m, perm)
            && eliminate::<3>(m, perm)
            && eliminate::<4>(m, perm)
            && eliminate::<5>(m, perm)
    }

    /// `A⁻¹·b` into `x`.
    fn solve(&self, b: &Vector6<f64>, x: &mut [f64]) {
        let m = &self.m;
        let mut y = [0.0; 6];
        for i in 0..6 {
            let mut t = b[self.perm[i]];
            for j in 0..i {
                t -= m[i][j] * y[j];
            }
            y[i] = t;
        }
        for i in (0..6).rev() {
            let mut t = y[i];
            for j in i + 1..6 {
                t -= m[i][j] * x[j];
            }
            x[i] = t / m[i][i];
        }
    }
}

/// Step `C` of [`Lu6::factor`]: the pivot of column `C` (the largest magnitude, the last
/// of equals, as `Iterator::max_by` picks it), its row exchanged into place, and the
/// rows below it eliminated. `false` where the pivot is zero or not finite. A constant
/// column lets the compiler unroll the loops.
fn eliminate<const C: usize>(m: &mut [[f64; 6]; 6], perm: &mut [usize; 6]) -> bool {
    let mut p = C;
    for r in C + 1..6 {
        if m[r][C].abs().total_cmp(&m[p][C].abs()).is_ge() {
            p = r;
        }
    }
    m.swap(C, p);
    perm.swap(C, p);
    let pivot = m[C][C];
    if pivot == 0.0 || !pivot.is_finite() {
        return false;
    }
    let row = m[C];
    for r in m.iter_mut().skip(C + 1) {
        let f = r[C] / pivot;
        r[C] = f;
        for k in C + 1..6 {
            r[k] -= f * row[k];
        }
    }
    true
}

impl Factored {
    /// Room for `limbs` limbs and `k` parasitic coordinates, to be [`refactor`](Self::refactor)ed.
    fn new(k: usize, limbs: usize) -> Self {
        let empty =
            LimbFactor { q: Reflectors::default(), r: Matrix6::zeros(), qv: Matrix6::zeros(), lu: Lu6::default() };
        Self { k, limbs: vec![empty; limbs], reduced: None }
    }

    /// Factors the limbs' columns in place; `false` where a limb's columns are
    /// dependent or the counts do not square the system.
    fn refactor(&mut self, parasitic: &[Vector6<f64>], columns: &[[Vector6<f64>; 6]], dofs: &[usize]) -> bool {
        let k = self.k;
        if k == 0 {
            // Every limb square (the counts of §12.3): each solved alone.
            return self
                .limbs
                .iter_mut()
                .zip(columns)
                .zip(dofs)
                .all(|((limb, cols), &n)| n == 6 && limb.lu.factor(cols));
        }
        let mut reduced = Matrix6::identity();
        let mut row = 0;
        for ((limb, cols), &n) in self.limbs.iter_mut().zip(columns).zip(dofs) {
            let a = &mut limb.r;
            a.fill(0.0);
            for (c, s) in cols[..n].iter().enumerate() {
                a.set_column(c, s);
            }
            if !householder_into(a, n, &mut limb.q) || row + 6 - n > k {
                return false;
            }
            for (c, s) in parasitic.iter().enumerate() {
                limb.qv.set_column(c, &limb.q.apply_qt(&(-s)));
            }
            for r in n..6 {
                for c in 0..k {
                    reduced[(row, c)] = limb.qv[(r, c)];
                }
                row += 1;
            }
        }
        if row != k {
            return false;
        }
        self.reduced = Some(reduced.lu());
        true
    }

    /// Solves `J_l·θ_l − V_par·x_par = b_l` for every limb l: `out` gets `x_par` then each
    /// limb's `θ_l`, in order. `false` where the system is singular.
    fn solve(&self, b: impl Fn(usize) -> Vector6<f64>, out: &mut [f64]) -> bool {
        if self.k == 0 {
            for (l, (limb, x)) in self.limbs.iter().zip(out.chunks_exact_mut(6)).enumerate() {
                limb.lu.solve(&b(l), x);
            }
            return out.iter().all(|v| v.is_finite());
        }
        let mut x = Vector6::zeros();
        if let Some(lu) = &self.reduced {
            let mut y = Vector6::zeros();
            let mut row = 0;
            for (l, limb) in self.limbs.iter().enumerate() {
                let cl = limb.q.apply_qt(&b(l));
                for r in limb.q.n..6 {
                    y[row] = cl[r];
                    row += 1;
                }
            }
            match lu.solve(&y) {
                Some(s) => x = s,
                None => return false,
            }
        }
        out[..self.k].copy_from_slice(&x.as_slice()[..self.k]);
        let mut at = self.k;
        for (l, limb) in self.limbs.iter().enumerate() {
            let n = limb.q.n;
            let t = limb.q.apply_qt(&b(l)) - limb.qv * x;
            let r = &limb.r;
            for i in (0..n).rev() {
                let mut s = t[i];
                for j in i + 1..n {
                    s -= r[(i, j)] * out[at + j];
                }
                out[at + i] = s / r[(i, i)];
            }
            at += n;
        }
        out.iter().all(|v| v.is_finite())
    }
}

/// The orthogonal factor `Q` of a Householder QR in R⁶, kept as its reflectors
/// `H_j = I − β_j·v_j·v_jᵀ` (`Q = H_0·H_1 ⋯ H_(n−1)`): applying them to a vector costs
/// a few dozen products, where forming `Qᵀ` cost hundreds.
#[derive(Clone, Copy, Debug, Default)]
pub struct Reflectors {
    /// The columns factored.
    pub n: usize,
    /// `v_j`, zero above row `j`.
    v: [Vector6<f64>; 6],
    beta: [f64; 6],
}

impl Reflectors {
    /// `Qᵀ·x`.
    pub fn apply_qt(&self, x: &Vector6<f64>) -> Vector6<f64> {
        let mut y = *x;
        for j in 0..self.n {
            y.axpy(-self.beta[j] * self.v[j].dot(&y), &self.v[j], 1.0);
        }
        y
    }

    /// `Q·x`.
    pub fn apply_q(&self, x: &Vector6<f64>) -> Vector6<f64> {
        let mut y = *x;
        for j in (0..self.n).rev() {
            y.axpy(-self.beta[j] * self.v[j].dot(&y), &self.v[j], 1.0);
        }
        y
    }

    /// Row `r` of `Qᵀ` (that is `Q·e_r`); rows `n..6` span the complement of the columns.
    pub fn qt_row(&self, r: usize) -> Vector6<f64> {
        self.apply_q(&Vector6::ith(r, 1.0))
    }
}

/// Householder QR of the first `n` columns of `a`: `a` becomes `R` (upper triangle),
/// and the result is `Q` as its reflectors (the last `6 − n` rows of `Qᵀ` span the
/// complement of the columns). `None` where a column is dependent on those before it
/// (exactly, or not finite).
pub fn householder(a: &mut Matrix6<f64>, n: usize) -> Option<Reflectors> {
    let mut q = Reflectors::default();
    householder_into(a, n, &mut q).then_some(q)
}

/// [`householder`] into `q`; `false` where a column is dependent.
fn householder_into(a: &mut Matrix6<f64>, n: usize, q: &mut Reflectors) -> bool {
    q.n = n;
    for j in 0..n {
        let mut v: Vector6<f64> = a.column(j).into_owned();
        for x in v.iter_mut().take(j) {
            *x = 0.0;
        }
        let norm = v.norm();
        if !(norm > 0.0 && norm.is_finite()) {
            return false;
        }
        v[j] -= if v[j] > 0.0 { -norm } else { norm };
        let beta = 2.0 / v.norm_squared();
        for c in j..n {
            let mut col = a.column_mut(c);
            let f = beta * v.dot(&col);
            col.axpy(-f, &v, 1.0);
        }
        (q.v[j], q.beta[j]) = (v, beta);
    }
    true
}

/// The spatial twists of the platform per unit rate of each coordinate at `c`.
fn coordinate_screws(c: &[f64; 6]) -> [Vector6<f64>; 6] {
    let p = V3::new(c[0], c[1], c[2]);
    let ry = Rotation3::from_axis_angle(&V3::y_axis(), c[5]).into_inner();
    let rx = Rotation3::from_axis_angle(&V3::x_axis(), c[4]).into_inner();
    let w = [ry * rx * V3::z(), ry * V3::x(), V3::y()];
    let ang = |w: V3| {
        let v = p.cross(&w);
        Vector6::new(w.x, w.y, w.z, v.x, v.y, v.z)
    };
    [
        translation_screw(&V3::x()),
        translation_screw(&V3::y()),
        translation_screw(&V3::z()),
        ang(w[0]),
        ang(w[1]),
        ang(w[2]),
    ]
}

/// The rate of change of [`coordinate_screws`] along `cd` (coordinate rates), applied to `cd`.
fn coordinate_drift(c: &[f64; 6], cd: &[f64; 6]) -> Vector6<f64> {
    let p = V3::new(c[0], c[1], c[2]);
    let pd = V3::new(cd[0], cd[1], cd[2]);
    let ry = Rotation3::from_axis_angle(&V3::y_axis(), c[5]).into_inner();
    let rx = Rotation3::from_axis_angle(&V3::x_axis(), c[4]).into_inner();
    let (wphi, wpsi, wth) = (ry * rx * V3::z(), ry * V3::x(), V3::y());
    // dω_φ/dt = (θ̇ ŷ + ψ̇ ω_ψ) × ω_φ, dω_ψ/dt = θ̇ ŷ × ω_ψ, ω_θ fixed.
    let dphi = (wth * cd[5] + wpsi * cd[4]).cross(&wphi);
    let dpsi = (wth * cd[5]).cross(&wpsi);
    let dw = dphi * cd[3] + dpsi * cd[4];
    let w = wphi * cd[3] + wpsi * cd[4] + wth * cd[5];
    let dv = pd.cross(&w) + p.cross(&dw);
    Vector6::new(dw.x, dw.y, dw.z, dv.x, dv.y, dv.z)
}

/// A residual twist of `e = g·d⁻¹`: `[axial(e_r); e_t]`, zero exactly at closure.
fn residual(g: &Rigid, d: &Rigid) -> Vector6<f64> {
    let e = g.then(&d.inverse());
    let r = e.r;
    let w = V3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]) / 2.0;
    Vector6::new(w.x, w.y, w.z, e.t.x, e.t.y, e.t.z)
}

/// The Newton matrix at `(coords, states)`: per limb, its columns, and minus the
/// parasitic coordinates' screws.
fn jacobian(geom: &CustomGeometry, coords: &[f64; 6], joints: &[Vec<PosedJoint>]) -> DMatrix<f64> {
    let n = 6 * geom.limbs.len();
    let mut m = DMatrix::zeros(n, n);
    let screws = coordinate_screws(coords);
    let mut col = geom.parasitic.len();
    for (l, pj) in joints.iter().enumerate() {
        for (k, &c) in geom.parasitic.iter().enumerate() {
            m.fixed_view_mut::<6, 1>(6 * l, k).copy_from(&(-screws[c]));
        }
        for s in pj.iter().flat_map(|j| &j.columns) {
            m.fixed_view_mut::<6, 1>(6 * l, col).copy_from(s);
            col += 1;
        }
    }
    m
}

/// Newton iterations at most per continuation step.
const NEWTON_STEPS: usize = 12;
/// A Newton iteration whose residual (as [`newton`] measures it) grows while above
/// this has failed.
const DIVERGING: f64 = 1e-8;
/// The largest change of an angle (rad) or of a length (in units of the mechanism's
/// length scale) in one continuation step: beyond, the step is halved, so that the
/// continuation does not jump branch.
const MAX_STEP_CHANGE: f64 = 0.25;
/// Continuation steps at most (halvings included).
const MAX_STEPS: usize = 200;

/// The parasitic coordinates' screws at `coords`.
fn parasitic_screws(geom: &CustomGeometry, coords: &[f64; 6]) -> [Vector6<f64>; 6] {
    let screws = coordinate_screws(coords);
    let mut parasitic = [Vector6::zeros(); 6];
    for (i, &c) in geom.parasitic.iter().enumerate() {
        parasitic[i] = screws[c];
    }
    parasitic
}

/// The factored Newton matrix at `coords` with the limbs' columns.
fn factor(geom: &CustomGeometry, coords: &[f64; 6], columns: &[[Vector6<f64>; 6]], dofs: &[usize]) -> Option<Factored> {
    let k = geom.parasitic.len();
    let mut f = Factored::new(k, columns.len());
    f.refactor(&parasitic_screws(geom, coords)[..k], columns, dofs).then_some(f)
}

/// Newton's buffers for one geometry's counts, kept per thread: a pose solves its closure
/// a few times, and a grid has millions of poses.
struct NewtonWork {
    columns: Vec<[Vector6<f64>; 6]>,
    /// Per limb, its joints as the last closure evaluated crossed them.
    crossed: Vec<[Crossing; 6]>,
    /// Whether the last Newton solve converged: `columns` and `crossed` are then those
    /// of the configuration it returned.
    converged: bool,
    dofs: Vec<usize>,
    r: Vec<Vector6<f64>>,
    dx: Vec<f64>,
    f: Factored,
}

impl NewtonWork {
    fn new(k: usize, limbs: usize, unknowns: usize) -> Self {
        Self {
            columns: vec![[Vector6::zeros(); 6]; limbs],
            crossed: vec![[Crossing::default(); 6]; limbs],
            converged: false,
            dofs: vec![0; limbs],
            r: vec![Vector6::zeros(); limbs],
            dx: vec![0.0; unknowns],
            f: Factored::new(k, limbs),
        }
    }

    /// Whether these buffers are sized for the counts (else fresh ones are: a factor's
    /// unused columns must be zero).
    fn fits(&self, k: usize, limbs: usize, unknowns: usize) -> bool {
        self.f.k == k && self.f.limbs.len() == limbs && self.dx.len() == unknowns
    }
}

thread_local! {
    static NEWTON_WORK: std::cell::RefCell<Option<NewtonWork>> = const { std::cell::RefCell::new(None) };
}

/// Solves the closure at `coords` (the inputs set, the parasitic ones a first guess)
/// by Newton from `states`; returns the increments' largest scaled size.
fn newton(geom: &CustomGeometry, coords: &mut [f64; 6], states: &mut [Vec<JointState>]) -> Option<f64> {
    let nl = geom.limbs.len();
    let k = geom.parasitic.len();
    let unknowns = k + geom.limbs.iter().map(LimbGeom::dof).sum::<usize>();
    NEWTON_WORK.with(|cell| {
        let mut cell = cell.borrow_mut();
        let work = match cell.take() {
            Some(w) if w.fits(k, nl, unknowns) => w,
            _ => NewtonWork::new(k, nl, unknowns),
        };
        let work = cell.insert(work);
        newton_in(geom, coords, states, work)
    })
}

fn newton_in(
    geom: &CustomGeometry,
    coords: &mut [f64; 6],
    states: &mut [Vec<JointState>],
    work: &mut NewtonWork,
) -> Option<f64> {
    let scale = geom.length;
    let mut moved = 0.0f64;
    let home = placement(&geom.home).inverse();
    let k = geom.parasitic.len();
    let NewtonWork { columns, crossed, converged, dofs, r, dx, f } = work;
    *converged = false;
    let mut last = f64::INFINITY;
    for _ in 0..NEWTON_STEPS {
        let d = placement(coords).then(&home);
        let mut size = 0.0f64;
        for (l, limb) in geom.limbs.iter().enumerate() {
            let (g, n) = closure(limb, &states[l], &mut columns[l], &mut crossed[l])?;
            dofs[l] = n;
            r[l] = residual(&g, &d);
            for (i, v) in r[l].iter().enumerate() {
                size = size.max(if i < 3 { v.abs() } else { v.abs() / scale });
            }
        }
        if size < 1e-14 {
            *converged = true;
            return Some(moved);
        }
        // A residual that grows while far above round-off is not converging: the
        // caller halves its step (or, at a pose out of reach, gives up) without
        // spending the rest of the iterations on it.
        if size > last && size > DIVERGING {
            return None;
        }
        last = size;
        if !f.refactor(&parasitic_screws(geom, coords)[..k], columns, dofs) {
            return None;
        }
        if !f.solve(|l| -r[l], dx) {
            return None;
        }
        let mut i = 0;
        for &c in &geom.parasitic {
            let s = if c < 3 { scale } else { 1.0 };
            moved = moved.max(dx[i].abs() / s);
            coords[c] += dx[i];
            i += 1;
        }
        for (limb, st) in geom.limbs.iter().zip(states.iter_mut()) {
            for (j, s) in limb.joints.iter().zip(st.iter_mut()) {
                let n = j.dof();
                let sc = if j.joint == JointType::P { scale } else { 1.0 };
                for v in &dx[i..i + n] {
                    moved = moved.max(v.abs() / sc);
                }
                s.step(&dx[i..i + n]);
                i += n;
            }
        }
        if moved > 4.0 * MAX_STEP_CHANGE {
            return None;
        }
    }
    None
}

/// Whether the inputs determine the pose at home: the closure's Jacobian there is
/// well conditioned (docs/model.md §12.3).
pub fn determined_at_home(geom: &CustomGeometry) -> bool {
    let states: Vec<Vec<JointState>> =
        geom.limbs.iter().map(|l| l.joints.iter().map(JointState::home).collect()).collect();
    let joints: Vec<Vec<PosedJoint>> = geom.limbs.iter().zip(&states).map(|(l, s)| chain(l, s).1).collect();
    let m = jacobian(geom, &geom.home, &joints);
    let s = m.singular_values();
    let (hi, lo) = (s.max(), s.min());
    lo > 1e-10 * hi
}

/// A solved configuration: the coordinates `x, y, z, φ, ψ, θ` and every joint's state.
pub type Configuration = ([f64; 6], Vec<Vec<JointState>>);

/// The configuration at the inputs `target` (values of the inputs, in canonical
/// order) on the branch of home: continuation from home along the straight segment
/// of the inputs, each step solved by Newton and halved where Newton fails or the
/// configuration moves too far in one step. The same inputs give the same bits,
/// whatever pose came before.
pub fn solve_configuration(geom: &CustomGeometry, target: &[f64]) -> Result<Configuration, Unsolved> {
    solve_configuration_near(geom, target, None)
}

/// [`solve_configuration`], continued from a configuration `near` on the branch of home
/// where one Newton solve from it converges within one continuation step (docs/model.md
/// §12.2 allows a neighbouring pose); from home otherwise. The result is the same
/// configuration to round-off.
pub fn solve_configuration_near(
    geom: &CustomGeometry,
    target: &[f64],
    near: Option<&Configuration>,
) -> Result<Configuration, Unsolved> {
    let reached = near.and_then(|(coords, states)| {
        let mut c = *coords;
        for (i, &k) in geom.inputs.iter().enumerate() {
            c[k] = target[i];
        }
        let mut st = states.clone();
        match newton(geom, &mut c, &mut st) {
            Some(moved) if moved <= MAX_STEP_CHANGE => Some((c, st)),
            _ => None,
        }
    });
    let (coords, states) = match reached {
        Some(found) => found,
        None => continue_from_home(geom, target)?,
    };
    for (limb, st) in geom.limbs.iter().zip(&states) {
        for (j, s) in limb.joints.iter().zip(st) {
            if let (Some((lo, hi)), JointState::Scalar(v)) = (j.range, s)
                && !(lo..=hi).contains(v)
            {
                return Err(Unsolved::OutOfRange(coords));
            }
        }
    }
    Ok((coords, states))
}

fn continue_from_home(geom: &CustomGeometry, target: &[f64]) -> Result<Configuration, Unsolved> {
    let mut coords = geom.home;
    let mut states: Vec<Vec<JointState>> =
        geom.limbs.iter().map(|l| l.joints.iter().map(JointState::home).collect()).collect();
    let start: Vec<f64> = geom.inputs.iter().map(|&k| geom.home[k]).collect();
    let (mut s, mut h) = (0.0f64, 1.0f64);
    let mut steps = 0;
    while s < 1.0 {
        steps += 1;
        if steps > MAX_STEPS || h < 1e-6 {
            return Err(Unsolved::Unreachable);
        }
        let next = (s + h).min(1.0);
        let mut c = coords;
        for (i, &k) in geom.inputs.iter().enumerate() {
            c[k] = if next == 1.0 { target[i] } else { start[i] + next * (target[i] - start[i]) };
        }
        let mut st = states.clone();
        match newton(geom, &mut c, &mut st) {
            Some(moved) if moved <= MAX_STEP_CHANGE => {
                coords = c;
                states = st;
                s = next;
                h *= 2.0;
            }
            _ => h /= 2.0,
        }
    }
    Ok((coords, states))
}

/// The posture at `target` inputs, with rates: `rates = [ẋ_in, ẍ_in]` along a
/// trajectory (`None` in statics: every twist zero).
pub fn custom_posture(
    geom: &CustomGeometry,
    target: &[f64],
    rates: Option<(&[f64], &[f64])>,
) -> Result<CustomPosture, Unsolved> {
    custom_posture_near(geom, target, rates, None)
}

/// [`custom_posture`] continued from `near` (see [`solve_configuration_near`]).
pub fn custom_posture_near(
    geom: &CustomGeometry,
    target: &[f64],
    rates: Option<(&[f64], &[f64])>,
    near: Option<&Configuration>,
) -> Result<CustomPosture, Unsolved> {
    let (coords, states) = solve_configuration_near(geom, target, near)?;
    // The last Newton solve of this thread is the one that reached `states` (either
    // way `solve_configuration_near` goes, the accepted solve is its last): its closure
    // crossed every joint at them already.
    let chains = NEWTON_WORK.with(|cell| {
        let cell = cell.borrow();
        let work = cell.as_ref().filter(|w| w.converged && w.crossed.len() == geom.limbs.len())?;
        Some(
            geom.limbs
                .iter()
                .enumerate()
                .map(|(l, limb)| Crossing::chain(limb, &work.crossed[l], &work.columns[l]))
                .unzip(),
        )
    });
    Ok(match chains {
        Some((motions, joints)) => posture_of(geom, coords, states, rates, motions, joints),
        None => posture_at(geom, coords, states, rates),
    })
}

/// The posture of a solved configuration.
pub fn posture_at(
    geom: &CustomGeometry,
    coords: [f64; 6],
    states: Vec<Vec<JointState>>,
    rates: Option<(&[f64], &[f64])>,
) -> CustomPosture {
    let (motions, joints) = geom.limbs.iter().zip(&states).map(|(limb, st)| chain(limb, st)).unzip();
    posture_of(geom, coords, states, rates, motions, joints)
}

/// [`posture_at`] with every limb's [`chain`] at `states` given: its bodies'
/// displacements (`motions`) and its posed joints.
fn posture_of(
    geom: &CustomGeometry,
    coords: [f64; 6],
    states: Vec<Vec<JointState>>,
    rates: Option<(&[f64], &[f64])>,
    motions: Vec<Vec<Rigid>>,
    joints: Vec<Vec<PosedJoint>>,
) -> CustomPosture {
    let platform = placement(&coords);
    let n_par = geom.parasitic.len();
    let (mut twist, mut accel) = (Vector6::zeros(), Vector6::zeros());
    // In statics every rate is zero, and so is every body's twist and acceleration
    // (+0, as the products with zero rates give for the finite screws of a solved pose).
    let moving = rates.is_some();
    let per_column = || -> Vec<Vec<f64>> {
        if moving { geom.limbs.iter().map(|l| vec![0.0; l.dof()]).collect() } else { Vec::new() }
    };
    let (mut rates_of_columns, mut accels_of_columns) = (per_column(), per_column());
    if let Some((vel, acc)) = rates {
        let mut columns = vec![[Vector6::zeros(); 6]; geom.limbs.len()];
        let mut dofs = vec![0; geom.limbs.len()];
        for (l, pj) in joints.iter().enumerate() {
            for (c, s) in pj.iter().flat_map(|j| &j.columns).take(6).enumerate() {
                columns[l][c] = *s;
                dofs[l] = c + 1;
            }
        }
        let factored = factor(geom, &coords, &columns, &dofs);
        let total = n_par + dofs.iter().sum::<usize>();
        // A singular closure has no rates: zero, as before.
        let solve = |b: &dyn Fn(usize) -> Vector6<f64>| {
            let mut x = vec![0.0; total];
            if !factored.as_ref().is_some_and(|f| f.solve(b, &mut x)) {
                x.iter_mut().for_each(|v| *v = 0.0);
            }
            x
        };
        let screws = coordinate_screws(&coords);
        let mut cd = [0.0; 6];
        for (i, &k) in geom.inputs.iter().enumerate() {
            cd[k] = vel[i];
        }
        let input_twist: Vector6<f64> = geom.inputs.iter().map(|&k| screws[k] * cd[k]).sum();
        let x = solve(&|_| input_twist);
        for (i, &k) in geom.parasitic.iter().enumerate() {
            cd[k] = x[i];
        }
        let mut at = n_par;
        for rc in rates_of_columns.iter_mut() {
            for v in rc.iter_mut() {
                *v = x[at];
                at += 1;
            }
        }
        twist = (0..6).map(|k| screws[k] * cd[k]).sum();
        // Accelerations: J·θ̈ − V_par·ẍ_par = V_in·ẍ_in + V̇·ẋ − Σ [V_(k−1), ξ_k]·θ̇_k.
        let mut cdd = [0.0; 6];
        for (i, &k) in geom.inputs.iter().enumerate() {
            cdd[k] = acc[i];
        }
        let known: Vector6<f64> =
            geom.inputs.iter().map(|&k| screws[k] * cdd[k]).sum::<Vector6<f64>>() + coordinate_drift(&coords, &cd);
        let drifts: Vec<Vector6<f64>> =
            joints.iter().enumerate().map(|(l, pj)| column_drift(pj, &rates_of_columns[l])).collect();
        let y = solve(&|l| known - drifts[l]);
        for (i, &k) in geom.parasitic.iter().enumerate() {
            cdd[k] = y[i];
        }
        let mut at = n_par;
        for ac in accels_of_columns.iter_mut() {
            for v in ac.iter_mut() {
                *v = y[at];
                at += 1;
            }
        }
        accel = (0..6).map(|k| screws[k] * cdd[k]).sum::<Vector6<f64>>() + coordinate_drift(&coords, &cd);
    }
    let mut bodies = Vec::with_capacity(geom.limbs.len());
    for (l, limb) in geom.limbs.iter().enumerate() {
        let mut out = Vec::with_capacity(limb.bodies.len());
        let (mut v, mut a) = (Vector6::zeros(), Vector6::zeros());
        let mut col = 0;
        for (j, pj) in joints[l].iter().enumerate() {
            if moving {
                for s in &pj.columns {
                    let rate = rates_of_columns[l][col];
                    a += s * accels_of_columns[l][col] + bracket(&v, s) * rate;
                    v += s * rate;
                    col += 1;
                }
            }
            if let Some(body) = limb.bodies.get(j) {
                let g = motions[l][j];
                out.push(PosedBody {
                    motion: Some(g),
                    com: g.apply(&body.com),
                    inertia: g.r * body.inertia * g.r.transpose(),
                    twist: v,
                    accel: a,
                });
            }
        }
        bodies.push(out);
    }
    CustomPosture { coords, platform, twist, accel, joints, bodies, states }
}

/// `Σ_k [V_(k−1), ξ_k]·θ̇_k` for one limb, `V_(k−1)` the twist of the body before
/// column k.
fn column_drift(joints: &[PosedJoint], rates: &[f64]) -> Vector6<f64> {
    let (mut v, mut drift) = (Vector6::zeros(), Vector6::zeros());
    let mut k = 0;
    for j in joints {
        for s in &j.columns {
            drift += bracket(&v, s) * rates[k];
            v += s * rates[k];
            k += 1;
        }
    }
    drift
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The factorisation as first written (a pivot by `Iterator::max_by`, loops over
    /// ranges): the reference the unrolled [`eliminate`] steps must equal bit for bit.
    fn reference(cols: &[Vector6<f64>; 6]) -> Option<([[f64; 6]; 6], [usize; 6])> {
        let mut m = [[0.0; 6]; 6];
        for (c, col) in cols.iter().enumerate() {
            for r in 0..6 {
                m[r][c] = col[r];
            }
        }
        let mut perm = [0, 1, 2, 3, 4, 5];
        for c in 0..6 {
            let p = (c..6).max_by(|&a, &b| m[a][c].abs().total_cmp(&m[b][c].abs())).unwrap_or(c);
            m.swap(c, p);
            perm.swap(c, p);
            let pivot = m[c][c];
            if pivot == 0.0 || !pivot.is_finite() {
                return None;
            }
            let row = m[c];
            for r in m.iter_mut().skip(c + 1) {
                let f = r[c] / pivot;
                r[c] = f;
                for k in c + 1..6 {
                    r[k] -= f * row[k];
                }
            }
        }
        Some((m, perm))
    }

    #[test]
    fn lu6_is_the_reference_factorisation_and_solves() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..3000 {
            // Random columns; one in three with entries of equal magnitude (ties of the
            // pivot), one in ten with a zero column (no factorisation).
            let mut cols: [Vector6<f64>; 6] =
                std::array::from_fn(|_| Vector6::from_fn(|_, _| rng.random_range(-1.0..1.0)));
            if trial % 3 == 0 {
                for c in cols.iter_mut() {
                    for v in c.iter_mut() {
                        *v = if rng.random_bool(0.5) { 0.5 } else { -0.5 }
                            * if rng.random_bool(0.3) { 0.0 } else { 1.0 };
                    }
                }
            }
            if trial % 10 == 1 {
                cols[rng.random_range(0..6)] = Vector6::zeros();
            }
            let mut lu = Lu6::default();
            let ok = lu.factor(&cols);
            let expected = reference(&cols);
            assert_eq!(ok, expected.is_some(), "trial {trial}");
            let Some((m, perm)) = expected else { continue };
            assert_eq!(perm, lu.perm, "trial {trial}");
            let bits = |m: &[[f64; 6]; 6]| m.map(|row| row.map(f64::to_bits));
            assert_eq!(bits(&m), bits(&lu.m), "trial {trial}");
            // And it solves: A·x = b to round-off of the conditioning.
            let a = Matrix6::from_columns(&cols);
            let b = Vector6::from_fn(|_, _| rng.random_range(-1.0..1.0));
            let mut x = [0.0; 6];
            lu.solve(&b, &mut x);
            let x = Vector6::from_column_slice(&x);
            let Some(inv) = a.try_inverse() else { continue };
            let kappa = a.norm() * inv.norm();
            assert!((a * x - b).norm() <= 1e-13 * kappa * (a.norm() * x.norm() + b.norm()), "trial {trial}");
        }
    }
}
