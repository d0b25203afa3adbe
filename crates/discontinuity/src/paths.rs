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

    /// The position on the path of the sample with index `i` (one of its samples).
    pub fn position(&self, i: u64) -> usize {
        ((i - self.origin) / self.stride) as usize
    }

    /// Whether its samples are consecutive (a trajectory, or a line of the fastest input).
    pub fn is_consecutive(&self) -> bool {
        self.stride == 1
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

/// One input that varies over the samples: sample `i` is node `(i / stride) % n`
/// of it. Its paths are the lines that step through it with the others fixed.
#[derive(Clone, Debug)]
pub struct Axis {
    pub along: Along,
    pub stride: u64,
    /// Nodes along it (more than one).
    pub n: u64,
    /// The input's value at each node.
    pub params: Arc<[f64]>,
}

impl Axis {
    /// The path along this axis whose first sample is `origin`.
    pub fn path(&self, origin: u64) -> Path {
        Path { along: self.along, params: self.params.clone(), origin, stride: self.stride }
    }

    /// Whether sample `i` is a path's first or last node along this axis.
    pub fn is_end(&self, i: u64) -> bool {
        let node = (i / self.stride) % self.n;
        node == 0 || node == self.n - 1
    }
}

/// The inputs the samples vary (row-major z, psi, theta on a grid; t along a
/// trajectory), fastest last.
pub fn axes(source: &SampleSource) -> Vec<Axis> {
    match source {
        SampleSource::Trajectory(tr) => {
            vec![Axis { along: Along::T, stride: 1, n: tr.time.len(), params: values(&tr.time) }]
        }
        SampleSource::Grid(g) => {
            let (np, nt) = (g.psi.len(), g.theta.len());
            [(Along::Z, &g.z, np * nt), (Along::Psi, &g.psi, nt), (Along::Theta, &g.theta, 1)]
                .into_iter()
                .filter(|(_, r, _)| r.len() > 1)
                .map(|(along, r, stride)| Axis { along, stride, n: r.len(), params: values(r) })
                .collect()
        }
    }
}

/// Every path of the source (docs/model.md §8): along each axis, fastest first, one line
/// per node of the other inputs, in order of its first sample.
pub fn paths(source: &SampleSource) -> Vec<Path> {
    let len = source.len();
    let mut out = Vec::new();
    for axis in axes(source).into_iter().rev() {
        let span = axis.stride * axis.n;
        for outer in 0..len / span {
            out.extend((0..axis.stride).map(|inner| axis.path(outer * span + inner)));
        }
    }
    out
}
