//! A finished run directory: its job, its variants and their pose errors.
//!
//! Only what the figures need is read: the `sample` and `mode` identity and the
//! error columns (`err_<c>`, `err_<kind>_<c>`, `env_<c>`, `dominant`) that the files hold, projected at
//! the Parquet level so a `full` run costs no more than a `minimal` one. Rows are
//! placed by their `sample` number, so part files can come in any order; on a grid
//! only the rows of one [`Plane`] are kept (the figures are maps over Ψ–Θ at the
//! first `z`, or over a 6-UPS grid's first two swept inputs at the first value of
//! the others).
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
use clearance_model::{JobSpec, MechanismKind, Variant};
use parquet::arrow::ProjectionMask;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use crate::PlotError;
use crate::figure::{COMPONENTS, INPUTS};

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

/// One axis of a map: an input and the values of its kept grid lines.
#[derive(Clone, Debug)]
pub(crate) struct Axis {
    /// The input's name (`psi`), one of [`INPUTS`].
    pub input: &'static str,
    pub values: Vec<f64>,
    /// Its place in [`INPUTS`] and every `stride`-th grid line kept.
    index: usize,
    stride: u64,
}

impl Axis {
    /// The axis label, `Ψ (rad)`.
    pub fn desc(&self) -> String {
        crate::figure::input_desc(self.input)
    }
}

/// The plane a grid is mapped on: two swept inputs, `across` and `up`, at the first
/// value of every other input (as the 3-limb maps show Ψ–Θ at the first `z`).
#[derive(Clone, Debug)]
pub(crate) struct Plane {
    pub across: Axis,
    pub up: Axis,
    /// The mechanism's other inputs with the value the plane has: `[("z", 2.05)]`.
    pub fixed: Vec<(&'static str, f64)>,
    /// The grid's lengths over [`INPUTS`] (a 3-limb grid's `x, y, phi` are 1).
    shape: [u64; 6],
}

impl Plane {
    /// The slot of each grid sample `(i_across/s)·len(up) + i_up/s`; `None` off the
    /// plane or between kept lines.
    fn slot(&self, sample: u64) -> Option<usize> {
        let mut rest = sample;
        let mut index = [0u64; 6];
        for k in (0..6).rev() {
            index[k] = rest % self.shape[k];
            rest /= self.shape[k];
        }
        if rest != 0 {
            return None;
        }
        let on_plane = (0..6).all(|k| k == self.across.index || k == self.up.index || index[k] == 0);
        let (a, u) = (&self.across, &self.up);
        let (ia, iu) = (index[a.index], index[u.index]);
        let kept = ia.is_multiple_of(a.stride) && iu.is_multiple_of(u.stride);
        (on_plane && kept).then(|| (ia / a.stride) as usize * u.values.len() + (iu / u.stride) as usize)
    }

    /// `Z = 2.05 m, Φ = 0 rad`: where the plane lies.
    pub fn fixed_desc(&self) -> String {
        let at: Vec<String> = self
            .fixed
            .iter()
            .map(|&(name, v)| {
                let (symbol, unit) = crate::figure::input_symbol(name);
                format!("{symbol} = {} {unit}", crate::short(v))
            })
            .collect();
        at.join(", ")
    }

    /// `at this Z` for one fixed input, else `on this plane`.
    pub fn here(&self) -> String {
        match self.fixed.as_slice() {
            [(name, _)] => format!("at this {}", crate::figure::input_symbol(name).0),
            _ => "on this plane".to_string(),
        }
    }
}

/// Where a sample's row goes in the per-mode arrays.
#[derive(Clone, Debug)]
pub(crate) enum Layout {
    /// A map over a [`Plane`]: slot `(i_across/s)·len(up) + i_up/s`.
    Grid(Plane),
    /// Every `stride`-th sample of the trajectory: slot `sample/stride`.
    Trajectory { samples: Vec<u64>, stride: u64 },
}

impl Layout {
    /// The layout of `source`'s samples for a mechanism of `kind`. A 3-limb grid is
    /// mapped over Ψ–Θ (the paper's maps); a 6-UPS grid over its first two swept
    /// inputs, in the order of [`INPUTS`]. `Err` says why a grid has no such plane.
    pub fn of(source: &SampleSource, kind: MechanismKind, custom_inputs: Option<&[String]>) -> Result<Self, String> {
        let SampleSource::Grid(grid) = source else {
            let stride = stride(source.len(), MAX_TRAJECTORY_POINTS);
            return Ok(Layout::Trajectory { samples: (0..source.len()).step_by(stride as usize).collect(), stride });
        };
        let ranges = grid.axes6();
        let shape = ranges.map(|r| r.len());
        // A custom mechanism's inputs are its description's; the others are parasitic.
        let custom: Vec<&'static str>;
        let inputs: &[&'static str] = match custom_inputs {
            Some(list) => {
                custom = INPUTS.iter().copied().filter(|i| list.iter().any(|l| l == i)).collect();
                &custom
            }
            None => kind.inputs(),
        };
        let index_of = |name: &str| INPUTS.iter().position(|i| *i == name).expect("an input");
        let (a, u) = if matches!(kind, MechanismKind::Ups6 | MechanismKind::Custom) {
            let swept: Vec<usize> = (0..6).filter(|&k| shape[k] > 1).collect();
            match swept[..] {
                [a, u, ..] => (a, u),
                _ => {
                    let names: Vec<&str> = swept.iter().map(|&k| INPUTS[k]).collect();
                    return Err(format!(
                        "a {} grid is drawn as maps over two swept inputs (ranges), and this one sweeps {}; \
                         give two of {} as {{ start, stop, n }}, or read the poses/ Parquet files with \
                         pyarrow, Polars or DuckDB",
                        kind.name(),
                        if names.is_empty() { "none".to_string() } else { format!("only `{}`", names.join("`, `")) },
                        inputs.join(", "),
                    ));
                }
            }
        } else {
            (index_of("psi"), index_of("theta"))
        };
        let axis = |k: usize| {
            let stride = stride(shape[k], MAX_MAP_AXIS);
            let values = (0..shape[k]).step_by(stride as usize).map(|i| ranges[k].value(i)).collect();
            Axis { input: INPUTS[k], values, index: k, stride }
        };
        let fixed = inputs
            .iter()
            .map(|&name| index_of(name))
            .filter(|&k| k != a && k != u)
            .map(|k| (INPUTS[k], ranges[k].value(0)))
            .collect();
        Ok(Layout::Grid(Plane { across: axis(a), up: axis(u), fixed, shape }))
    }

