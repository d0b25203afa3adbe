//! The `poses` columns and how each is filled.

use std::collections::HashMap;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::record_batch::RecordBatch;
use clearance_grid::Sample;
use clearance_model::{KINDS, Mode};
use clearance_solver::{PoseError, PoseResult, Status};
use rayon::prelude::*;

/// Which columns to write (INTERFACE.md `--columns`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum ColumnSet {
    /// Identity, inputs, status and the total errors.
    Minimal,
    /// Adds per-kind errors, parasitic motions, actuators and margins (the default).
    Standard,
    /// Adds reactions and condition numbers.
    Full,
}

impl ColumnSet {
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "minimal" => Some(Self::Minimal),
            "standard" => Some(Self::Standard),
            "full" => Some(Self::Full),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Minimal => "minimal",
            Self::Standard => "standard",
            Self::Full => "full",
        }
    }
}

/// When a column has a value (docs/conventions.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Needs {
    /// Always: inputs and parasitic motions.
    Always,
    /// Any reachable pose: actuators, condition numbers.
    Reachable,
    /// Reactions solved and trusted: `ok` or `indeterminate_contact`.
    Solved,
    /// Kind k's take-up determinate on a solved pose.
    Kind(usize),
    /// Status `ok`.
    Ok,
    /// The exact error converged.
    Exact,
}

type Getter = Box<dyn Fn(&Sample, &PoseResult) -> f64 + Send + Sync>;

struct FloatColumn {
    name: String,
    unit: &'static str,
    needs: Needs,
    get: Getter,
}

/// The `poses` schema of one column set, and the batch builder for it.
pub struct PoseSchema {
    schema: SchemaRef,
    floats: Vec<FloatColumn>,
}

const ERR_PARTS: [(&str, &str); 9] = [
    ("x", "m"),
    ("y", "m"),
    ("z", "m"),
    ("rx", "rad"),
    ("ry", "rad"),
    ("rz", "rad"),
    ("phi", "rad"),
    ("psi", "rad"),
    ("theta", "rad"),
];

fn err_part(e: &PoseError, i: usize) -> f64 {
    match i {
        0..=2 => e.dp[i],
        3..=5 => e.dalpha[i - 3],
        _ => e.euler[i - 6],
    }
}

fn float(name: impl Into<String>, unit: &'static str, needs: Needs, get: Getter) -> FloatColumn {
    FloatColumn { name: name.into(), unit, needs, get }
}

