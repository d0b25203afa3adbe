//! Paths along which take-up is followed: a trajectory is one path; a grid has
//! one line per node of the other inputs along every input with more than one value.

use clearance_grid::{Sample, SampleSource};
use clearance_model::RangeSpec;
use std::sync::Arc;

/// The input a path varies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Along {
    /// Time, along a trajectory.
    T,
    Z,
    Psi,
    Theta,
}

impl Along {
    pub fn name(self) -> &'static str {
        match self {
            Along::T => "t",
            Along::Z => "z",
            Along::Psi => "psi",
            Along::Theta => "theta",
        }
    }
}

/// One path: which samples lie on it, in order, and how to evaluate any point
/// between them. A path is a few numbers (its first sample and the stride between
/// samples); the parameter values are shared by every line along the same input, so
/// the paths of a 50-million-pose grid cost kilobytes, not gigabytes.
#[derive(Clone, Debug)]
pub struct Path {
    pub along: Along,
    /// The path parameter (the varying input, or t) at each sample, shared.
    pub params: Arc<[f64]>,
    /// Sample index of the path's first point (it fixes the other inputs).
    origin: u64,
    /// Index step from one sample of the path to the next.
    stride: u64,
}

impl Path {
    /// The number of samples on the path.
    pub fn len(&self) -> usize {
        self.params.len()
    }

    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// The sample index of the `k`-th point.
    pub fn sample_index(&self, k: usize) -> u64 {
        self.origin + k as u64 * self.stride
    }

    /// The sample at parameter `p` (not necessarily a grid or time node).
    pub fn sample_at(&self, source: &SampleSource, p: f64) -> Sample {
        match source {
            SampleSource::Trajectory(tr) => {
                Sample { index: u64::MAX, t: Some(p), z: tr.z.eval(p), psi: tr.psi.eval(p), theta: tr.theta.eval(p) }
            }
            SampleSource::Grid(_) => {
                let mut s = source.sample(self.origin);
                s.index = u64::MAX;
                let v = [p, 0.0, 0.0];
                match self.along {
                    Along::Z => s.z = v,
                    Along::Psi => s.psi = v,
                    Along::Theta => s.theta = v,
                    Along::T => unreachable!("grids have no time"),
                }
                s
            }
        }
    }
}

fn values(r: &RangeSpec) -> Arc<[f64]> {
    (0..r.len()).map(|i| r.value(i)).collect()
}

/// Every path of the source (MODEL.md §8).
pub fn paths(source: &SampleSource) -> Vec<Path> {
    match source {
        SampleSource::Trajectory(tr) => {
            vec![Path { along: Along::T, params: values(&tr.time), origin: 0, stride: 1 }]
        }
        SampleSource::Grid(g) => {
            let (nz, np, nt) = (g.z.len(), g.psi.len(), g.theta.len());
            let index = |iz: u64, ip: u64, it: u64| (iz * np + ip) * nt + it;
            let mut out = Vec::new();
            if nt > 1 {
                let params = values(&g.theta);
                for iz in 0..nz {
                    for ip in 0..np {
                        out.push(Path {
                            along: Along::Theta,
                            params: params.clone(),
                            origin: index(iz, ip, 0),
                            stride: 1,
                        });
                    }
                }
            }
            if np > 1 {
                let params = values(&g.psi);
                for iz in 0..nz {
                    for it in 0..nt {
                        out.push(Path {
                            along: Along::Psi,
                            params: params.clone(),
                            origin: index(iz, 0, it),
                            stride: nt,
                        });
                    }
                }
            }
            if nz > 1 {
                let params = values(&g.z);
                for ip in 0..np {
                    for it in 0..nt {
                        out.push(Path {
                            along: Along::Z,
                            params: params.clone(),
                            origin: index(0, ip, it),
                            stride: np * nt,
                        });
                    }
                }
            }
            out
        }
    }
}
