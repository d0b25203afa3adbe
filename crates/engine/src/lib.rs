//! # clearance-engine
//!
//! A clearance run as a library: the job's plan (variants × modes × chunks of
//! samples), shards, resume, the run directory's [`Layout`], the statistics and
//! trace files behind the summary and the discontinuity search, and the pipeline
//! that streams poses to Parquet (docs/interface.md §4). The `clearance` binary
//! and the Python package are two doors onto it: they parse arguments, show
//! progress ([`Progress`]) and map [`EngineError`] to exit codes or exceptions.
//! The engine never prints and never reads the environment.
//!
//! - [`run`]: a job into a directory, on the caller's rayon pool;
//! - [`solve`]: the same rows in memory, as Arrow record batches, optionally for
//!   explicit [`Poses`] instead of the job's grid or trajectory;
//! - [`plan`]: what a job will compute; [`status`]: is a run complete?
//!
//! A 6-UPS job (`[mechanism] kind = "6-UPS"`) takes the same doors: [`run`] and
//! [`solve`] hand it to its own module, with six inputs, six limbs and its tables.
//!
//! ```
//! use clearance_engine::{JobSpec, SolveOptions, solve};
//! let job = JobSpec::from_toml_str(
//!     "[clearance]\nr_radial = 1e-4\n[grid]\nz = 2.05\npsi = 0.1\ntheta = { start = -0.5, stop = 0.5, n = 5 }\n",
//!     "doc.toml",
//! ).unwrap();
//! let batches = solve(&job, "doc.toml", &SolveOptions::default()).unwrap();
//! assert_eq!(batches[0].num_rows(), 5);
//! assert!(batches[0].schema().field_with_name("err_z").is_ok());
//! ```

mod allocate;
mod custom;
mod describe;
mod error;
mod estimate;
mod groups;
mod kernel;
mod layout;
mod owned;
mod plan;
mod preset;
mod progress;
mod run;
mod solve;
mod status;
mod units;
mod ups;

pub use allocate::{
    AllocModel, AllocateOptions, Allocation, Binding, Variable, allocate, allocate_budgets, short as short_coordinate,
};
pub use describe::describe;
pub use error::{EngineError, OutputDirError};
pub use estimate::{Calibration, Estimate, calibration_dir, estimate, scaled};
pub use kernel::{bench_job, kernel_rate, kernel_rate_with};
pub use layout::Layout;
pub use plan::{ColumnSize, Plan, PlannedVariant, Samples, plan};
pub use preset::uses_kernel;
pub use progress::{Progress, Reporter};
pub use run::{RunOptions, RunReport, StageTimes, run};
pub use solve::{Poses, SolveOptions, solve};
pub use status::{RunStatus, status};

pub use clearance_model::{JobError, JobSpec, MechanismKind};
pub use clearance_parquet::{Codec, ColumnSet, Precision, Writer};
pub use clearance_solver::{Isa, SolverKind, cap_isa};
