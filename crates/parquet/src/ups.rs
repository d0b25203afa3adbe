//! The 6-UPS tables (docs/model.md §10.3, docs/interface.md): `poses` rows with the
//! six inputs, six limbs and the kinds `s_radial`, `u_radial`, `u_angular`; the
//! summary's statistics; the switches of `discontinuities.parquet`.
//!
//! The 3-limb tables ([`PoseSchema`](crate::PoseSchema)) are built page by page for
//! throughput; these are plain Arrow batches, which a 42 × 42 solve per pose
//! leaves far from the bottleneck. Nulls follow docs/conventions.md as for the
//! other kinds, and no value that is not finite is ever written.

use std::collections::HashMap;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt32Array, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::record_batch::RecordBatch;
use clearance_model::Mode;
use clearance_solver::ups::{UPS_KINDS, UpsResult};
use clearance_solver::{PoseError, Status};
use serde::{Deserialize, Serialize};

use crate::schema::{ColumnSet, ENVELOPE_PARTS, ERR_PARTS, finite_rows};
use crate::summary::{Series, SummaryTable, field};

/// The six inputs, in the grid's row-major order.
pub const UPS_INPUTS: [&str; 6] = ["x", "y", "z", "phi", "psi", "theta"];
/// The units of `x, y, z, phi, psi, theta`.
pub(crate) const INPUT_UNITS: [&str; 6] = ["m", "m", "m", "rad", "rad", "rad"];

/// One 6-UPS sample's identity: its index, its time (trajectories) and inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpsRow {
    pub sample: u64,
    pub t: Option<f64>,
    pub inputs: [f64; 6],
}

/// The `poses` columns of a 6-UPS run for one column set.
pub struct UpsSchema {
    schema: SchemaRef,
    set: ColumnSet,
    exact: bool,
    /// How many float columns [`visit`] gives for `set` and `exact`.
    floats: usize,
    /// The `dominant` column's values, by `6·kind + limb`, when the set has the column
    /// (after `status`).
    dominant: Option<Vec<String>>,
}

/// The `dominant` column's values, by `6·kind + limb`.
fn joint_names() -> Vec<String> {
    UPS_KINDS.iter().flat_map(|k| (0..6).map(move |l| clearance_solver::joint_label(k, l))).collect()
}

fn error_part(e: &PoseError, i: usize) -> f64 {
    match i {
        0..3 => e.dp[i],
        3..6 => e.dalpha[i - 3],
        _ => e.euler[i - 6],
    }
}

/// Reactions, margins and per-kind errors exist for `ok` and indeterminate rows.
fn loaded(r: &UpsResult) -> bool {
    matches!(r.status, Status::Ok | Status::IndeterminateContact)
}

/// What [`visit`] gives each float column to: its name and unit (built only where they
/// are wanted), and its value on a row (`None`, or a value that is not finite: null).
trait Columns {
    fn column(
        &mut self,
        name: impl FnOnce() -> String,
        unit: &'static str,
        value: impl FnOnce(&UpsRow, &UpsResult) -> Option<f64>,
    );
}

