//! The refined take-up switches of `discontinuities.parquet`, drawn over the figures.
//!
//! The file is optional: a run made before the discontinuity analysis existed has
//! none, and its figures are drawn without switch overlays.

use std::fs::File;
use std::path::Path;

use arrow::array::Array;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use crate::PlotError;
use crate::run_dir::{column_error, to_f64, to_u64, to_utf8};

/// One switch: where the take-up of `kind` at `limb` flips.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Switch {
    pub variant: u64,
    pub mode: String,
    pub kind: String,
    pub t: Option<f64>,
    pub z: f64,
    pub psi: f64,
    pub theta: f64,
}

impl Switch {
    /// The switch's coordinate along an input (`t`, `z`, `psi`, `theta`).
    pub fn coordinate(&self, input: &str) -> Option<f64> {
        match input {
            "t" => self.t,
            "z" => Some(self.z),
            "psi" => Some(self.psi),
            "theta" => Some(self.theta),
            _ => None,
        }
        .filter(|v| v.is_finite())
    }
}

/// The switches of a run; `None` when it has no `discontinuities.parquet`.
pub(crate) fn read_switches(path: &Path) -> Result<Option<Vec<Switch>>, PlotError> {
    if !path.exists() {
        return Ok(None);
    }
    let pq = |source| PlotError::Parquet { path: path.to_path_buf(), source };
    let file = File::open(path).map_err(PlotError::io(path))?;
    let reader = ParquetRecordBatchReaderBuilder::try_new(file).map_err(pq)?.build().map_err(pq)?;
    let mut out = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|source| PlotError::Arrow { path: path.to_path_buf(), source })?;
        let col = |name: &str| batch.column_by_name(name).ok_or_else(|| column_error(path, name, "missing"));
        let variant = to_u64(path, "variant", col("variant")?)?;
        let mode = to_utf8(path, "mode", col("mode")?)?;
        let kind = to_utf8(path, "kind", col("kind")?)?;
        let z = to_f64(path, "z", col("z")?)?;
        let psi = to_f64(path, "psi", col("psi")?)?;
        let theta = to_f64(path, "theta", col("theta")?)?;
        let t = match batch.column_by_name("t") {
            Some(a) => Some(to_f64(path, "t", a)?),
            None => None,
        };
        let f = |a: &arrow::array::Float64Array, i: usize| {
            if a.is_valid(i) { a.value(i) } else { f64::NAN }
        };
        for i in 0..batch.num_rows() {
            if !(variant.is_valid(i) && mode.is_valid(i) && kind.is_valid(i)) {
                continue;
            }
            out.push(Switch {
                variant: variant.value(i),
                mode: mode.value(i).to_string(),
                kind: kind.value(i).to_string(),
                t: t.as_ref().filter(|t| t.is_valid(i)).map(|t| t.value(i)),
                z: f(&z, i),
                psi: f(&psi, i),
                theta: f(&theta, i),
            });
        }
    }
    Ok(Some(out))
}
