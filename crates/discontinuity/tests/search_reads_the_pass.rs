//! A search handed what the pass solved at the samples (`Search::extend_known`) reads
//! their forces rather than solving the samples again, and finds the
//! switches, bit for bit, of the search that solves every sample itself
//! (`find_discontinuities`): whatever the parts the samples arrive in and however far
//! back their values are kept, and however the paths each part completes are cut into
//! batches and in whatever order, on whichever thread, the batches are searched
//! (`Search::receive`, `batches`, `search_batch`, `searched`, as a run does). On a
//! 3-PRS 3-D grid with a mass (vector and axial switches), a 3-RPS grid (whose Z-lines
//! are searched) and a dynamic trajectory. A control run handed each sample the
//! forces of the next changes the switches: the values are read, not ignored.

mod common;

use clearance_discontinuity::{Discontinuity, Sampled, Search, SearchOptions, find_discontinuities, traces};
use clearance_grid::SampleSource;
use clearance_model::Mode;
use clearance_solver::{Model, PoseResult, Workspace, solve_poses};

const KINDS: &str = "[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n";

/// Every field, floats by their shortest round-trip form: equal strings are equal bits.
fn bits(found: &[Discontinuity]) -> String {
    format!("{found:?}")
}

/// The switches of a search fed `values` in parts of `part` samples, keeping the
/// values of the last `keep` samples before each part. With `batches`, as a run
/// searches: each part's paths cut into about that many batches, searched last
/// first, each on a thread of its own, then taken in order; else in one call
/// (`Search::extend_known`).
#[allow(clippy::too_many_arguments)]
fn in_parts(
    model: &Model,
    source: &SampleSource,
    mode: Mode,
    opts: &SearchOptions,
    traced: &[u64],
    values: &[Sampled],
    part: usize,
    keep: u64,
    batches: Option<usize>,
) -> Vec<Discontinuity> {
    let mut search = Search::new(model, source, mode, opts);
    for (t, v) in traced.chunks(part).zip(values.chunks(part)) {
        let Some(most) = batches else {
            search.extend_known(t, v.to_vec(), keep);
            continue;
        };
        search.receive(t, v.to_vec());
        let batches = search.batches(most);
        // About `most`: one more at most for each of the (up to three) axes.
        assert!(batches.len() <= most.max(1) + 3, "{} batches for about {most}", batches.len());
        let search_ref = &search;
        let mut found: Vec<Vec<Discontinuity>> = std::thread::scope(|s| {
            let handles: Vec<_> = batches.iter().rev().map(|b| s.spawn(move || search_ref.search_batch(b))).collect();
            handles.into_iter().map(|h| h.join().expect("a batch searched")).collect()
        });
        found.reverse();
        search.searched(&batches, found, keep);
    }
    search.finish()
}

fn check(text: &str, mode: Mode) {
    let (job, model, source) = common::job(text);
    let opts = SearchOptions { dip_threshold: job.analysis.discontinuity_load_fraction * job.weight() };
    let expected = find_discontinuities(&model, &source, mode, &opts);
    assert!(expected.len() > 10, "{} switches to find", expected.len());
    let n = source.len();
    let samples: Vec<_> = (0..n).map(|i| source.sample(i)).collect();
    let mut results = vec![PoseResult::default(); n as usize];
    solve_poses(&model, &samples, mode, &mut Workspace::new(), &mut results);
    let values: Vec<Sampled> = results.iter().map(Sampled::of).collect();
    let traced = traces(&model, &source, mode, 0..n, &opts);
    let n = n as usize;
    for (part, keep) in [(n, 0), (n / 3 + 1, 0), (n / 7 + 5, 97), (499, 2_000), (97, n as u64)] {
        let found = in_parts(&model, &source, mode, &opts, &traced, &values, part, keep, None);
        assert_eq!(bits(&found), bits(&expected), "parts of {part}, keeping {keep}");
    }
    for (part, keep, most) in [(n, 0, 1), (n / 3 + 1, n as u64, 5), (499, 2_000, 64), (n / 7 + 5, 97, 10_000)] {
        let found = in_parts(&model, &source, mode, &opts, &traced, &values, part, keep, Some(most));
        assert_eq!(bits(&found), bits(&expected), "parts of {part}, keeping {keep}, about {most} batches");
    }
    // The control: each sample handed the next one's forces finds other switches.
    let shifted: Vec<Sampled> = (0..n).map(|i| Sampled::of(&results[(i + 1) % n])).collect();
    let found = in_parts(&model, &source, mode, &opts, &traced, &shifted, n, 0, None);
    assert_ne!(bits(&found), bits(&expected), "the search read none of the values");
}

#[test]
fn a_3prs_grid_with_a_mass() {
    check(
        &format!(
            "{KINDS}[mass]\npoints = [ {{ mass = 20.0, at = [0.0, 0.0, 1.0] }} ]\n\
             [grid]\nz = {{ start = 1.95, stop = 2.1, n = 3 }}\npsi = {{ start = -0.5, stop = 0.5, n = 31 }}\n\
             theta = {{ start = -0.5, stop = 0.5, n = 27 }}\n"
        ),
        Mode::Kinetostatic,
    );
}

#[test]
fn a_3rps_grid() {
    check(
        &format!(
            "[mechanism]\nkind = \"3-RPS\"\n{KINDS}[grid]\nz = {{ start = 1.0, stop = 1.4, n = 5 }}\n\
             psi = {{ start = -0.4, stop = 0.4, n = 23 }}\ntheta = {{ start = -0.4, stop = 0.4, n = 21 }}\n"
        ),
        Mode::Kinetostatic,
    );
}

#[test]
fn a_dynamic_trajectory() {
    check(
        &format!(
            "{KINDS}[mass]\npoints = [ {{ mass = 30.0, at = [0.0, 0.0, 1.0] }} ]\n\
             [analysis]\nmodes = [\"dynamic\"]\n\
             [trajectory]\ntime = {{ start = 0.0, stop = 10.0, n = 4001 }}\n\
             z = {{ offset = 2.05, harmonics = [ {{ amplitude = 0.05, period = 2.5 }} ] }}\n\
             psi = {{ harmonics = [ {{ amplitude = 0.3, period = 3.3, phase = 0.5 }} ] }}\n\
             theta = {{ harmonics = [ {{ amplitude = 0.5, period = 5.0 }} ] }}\n"
        ),
        Mode::Dynamic,
    );
}
