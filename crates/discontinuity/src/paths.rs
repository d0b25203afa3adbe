//! Paths along which take-up is followed: a trajectory is one path; a grid has
//! one line per node of the other inputs along every input with more than one value.

use clearance_grid::{Sample, SampleSource};
use clearance_model::RangeSpec;

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

/// One path: the samples on it, in order, and how to evaluate any point between them.
#[derive(Clone, Debug)]
pub struct Path {
    pub along: Along,
    /// Sample indices on the path, in increasing order of the parameter.
    pub samples: Vec<u64>,
    /// The path parameter (the varying input, or t) at each sample.
    pub params: Vec<f64>,
    /// The fixed node: sample index of the path's first point (its other inputs).
    origin: u64,
}

impl Path {
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

fn values(r: &RangeSpec) -> Vec<f64> {
    (0..r.len()).map(|i| r.value(i)).collect()
}

/// Every path of the source (MODEL.md §8).
pub fn paths(source: &SampleSource) -> Vec<Path> {
    match source {
        SampleSource::Trajectory(tr) => {
            let n = tr.time.len();
            vec![Path { along: Along::T, samples: (0..n).collect(), params: values(&tr.time), origin: 0 }]
        }
        SampleSource::Grid(g) => {
            let (nz, np, nt) = (g.z.len(), g.psi.len(), g.theta.len());
            let index = |iz: u64, ip: u64, it: u64| (iz * np + ip) * nt + it;
            let mut out = Vec::new();
            if nt > 1 {
                for iz in 0..nz {
                    for ip in 0..np {
                        let samples: Vec<u64> = (0..nt).map(|it| index(iz, ip, it)).collect();
                        out.push(Path { along: Along::Theta, origin: samples[0], samples, params: values(&g.theta) });
                    }
                }
            }
            if np > 1 {
                for iz in 0..nz {
                    for it in 0..nt {
                        let samples: Vec<u64> = (0..np).map(|ip| index(iz, ip, it)).collect();
                        out.push(Path { along: Along::Psi, origin: samples[0], samples, params: values(&g.psi) });
                    }
                }
            }
            if nz > 1 {
                for ip in 0..np {
                    for it in 0..nt {
                        let samples: Vec<u64> = (0..nz).map(|iz| index(iz, ip, it)).collect();
                        out.push(Path { along: Along::Z, origin: samples[0], samples, params: values(&g.z) });
                    }
                }
            }
            out
        }
    }
}
