//! `discontinuities.parquet`: one row per refined switch.

use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt32Array, UInt64Array};
use arrow::datatypes::{DataType, Schema};
use arrow::record_batch::RecordBatch;
use clearance_discontinuity::Discontinuity;

use crate::summary::field;

/// The switches of a run, each with its variant.
pub fn discontinuity_batch(rows: &[(u64, Discontinuity)]) -> RecordBatch {
    let f64s = |get: &dyn Fn(&Discontinuity) -> f64| -> ArrayRef {
        Arc::new(Float64Array::from_iter_values(rows.iter().map(|(_, d)| get(d))))
    };
    let mut fields = vec![
        field("variant", DataType::UInt64, false, "1"),
        field("mode", DataType::Utf8, false, ""),
        field("limb", DataType::UInt32, false, "1"),
        field("kind", DataType::Utf8, false, ""),
        field("along", DataType::Utf8, false, ""),
        field("t", DataType::Float64, true, "s"),
        field("z", DataType::Float64, false, "m"),
        field("psi", DataType::Float64, false, "rad"),
        field("theta", DataType::Float64, false, "rad"),
        field("margin", DataType::Float64, true, "N or N*m"),
    ];
    let mut cols: Vec<ArrayRef> = vec![
        Arc::new(UInt64Array::from_iter_values(rows.iter().map(|(v, _)| *v))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|(_, d)| d.mode.name()))),
        Arc::new(UInt32Array::from_iter_values(rows.iter().map(|(_, d)| d.limb as u32))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|(_, d)| d.kind.name()))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|(_, d)| d.along.name()))),
        Arc::new(Float64Array::from_iter(rows.iter().map(|(_, d)| d.t))),
        f64s(&|d| d.z),
        f64s(&|d| d.psi),
        f64s(&|d| d.theta),
        Arc::new(Float64Array::from_iter(rows.iter().map(|(_, d)| Some(d.margin).filter(|m| m.is_finite())))),
    ];
    for (i, (c, unit)) in
        [("x", "m"), ("y", "m"), ("z", "m"), ("rx", "rad"), ("ry", "rad"), ("rz", "rad")].into_iter().enumerate()
    {
        fields.push(field(&format!("jump_{c}"), DataType::Float64, false, unit));
        cols.push(f64s(&move |d: &Discontinuity| d.jump[i]));
    }
    RecordBatch::try_new(Arc::new(Schema::new(fields)), cols).expect("columns match the schema")
}