impl PoseSchema {
    /// The columns of `set`, plus the exact-error columns when `exact` is on.
    pub fn new(set: ColumnSet, exact: bool) -> Self {
        let mut f: Vec<FloatColumn> = Vec::new();
        f.push(float("z", "m", Needs::Always, Box::new(|s, _| s.z[0])));
        f.push(float("psi", "rad", Needs::Always, Box::new(|s, _| s.psi[0])));
        f.push(float("theta", "rad", Needs::Always, Box::new(|s, _| s.theta[0])));
        if set >= ColumnSet::Standard {
            f.push(float("x", "m", Needs::Always, Box::new(|_, r| r.x)));
            f.push(float("y", "m", Needs::Always, Box::new(|_, r| r.y)));
            f.push(float("phi", "rad", Needs::Always, Box::new(|_, r| r.phi)));
            for j in 0..3 {
                f.push(float(format!("q{}", j + 1), "m", Needs::Reachable, Box::new(move |_, r| r.q[j])));
            }
        }
        for (i, (c, unit)) in ERR_PARTS.iter().enumerate() {
            f.push(float(format!("err_{c}"), unit, Needs::Ok, Box::new(move |_, r| err_part(&r.total, i))));
        }
        if set >= ColumnSet::Standard {
            for kind in KINDS {
                let k = kind.index();
                for (i, (c, unit)) in ERR_PARTS.iter().enumerate() {
                    f.push(float(
                        format!("err_{}_{c}", kind.name()),
                        unit,
                        Needs::Kind(k),
                        Box::new(move |_, r| err_part(&r.errors[k], i)),
                    ));
                }
            }
            for j in 0..3 {
                let l = j + 1;
                f.push(float(
                    format!("margin_r{l}_radial"),
                    "N",
                    Needs::Solved,
                    Box::new(move |_, r| r.margins.r_radial[j]),
                ));
                f.push(float(
                    format!("margin_r{l}_axial"),
                    "N",
                    Needs::Solved,
                    Box::new(move |_, r| r.margins.r_axial[j]),
                ));
                f.push(float(
                    format!("margin_r{l}_angular"),
                    "N*m",
                    Needs::Solved,
                    Box::new(move |_, r| r.margins.r_angular[j]),
                ));
                f.push(float(format!("margin_s{l}"), "N", Needs::Solved, Box::new(move |_, r| r.margins.s[j])));
            }
        }
        if set >= ColumnSet::Full {
            for j in 0..3 {
                let l = j + 1;
                for (i, c) in ["x", "y", "z"].iter().enumerate() {
                    f.push(float(
                        format!("f_r{l}_{c}"),
                        "N",
                        Needs::Solved,
                        Box::new(move |_, r| r.reactions.f_r[j][i]),
                    ));
                }
                for (i, c) in ["x", "y", "z"].iter().enumerate() {
                    f.push(float(
                        format!("m_r{l}_{c}"),
                        "N*m",
                        Needs::Solved,
                        Box::new(move |_, r| r.reactions.m_r[j][i]),
                    ));
                }
                for (i, c) in ["x", "y", "z"].iter().enumerate() {
                    f.push(float(
                        format!("f_s{l}_{c}"),
                        "N",
                        Needs::Solved,
                        Box::new(move |_, r| r.reactions.f_s[j][i]),
                    ));
                }
            }
            f.push(float("cond_a", "1", Needs::Reachable, Box::new(|_, r| r.cond_a)));
            f.push(float("cond_jp", "1", Needs::Reachable, Box::new(|_, r| r.cond_jp)));
        }
        if exact {
            for (i, (c, unit)) in ERR_PARTS[..6].iter().enumerate() {
                // The stored exact error is [Δα; Δp]; columns follow the err_* order (Δp first).
                let idx = if i < 3 { i + 3 } else { i - 3 };
                f.push(float(
                    format!("exact_err_{c}"),
                    unit,
                    Needs::Exact,
                    Box::new(move |_, r| r.exact.map_or(f64::NAN, |e| e[idx])),
                ));
            }
        }

        let unit = |u: &str| HashMap::from([("unit".to_string(), u.to_string())]);
        let mut fields = vec![
            Field::new("mode", DataType::Utf8, false).with_metadata(unit("")),
            Field::new("sample", DataType::UInt64, false).with_metadata(unit("1")),
            Field::new("t", DataType::Float64, true).with_metadata(unit("s")),
            Field::new("status", DataType::Utf8, false).with_metadata(unit("")),
        ];
        fields.extend(f.iter().map(|c| Field::new(&c.name, DataType::Float64, true).with_metadata(unit(c.unit))));
        Self { schema: Arc::new(Schema::new(fields)), floats: f }
    }

    pub fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Column names in order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.schema.fields().iter().map(|f| f.name().as_str())
    }

    /// One record batch from the rows of one mode.
    pub fn batch(&self, mode: Mode, rows: &[(Sample, PoseResult)]) -> RecordBatch {
        let mut cols: Vec<ArrayRef> = Vec::with_capacity(self.floats.len() + 4);
        cols.push(Arc::new(StringArray::from_iter_values(rows.iter().map(|_| mode.name()))));
        cols.push(Arc::new(UInt64Array::from_iter_values(rows.iter().map(|(s, _)| s.index))));
        cols.push(Arc::new(Float64Array::from_iter(rows.iter().map(|(s, _)| s.t))));
        cols.push(Arc::new(StringArray::from_iter_values(rows.iter().map(|(_, r)| r.status.name()))));
        // Columns are independent: build them on the rayon pool.
        let floats: Vec<ArrayRef> = self
            .floats
            .par_iter()
            .map(|c| {
                let values = rows.iter().map(|(s, r)| {
                    let filled = match c.needs {
                        Needs::Always => true,
                        Needs::Reachable => r.status != Status::Unreachable,
                        Needs::Solved => matches!(r.status, Status::Ok | Status::IndeterminateContact),
                        Needs::Kind(k) => matches!(r.status, Status::Ok | Status::IndeterminateContact) && r.kind_ok[k],
                        Needs::Ok => r.status == Status::Ok,
                        Needs::Exact => r.exact.is_some(),
                    };
                    let v = if filled { (c.get)(s, r) } else { f64::NAN };
                    v.is_finite().then_some(v)
                });
                Arc::new(Float64Array::from_iter(values)) as ArrayRef
            })
            .collect();
        cols.extend(floats);
        RecordBatch::try_new(self.schema.clone(), cols).expect("columns match the schema")
    }
}
