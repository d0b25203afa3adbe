//! A run's wall time, estimated from short runs of the job itself (`clearance
//! check`): its own poses, variants, modes and column set, end to end (solving,
//! the switch search and writing), at growing sizes, extrapolated in the rows.

use std::path::PathBuf;
use std::time::Instant;

use clearance_model::{JobSpec, RangeSpec};

use crate::error::EngineError;
use crate::run::{RunOptions, run};

/// `job` with about `scale` times its samples: each range of a grid gets
/// `scale^(1/d)` times its values (d the ranges, among all six inputs: a 6-UPS
/// grid ranges over `x`, `y` and `phi` too), a trajectory `scale` times its
/// times; at least 2 values a range, the shortest ranges first so that what one
/// cannot lose the others do. Variants and modes are kept.
pub fn scaled(mut job: JobSpec, scale: f64) -> JobSpec {
    let resize = |r: &mut RangeSpec, f: f64| {
        let RangeSpec::Range { n, .. } = r else { return };
        *n = ((*n as f64 * f).round() as u64).max(2);
    };
    if let Some(g) = &mut job.grid {
        let mut ranges: Vec<&mut RangeSpec> =
            [g.x.as_mut(), g.y.as_mut(), Some(&mut g.z), g.phi.as_mut(), Some(&mut g.psi), Some(&mut g.theta)]
                .into_iter()
                .flatten()
                .filter(|r| matches!(r, RangeSpec::Range { .. }))
                .collect();
        ranges.sort_by_key(|r| r.len());
        let (mut left, d) = (scale, ranges.len());
        for (i, r) in ranges.into_iter().enumerate() {
            let before = r.len() as f64;
            resize(r, left.powf(1.0 / (d - i) as f64));
            left /= r.len() as f64 / before;
        }
    }
    if let Some(t) = &mut job.trajectory {
        resize(&mut t.time, scale);
    }
    job
}

/// Rows of a job's run: samples × variants × modes.
fn rows(job: &JobSpec) -> u64 {
    job.sample_count() * job.variant_count() * job.analysis.modes.len() as u64
}

/// The paths a job's switch search follows, over variants and modes: each grid line of
/// each swept input, or the trajectory. A path has about as many minima to refine
/// whatever its sampling, so the search costs about as much per path, not per row.
fn paths(job: &JobSpec) -> u64 {
    let per_mode = match &job.grid {
        Some(g) => {
            let lens = g.axes6().map(|r| r.len());
            let samples: u64 = lens.iter().product();
            lens.iter().filter(|&&n| n > 1).map(|&n| samples / n).sum::<u64>().max(1)
        }
        None => 1,
    };
    per_mode * job.variant_count() * job.analysis.modes.len() as u64
}

/// What [`estimate`] measured and what it makes of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// The whole run's estimated wall time (s).
    pub seconds: f64,
    /// The whole run's rows.
    pub rows: u64,
    /// The calibration runs, smallest first.
    pub runs: Vec<Calibration>,
    /// The rayon pool's threads the runs had.
    pub threads: usize,
}

/// One calibration run of [`estimate`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Calibration {
    pub rows: u64,
    /// The paths its switch search followed: each grid line of each swept input, or
    /// the trajectory, over variants and modes.
    pub paths: u64,
    /// Wall time, and the part of it the search took (s).
    pub seconds: f64,
    pub search: f64,
}

/// Rows of the first calibration run.
const FIRST_ROWS: f64 = 500.0;
/// Each calibration run has about this many times the rows of the one before.
const GROWTH: f64 = 4.0;
/// At most this many calibration runs.
const MOST_RUNS: usize = 8;

/// Runs `job` (named `file` in messages) scaled down ([`scaled`]: the whole extent
/// of every range, fewer samples) into `opts.out`, with `opts`' column set, solver,
/// compression and writer on the current rayon pool, at sizes growing
/// fourfold as long as the next is expected within `budget` seconds (two runs
/// at least), or up to the whole job. The estimate scales the search by the rows and
/// the paths it follows, and the rest by the rows. A calibration run that is
/// the whole job is the estimate. `opts.out` is replaced by each run and removed at
/// the end; `opts.shard` and `opts.resume` are ignored.
pub fn estimate(job: &JobSpec, file: &str, opts: &RunOptions, budget: f64) -> Result<Estimate, EngineError> {
    let total = rows(job);
    let opts = RunOptions { shard: None, resume: false, overwrite: true, ..opts.clone() };
    let mut runs: Vec<Calibration> = Vec::new();
    let mut scale = (FIRST_ROWS / total.max(1) as f64).min(1.0);
    let result = loop {
        let small = if scale >= 1.0 { job.clone() } else { scaled(job.clone(), scale) };
        let start = Instant::now();
        let report = match run(&small, file, &opts) {
            Ok(r) => r,
            Err(e) => break Err(e),
        };
        let seconds = start.elapsed().as_secs_f64();
        runs.push(Calibration { rows: rows(&small), paths: paths(&small), seconds, search: report.stages.search });
        // Two runs at least: one cannot tell the fixed cost from the cost per row. No
        // run expected to take longer than `budget`.
        if rows(&small) >= total || (seconds * GROWTH > budget && runs.len() >= 2) || runs.len() == MOST_RUNS {
            break Ok(());
        }
        scale = (scale * GROWTH).min(1.0);
    };
    let _ = std::fs::remove_dir_all(&opts.out);
    result?;
    let seconds = extrapolate(&runs, total, paths(job));
    Ok(Estimate { seconds, rows: total, runs, threads: rayon::current_num_threads() })
}

