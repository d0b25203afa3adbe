//! A finished run directory: its job, its variants and their pose errors.
//!
//! Only what the figures need is read: the `sample` and `mode` identity and the
//! error columns (`err_<c>`, `err_<kind>_<c>`, `env_<c>`, `dominant`) that the files hold, projected at
//! the Parquet level so a `full` run costs no more than a `minimal` one. Rows are
//! placed by their `sample` number, so part files can come in any order; on a grid
//! only the first `z` value is kept (the figures are maps over Ψ–Θ at one `z`).
//! Grids finer than [`MAX_MAP_AXIS`] lines per axis and trajectories longer than
//! [`MAX_TRAJECTORY_POINTS`] are decimated while reading: a figure cannot show more,
//! and a 50-million-pose run must not need gigabytes to plot.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};

use arrow::array::{Array, ArrayRef, Float64Array, StringArray, UInt64Array};
use arrow::compute::cast;
use arrow::datatypes::DataType;
use clearance_engine::Layout as RunLayout;
use clearance_grid::SampleSource;
use clearance_model::{JobSpec, KINDS, Variant, joint_name};
use parquet::arrow::ProjectionMask;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use crate::PlotError;
use crate::figure::COMPONENTS;

/// A run directory with its job parsed and its sweeps expanded.
pub(crate) struct RunDir {
    pub layout: RunLayout,
    pub job: JobSpec,
    pub variants: Vec<Variant>,
}

impl RunDir {
    /// Opens `dir`, refusing anything but a complete run (`_SUCCESS` present).
    pub fn open(dir: &Path) -> Result<Self, PlotError> {
        let not_a_run = |why: &str| PlotError::NotARun { dir: dir.to_path_buf(), why: why.to_string() };
        let layout = RunLayout::new(dir);
        let job_path = layout.job();
        if !job_path.is_file() {
            return Err(not_a_run("no job.toml"));
        }
        if !layout.success().is_file() {
            return Err(not_a_run("no _SUCCESS (the run, or one of its shards, has not finished)"));
        }
        let text = std::fs::read_to_string(&job_path).map_err(PlotError::io(&job_path))?;
        let file = job_path.display().to_string();
        let job = JobSpec::from_toml_str(&text, &file)?;
        if job.mechanism.kind == clearance_model::MechanismKind::Ups6 {
            return Err(PlotError::Unsupported {
                dir: dir.to_path_buf(),
                why: "a 6-UPS run has no figures yet; its Parquet files (poses/, summary.parquet, \
                      discontinuities.parquet) read with pyarrow, Polars or DuckDB"
                    .to_string(),
            });
        }
        let variants = job.variants(&file)?;
        Ok(Self { layout, job, variants })
    }

    /// The part files of variant `k`, sorted by name (hidden temporaries skipped).
    pub fn part_files(&self, k: u64) -> Result<Vec<PathBuf>, PlotError> {
        let dir = self.layout.variant_dir(k);
        let mut files = Vec::new();
        for entry in std::fs::read_dir(&dir).map_err(PlotError::io(&dir))? {
            let path = entry.map_err(PlotError::io(&dir))?.path();
            let name = path.file_name().unwrap_or_default().to_string_lossy();
            if !name.starts_with('.') && name.ends_with(".parquet") {
                files.push(path);
            }
        }
        files.sort();
        Ok(files)
    }
}

/// Samples kept per map axis: a panel is about 380 pixels wide, so a finer grid
/// is decimated at read time (every k-th grid line) instead of filling memory.
pub(crate) const MAX_MAP_AXIS: u64 = 800;
/// Samples kept along a trajectory, for the same reason.
pub(crate) const MAX_TRAJECTORY_POINTS: u64 = 20_000;

/// Every `stride`-th of `n` indices keeps at most `max` of them (and the last
/// one whenever `n − 1` is a multiple of the stride).
fn stride(n: u64, max: u64) -> u64 {
    if n <= max { 1 } else { (n - 1).div_ceil(max - 1) }
}

/// Where a sample's row goes in the per-mode arrays.
#[derive(Clone, Debug)]
pub(crate) enum Layout {
    /// The Ψ–Θ plane at the first `z`, every `strides`-th grid line:
    /// slot `(i_ψ/s_ψ)·len(theta) + i_θ/s_θ`. `psi`, `theta` hold the kept values.
    Grid { z0: f64, psi: Vec<f64>, theta: Vec<f64>, n_theta: u64, strides: [u64; 2] },
    /// Every `stride`-th sample of the trajectory: slot `sample/stride`.
    Trajectory { samples: Vec<u64>, stride: u64 },
}

impl Layout {
    pub fn of(source: &SampleSource) -> Self {
        match source.grid_shape() {
            Some([_, n_psi, n_theta]) => {
                let strides = [stride(n_psi, MAX_MAP_AXIS), stride(n_theta, MAX_MAP_AXIS)];
                Layout::Grid {
                    z0: source.sample(0).z[0],
                    psi: (0..n_psi).step_by(strides[0] as usize).map(|i| source.sample(i * n_theta).psi[0]).collect(),
                    theta: (0..n_theta).step_by(strides[1] as usize).map(|i| source.sample(i).theta[0]).collect(),
                    n_theta,
                    strides,
                }
            }
            None => {
                let stride = stride(source.len(), MAX_TRAJECTORY_POINTS);
                Layout::Trajectory { samples: (0..source.len()).step_by(stride as usize).collect(), stride }
            }
        }
    }

