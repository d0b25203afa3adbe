//! The run loop of the mechanisms whose units are solved a work at a time and written
//! as record batches or as pages encoded as they are solved: the 6-UPS
//! ([`crate::ups`]) and any mechanism from its joints ([`crate::custom`]). What
//! differs between them (how a work is solved, its units' rows and statistics, what
//! the search keeps, the search, the run's tables) is a [`UnitRun`]; the plan, the
//! order of solving and writing, progress, the sync, shards and resume are
//! [`run_units`], once for both.
//!
//! The order: each work is solved on the pool while the last part of the work before
//! is written (writing a part is partly serial: its file, its footer); a work's other
//! units are written as they are built. Without shards the run's last part is written
//! while the search runs, which reads what the pass kept rather than the files.

use std::path::PathBuf;
use std::time::Instant;

use arrow::record_batch::RecordBatch;
use clearance_parquet::{CustomPages, Landing, ParquetError, WriteOptions, write_bytes, write_custom_part};
use std::sync::Arc;

use crate::error::EngineError;
use crate::layout::Layout;
use crate::run::{
    RunOptions, RunReport, Setup, StageTimes, Unit, Work, mark_shard_done, part_metadata, sync_units, write_marker,
};

type Result<T, E = EngineError> = std::result::Result<T, E>;

/// What a kind of mechanism brings to [`run_units`].
pub(crate) trait UnitRun {
    /// A work's solution, from which its units' rows and statistics are built.
    type Solved: Send;
    /// The switches of every (group or variant, mode), from [`UnitRun::searches`].
    type Found: Send + Default;

    /// Solves work `w` on the current rayon pool; `spare` is an earlier work's
    /// solution ([`UnitRun::done`]), whose memory it may reuse.
    fn solve(&self, w: &Work, spare: Option<Self::Solved>) -> Self::Solved;

    /// Takes in a solved work before its units are built (what the search keeps of
    /// its samples, say).
    fn solved(&mut self, _w: &Work, _solved: &Self::Solved) {}

    /// Unit `k` of `w`: its part's rows (only when `poses`) and its statistics file's
    /// bytes. It may take the unit's own results out of `solved`.
    fn unit(&mut self, w: &Work, k: usize, solved: &mut Self::Solved, poses: bool) -> (Option<PartRows>, Vec<u8>);

    /// The work's solution once every unit is built: what the next work may reuse.
    fn done(&mut self, solved: Self::Solved) -> Option<Self::Solved> {
        drop(solved);
        None
    }

    /// The search over every (group or variant, mode) from what was kept (solving
    /// what was not), and the seconds it took.
    fn searches(&mut self) -> (Self::Found, f64);

    /// `summary.parquet` and `discontinuities.parquet` of a run whose units are all
    /// written, with the switches `found`.
    fn finalize(
        &self,
        layout: &Layout,
        all: &[Unit],
        write_opts: &WriteOptions,
        found: Self::Found,
        stages: &mut StageTimes,
    ) -> Result<()>;
}

/// A unit's rows, to write as its part file.
pub(crate) enum PartRows {
    /// Its columns, to encode.
    Batch(RecordBatch),
    /// A custom run's rows, their pages encoded.
    Pages(Box<CustomPages>),
}

/// A unit's part file and statistics, written together.
struct Written {
    part: PathBuf,
    stats_path: PathBuf,
    stats: Vec<u8>,
    rows: Option<PartRows>,
    meta: Vec<(String, String)>,
    poses: u64,
}

/// Waits for a run's background files when it ends, on every path: nothing is
/// written after the run returns (their failures are reported where the run waits
/// for them first, before it syncs them).
struct Landed<'a>(&'a Landing);

impl Drop for Landed<'_> {
    fn drop(&mut self) {
        let _ = self.0.wait();
    }
}