/// Every float column of `set` (plus the exact error's with `exact`), in order. One
/// walk gives the schema's names and each row's values, so that the two agree; a
/// row's values are written in one pass over its result, with no call through a
/// pointer per value (a fifth of a 6-UPS run's CPU when each column had its closure).
fn visit(set: ColumnSet, exact: bool, c: &mut impl Columns) {
    for (i, (name, unit)) in UPS_INPUTS.iter().zip(INPUT_UNITS).enumerate() {
        c.column(|| name.to_string(), unit, |s, _| Some(s.inputs[i]));
    }
    for (i, (p, unit)) in ERR_PARTS.iter().enumerate() {
        c.column(|| format!("err_{p}"), unit, |_, r| (r.status == Status::Ok).then(|| error_part(&r.total, i)));
    }
    if set >= ColumnSet::Standard {
        for (k, kind) in UPS_KINDS.iter().enumerate() {
            for (i, (p, unit)) in ERR_PARTS.iter().enumerate() {
                c.column(
                    || format!("err_{kind}_{p}"),
                    unit,
                    |_, r| (loaded(r) && r.kind_ok[k]).then(|| error_part(&r.errors[k], i)),
                );
            }
        }
        for l in 0..6 {
            c.column(|| format!("q{}", l + 1), "m", |_, r| (r.status != Status::Unreachable).then_some(r.q[l]));
        }
        for l in 0..6 {
            let n = l + 1;
            // margins: [s_radial, u_radial, u_angular] by kind, then limb.
            for (name, k, unit) in [("radial", 1, "N"), ("angular", 2, "N*m"), ("", 0, "N")] {
                let name = || if k == 0 { format!("margin_s{n}") } else { format!("margin_u{n}_{name}") };
                c.column(name, unit, |_, r| loaded(r).then_some(r.margins[k][l]));
            }
        }
        // The envelope of all kinds, then of each kind (NaN outside loaded rows).
        for (p, (part, unit)) in ENVELOPE_PARTS.iter().enumerate() {
            c.column(|| format!("env_{part}"), unit, |_, r| Some(r.envelope_total()[p]));
        }
        for (k, kind) in UPS_KINDS.iter().enumerate() {
            for (p, (part, unit)) in ENVELOPE_PARTS.iter().enumerate() {
                c.column(|| format!("env_{kind}_{part}"), unit, |_, r| Some(r.envelope[k][p]));
            }
        }
    }
    if set >= ColumnSet::Full {
        for l in 0..6 {
            let n = l + 1;
            for (a, x) in ["x", "y", "z"].into_iter().enumerate() {
                c.column(|| format!("f_u{n}_{x}"), "N", |_, r| loaded(r).then_some(r.f_u[l][a]));
            }
            c.column(|| format!("m_u{n}"), "N*m", |_, r| loaded(r).then_some(r.mu[l]));
            for (a, x) in ["x", "y", "z"].into_iter().enumerate() {
                c.column(|| format!("f_s{n}_{x}"), "N", |_, r| loaded(r).then_some(r.f_s[l][a]));
            }
        }
        c.column(|| "cond_a".into(), "1", |_, r| (r.status != Status::Unreachable).then_some(r.cond_a));
        c.column(|| "cond_jp".into(), "1", |_, r| (r.status != Status::Unreachable).then_some(r.cond_jp));
    }
    if exact {
        // The stored exact error is [Δα; Δp]; columns follow the err_* order (Δp first).
        for (i, (p, unit)) in ERR_PARTS[..6].iter().enumerate() {
            let at = if i < 3 { i + 3 } else { i - 3 };
            c.column(|| format!("exact_err_{p}"), unit, |_, r| r.exact.map(|e| e[at]));
        }
    }
}

/// The names and units of the float columns.
struct Names(Vec<(String, &'static str)>);

impl Columns for Names {
    fn column(
        &mut self,
        name: impl FnOnce() -> String,
        unit: &'static str,
        _: impl FnOnce(&UpsRow, &UpsResult) -> Option<f64>,
    ) {
        self.0.push((name(), unit));
    }
}

/// One row's values, NaN for a null.
struct Values<'a> {
    row: &'a UpsRow,
    result: &'a UpsResult,
    out: &'a mut [f64],
    next: usize,
}

impl Columns for Values<'_> {
    #[inline(always)]
    fn column(
        &mut self,
        _: impl FnOnce() -> String,
        _: &'static str,
        value: impl FnOnce(&UpsRow, &UpsResult) -> Option<f64>,
    ) {
        self.out[self.next] = value(self.row, self.result).unwrap_or(f64::NAN);
        self.next += 1;
    }
}

