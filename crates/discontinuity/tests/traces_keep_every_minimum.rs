//! The candidates a run's traces keep ([`keep_local_minima`]) lose no switch: the
//! search over pruned traces finds exactly what it finds when every sample is
//! a candidate, however the samples are cut into ranges, and the pruning does
//! remove most candidates (otherwise it saves nothing). A [`Search`] given the
//! traces a range at a time, as a run computes them, finds the same switches, and
//! searches each path as soon as its last sample is in. So does the search that
//! reads the traces a batch of paths at a time, with any memory budget.

use clearance_discontinuity::{
    Search, SearchOptions, Trace, axes, find_discontinuities_read, find_discontinuities_traced, paths, trace, traces,
};
use clearance_grid::SampleSource;
use clearance_model::{JobSpec, Mode};
use clearance_solver::{Model, Workspace, solve_pose};

/// Candidate bits (the minima and turns that `keep_local_minima` settles): bits
/// 16 and up.
fn candidates(t: &[Trace]) -> u32 {
    t.iter().map(|t| ((t >> 16) << 16).count_ones()).sum()
}

/// `prunes`: whether, with all samples in one range, at most a fifth of the
/// candidates may stay (not so where a load is flat along some axis).
fn check(text: &str, mode: Mode, ranges: &[u64], prunes: bool) {
    let job = JobSpec::from_toml_str(text, "case.toml").unwrap();
    let model = Model::from_job(&job);
    let source = SampleSource::new(&job);
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    let n = source.len();
    let mut ws = Workspace::new();
    let every: Vec<Trace> =
        (0..n).map(|i| trace(&solve_pose(&model, &source.sample(i), mode, &mut ws), &model)).collect();
    let expected = find_discontinuities_traced(&model, &source, mode, &opts, &every);
    assert!(!expected.is_empty(), "the case must have switches to lose");
    for &len in ranges {
        let mut pruned = Vec::new();
        let mut start = 0;
        while start < n {
            let end = (start + len).min(n);
            pruned.extend(traces(&model, &source, mode, start..end, &opts));
            start = end;
        }
        assert_eq!(find_discontinuities_traced(&model, &source, mode, &opts, &pruned), expected, "ranges of {len}");
        let mut search = Search::new(&model, &source, mode, &opts);
        let searched: usize = pruned.chunks(len as usize).map(|range| search.extend(range)).sum();
        assert_eq!(searched, paths(&source).len(), "ranges of {len}: every path searched once");
        assert_eq!(search.finish(), expected, "ranges of {len}, searched as they come");
        // A read fills the batch's buffer, or part of it: never more than the budget
        // or one path's samples.
        let longest = axes(&source).iter().map(|a| a.n as usize).max().unwrap();
        for budget in [1, 5, 29, 100, 700, n as usize] {
            let mut read = 0;
            let found = find_discontinuities_read(&model, &source, mode, &opts, budget, |range, dst: &mut [Trace]| {
                assert_eq!(dst.len() as u64, range.end - range.start);
                assert!(dst.len() <= budget.max(longest), "budget {budget}: a read of {}", dst.len());
                dst.copy_from_slice(&pruned[range.start as usize..range.end as usize]);
                read += dst.len();
                Ok::<(), ()>(())
            });
            assert_eq!(found, Ok(expected.clone()), "ranges of {len}, read with a budget of {budget}");
            assert_eq!(read as u64, n * axes(&source).len() as u64, "budget {budget}: each sample read once per axis");
        }
        let (before, after) = (candidates(&every), candidates(&pruned));
        if prunes && len >= n {
            assert!(after * 5 < before, "ranges of {len}: {after} of {before} candidates left");
        }
    }
}

/// A grid in Z, Ψ and Θ with an added mass (radial switches) and a dip threshold
/// of half the weight, so most vector loads are low. Some loads barely change
/// with Z, so the middle Z node stays a candidate along Z.
#[test]
fn grid_switches_survive_pruning_in_any_ranges() {
    let text = "[mass]\npoints = [{ mass = 30.0, at = [0.0, 0.0, 1.0] }]\n\
        [clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
        [analysis]\ndiscontinuity_load_fraction = 0.5\n\
        [grid]\nz = { start = 2.0, stop = 2.1, n = 3 }\n\
        psi = { start = -0.5, stop = 0.5, n = 23 }\ntheta = { start = -0.5, stop = 0.5, n = 29 }\n";
    check(text, Mode::Kinetostatic, &[1, 7, 29, 500, 2001], false);
    let flat = text.replace("z = { start = 2.0, stop = 2.1, n = 3 }", "z = 2.05");
    check(&flat, Mode::Kinetostatic, &[13, 300, 667], true);
}

/// A trajectory in dynamics, where the path is the time axis.
#[test]
fn trajectory_switches_survive_pruning_in_any_ranges() {
    let text = "[mass]\npoints = [{ mass = 30.0, at = [0.0, 0.0, 1.0] }]\n\
        [clearance]\nr_radial = 1e-4\nr_angular = 1e-4\n\
        [analysis]\nmodes = [\"dynamic\"]\ndiscontinuity_load_fraction = 0.5\n\
        [trajectory]\ntime = { start = 1.25, stop = 3.75, n = 801 }\nz = 2.05\npsi = 0.1\n\
        theta = { harmonics = [ { amplitude = 0.5, period = 5.0 } ] }\n";
    check(text, Mode::Dynamic, &[3, 100, 801], true);
}

/// Each path is searched once its last sample is in, not before and not later: on
/// a 3 × 4 × 5 grid (Z, Ψ, Θ), a sample completes the line along each input of
/// which it is the last node.
#[test]
fn search_takes_each_path_as_its_last_sample_arrives() {
    let text = "[clearance]\nr_axial = 1e-4\n[grid]\nz = { start = 2.0, stop = 2.1, n = 3 }\n\
        psi = { start = -0.3, stop = 0.3, n = 4 }\ntheta = { start = -0.3, stop = 0.3, n = 5 }\n";
    let job = JobSpec::from_toml_str(text, "case.toml").unwrap();
    let model = Model::from_job(&job);
    let source = SampleSource::new(&job);
    let traces = vec![0 as Trace; source.len() as usize];
    let opts = SearchOptions { dip_threshold: 0.05 * job.weight() };
    let mut search = Search::new(&model, &source, Mode::Kinetostatic, &opts);
    let counts: Vec<usize> = traces.iter().map(|t| search.extend(std::slice::from_ref(t))).collect();
    let expected: Vec<usize> = (0..60)
        .map(|i| {
            let (z, psi, theta) = (i / 20, i / 5 % 4, i % 5);
            usize::from(theta == 4) + usize::from(psi == 3) + usize::from(z == 2)
        })
        .collect();
    assert_eq!(counts, expected);
    assert!(search.is_complete());
    assert_eq!(counts.iter().sum::<usize>(), paths(&source).len());
}