    pub fn slots(&self) -> usize {
        match self {
            Layout::Grid { psi, theta, .. } => psi.len() * theta.len(),
            Layout::Trajectory { samples, .. } => samples.len(),
        }
    }

    /// The slot of `sample`; `None` for samples at another `z` or between kept lines.
    fn slot(&self, sample: u64) -> Option<usize> {
        match self {
            Layout::Grid { psi, theta, n_theta, strides, .. } => {
                let (i_psi, i_theta) = (sample / n_theta, sample % n_theta);
                let (j_psi, j_theta) = (i_psi / strides[0], i_theta / strides[1]);
                let kept = i_psi % strides[0] == 0 && i_theta % strides[1] == 0;
                // Rows past the first z plane have j_psi ≥ len(psi).
                (kept && j_psi < psi.len() as u64).then(|| (j_psi as usize) * theta.len() + j_theta as usize)
            }
            Layout::Trajectory { stride, .. } => sample.is_multiple_of(*stride).then_some((sample / stride) as usize),
        }
    }
}

/// The error columns of one (variant, mode), indexed by slot; NaN where the
/// file holds a null (a status other than `ok`) or no row.
pub(crate) struct ModeData {
    pub mode: String,
    pub columns: BTreeMap<String, Vec<f64>>,
    /// Slots that some file filled.
    pub rows: usize,
}

impl ModeData {
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns.get(name).map(Vec::as_slice)
    }
}

/// Every error column a figure may draw.
fn wanted_columns() -> Vec<String> {
    let mut names: Vec<String> = COMPONENTS.iter().map(|c| format!("err_{}", c.suffix)).collect();
    for kind in KINDS {
        for c in COMPONENTS {
            names.push(format!("err_{}_{}", kind.name(), c.suffix));
        }
    }
    names.extend(crate::figure::ENVELOPE_COMPONENTS.iter().map(|c| format!("env_{}", c.suffix)));
    names.push(DOMINANT.to_string());
    names
}

/// The string column of the joint that moves P most; read as its place in
/// [`joints`] (a category number stored as `f64`, NaN for a null or a name the
/// engine does not write).
pub(crate) const DOMINANT: &str = "dominant";

/// Every joint the `dominant` column can name, kind by kind, limb by limb: a
/// category keeps its place (and its colour) whichever joints a run holds.
pub(crate) fn joints() -> Vec<String> {
    (0..KINDS.len()).flat_map(|k| (0..3).map(move |j| joint_name(k, j))).collect()
}

/// A column of `batch` as `f64` values: numbers cast, the `dominant` names as
/// their place in [`joints`].
fn values_of(path: &Path, name: &str, a: &ArrayRef, joints: &[String]) -> Result<Float64Array, PlotError> {
    if name != DOMINANT {
        return to_f64(path, name, a);
    }
    let names = to_utf8(path, name, a)?;
    Ok(names
        .iter()
        .map(|n| Some(n.and_then(|n| joints.iter().position(|j| j == n)).map_or(f64::NAN, |i| i as f64)))
        .collect())
}

/// Reads the poses of variant `k`, one [`ModeData`] per mode, in the job's mode order.
pub(crate) fn read_variant(run: &RunDir, k: u64, layout: &Layout) -> Result<Vec<ModeData>, PlotError> {
    let wanted = wanted_columns();
    let mut modes: BTreeMap<String, ModeData> = BTreeMap::new();
    for path in run.part_files(k)? {
        read_part(&path, layout, &wanted, &mut modes)?;
    }
    let order: Vec<&str> = run.job.analysis.modes.iter().map(|m| m.name()).collect();
    let mut out: Vec<ModeData> = modes.into_values().collect();
    out.sort_by_key(|m| order.iter().position(|o| *o == m.mode).unwrap_or(usize::MAX));
    Ok(out)
}

