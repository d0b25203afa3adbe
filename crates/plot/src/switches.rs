//! The refined take-up switches of `discontinuities.parquet`, drawn over the figures.
//!
//! The file is optional: a run made before the discontinuity analysis existed has
//! none, and its figures are drawn without switch overlays.

use std::fs::File;
use std::path::Path;

use arrow::array::{Array, Float64Array};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

use crate::PlotError;
use crate::figure::INPUTS;
use crate::run_dir::{Plane, column_error, to_f64, to_u64, to_utf8};

/// One switch: where the take-up of `kind` at `limb` flips.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Switch {
    pub variant: u64,
    pub mode: String,
    pub kind: String,
    pub t: Option<f64>,
    /// The inputs of [`INPUTS`] where the file has them (a 3-limb run's switches have
    /// no `x`, `y`, `phi`), NaN for a null.
    pub inputs: [Option<f64>; 6],
}

impl Switch {
    /// The switch's coordinate along an input (`t`, `z`, `psi`, …).
    pub fn coordinate(&self, input: &str) -> Option<f64> {
        match input {
            "t" => self.t,
            _ => INPUTS.iter().position(|i| *i == input).and_then(|k| self.inputs[k]),
        }
        .filter(|v| v.is_finite())
    }

    /// Is the switch on `plane`: at its value of every fixed input the file gives?
    pub fn on(&self, plane: &Plane) -> bool {
        plane.fixed.iter().all(|&(name, v0)| {
            let k = INPUTS.iter().position(|i| *i == name).expect("an input");
            self.inputs[k].is_none_or(|v| (v - v0).abs() <= 1e-9 * v0.abs().max(1.0))
        })
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
        // Every input the file has: z, psi, theta always, x, y, phi on a 6-UPS.
        let inputs = INPUTS.map(|name| batch.column_by_name(name).map(|a| to_f64(path, name, a)));
        let inputs: Vec<Option<Float64Array>> = inputs.into_iter().map(Option::transpose).collect::<Result<_, _>>()?;
        for name in ["z", "psi", "theta"] {
            col(name)?;
        }
        let t = match batch.column_by_name("t") {
            Some(a) => Some(to_f64(path, "t", a)?),
            None => None,
        };
        let f = |a: &Float64Array, i: usize| {
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
                inputs: std::array::from_fn(|k| inputs[k].as_ref().map(|a| f(a, i))),
            });
        }
    }
    Ok(Some(out))
}