    pub fn slots(&self) -> usize {
        match self {
            Layout::Grid(p) => p.across.values.len() * p.up.values.len(),
            Layout::Trajectory { samples, .. } => samples.len(),
        }
    }

    /// The slot of `sample`; `None` for samples off the plane or between kept lines.
    fn slot(&self, sample: u64) -> Option<usize> {
        match self {
            Layout::Grid(plane) => plane.slot(sample),
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

/// Every error column a figure may draw, for the clearance `kinds` of the mechanism.
fn wanted_columns(kinds: &[&str]) -> Vec<String> {
    let mut names: Vec<String> = COMPONENTS.iter().map(|c| format!("err_{}", c.suffix)).collect();
    for kind in kinds {
        for c in COMPONENTS {
            names.push(format!("err_{kind}_{}", c.suffix));
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

/// Every joint the `dominant` column of a `kind` run can name, clearance kind by
/// clearance kind, limb by limb (`s1_radial`, …, `r3_angular`; `s1_radial`, …,
/// `u6_angular`): a category keeps its place whichever joints a run holds.
pub(crate) fn joints(kind: MechanismKind) -> Vec<String> {
    kind.clearance_keys()
        .iter()
        .flat_map(|name| (1..=kind.limbs()).map(move |limb| format!("{}{limb}{}", &name[..1], &name[1..])))
        .collect()
}

/// A column of `batch` as `f64` values: numbers cast, the `dominant` names as
/// their place in `joints`.
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
    let kind = run.job.mechanism.kind;
    let wanted = wanted_columns(kind.clearance_keys());
    let joints = joints(kind);
    let mut modes: BTreeMap<String, ModeData> = BTreeMap::new();
    for path in run.part_files(k)? {
        read_part(&path, layout, &wanted, &joints, &mut modes)?;
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
    joints: &[String],
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
            .map(|(f, a)| Ok((f.name().as_str(), values_of(path, f.name(), a, joints)?)))
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
        let axis = |input: &'static str, index: usize, n: usize| Axis { input, values: vec![0.0; n], index, stride: 2 };
        // A 3-limb grid of 2 z × 7 Ψ × 5 Θ: ψ lines 0, 2, 4, 6; θ lines 0, 2, 4.
        let plane =
            Plane { across: axis("psi", 4, 4), up: axis("theta", 5, 3), fixed: vec![], shape: [1, 1, 2, 1, 7, 5] };
        let layout = Layout::Grid(plane);
        assert_eq!(layout.slot(0), Some(0));
        assert_eq!(layout.slot(4), Some(2));
        assert_eq!(layout.slot(2 * 5 + 2), Some(4));
        assert_eq!(layout.slot(6 * 5 + 4), Some(11));
        assert_eq!(layout.slot(1), None);
        assert_eq!(layout.slot(5), None);
        assert_eq!(layout.slot(7 * 5), None, "the next z plane");
        // A 6-UPS grid of 3 x × 2 y × 4 ψ mapped over x–ψ: y's second value is off the plane.
        let plane = Plane { across: axis("x", 0, 2), up: axis("psi", 4, 2), fixed: vec![], shape: [3, 2, 1, 1, 4, 1] };
        let layout = Layout::Grid(plane);
        assert_eq!(layout.slot(2 * 8 + 2), Some(3), "x line 2, ψ line 2");
        assert_eq!(layout.slot(2 * 8 + 4 + 2), None, "y line 1");
        assert_eq!(layout.slot(8 + 2), None, "x line 1 is not kept");
        let t = Layout::Trajectory { samples: vec![0, 3, 6], stride: 3 };
        assert_eq!((t.slot(6), t.slot(4)), (Some(2), None));
    }
}
