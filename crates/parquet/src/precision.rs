//! `--precision`: how the error, envelope and margin columns of the `poses` part files
//! are stored (docs/interface.md).

use std::sync::Arc;

use arrow::array::{Array, ArrayRef, Float32Array, Float64Array};
use arrow::buffer::{BooleanBuffer, NullBuffer};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::record_batch::RecordBatch;

/// The storage of the error, envelope and margin columns of a run's part files.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// Every float column as `float64` (the default).
    #[default]
    Double,
    /// The error (`err_*`, `exact_err_*`), envelope (`env_*`) and margin (`margin_*`)
    /// columns as `float32`, each value rounded to the nearest: a relative change of
    /// at most 2⁻²⁴ (6e-8) of the value. The inputs, parasitic motions, actuator
    /// positions, reactions and condition numbers stay `float64`.
    Single,
}

impl Precision {
    /// The names `--precision` takes.
    pub const NAMES: [&str; 2] = ["double", "single"];

    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "double" => Some(Self::Double),
            "single" => Some(Self::Single),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Double => "double",
            Self::Single => "single",
        }
    }
}

/// Whether `--precision single` stores the column `name` as `float32`.
pub fn stored_single(name: &str) -> bool {
    ["err_", "exact_err_", "env_", "margin_"].iter().any(|p| name.starts_with(p))
}

/// `field` as a part file of `precision` stores it: with [`Precision::Single`], a double
/// column that [`stored_single`] names as `float32` (name, nullability and metadata
/// kept); any other as it is. The one rule for the schemas and the batches.
pub(crate) fn stored_field(field: &Field, precision: Precision) -> Field {
    let narrow =
        precision == Precision::Single && field.data_type() == &DataType::Float64 && stored_single(field.name());
    let field = field.clone();
    if narrow { field.with_data_type(DataType::Float32) } else { field }
}

/// `batch` as a part file of `precision` stores it: with [`Precision::Single`] each
/// double column that [`stored_single`] names becomes `float32`, its field's metadata
/// kept, each value rounded to the nearest `f32`; a value beyond the range of `f32`
/// (which would round to an infinity) becomes null, as every value that is not finite
/// is. Other columns are shared, not copied.
pub fn with_precision(batch: &RecordBatch, precision: Precision) -> RecordBatch {
    if precision == Precision::Double {
        return batch.clone();
    }
    let schema = batch.schema();
    let mut fields = Vec::with_capacity(schema.fields().len());
    let mut columns = Vec::with_capacity(schema.fields().len());
    for (field, column) in schema.fields().iter().zip(batch.columns()) {
        let stored = stored_field(field, precision);
        match column.as_any().downcast_ref::<Float64Array>().filter(|_| stored.data_type() == &DataType::Float32) {
            Some(doubles) => {
                let single: Vec<f32> = doubles.values().iter().map(|&v| v as f32).collect();
                let valid = BooleanBuffer::collect_bool(single.len(), |i| doubles.is_valid(i) && single[i].is_finite());
                let nulls = (valid.count_set_bits() < single.len()).then(|| NullBuffer::new(valid));
                columns.push(Arc::new(Float32Array::new(single.into(), nulls)) as ArrayRef);
            }
            None => columns.push(column.clone()),
        }
        fields.push(Arc::new(stored));
    }
    let schema = Arc::new(Schema::new_with_metadata(fields, schema.metadata().clone()));
    RecordBatch::try_new(schema, columns).expect("the same columns, some narrowed")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Chosen columns narrowed with their values rounded, nulls kept, a value beyond
    /// `f32` null, every other column untouched.
    #[test]
    fn single_narrows_errors_envelopes_and_margins_only() {
        let f = |name: &str| Field::new(name, DataType::Float64, true);
        let schema = Arc::new(Schema::new(vec![f("q1"), f("err_x"), f("env_p"), f("margin_r1_radial")]));
        let q: ArrayRef = Arc::new(Float64Array::from(vec![Some(0.1), Some(0.2), None]));
        let err: ArrayRef = Arc::new(Float64Array::from(vec![Some(1.234_567_891e-5), None, Some(-3.0)]));
        let env: ArrayRef = Arc::new(Float64Array::from(vec![Some(1e300), Some(2.5), Some(0.0)]));
        let margin: ArrayRef = Arc::new(Float64Array::from(vec![Some(7.0), Some(8.0), Some(9.0)]));
        let batch = RecordBatch::try_new(schema, vec![q.clone(), err, env, margin]).unwrap();
        assert_eq!(with_precision(&batch, Precision::Double), batch);
        let single = with_precision(&batch, Precision::Single);
        assert_eq!(single.column(0), &q);
        assert_eq!(single.schema().field(0).data_type(), &DataType::Float64);
        for c in 1..4 {
            assert_eq!(single.schema().field(c).data_type(), &DataType::Float32);
        }
        let err = single.column(1).as_any().downcast_ref::<Float32Array>().unwrap();
        assert_eq!(err.value(0), 1.234_567_891e-5_f64 as f32);
        assert_ne!(f64::from(err.value(0)), 1.234_567_891e-5);
        assert!(err.is_null(1) && err.value(2) == -3.0);
        let env = single.column(2).as_any().downcast_ref::<Float32Array>().unwrap();
        assert!(env.is_null(0) && env.value(1) == 2.5 && env.null_count() == 1);
        assert_eq!(single.column(3).null_count(), 0);
    }
}
