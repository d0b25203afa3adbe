//! What the engine's integration tests share: run options, a job of `jobs/` edited,
//! and reading a run's Parquet files back with the `parquet` crate's Arrow reader.
//! Each test file uses some of it.
#![allow(dead_code)]

use std::fs::File;
use std::path::{Path, PathBuf};

use arrow::array::{Array, RecordBatch};
use arrow::compute::concat_batches;
use clearance_engine::{Codec, ColumnSet, Reporter, RunOptions, SolverKind, Writer};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

/// A whole run into `out`: full columns, parts of 65 536 samples, the fast solver,
/// zstd, the engine's writer, buffered I/O, no shard, no resume.
pub fn options(out: &Path) -> RunOptions {
    RunOptions {
        out: out.to_path_buf(),
        columns: ColumnSet::Full,
        shard: None,
        resume: false,
        overwrite: false,
        chunk_size: 65536,
        solver: SolverKind::Fast,
        compression: Codec::Zstd,
        writer: Writer::Engine,
        precision: clearance_engine::Precision::Double,
        progress: Reporter::default(),
        direct_io: false,
        search: true,
        poses: true,
    }
}

/// One Parquet file as one batch (a file without rows gives its schema, empty).
pub fn read(path: &Path) -> RecordBatch {
    let builder = ParquetRecordBatchReaderBuilder::try_new(File::open(path).unwrap()).unwrap();
    let schema = builder.schema().clone();
    let batches: Vec<RecordBatch> = builder.build().unwrap().map(|b| b.unwrap()).collect();
    concat_batches(&schema, &batches).unwrap()
}

/// Part files, in the order given, as one batch.
pub fn read_parts(paths: impl IntoIterator<Item = PathBuf>) -> RecordBatch {
    let batches: Vec<RecordBatch> = paths.into_iter().map(|p| read(&p)).collect();
    concat_batches(&batches[0].schema(), &batches).unwrap()
}

/// `text` with `from` replaced by `to`; `from` must be in it (a job of `jobs/` edited
/// for a test fails loudly when the job changes under it).
pub fn replaced(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "the job has `{from}`");
    text.replace(from, to)
}

/// Column `name` of `b` as its array type.
pub fn column<'a, T: 'static>(b: &'a RecordBatch, name: &str) -> &'a T {
    b.column_by_name(name).unwrap_or_else(|| panic!("no {name}")).as_any().downcast_ref().unwrap()
}

/// `job`, a description of a built-in 3-PRS or 6-UPS (as `describe` writes it), with a
/// body written another way: each 3-PRS leg's centre of mass written out where the
/// description leaves the default (the midpoint of the leg's joints), each 6-UPS
/// cylinder's inertia left to the default (a slender rod between its U and P joints,
/// which it is). The same mechanism, which is then not recognised as the built-in
/// kind's, so that its poses go the description's general way and not through that
/// kind's kernel (docs/model.md §12.10).
pub fn general_path(job: &clearance_engine::JobSpec) -> clearance_engine::JobSpec {
    let mut out = job.clone();
    for limb in out.mechanism.limb.as_mut().expect("a description").iter_mut() {
        let n = limb.joints.len();
        if limb.joints[0].joint == clearance_model::custom::JointType::U {
            limb.bodies[0].inertia = None;
            continue;
        }
        for (k, body) in limb.bodies.iter_mut().enumerate().filter(|(k, _)| k + 1 < n) {
            if body.com.is_none() {
                let (a, b) = (limb.joints[k].at, limb.joints[k + 1].at);
                body.com = Some(std::array::from_fn(|i| (a[i] + b[i]) / 2.0));
            }
        }
    }
    assert!(!clearance_engine::uses_kernel(&out, "general.toml").unwrap(), "the kernel still applies");
    out
}

/// The family of a column whose values share a scale (loads: reactions and margins;
/// errors: errors and envelopes), for [`ColumnScales`].
pub fn family(name: &str) -> Option<&'static str> {
    if ["f_", "m_", "margin_", "tau"].iter().any(|p| name.starts_with(p)) {
        Some("loads")
    } else if ["err_", "env_", "exact_err_"].iter().any(|p| name.starts_with(p)) {
        Some("errors")
    } else {
        None
    }
}

/// The largest magnitude among a column's valid values (0 if none).
pub fn largest(a: &arrow::array::Float64Array) -> f64 {
    (0..a.len()).filter(|&r| a.is_valid(r)).map(|r| a.value(r).abs()).fold(0.0, f64::max)
}

/// Each column's scale in a reference batch: its largest value, or a hundredth of its
/// family's (see [`family`]) where that is larger, so that a column zero to round-off
/// (a couple along an axis that transmits none) is measured against its run's loads
/// or errors.
pub struct ColumnScales(std::collections::HashMap<&'static str, f64>);

impl ColumnScales {
    pub fn of(reference: &RecordBatch) -> Self {
        let mut families = std::collections::HashMap::new();
        for (i, field) in reference.schema().fields().iter().enumerate() {
            let a = reference.column(i).as_any().downcast_ref::<arrow::array::Float64Array>();
            if let (Some(f), Some(a)) = (family(field.name()), a) {
                let e = families.entry(f).or_insert(0.0f64);
                *e = e.max(largest(a));
            }
        }
        Self(families)
    }

    /// Asserts column `name` of the other run (`y`) equal to the reference's (`x`):
    /// strings and nulls exactly, numbers within `tol` of the column's scale. Returns
    /// how many numbers differ in their bits, or `None` for a column of another type
    /// (not compared).
    pub fn assert_close(&self, name: &str, x: &dyn Array, y: &dyn Array, tol: f64) -> Option<usize> {
        use arrow::array::{Float64Array, StringArray};
        if let (Some(x), Some(y)) = (x.as_any().downcast_ref::<StringArray>(), y.as_any().downcast_ref::<StringArray>())
        {
            for r in 0..x.len() {
                let (a, b) = (x.is_valid(r).then(|| x.value(r)), y.is_valid(r).then(|| y.value(r)));
                assert_eq!(a, b, "{name} row {r}");
            }
            return Some(0);
        }
        let (x, y) = (x.as_any().downcast_ref::<Float64Array>()?, y.as_any().downcast_ref::<Float64Array>()?);
        let scale = largest(x).max(family(name).map_or(0.0, |f| 1e-2 * self.0[f]));
        let mut differing = 0;
        for r in 0..x.len() {
            assert_eq!(x.is_valid(r), y.is_valid(r), "{name} row {r}: null in one run only");
            if x.is_valid(r) {
                let d = (x.value(r) - y.value(r)).abs();
                differing += usize::from(x.value(r) != y.value(r));
                assert!(
                    d <= tol * scale.max(1e-300),
                    "{name} row {r}: {} vs {} (scale {scale:e})",
                    x.value(r),
                    y.value(r)
                );
            }
        }
        Some(differing)
    }
}
