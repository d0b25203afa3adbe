//! # clearance-solver
//!
//! The physics of one pose, after its nominal kinematics (`clearance-kinematics`):
//!
//! 1. [`equilibrium`]: Newton-Euler joint reactions, the 24 × 24 system `A·w = b`
//!    (docs/model.md §4), with gravity, point masses, an external wrench and, in dynamics,
//!    inertial terms. Solved by faer's partial-pivoting LU ([`LuSolver`]).
//! 2. [`takeup`]: how each clearance is taken up under those reactions (docs/model.md §5),
//!    with the contact margins.
//! 3. [`error_system`]: the 12 × 12 loop-closure system `J_P·Δq_P = J_Cl·Δq_Cl`
//!    (docs/model.md §6), one right-hand side per clearance kind, giving the pose error
//!    `ΔΓ = [Δα; Δp]` and its Euler-angle form.
//! 4. [`exact`]: the same take-up applied as finite offsets to the nonlinear closure
//!    (docs/model.md §7).
//!
//! [`solve_pose`] runs them in order; a bad pose becomes a [`Status`], never a panic.
//!
//! [`assembly`] builds the same two systems from a description of the mechanism as
//! [`limbs`] (base joint, leg bodies, spherical joint, clearance sites), for any number
//! of limbs: the 3-PRS and 3-RPS described that way agree with the paths above, and
//! [`ups`] describes the 6-UPS Gough–Stewart platform (docs/model.md §10.3) with it.
//! [`fast`] solves the same two systems in their 6 × 6 reduced forms (the default,
//! [`SolverKind::Fast`]); the assembled faer path ([`SolverKind::General`]) is the
//! reference, and the two agree to round-off.
//!
//! Symbols: `A` the equilibrium matrix, `w` the reactions, `b` the known loads;
//! `J_P` the passive-joint screw matrix, `Δq_P` the passive joint motions, `J_Cl·Δq_Cl`
//! the clearance twists; `κ₁` the 1-norm condition number.
//!
//! ```
//! use clearance_grid::SampleSource;
//! use clearance_model::{JobSpec, Mode};
//! use clearance_solver::{Model, Workspace, solve_pose, Status};
//! let job = JobSpec::from_toml_str(
//!     "[clearance]\ns_radial = 1e-4\n[grid]\nz = 2.05\npsi = 0.1\ntheta = 0.2\n", "j.toml").unwrap();
//! let model = Model::from_job(&job);
//! let sample = SampleSource::new(&job).sample(0);
//! let r = solve_pose(&model, &sample, Mode::Kinetostatic, &mut Workspace::new());
//! assert_eq!(r.status, Status::Ok);
//! assert!(r.total.dp.z < 0.0); // under its own weight the platform sags
//! ```

#![allow(non_snake_case)]
// Limb loops index several per-limb arrays at once, as the equations do.
#![allow(clippy::needless_range_loop)]

pub mod assembly;
pub mod bodies;
pub mod custom;
pub mod equilibrium;
pub mod error_system;
pub mod exact;
pub mod fast;
pub mod lanes;
pub mod limbs;
mod linalg;
mod pose;
pub mod takeup;
pub mod ups;

pub use assembly::{Assembly, AssemblyData, LimbsSolution};
pub use bodies::{Inertial, Load, MassModel, Model, SolverKind};
/// The `dominant` column's joint names (defined beside the clearance kinds).
pub use clearance_model::{joint_label, joint_name};
pub use equilibrium::JointReactions;
pub use error_system::PoseError;
pub use linalg::LuSolver;
pub use pose::{
    Blocks, DOMINANT_TIE, Isa, PoseResult, Status, Workspace, cap_isa, dominant_joint, solve_batches, solve_errors,
    solve_in_blocks, solve_pose, solve_poses, solve_poses_posed, solve_reactions, solve_reactions_if_solvable,
    solve_reactions_posed,
};
pub use takeup::{Margins, TakeUp};
