//! The run directory's layout, spelled once (docs/interface.md §4):
//!
//! ```text
//! DIR/
//!   job.toml                                        the job as run, after defaults
//!   poses/variant=K/part-<mode>-<chunk>.parquet     one row per (variant, mode, sample)
//!   discontinuities.parquet                         one row per refined switch
//!   summary.parquet                                 one row per (variant, mode)
//!   _stats/variant=K/<mode>-<chunk>.json            each part's partial statistics
//!   _stats/variant=K/<mode>-<chunk>.trace4          each part's discontinuity traces
//!   _stats/switches-I-of-N.bin                      the switches shard I found (sharded runs)
//!   _SUCCESS.shard-I-of-N                           shard I is done (sharded runs)
//!   _SUCCESS                                        written last
//! ```
//!
//! The run, `clearance status`, the plots and the benches all find their files here.
//!
//! ```
//! use clearance_engine::Layout;
//! use clearance_model::Mode;
//! let l = Layout::new("out/fig08");
//! assert_eq!(l.part(3, Mode::Kinetostatic, 12), std::path::Path::new("out/fig08/poses/variant=3/part-kinetostatic-000012.parquet"));
//! assert_eq!(Layout::parse_shard_marker("_SUCCESS.shard-2-of-8"), Some((2, 8)));
//! ```

use std::path::{Path, PathBuf};

use clearance_model::Mode;

/// The paths of one run directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    root: PathBuf,
}

impl Layout {
    /// The files a run owns besides the [`Layout::final_files`] and the shard
    /// markers, removed by `--overwrite`.
    pub const RUN_FILES: [&'static str; 2] = ["job.toml", "_SUCCESS"];
    /// The directories a run owns.
    pub const RUN_DIRS: [&'static str; 2] = ["poses", "_stats"];
    const FINAL_FILES: [&'static str; 2] = ["discontinuities.parquet", "summary.parquet"];
    const SHARD_PREFIX: &'static str = "_SUCCESS.shard-";

    pub fn new(root: impl Into<PathBuf>) -> Self {
        Self { root: root.into() }
    }

    /// The run directory itself.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The job as run, after defaults (provenance, and how `--resume` knows the job).
    pub fn job(&self) -> PathBuf {
        self.root.join("job.toml")
    }

    /// The Hive-partitioned poses dataset.
    pub fn poses(&self) -> PathBuf {
        self.root.join("poses")
    }

    /// The part files of variant `variant`.
    pub fn variant_dir(&self, variant: u64) -> PathBuf {
        self.poses().join(format!("variant={variant}"))
    }

    /// Part file `chunk` of (`variant`, `mode`).
    pub fn part(&self, variant: u64, mode: Mode, chunk: u64) -> PathBuf {
        self.variant_dir(variant).join(format!("part-{}-{chunk:06}.parquet", mode.name()))
    }

    /// The summary statistics of a part, written just before the part itself, so a
    /// complete part always has them (outside `poses/`, where dataset readers look).
    pub fn stats(&self, variant: u64, mode: Mode, chunk: u64) -> PathBuf {
        self.root.join("_stats").join(format!("variant={variant}")).join(format!("{}-{chunk:06}.json", mode.name()))
    }

    /// The discontinuity trace of each pose of a part, beside its statistics: the
    /// search at the end of the run reads these instead of solving every pose again.
    pub fn trace(&self, variant: u64, mode: Mode, chunk: u64) -> PathBuf {
        // The extension names the bits' meaning: a `.trace`, `.trace2` or `.trace3`
        // file of an older engine (whose bits differ: a `.trace3` cleared minima that
        // this search refines) is not read, but rebuilt under this name.
        self.stats(variant, mode, chunk).with_extension("trace4")
    }

    /// The switches shard `i` of `n` found on the grid lines it owns, which the step
    /// that finishes a sharded run merges instead of searching again.
    pub fn shard_switches(&self, i: u64, n: u64) -> PathBuf {
        self.root.join("_stats").join(format!("switches-{i}-of-{n}.bin"))
    }

    pub fn discontinuities(&self) -> PathBuf {
        self.root.join(Self::FINAL_FILES[0])
    }

    pub fn summary(&self) -> PathBuf {
        self.root.join(Self::FINAL_FILES[1])
    }

    /// `discontinuities.parquet` and `summary.parquet`, written when every part is in.
    pub fn final_files(&self) -> [PathBuf; 2] {
        [self.discontinuities(), self.summary()]
    }

    /// Written last: no `_SUCCESS`, no complete run.
    pub fn success(&self) -> PathBuf {
        self.root.join("_SUCCESS")
    }

    /// The marker of shard `i` of `n`.
    pub fn shard_marker(&self, i: u64, n: u64) -> PathBuf {
        self.root.join(format!("{}{i}-of-{n}", Self::SHARD_PREFIX))
    }

    /// `(i, n)` when `name` is the file name of a shard marker.
    pub fn parse_shard_marker(name: &str) -> Option<(u64, u64)> {
        let (i, n) = name.strip_prefix(Self::SHARD_PREFIX)?.split_once("-of-")?;
        Some((i.parse().ok()?, n.parse().ok()?))
    }

    /// Where `clearance plot` writes its figures by default.
    pub fn plots(&self) -> PathBuf {
        self.root.join("plots")
    }
}