impl UpsSchema {
    /// The columns of `set`, plus the exact-error columns when `exact` is on.
    pub fn new(set: ColumnSet, exact: bool) -> Self {
        let mut names = Names(Vec::new());
        visit(set, exact, &mut names);
        let unit = |u: &str| HashMap::from([("unit".to_string(), u.to_string())]);
        let mut fields = vec![
            Field::new("mode", DataType::Utf8, false).with_metadata(unit("")),
            Field::new("sample", DataType::UInt64, false).with_metadata(unit("1")),
            Field::new("t", DataType::Float64, true).with_metadata(unit("s")),
            Field::new("status", DataType::Utf8, false).with_metadata(unit("")),
        ];
        let dominant = (set >= ColumnSet::Standard).then(joint_names);
        if dominant.is_some() {
            fields.push(Field::new("dominant", DataType::Utf8, true).with_metadata(unit("")));
        }
        fields.extend(names.0.iter().map(|(n, u)| Field::new(n, DataType::Float64, true).with_metadata(unit(u))));
        Self { schema: Arc::new(Schema::new(fields)), set, exact, floats: names.0.len(), dominant }
    }

    pub fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Column names in order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.schema.fields().iter().map(|f| f.name().as_str())
    }

    /// The record batch of one mode's rows (`rows` and `results` of the same length).
    #[track_caller]
    pub fn batch(&self, mode: Mode, rows: &[UpsRow], results: &[UpsResult]) -> RecordBatch {
        assert_eq!(rows.len(), results.len(), "one result per row");
        let mut out: Vec<ArrayRef> = vec![
            Arc::new(StringArray::from_iter_values(rows.iter().map(|_| mode.name()))),
            Arc::new(UInt64Array::from_iter_values(rows.iter().map(|s| s.sample))),
            Arc::new(Float64Array::from_iter(rows.iter().map(|s| s.t.filter(|t| t.is_finite())))),
            Arc::new(StringArray::from_iter_values(results.iter().map(|r| r.status.name()))),
        ];
        if let Some(names) = &self.dominant {
            out.push(Arc::new(StringArray::from_iter(
                results.iter().map(|r| r.dominant.map(|(k, l)| names[6 * k + l].as_str())),
            )));
        }
        out.extend(finite_rows(rows.len(), self.floats, |i, values| {
            let mut v = Values { row: &rows[i], result: &results[i], out: values, next: 0 };
            visit(self.set, self.exact, &mut v);
        }));
        RecordBatch::try_new(self.schema.clone(), out).expect("columns match the schema")
    }
}

/// The partial statistics of a set of 6-UPS poses of one (variant, mode).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UpsStats {
    pub samples: u64,
    /// Counts per status, in the order of `Status::ALL`.
    pub status: [u64; 4],
    /// |Δp| and |Δα| of the total error (`ok` poses).
    pub dp: Series,
    pub dalpha: Series,
    /// The same per kind (poses where that kind is determinate), order of [`UPS_KINDS`].
    pub dp_kind: [Series; 3],
    pub dalpha_kind: [Series; 3],
    pub cond_a_max: f64,
    pub cond_jp_max: f64,
    /// The envelope's bounds on |Δp| and |Δα| (`ok` and indeterminate poses).
    #[serde(default)]
    pub env_p: Series,
    #[serde(default)]
    pub env_alpha: Series,
    /// Per joint (`[kind][limb]`), over `ok` poses: how often it dominates, and the sum
    /// of squares of its own contribution to |Δp|.
    #[serde(default)]
    pub dominant: [[u64; 6]; 3],
    #[serde(default)]
    pub joint_sum_sq: [[f64; 6]; 3],
}