/// The whole run's time from the calibration runs, in two parts fitted through the
/// last two: the search, `c_r·rows + c_p·paths` (scanning the rows, refining the
/// minima each path has whatever its sampling), and the rest, `a + b·rows` (a fixed
/// cost and a cost per row). Coefficients are at least zero; where a fit cannot
/// give that, or with one run, the part is proportional to the rows (the search to
/// the paths if it is all per path). A run of `total` rows is the answer.
fn extrapolate(runs: &[Calibration], total: u64, total_paths: u64) -> f64 {
    let last = runs.last().expect("at least one calibration run");
    if last.rows >= total {
        return last.seconds;
    }
    let (rows, paths) = (total as f64, total_paths as f64);
    let rest = |c: &Calibration| (c.seconds - c.search).max(0.0);
    let per_row = |t: f64, c: &Calibration| t / c.rows.max(1) as f64 * rows;
    let Some(before) = runs.len().checked_sub(2).map(|i| &runs[i]) else {
        return per_row(last.search, last) + per_row(rest(last), last);
    };
    let (r1, p1, r2, p2) = (before.rows as f64, before.paths as f64, last.rows as f64, last.paths as f64);
    let search = {
        let det = r1 * p2 - r2 * p1;
        let c_r = (before.search * p2 - last.search * p1) / det;
        let c_p = (r1 * last.search - r2 * before.search) / det;
        if det != 0.0 && c_r >= 0.0 && c_p >= 0.0 && (c_r + c_p).is_finite() {
            c_r * rows + c_p * paths
        } else if c_r < 0.0 && det != 0.0 {
            last.search / p2.max(1.0) * paths
        } else {
            per_row(last.search, last)
        }
    };
    if last.rows <= before.rows || rest(last) <= rest(before) {
        return search + per_row(rest(last), last);
    }
    let slope = (rest(last) - rest(before)) / (r2 - r1);
    let intercept = (rest(before) - slope * r1).max(0.0);
    search + intercept + slope * rows
}

/// A calibration directory under `parent`, unique to this process.
pub fn calibration_dir(parent: &std::path::Path) -> PathBuf {
    parent.join(format!("clearance-check-{}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cal(rows: u64, seconds: f64) -> Calibration {
        Calibration { rows, paths: 1, seconds, search: 0.0 }
    }

    /// A fixed cost and a cost per row are told apart; what cannot be fitted is
    /// proportional; a whole-job run is the answer; the search scales by the paths.
    #[test]
    fn extrapolation() {
        // t = 0.1 + 1e-6·N, measured at 10k and 40k rows: 1 M rows take 1.1 s.
        let runs = [cal(10_000, 0.11), cal(40_000, 0.14)];
        assert!((extrapolate(&runs, 1_000_000, 1) - 1.1).abs() < 1e-12);
        // One run: proportional.
        assert!((extrapolate(&[cal(1_000, 0.5)], 4_000, 1) - 2.0).abs() < 1e-12);
        // Noise made the larger run faster: proportional to the last.
        assert!((extrapolate(&[cal(1_000, 0.5), cal(4_000, 0.4)], 8_000, 1) - 0.8).abs() < 1e-12);
        // A negative intercept is clamped to zero.
        assert!((extrapolate(&[cal(1_000, 0.05), cal(2_000, 0.2)], 3_000, 1) - 0.45).abs() < 1e-12);
        assert_eq!(extrapolate(&[cal(500, 0.01), cal(2_000, 0.3)], 2_000, 1), 0.3);
        // Search 0.1 s at (1k rows, 50 paths), 0.2 s at (4k, 100): all per path
        // (2 ms a path, nothing per row), so 1000 paths take 2 s; the rest is 0.2 s at
        // 1k rows and 0.4 s at 4k: 0.1333 + 6.667e-5·N.
        let per_path = [
            Calibration { rows: 1_000, paths: 50, seconds: 0.3, search: 0.1 },
            Calibration { rows: 4_000, paths: 100, seconds: 0.6, search: 0.2 },
        ];
        let expect = 2.0 + (0.2 - 0.2 / 3.0) + 0.2 / 3000.0 * 40_000.0;
        assert!((extrapolate(&per_path, 40_000, 1_000) - expect).abs() < 1e-12);
        // Search 0.1 s at (1k, 50), 0.4 s at (4k, 100): all per row (1e-4 s a row).
        let per_row = [
            Calibration { rows: 1_000, paths: 50, seconds: 0.3, search: 0.1 },
            Calibration { rows: 4_000, paths: 100, seconds: 0.8, search: 0.4 },
        ];
        let expect = 4.0 + (0.2 - 0.2 / 3.0) + 0.2 / 3000.0 * 40_000.0;
        assert!((extrapolate(&per_row, 40_000, 1_000) - expect).abs() < 1e-12);
    }

    /// The scaled job has about `scale` times the samples over every swept input.
    #[test]
    fn scaling_keeps_variants_and_shrinks_every_range() {
        let job = JobSpec::from_toml_str(
            "[grid]\nz = { start = 1.9, stop = 2.1, n = 10 }\npsi = { start = -0.3, stop = 0.3, n = 100 }\n\
             theta = { start = -0.3, stop = 0.3, n = 100 }\n[[sweep]]\nparam = \"mass.platform\"\nvalues = [5.0, 10.0]\n",
            "s.toml",
        )
        .unwrap();
        let small = scaled(job.clone(), 0.01);
        assert_eq!(small.variant_count(), 2);
        let ratio = small.sample_count() as f64 / job.sample_count() as f64;
        assert!((0.005..0.02).contains(&ratio), "{ratio}");
    }
}
