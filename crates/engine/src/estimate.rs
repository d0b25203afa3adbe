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
///
/// A sweep over clearance magnitudes solves each group of variants once
/// (docs/interface.md §3), so most of its rows cost only their writing: it is
/// estimated as its counterpart with one variant a group (each `clearance.*` sweep
/// cut to its largest value), calibrated as above, plus its other rows at what they
/// cost in one more run: the counterpart with as many variants a group as that run
/// can take within `budget` (2 to 16), at the size of the last calibration run, or
/// of the one before when the last is too slow to repeat several times over.
pub fn estimate(job: &JobSpec, file: &str, opts: &RunOptions, budget: f64) -> Result<Estimate, EngineError> {
    let opts = RunOptions { shard: None, resume: false, overwrite: true, ..opts.clone() };
    let result = match clearance_split(job) {
        None => calibrate(job, file, &opts, budget).map(|(runs, seconds, _)| (runs, seconds)),
        Some((counterpart, clearance_sweeps)) => {
            calibrate(&counterpart, file, &opts, budget).and_then(|(mut runs, base, scales)| {
                let last = runs.len() - 1;
                let at = if runs[last].seconds * 2.0 <= budget { last } else { last.saturating_sub(1) };
                let (reference, scale) = (runs[at], scales[at]);
                let members = (budget / reference.seconds.max(1e-9)).clamp(2.0, 16.0) as usize;
                let few = with_members(job, &clearance_sweeps, members);
                let small = if scale >= 1.0 { few } else { scaled(few, scale) };
                let run = time_run(&small, file, &opts)?;
                runs.push(run);
                if run.rows >= rows(job) {
                    return Ok((runs, run.seconds));
                }
                // What each row beyond one variant a group cost, at this size.
                let per_row = (run.seconds - reference.seconds).max(0.0) / (run.rows - reference.rows).max(1) as f64;
                Ok((runs, base + per_row * (rows(job) - rows(&counterpart)) as f64))
            })
        }
    };
    let _ = std::fs::remove_dir_all(&opts.out);
    let (runs, seconds) = result?;
    Ok(Estimate { seconds, rows: rows(job), runs, threads: rayon::current_num_threads() })
}

/// For a job whose sweeps over `clearance.*` make groups of several variants (and
/// that does not ask for exact errors, which are never grouped): the job with each
/// such sweep cut to one value, its largest (so that every swept kind that can be
/// non-zero is, and the search follows it), one variant a group; and the indices of
/// those sweeps.
fn clearance_split(job: &JobSpec) -> Option<(JobSpec, Vec<usize>)> {
    let sweeps: Vec<usize> = (0..job.sweep.len()).filter(|&i| job.sweep[i].param.starts_with("clearance.")).collect();
    let members: usize = sweeps.iter().map(|&i| job.sweep[i].values.len()).product();
    if job.analysis.exact || members < 2 {
        return None;
    }
    let mut counterpart = job.clone();
    for &i in &sweeps {
        let values = &mut counterpart.sweep[i].values;
        *values = vec![values.iter().copied().fold(f64::NEG_INFINITY, f64::max)];
    }
    Some((counterpart, sweeps))
}

/// `job` with its `clearance_sweeps` cut to about `members` variants a group (at
/// least one value each, the first sweeps kept longest).
fn with_members(job: &JobSpec, clearance_sweeps: &[usize], members: usize) -> JobSpec {
    let mut few = job.clone();
    let mut room = members;
    for &i in clearance_sweeps {
        let values = &mut few.sweep[i].values;
        values.truncate(room.max(1));
        room /= values.len();
    }
    few
}

/// One run of `job` into `opts.out`, timed.
fn time_run(job: &JobSpec, file: &str, opts: &RunOptions) -> Result<Calibration, EngineError> {
    let start = Instant::now();
    let report = run(job, file, opts)?;
    let seconds = start.elapsed().as_secs_f64();
    Ok(Calibration { rows: rows(job), paths: paths(job), seconds, search: report.stages.search })
}

/// The calibration runs of [`estimate`], the estimate they give, and the scale of
/// each run (1: the whole job).
fn calibrate(
    job: &JobSpec,
    file: &str,
    opts: &RunOptions,
    budget: f64,
) -> Result<(Vec<Calibration>, f64, Vec<f64>), EngineError> {
    let total = rows(job);
    let (mut runs, mut scales) = (Vec::new(), Vec::new());
    let mut scale = (FIRST_ROWS / total.max(1) as f64).min(1.0);
    loop {
        let small = if scale >= 1.0 { job.clone() } else { scaled(job.clone(), scale) };
        let run = time_run(&small, file, opts)?;
        runs.push(run);
        scales.push(scale);
        // Two runs at least: one cannot tell the fixed cost from the cost per row. No
        // run expected to take longer than `budget`.
        if run.rows >= total || (run.seconds * GROWTH > budget && runs.len() >= 2) || runs.len() == MOST_RUNS {
            break;
        }
        scale = (scale * GROWTH).min(1.0);
    }
    let seconds = extrapolate(&runs, total, paths(job));
    Ok((runs, seconds, scales))
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

    /// A clearance sweep splits into its counterpart with one variant a group (every
    /// swept kind at its largest value), and can be cut to a few variants a group;
    /// other sweeps and exact errors do not split.
    #[test]
    fn clearance_sweeps_split_into_one_and_a_few_variants_a_group() {
        let text = |extra: &str| {
            format!(
                "[grid]\nz = 2.0\npsi = {{ start = -0.3, stop = 0.3, n = 10 }}\ntheta = 0.0\n{extra}\
                 [[sweep]]\nparam = \"mass.platform\"\nvalues = [5.0, 10.0, 20.0]\n\
                 [[sweep]]\nparam = \"clearance.r_axial\"\nvalues = [0.0, 3e-4, 1e-4]\n\
                 [[sweep]]\nparam = \"clearance.s_radial\"\nvalues = [1e-4, 2e-4, 4e-4]\n"
            )
        };
        let job = JobSpec::from_toml_str(&text(""), "s.toml").unwrap();
        let (one, sweeps) = clearance_split(&job).unwrap();
        assert_eq!(sweeps, [1, 2]);
        assert_eq!(one.variant_count(), 3);
        assert_eq!(one.sweep[0].values, job.sweep[0].values);
        assert_eq!(one.sweep[1].values, [3e-4]);
        assert_eq!(one.sweep[2].values, [4e-4]);
        let few = with_members(&job, &sweeps, 4);
        assert_eq!(few.variant_count(), 3 * 3);
        assert_eq!(few.sweep[0].values, job.sweep[0].values);
        assert_eq!(few.sweep[1].values, [0.0, 3e-4, 1e-4]);
        assert_eq!(few.sweep[2].values, [1e-4]);
        assert_eq!(with_members(&job, &sweeps, 16).variant_count(), 3 * 9);
        assert_eq!(with_members(&job, &sweeps, 2).sweep[1].values, [0.0, 3e-4]);
        let exact = JobSpec::from_toml_str(&text("[analysis]\nexact = true\n"), "s.toml").unwrap();
        assert!(clearance_split(&exact).is_none());
        let mut masses_only = job.clone();
        masses_only.sweep.truncate(1);
        assert!(clearance_split(&masses_only).is_none());
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
