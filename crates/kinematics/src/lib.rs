//! # clearance-kinematics
//!
//! Nominal inverse kinematics of the 3-PRS robot (docs/model.md §1–2) and its family
//! (§10.1–10.2); [`ups`] holds the 6-UPS Gough–Stewart platform's (§10.3).
//!
//! Inputs are `(Z, Ψ, Θ)`; the constraints `A_j·y_j = 0` give the parasitic
//! motions in closed form (paper Eqs. 3–5, corrected):
//!
//! ```text
//! Φ = atan2(sΨ·sΘ, cΨ + cΘ),  Y = −r_p·cΨ·sΦ,  X = r_p/2·(cΘ·cΦ − cΦ·cΨ + sΨ·sΘ·sΦ)
//! q_j = h_j − sqrt(L² − (ρ_j − R_b)²),  ρ_j = A_j·x_j,  h_j = A_j·z
//! ```
//!
//! with `R = R_y(Θ)·R_x(Ψ)·R_z(Φ)`, `A_j = p + R·a'_j`, `B_j = R_b·x_j + q_j·z` and the
//! leg direction `e_j = (A_j − B_j)/L`. [`inverse_kinematics`] gives the [`Posture`];
//! [`inverse_kinematics_motion`] also gives exact velocities and accelerations
//! ([`Motion`]) by second-order automatic differentiation ([`Jet`]).
//!
//! ```
//! use clearance_kinematics::{Geometry, inverse_kinematics};
//! let geom = Geometry::prototype();
//! let pose = inverse_kinematics(&geom, 2.05, 0.1, -0.2).unwrap();
//! // Every vertex lies in its limb plane.
//! for j in 0..3 {
//!     assert!(pose.a[j].dot(&geom.y[j]).abs() < 1e-15);
//! }
//! ```

#![allow(non_snake_case)]

pub mod custom;
mod inverse;
mod jet;
pub mod ups;

pub use inverse::{
    Geometry, Motion, Posture, Unreachable, euler_rates_matrix, inverse_kinematics, inverse_kinematics_motion, limb,
    parasitic, parasitic_of, parasitic_sc, rotation, rotation_sc, slider,
};
pub use jet::{Elementary, Jet, Real};
pub use ups::{
    UpsGeometry, UpsMotion, UpsParams, UpsPosture, ups_inverse_kinematics, ups_inverse_kinematics_into,
    ups_inverse_kinematics_motion,
};