impl UpsStats {
    pub fn push(&mut self, r: &UpsResult) {
        self.samples += 1;
        self.status[r.status.index()] += 1;
        if r.status != Status::Unreachable {
            self.cond_a_max = self.cond_a_max.max(r.cond_a);
            self.cond_jp_max = self.cond_jp_max.max(r.cond_jp);
        }
        if r.status == Status::Ok {
            self.dp.push(r.total.dp.norm());
            self.dalpha.push(r.total.dalpha.norm());
            if let Some((k, l)) = r.dominant {
                self.dominant[k][l] += 1;
            }
            for (sums, limbs) in self.joint_sum_sq.iter_mut().zip(&r.contribution) {
                for (sum, v) in sums.iter_mut().zip(limbs) {
                    if v.is_finite() {
                        *sum += v * v;
                    }
                }
            }
        }
        if loaded(r) {
            let total = r.envelope_total();
            if total[6].is_finite() && total[7].is_finite() {
                self.env_p.push(total[6]);
                self.env_alpha.push(total[7]);
            }
            for k in 0..3 {
                if r.kind_ok[k] {
                    self.dp_kind[k].push(r.errors[k].dp.norm());
                    self.dalpha_kind[k].push(r.errors[k].dalpha.norm());
                }
            }
        }
    }

    /// Moves every series' pending values into its histogram.
    pub fn flush(&mut self) {
        let totals = [&mut self.dp, &mut self.dalpha, &mut self.env_p, &mut self.env_alpha];
        for s in totals.into_iter().chain(&mut self.dp_kind).chain(&mut self.dalpha_kind) {
            s.flush();
        }
    }

    pub fn merge(&mut self, o: &UpsStats) {
        self.samples += o.samples;
        for i in 0..4 {
            self.status[i] += o.status[i];
        }
        for k in 0..3 {
            self.dp_kind[k].merge(&o.dp_kind[k]);
            self.dalpha_kind[k].merge(&o.dalpha_kind[k]);
        }
        self.dp.merge(&o.dp);
        self.dalpha.merge(&o.dalpha);
        self.env_p.merge(&o.env_p);
        self.env_alpha.merge(&o.env_alpha);
        for k in 0..3 {
            for l in 0..6 {
                self.dominant[k][l] += o.dominant[k][l];
                self.joint_sum_sq[k][l] += o.joint_sum_sq[k][l];
            }
        }
        self.cond_a_max = self.cond_a_max.max(o.cond_a_max);
        self.cond_jp_max = self.cond_jp_max.max(o.cond_jp_max);
    }
}

/// The kinds whose take-up can switch (docs/model.md §8): `u_angular` never does.
pub const UPS_SWITCH_KINDS: [&str; 2] = ["s_radial", "u_radial"];

/// One row of a 6-UPS `summary.parquet`.
pub struct UpsSummaryRow {
    pub variant: u64,
    pub mode: &'static str,
    /// The swept parameters' values, in the order of the job's `[[sweep]]`.
    pub params: Vec<f64>,
    pub stats: UpsStats,
    /// Switch counts per kind, order of [`UPS_SWITCH_KINDS`].
    pub switches: [u64; 2],
}

/// A 6-UPS `summary.parquet`: the 3-limb summary's columns for this kind's kinds and
/// joints.
pub fn ups_summary_batch(param_names: &[String], rows: &[UpsSummaryRow]) -> RecordBatch {
    let mut t = SummaryTable::new(rows);
    t.head(param_names, |r| (r.variant, r.mode, &r.params, r.stats.samples, r.stats.status));
    t.series("dp", "m", |r| &r.stats.dp);
    t.series("dalpha", "rad", |r| &r.stats.dalpha);
    for (k, kind) in UPS_KINDS.iter().enumerate() {
        t.series(&format!("dp_{kind}"), "m", move |r| &r.stats.dp_kind[k]);
        t.series(&format!("dalpha_{kind}"), "rad", move |r| &r.stats.dalpha_kind[k]);
    }
    t.series("env_p", "m", |r| &r.stats.env_p);
    t.series("env_alpha", "rad", |r| &r.stats.env_alpha);
    let joints = UPS_KINDS
        .iter()
        .enumerate()
        .flat_map(|(k, kind)| (0..6).map(move |l| (clearance_solver::joint_label(kind, l), k, l)));
    let ok = Status::Ok.index();
    t.joints(joints, |r, k, l| (r.stats.status[ok], r.stats.dominant[k][l], r.stats.joint_sum_sq[k][l]));
    t.switches(&UPS_SWITCH_KINDS, |r| &r.switches);
    t.conditions(|r| (r.stats.cond_a_max, r.stats.cond_jp_max));
    t.finish()
}

