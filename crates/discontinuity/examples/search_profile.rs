//! The discontinuity search of a job on its own, for a profiler and for side-by-side
//! timings of two builds: every variant's samples are solved and traced once (their
//! traces settled with every sample in hand, as a run settles them across its
//! units), then searched `ROUNDS` times (default 20) as a run searches them, with the
//! values the pass solved at hand, on a pool of one thread (`SEARCH_THREADS` for more).
//! `perf record target/release/examples/search_profile JOB.toml [ROUNDS]`; prints the
//! switches and the search's least milliseconds a round.
use clearance_discontinuity::{Sampled, Search, SearchOptions, axes, keep_local_minima, trace_loads};
use clearance_grid::SampleSource;
use clearance_model::JobSpec;
use clearance_solver::{Model, PoseResult, Workspace, solve_poses};
use std::time::Instant;

fn main() {
    let mut args = std::env::args().skip(1);
    let file = args.next().expect("a job file");
    let rounds: usize = args.next().map_or(20, |a| a.parse().expect("a round count"));
    let text = std::fs::read_to_string(&file).expect("a readable job file");
    let job = JobSpec::from_toml_str(&text, &file).expect("a valid job");
    let threads: usize = std::env::var("SEARCH_THREADS").ok().map_or(1, |v| v.parse().expect("a thread count"));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
    let mut inputs = Vec::new();
    for variant in job.variants(&file).expect("variants") {
        let model = Model::from_job(&variant.job);
        let source = SampleSource::new(&variant.job);
        let opts =
            SearchOptions { dip_threshold: variant.job.analysis.discontinuity_load_fraction * variant.job.weight() };
        let mode = variant.job.analysis.modes[0];
        let mut ws = Workspace::new();
        let mut values = Vec::with_capacity(source.len() as usize);
        let (mut raw, mut loads) = (Vec::new(), Vec::new());
        let mut out = vec![PoseResult::default(); 1024];
        for start in (0..source.len()).step_by(1024) {
            let samples: Vec<_> = (start..source.len().min(start + 1024)).map(|i| source.sample(i)).collect();
            let out = &mut out[..samples.len()];
            solve_poses(&model, &samples, mode, &mut ws, out);
            values.extend(out.iter().map(Sampled::of));
            for r in out.iter() {
                let (t, l) = trace_loads(r, &model);
                raw.push(t);
                loads.push(l);
            }
        }
        let traced = keep_local_minima(&axes(&source), 0, &raw, &loads);
        inputs.push((model, source, opts, mode, traced, values));
    }
    let mut best = f64::INFINITY;
    let mut found = 0;
    for _ in 0..rounds {
        let mut copies: Vec<Vec<Sampled>> = inputs.iter().map(|i| i.5.clone()).collect();
        let start = Instant::now();
        found = pool.install(|| {
            inputs
                .iter()
                .zip(&mut copies)
                .map(|((model, source, opts, mode, traced, _), values)| {
                    let mut search = Search::new(model, source, *mode, opts);
                    search.extend_known(traced, std::mem::take(values), source.len());
                    search.finish().len()
                })
                .sum::<usize>()
        });
        best = best.min(start.elapsed().as_secs_f64());
    }
    println!("{found} switches, search {:.2} ms a round (best of {rounds})", best * 1e3);
}