fn read_part(
    path: &Path,
    layout: &Layout,
    wanted: &[String],
    modes: &mut BTreeMap<String, ModeData>,
) -> Result<(), PlotError> {
    let pq = |source| PlotError::Parquet { path: path.to_path_buf(), source };
    let file = File::open(path).map_err(PlotError::io(path))?;
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).map_err(pq)?;
    let fields = builder.schema().fields().clone();
    let keep: Vec<usize> = fields
        .iter()
        .enumerate()
        .filter(|(_, f)| {
            let n = f.name();
            n == "sample" || n == "mode" || wanted.iter().any(|w| w == n)
        })
        .map(|(i, _)| i)
        .collect();
    let mask = ProjectionMask::roots(builder.parquet_schema(), keep);
    let reader = builder.with_projection(mask).with_batch_size(64 * 1024).build().map_err(pq)?;
    // A file without a `mode` column (not written by this engine) takes it from its name.
    let fallback_mode = path
        .file_name()
        .and_then(|n| n.to_str())
        .and_then(|n| n.strip_prefix("part-"))
        .and_then(|n| n.split('-').next())
        .unwrap_or("kinetostatic")
        .to_string();
    let slots = layout.slots();
    let joints = joints();
    for batch in reader {
        let batch = batch.map_err(|source| PlotError::Arrow { path: path.to_path_buf(), source })?;
        let sample = batch.column_by_name("sample").ok_or_else(|| column_error(path, "sample", "missing"))?;
        let sample = to_u64(path, "sample", sample)?;
        let mode = match batch.column_by_name("mode") {
            Some(m) => Some(to_utf8(path, "mode", m)?),
            None => None,
        };
        let schema = batch.schema();
        let values: Vec<(&str, Float64Array)> = schema
            .fields()
            .iter()
            .zip(batch.columns())
            .filter(|(f, _)| wanted.iter().any(|w| w == f.name()))
            .map(|(f, a)| Ok((f.name().as_str(), values_of(path, f.name(), a, &joints)?)))
            .collect::<Result<_, PlotError>>()?;
        let mode_of = |row: usize| match &mode {
            Some(m) if m.is_valid(row) => m.value(row),
            _ => fallback_mode.as_str(),
        };
        // Rows of one file share their mode; group anyway, it costs one pass.
        let mut distinct: Vec<&str> = Vec::new();
        for row in 0..batch.num_rows() {
            let m = mode_of(row);
            if !distinct.contains(&m) {
                distinct.push(m);
            }
        }
        for m in distinct {
            let data = modes.entry(m.to_string()).or_insert_with(|| ModeData {
                mode: m.to_string(),
                columns: BTreeMap::new(),
                rows: 0,
            });
            for (name, _) in &values {
                data.columns.entry(name.to_string()).or_insert_with(|| vec![f64::NAN; slots]);
            }
            for row in (0..batch.num_rows()).filter(|&r| mode_of(r) == m) {
                if !sample.is_valid(row) {
                    return Err(column_error(path, "sample", "holds a null"));
                }
                let s = sample.value(row);
                let Some(slot) = layout.slot(s) else { continue };
                if slot >= slots {
                    return Err(column_error(
                        path,
                        "sample",
                        &format!("sample {s} is beyond the job's {slots} samples"),
                    ));
                }
                data.rows += 1;
                for (name, array) in &values {
                    let col = data.columns.get_mut(*name).expect("created above");
                    col[slot] = if array.is_valid(row) { array.value(row) } else { f64::NAN };
                }
            }
        }
    }
    Ok(())
}

pub(crate) fn column_error(path: &Path, column: &str, why: &str) -> PlotError {
    PlotError::Column { path: path.to_path_buf(), column: column.to_string(), why: why.to_string() }
}

fn cast_to(path: &Path, name: &str, a: &ArrayRef, to: &DataType) -> Result<ArrayRef, PlotError> {
    cast(a, to).map_err(|e| column_error(path, name, &format!("not convertible to {to}: {e}")))
}

pub(crate) fn to_f64(path: &Path, name: &str, a: &ArrayRef) -> Result<Float64Array, PlotError> {
    let c = cast_to(path, name, a, &DataType::Float64)?;
    Ok(c.as_any().downcast_ref::<Float64Array>().expect("cast to Float64").clone())
}

pub(crate) fn to_u64(path: &Path, name: &str, a: &ArrayRef) -> Result<UInt64Array, PlotError> {
    let c = cast_to(path, name, a, &DataType::UInt64)?;
    Ok(c.as_any().downcast_ref::<UInt64Array>().expect("cast to UInt64").clone())
}

pub(crate) fn to_utf8(path: &Path, name: &str, a: &ArrayRef) -> Result<StringArray, PlotError> {
    let c = cast_to(path, name, a, &DataType::Utf8)?;
    Ok(c.as_any().downcast_ref::<StringArray>().expect("cast to Utf8").clone())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fine_grids_keep_every_kth_line_including_the_last() {
        assert_eq!(stride(201, 800), 1);
        assert_eq!(stride(2001, 800), 3);
        let layout = Layout::Grid { z0: 0.0, psi: vec![0.0; 4], theta: vec![0.0; 3], n_theta: 5, strides: [2, 2] };
        // 7 × 5 plane: ψ lines 0, 2, 4, 6; θ lines 0, 2, 4.
        assert_eq!(layout.slot(0), Some(0));
        assert_eq!(layout.slot(4), Some(2));
        assert_eq!(layout.slot(2 * 5 + 2), Some(4));
        assert_eq!(layout.slot(6 * 5 + 4), Some(11));
        assert_eq!(layout.slot(1), None);
        assert_eq!(layout.slot(5), None);
        assert_eq!(layout.slot(7 * 5), None, "the next z plane");
        let t = Layout::Trajectory { samples: vec![0, 3, 6], stride: 3 };
        assert_eq!((t.slot(6), t.slot(4)), (Some(2), None));
    }
}