/// One refined switch of a joint's take-up, located by the six platform coordinates:
/// a 6-UPS's (its inputs) and a custom mechanism's.
#[derive(Clone, Debug, PartialEq)]
pub struct SixSwitch {
    pub variant: u64,
    pub mode: Mode,
    /// 1.. (1..6 for a 6-UPS).
    pub limb: usize,
    /// An index into the kind's switch kinds ([`UPS_SWITCH_KINDS`], a custom model's
    /// `kinds`).
    pub kind: usize,
    /// The input the path varies (`t` along a trajectory).
    pub along: &'static str,
    pub t: Option<f64>,
    /// The six platform coordinates there (`x, y, z, phi, psi, theta`).
    pub coords: [f64; 6],
    /// The deciding load there (N, or N·m for a couple).
    pub margin: f64,
    /// That kind's ΔΓ after minus before, as `[Δp; Δα]`.
    pub jump: [f64; 6],
}

/// One refined switch of a 6-UPS joint's take-up.
pub type UpsSwitch = SixSwitch;

/// A 6-UPS `discontinuities.parquet`: every input of the kind, `limb` 1..6.
pub fn ups_discontinuity_batch(rows: &[UpsSwitch]) -> RecordBatch {
    six_coordinate_switch_batch(rows, &UPS_SWITCH_KINDS, false, "N")
}

/// The `discontinuities.parquet` of switches located by six coordinates, for the
/// 6-UPS and every custom mechanism: `variant, mode, limb, kind` (named by `kinds`),
/// `along, t`, the coordinates `x … theta` (null where not finite when
/// `coords_nullable`, else a non-nullable column), `margin` (in `margin_unit`) and
/// `jump_x … jump_rz`, null where not finite (a side of the switch with that kind
/// indeterminate).
pub(crate) fn six_coordinate_switch_batch(
    rows: &[SixSwitch],
    kinds: &[&str],
    coords_nullable: bool,
    margin_unit: &str,
) -> RecordBatch {
    let finite = |v: f64| Some(v).filter(|v| v.is_finite());
    let mut fields = vec![
        field("variant", DataType::UInt64, false, "1"),
        field("mode", DataType::Utf8, false, ""),
        field("limb", DataType::UInt32, false, "1"),
        field("kind", DataType::Utf8, false, ""),
        field("along", DataType::Utf8, false, ""),
        field("t", DataType::Float64, true, "s"),
    ];
    let mut cols: Vec<ArrayRef> = vec![
        Arc::new(UInt64Array::from_iter_values(rows.iter().map(|d| d.variant))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|d| d.mode.name()))),
        Arc::new(UInt32Array::from_iter_values(rows.iter().map(|d| d.limb as u32))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|d| kinds[d.kind]))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|d| d.along))),
        Arc::new(Float64Array::from_iter(rows.iter().map(|d| d.t))),
    ];
    for (i, (name, unit)) in UPS_INPUTS.iter().zip(INPUT_UNITS).enumerate() {
        fields.push(field(name, DataType::Float64, coords_nullable, unit));
        cols.push(if coords_nullable {
            Arc::new(Float64Array::from_iter(rows.iter().map(|d| finite(d.coords[i]))))
        } else {
            Arc::new(Float64Array::from_iter_values(rows.iter().map(|d| d.coords[i])))
        });
    }
    fields.push(field("margin", DataType::Float64, true, margin_unit));
    cols.push(Arc::new(Float64Array::from_iter(rows.iter().map(|d| finite(d.margin)))));
    for (i, (c, unit)) in ERR_PARTS[..6].iter().enumerate() {
        fields.push(field(&format!("jump_{c}"), DataType::Float64, true, unit));
        cols.push(Arc::new(Float64Array::from_iter(rows.iter().map(|d| finite(d.jump[i])))));
    }
    RecordBatch::try_new(Arc::new(Schema::new(fields)), cols).expect("columns match the schema")
}
