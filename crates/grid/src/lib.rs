//! # clearance-grid
//!
//! Turns a job's `[grid]` or `[trajectory]` into numbered samples, without
//! materialising them: sample `i` is computed on demand, so a 50-million-pose grid
//! costs no memory until a batch asks for it.
//!
//! - Grid: row-major over `(z, ψ, θ)`, `i = (i_z·n_ψ + i_ψ)·n_θ + i_θ`; range values
//!   `start + (stop − start)·k/(n − 1)` (docs/conventions.md).
//! - Trajectory: `t_i` from `time` likewise; each input `offset + Σ a·sin(2πt/T + φ)`
//!   with analytic first and second derivatives.
//!
//! ```
//! use clearance_grid::SampleSource;
//! use clearance_model::JobSpec;
//! let job = JobSpec::from_toml_str(
//!     "[grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 3 }\ntheta = { start = 0.0, stop = 1.0, n = 2 }\n",
//!     "g.toml",
//! ).unwrap();
//! let src = SampleSource::new(&job);
//! assert_eq!(src.len(), 6);
//! let s = src.sample(5); // last ψ, last θ
//! assert_eq!((s.psi[0], s.theta[0]), (0.5, 1.0));
//! ```

use clearance_model::{GridSpec, JobSpec, RangeSpec, SamplesSpec, TrajectorySpec};
use std::ops::Range;

/// One sample: its index, its time (trajectories) and each input as
/// `[value, rate, acceleration]` (rates are zero on grids).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub index: u64,
    pub t: Option<f64>,
    pub z: [f64; 3],
    pub psi: [f64; 3],
    pub theta: [f64; 3],
}

/// The samples of one job, computed on demand.
#[derive(Clone, Debug)]
pub enum SampleSource {
    Grid(GridSpec),
    Trajectory(TrajectorySpec),
}

impl SampleSource {
    pub fn new(job: &JobSpec) -> Self {
        match job.samples() {
            SamplesSpec::Grid(g) => SampleSource::Grid(g.clone()),
            SamplesSpec::Trajectory(t) => SampleSource::Trajectory(t.clone()),
        }
    }

    pub fn is_trajectory(&self) -> bool {
        matches!(self, SampleSource::Trajectory(_))
    }

    pub fn len(&self) -> u64 {
        match self {
            SampleSource::Grid(g) => g.axes6().iter().map(|r| r.len()).product(),
            SampleSource::Trajectory(t) => t.time.len(),
        }
    }

    /// Sample `i` of a 6-UPS job (`i < len()`): its time and each of the six inputs
    /// `x, y, z, phi, psi, theta` as `[value, rate, acceleration]`. A grid is
    /// row-major in that order (the last input fastest).
    #[track_caller]
    pub fn sample6(&self, i: u64) -> (Option<f64>, [[f64; 3]; 6]) {
        assert!(i < self.len(), "sample index {i} out of range 0..{}", self.len());
        match self {
            SampleSource::Grid(g) => {
                let axes = g.axes6();
                let mut rest = i;
                let mut out = [[0.0; 3]; 6];
                for k in (0..6).rev() {
                    let n = axes[k].len();
                    out[k] = [axes[k].value(rest % n), 0.0, 0.0];
                    rest /= n;
                }
                (None, out)
            }
            SampleSource::Trajectory(tr) => {
                let t = tr.time.value(i);
                (Some(t), tr.inputs6().map(|input| input.eval(t)))
            }
        }
    }

    /// A 6-UPS grid's six axes' lengths (`x, y, z, phi, psi, theta`).
    pub fn grid_shape6(&self) -> Option<[u64; 6]> {
        match self {
            SampleSource::Grid(g) => Some(g.axes6().map(|r| r.len())),
            SampleSource::Trajectory(_) => None,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample `i` (`i < len()`).
    #[track_caller]
    pub fn sample(&self, i: u64) -> Sample {
        assert!(i < self.len(), "sample index {i} out of range 0..{}", self.len());
        match self {
            SampleSource::Grid(g) => {
                let (nps, nth) = (g.psi.len(), g.theta.len());
                let ith = i % nth;
                let ips = (i / nth) % nps;
                let iz = i / (nth * nps);
                let c = |r: &RangeSpec, k: u64| [r.value(k), 0.0, 0.0];
                Sample { index: i, t: None, z: c(&g.z, iz), psi: c(&g.psi, ips), theta: c(&g.theta, ith) }
            }
            SampleSource::Trajectory(tr) => {
                let t = tr.time.value(i);
                Sample { index: i, t: Some(t), z: tr.z.eval(t), psi: tr.psi.eval(t), theta: tr.theta.eval(t) }
            }
        }
    }

    /// The grid's axes `(z, ψ, θ)` with their lengths, for searches along grid lines.
    pub fn grid_shape(&self) -> Option<[u64; 3]> {
        match self {
            SampleSource::Grid(g) => Some([g.z.len(), g.psi.len(), g.theta.len()]),
            SampleSource::Trajectory(_) => None,
        }
    }
}

/// Splits `0..len` into consecutive chunks of at most `chunk` samples. The split
/// depends only on `len` and `chunk`, never on the thread count, so output is
/// reproducible.
#[track_caller]
pub fn chunks(len: u64, chunk: u64) -> impl Iterator<Item = Range<u64>> {
    assert!(chunk > 0, "chunk size must be positive");
    (0..len.div_ceil(chunk)).map(move |k| k * chunk..((k + 1) * chunk).min(len))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(text: &str) -> JobSpec {
        JobSpec::from_toml_str(text, "t.toml").unwrap()
    }

    #[test]
    fn grid_is_row_major_and_hits_range_ends_exactly() {
        let j = job(
            "[grid]\nz = { start = 2.0, stop = 2.1, n = 2 }\npsi = { start = -0.5, stop = 0.5, n = 201 }\ntheta = { start = -0.5, stop = 0.5, n = 3 }\n",
        );
        let s = SampleSource::new(&j);
        assert_eq!(s.len(), 2 * 201 * 3);
        let mid = s.sample(100 * 3 + 1);
        assert_eq!((mid.z[0], mid.psi[0], mid.theta[0]), (2.0, 0.0, 0.0));
        let last = s.sample(s.len() - 1);
        assert_eq!((last.z[0], last.psi[0], last.theta[0]), (2.1, 0.5, 0.5));
    }

    #[test]
    fn trajectory_rates_match_finite_differences() {
        let j = job(
            "[analysis]\nmodes=[\"dynamic\"]\n[trajectory]\ntime = { start = 0.0, stop = 5.0, n = 11 }\nz = 2.0\npsi = { offset = 0.1, harmonics = [{ amplitude = 0.2, period = 3.0, phase = 0.4 }] }\ntheta = { harmonics = [{ amplitude = 0.5, period = 5.0 }, { amplitude = 0.1, period = 1.0 }] }\n",
        );
        let TrajectorySpec { theta, .. } = j.trajectory.clone().unwrap();
        for t in [0.3, 1.7, 4.2] {
            let h = 1e-4;
            let f = |t: f64| theta.eval(t)[0];
            let d = theta.eval(t);
            assert!((d[1] - (f(t + h) - f(t - h)) / (2.0 * h)).abs() < 1e-7);
            assert!((d[2] - (f(t + h) - 2.0 * f(t) + f(t - h)) / (h * h)).abs() < 1e-4);
        }
    }

    #[test]
    fn chunks_cover_exactly_once() {
        let c: Vec<_> = chunks(10, 4).collect();
        assert_eq!(c, vec![0..4, 4..8, 8..10]);
        assert_eq!(chunks(0, 4).count(), 0);
    }
}