/// Runs the plan of `setup` (from [`crate::run::prepare_run`]) with `r`.
pub(crate) fn run_units<R: UnitRun + Send + Sync>(r: &mut R, opts: &RunOptions, setup: &Setup) -> Result<RunReport> {
    let Setup { variants, layout, mine, all, todo_work, mine_poses, todo_poses, total, write_opts, .. } = setup;
    let progress = opts.progress.get();
    progress.start(*mine_poses, mine_poses - todo_poses);
    let start = Instant::now();
    let mut done = mine_poses - todo_poses;
    let mut stages = StageTimes::default();
    // The part files go to the disk on threads of their own: a pool worker that
    // waited on a direct write computed nothing meanwhile. They are all in place
    // before the run syncs them, and before it returns, whatever it returns.
    let landing = Landing::new();
    let _landed = Landed(&landing);
    let write_opts = &WriteOptions { landing: Some(Arc::clone(&landing)), ..write_opts.clone() };
    // Returns the unit's poses and the seconds it took (its copy, not its disk time).
    let write_unit = |w: Written| -> Result<(u64, f64)> {
        // A part that failed in the background stops the run here, not at its end.
        landing.failure().map_err(|(path, source)| ParquetError::Io { path, source })?;
        let writing = Instant::now();
        for dir in [w.part.parent().filter(|_| w.rows.is_some()), w.stats_path.parent()].into_iter().flatten() {
            std::fs::create_dir_all(dir).map_err(EngineError::io("create", dir))?;
        }
        write_bytes(&w.stats_path, &w.stats, write_opts)?;
        match &w.rows {
            Some(PartRows::Batch(batch)) => {
                crate::run::write_part_batch(opts.writer, opts.precision, &w.part, batch, write_opts, &w.meta)?
            }
            Some(PartRows::Pages(pages)) => write_custom_part(&w.part, pages, write_opts, &w.meta)?,
            None => {}
        }
        Ok((w.poses, writing.elapsed().as_secs_f64()))
    };
    let written = |stages: &mut StageTimes, done: &mut u64, (poses, secs): (u64, f64)| {
        stages.writing += secs;
        *done += poses;
        progress.advance(poses, *done);
    };
    let mut pending: Option<Written> = None;
    let mut spare: Option<R::Solved> = None;
    for w in todo_work {
        let u0 = &w.units[0];
        progress.stage(&format!("variant {} {}", u0.variant, u0.mode.name()));
        let pose_pass = Instant::now();
        let (earlier, reused) = (pending.take(), spare.take());
        let solver: &R = r;
        let (mut solved, earlier) = rayon::join(|| solver.solve(w, reused), || earlier.map(write_unit));
        if let Some(earlier) = earlier {
            written(&mut stages, &mut done, earlier?);
        }
        r.solved(w, &solved);
        stages.pose_pass += pose_pass.elapsed().as_secs_f64();
        for (k, u) in w.units.iter().enumerate() {
            let pose_pass = Instant::now();
            let (rows, stats) = r.unit(w, k, &mut solved, opts.poses);
            stages.pose_pass += pose_pass.elapsed().as_secs_f64();
            let unit = Written {
                part: layout.part(u.variant, u.mode, u.chunk),
                stats_path: layout.stats(u.variant, u.mode, u.chunk),
                stats,
                rows,
                meta: part_metadata(&variants[u.variant as usize]),
                poses: u.range.end - u.range.start,
            };
            if let Some(p) = pending.replace(unit) {
                written(&mut stages, &mut done, write_unit(p)?);
            }
        }
        spare = r.done(solved);
    }
    // Without shards the run is complete once its last unit is written: the search,
    // which reads what the pass kept (or solves), runs while it is.
    let early = opts.shard.is_none() && opts.search && pending.is_some();
    let (last, searched) = rayon::join(|| pending.take().map(write_unit), || early.then(|| r.searches()));
    if let Some(last) = last {
        written(&mut stages, &mut done, last?);
    }
    progress.finish();
    let syncing = Instant::now();
    landing.wait().map_err(|(path, source)| ParquetError::Io { path, source })?;
    sync_units(layout, mine, &[])?;
    stages.writing += syncing.elapsed().as_secs_f64();
    let complete = mark_shard_done(layout, opts)?;
    if complete {
        progress.searching();
        let durable = WriteOptions { durable: true, ..write_opts.clone() };
        // Searched here where it did not run beside the last write (shards, resumed
        // runs with nothing left to compute); not at all without `RunOptions::search`.
        let (found, seconds) = match searched {
            Some(s) => s,
            None if opts.search => r.searches(),
            None => (R::Found::default(), 0.0),
        };
        stages.search += seconds;
        r.finalize(layout, all, &durable, found, &mut stages)?;
        write_marker(&layout.success())?;
    }
    Ok(RunReport { computed: *todo_poses, total: *total, seconds: start.elapsed().as_secs_f64(), complete, stages })
}
