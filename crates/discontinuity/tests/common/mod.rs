//! What the tests of the search share: jobs from text, and switch sets compared
//! line by line.

#![allow(dead_code)]

use clearance_discontinuity::{Along, Discontinuity, SearchOptions, find_discontinuities};
use clearance_grid::SampleSource;
use clearance_model::{JobSpec, Mode};
use clearance_solver::Model;

pub fn job(text: &str) -> (JobSpec, Model, SampleSource) {
    let job = JobSpec::from_toml_str(text, "case.toml").unwrap();
    let model = Model::from_job(&job);
    let source = SampleSource::new(&job);
    (job, model, source)
}

pub fn run(text: &str, mode: Mode) -> Vec<Discontinuity> {
    let (job, model, source) = job(text);
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    find_discontinuities(&model, &source, mode, &opts)
}

/// The line a switch lies on (its axis, and the other inputs' values to 1e-9, as
/// whole multiples) and its joint.
pub type Line = (Along, i64, i64, usize, usize);

pub fn line(d: &Discontinuity) -> Line {
    let node = |v: f64| (v * 1e9).round() as i64;
    let (a, b) = match d.along {
        Along::T => (0, 0),
        Along::Z => (node(d.psi), node(d.theta)),
        Along::Psi => (node(d.z), node(d.theta)),
        Along::Theta => (node(d.z), node(d.psi)),
    };
    (d.along, a, b, d.limb, d.kind.index())
}

/// The switches by line, each line's in order of the path parameter.
pub fn by_line(found: &[Discontinuity]) -> Vec<(Line, f64)> {
    let mut out: Vec<(Line, f64)> = found.iter().map(|d| (line(d), d.param)).collect();
    out.sort_by(|x, y| x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)));
    out
}

/// `coarse` and `fine` have the same switches (count and locations within `tol`)
/// on the lines of `coarse`'s sampling, which `fine`'s has too (`on_coarse_line`
/// says which of `fine`'s switches lie on one).
pub fn assert_same_switches(
    coarse: &[Discontinuity],
    fine: &[Discontinuity],
    on_coarse_line: impl Fn(&Discontinuity) -> bool,
    tol: f64,
    what: &str,
) {
    let fine: Vec<Discontinuity> = fine.iter().filter(|d| on_coarse_line(d)).cloned().collect();
    let (c, f) = (by_line(coarse), by_line(&fine));
    assert!(!c.is_empty(), "{what}: the case must have switches");
    assert_eq!(c.len(), f.len(), "{what}: {c:?}\nvs\n{f:?}");
    for (a, b) in c.iter().zip(&f) {
        assert_eq!(a.0, b.0, "{what}");
        assert!((a.1 - b.1).abs() < tol, "{what}: {a:?} vs {b:?}");
    }
}

/// Whether `v` is a node of `n` values evenly from −0.5 to 0.5 (to 1e-9).
pub fn is_node(v: f64, n: u32) -> bool {
    let k = (v + 0.5) * f64::from(n - 1);
    (k - k.round()).abs() < 1e-6
}
