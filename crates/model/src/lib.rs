//! # clearance-model
//!
//! The typed, validated description of one `clearance` job: the mechanism (a 3-PRS
//! with any rails and limb layout, or a 3-RPS),
//! its masses and loads, the clearance magnitudes, the analysis options and the
//! samples (a workspace grid or a trajectory). A job file (TOML, see
//! docs/interface.md) is exactly one [`JobSpec`]; [`JobSpec::from_toml_str`]
//! parses, applies defaults (the paper's prototype) and validates it, and
//! [`JobSpec::variants`] expands its `[[sweep]]` tables into concrete jobs.
//!
//! Symbols follow docs/model.md: base radius `R_b`, platform radius `r_p`,
//! leg length `L`, limb angles `α_j = 0°, 120°, 240°`.
//!
//! ```
//! use clearance_model::JobSpec;
//! let job = JobSpec::from_toml_str(
//!     "[grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 3 }\ntheta = 0.0\n",
//!     "example.toml",
//! ).unwrap();
//! assert_eq!(job.mechanism.leg_length(), 1.0);
//! assert_eq!(job.sample_count(), 3);
//! ```

pub mod custom;
mod error;
mod job;
mod keys;
mod kinds;
mod mechanism;
mod sweep;

pub use error::JobError;
pub use job::{
    AllocateSpec, AnalysisSpec, ClearanceSpec, GridSpec, Harmonic, InputSpec, JobSpec, LoadSpec, Mode, RangeSpec,
    SamplesSpec, SweepSpec, TrajectorySpec,
};
pub use kinds::{ClearanceKind, KINDS, joint_label, joint_name};
pub use mechanism::{
    MECHANISM_KINDS, MassSpec, MechanismKind, MechanismSpec, PROTOTYPE_LIMB_ANGLES_DEG, PointMass, UPS_BASE_ANGLES_DEG,
    UPS_PLATFORM_ANGLES_DEG, UPS_PLATFORM_MASS,
};
pub use sweep::{MAX_VARIANTS, Variant};

/// Angles of the three limbs about `z` (docs/model.md §1), in radians.
pub const LIMB_ANGLES: [f64; 3] = [0.0, 2.0 * std::f64::consts::PI / 3.0, 4.0 * std::f64::consts::PI / 3.0];
