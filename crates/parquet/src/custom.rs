//! The tables of a custom mechanism (docs/model.md §12, docs/interface.md §5): `poses`
//! rows with the six platform coordinates, an actuator and a motor load per actuated
//! joint, and columns per clearance kind `<name>_<group>` and per joint of each limb;
//! the summary's statistics; the switches of `discontinuities.parquet`. Built from the
//! model, so every mechanism gets the same code. Nulls follow docs/conventions.md, and
//! no value that is not finite is ever written.

use std::collections::HashMap;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::record_batch::RecordBatch;
use clearance_model::Mode;
use clearance_model::custom::{COORDINATES, Group, JointType};
use clearance_solver::Status;
use clearance_solver::custom::{CustomModel, CustomResult};
use serde::{Deserialize, Serialize};

use crate::pages::{PAGE_ROWS, PageStats, encode_page, encode_page_single};
use crate::precision::{Precision, stored_field};
use crate::schema::{ColumnSet, ENVELOPE_PARTS, ERR_PARTS, FiniteRows};
use crate::summary::{Series, SummaryTable};
use crate::ups::{INPUT_UNITS, SixSwitch, six_coordinate_switch_batch};
use crate::writer::Codec;
use rayon::prelude::*;

/// One sample's identity: its index and its time (trajectories).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CustomRow {
    pub sample: u64,
    pub t: Option<f64>,
}

/// What a float column of a custom run holds, in [`CustomSchema::new`]'s words: read from
/// each row's result a [`Span`] of columns at a time (a boxed closure a column, called
/// for every value, was most of filling a row).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fill {
    /// A platform coordinate, known wherever the closure was solved.
    Coord(usize),
    /// A component of the total error (`ok` poses).
    Err(usize),
    /// An actuator's position from home.
    Q(usize),
    /// An actuator's motor load.
    Tau(usize),
    /// A component of a kind's error: (kind, component).
    KindErr(usize, usize),
    /// A group's margin.
    Margin(usize),
    /// A part of the envelope of every kind.
    Env(usize),
    /// A part of a kind's envelope: (kind, part).
    KindEnv(usize, usize),
    /// A component of a joint's force: (limb, joint, axis).
    Force(usize, usize, usize),
    /// A component of a joint's couple: (limb, joint, axis).
    Moment(usize, usize, usize),
    /// The condition number (`cond_a` and `cond_jp` both).
    Cond,
    /// A component of the exact error.
    Exact(usize),
}

/// `out.copy_from_slice(src)` for the short runs a span copies (at most nine values,
/// a kind's error): a copy of a length known here rather than a call to `memcpy` for
/// each of a row's thirty-odd spans (the calls were a fifth of filling a row,
/// callgrind). Panics, as `copy_from_slice` does, where the lengths differ.
#[inline(always)]
fn copy_short(out: &mut [f64], src: &[f64]) {
    macro_rules! fixed {
        ($($n:literal)*) => {
            match out.len() {
                $($n => {
                    let to: &mut [f64; $n] = out.try_into().expect("matched length");
                    *to = src.try_into().expect("the source as long as the span");
                })*
                _ => out.copy_from_slice(src),
            }
        };
    }
    fixed!(1 2 3 4 5 6 7 8 9)
}

impl Fill {
    /// The column's value in the row of `r` (`loaded`: [`CustomResult::loaded`]); `None`
    /// where it has none.
    #[cfg(test)]
    fn of(self, r: &CustomResult, loaded: bool) -> Option<f64> {
        let reachable = r.status != Status::Unreachable;
        match self {
            Fill::Coord(k) => Some(r.coords[k]),
            Fill::Err(i) => (r.status == Status::Ok).then(|| r.total.map(|e| e[i])).flatten(),
            Fill::Q(i) => r.q.get(i).copied().filter(|_| reachable),
            Fill::Tau(i) => loaded.then(|| r.tau.get(i).copied()).flatten(),
            Fill::KindErr(k, i) => loaded.then(|| r.kind_errors.get(k).copied().flatten().map(|e| e[i])).flatten(),
            Fill::Margin(g) => loaded.then(|| r.takes.get(g).map(|t| t.margin)).flatten(),
            Fill::Env(c) => loaded.then_some(r.env_total[c]),
            Fill::KindEnv(k, c) => loaded.then(|| r.envelope.get(k).map(|e| e[c])).flatten(),
            Fill::Force(l, j, a) => loaded.then(|| r.reactions[l][j].0[a]),
            Fill::Moment(l, j, a) => loaded.then(|| r.reactions[l][j].1[a]),
            Fill::Cond => reachable.then_some(r.cond),
            Fill::Exact(i) => r.exact.map(|e| e[i]),
        }
    }

    /// The column after this one in a [`Span`] of consecutive components of one place,
    /// if there is one.
    fn next(self) -> Option<Fill> {
        Some(match self {
            Fill::Coord(k) => Fill::Coord(k + 1),
            Fill::Err(i) => Fill::Err(i + 1),
            Fill::Q(i) => Fill::Q(i + 1),
            Fill::Tau(i) => Fill::Tau(i + 1),
            Fill::KindErr(k, i) => Fill::KindErr(k, i + 1),
            Fill::Margin(g) => Fill::Margin(g + 1),
            Fill::Env(c) => Fill::Env(c + 1),
            Fill::KindEnv(k, c) => Fill::KindEnv(k, c + 1),
            Fill::Force(l, j, a) => Fill::Force(l, j, a + 1),
            Fill::Moment(l, j, a) => Fill::Moment(l, j, a + 1),
            Fill::Cond => return None,
            Fill::Exact(i) => Fill::Exact(i + 1),
        })
    }
}

/// Consecutive float columns that read consecutive components of one place of a row's
/// result (a kind's nine error components, a joint's force): filled by one `match` a
/// span, the values copied together. One `match` a value, with its checks, was most of
/// filling a row (a described 3-PRS: 6 k instructions a row of 109 floats, callgrind).
#[derive(Clone, Copy, Debug)]
struct Span {
    /// The first column's.
    first: Fill,
    len: usize,
}

impl Span {
    /// The spans of `floats`, in order.
    fn of(floats: &[Fill]) -> Vec<Span> {
        let mut out: Vec<Span> = Vec::new();
        let mut next: Option<Fill> = None;
        for &f in floats {
            match (out.last_mut(), next) {
                (Some(span), Some(n)) if n == f => span.len += 1,
                _ => out.push(Span { first: f, len: 1 }),
            }
            next = f.next();
        }
        out
    }

    /// Writes the span's values in the row of `r` to `out` (its `len` columns; NaN where
    /// a column has none), as [`Fill::of`] reads each (`loaded`: [`CustomResult::loaded`]).
    fn put(self, r: &CustomResult, loaded: bool, out: &mut [f64]) {
        let reachable = r.status != Status::Unreachable;
        let n = self.len;
        let from = |src: Option<&[f64]>, start: usize, out: &mut [f64]| match src.and_then(|s| s.get(start..start + n))
        {
            Some(values) => copy_short(out, values),
            None => {
                // Part of the range may be there (a shorter list): each on its own.
                for (k, o) in out.iter_mut().enumerate() {
                    *o = src.and_then(|s| s.get(start + k)).copied().unwrap_or(f64::NAN);
                }
            }
        };
        match self.first {
            Fill::Coord(k) => copy_short(out, &r.coords[k..k + n]),
            Fill::Err(i) => {
                let total = if r.status == Status::Ok { r.total.as_ref() } else { None };
                from(total.map(|e| &e[..]), i, out)
            }
            Fill::Q(i) => from(reachable.then_some(&r.q[..]), i, out),
            Fill::Tau(i) => from(loaded.then_some(&r.tau[..]), i, out),
            Fill::KindErr(k, i) => {
                let e = if loaded { r.kind_errors.get(k).and_then(Option::as_ref) } else { None };
                from(e.map(|e| &e[..]), i, out)
            }
            Fill::Margin(g) => {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = if loaded { r.takes.get(g + k).map_or(f64::NAN, |t| t.margin) } else { f64::NAN };
                }
            }
            Fill::Env(c) => from(loaded.then_some(&r.env_total[..]), c, out),
            Fill::KindEnv(k, c) => from(if loaded { r.envelope.get(k).map(|e| &e[..]) } else { None }, c, out),
            // A pose without loads may have no reactions at all.
            Fill::Force(l, j, a) if loaded => copy_short(out, &r.reactions[l][j].0.as_slice()[a..a + n]),
            Fill::Moment(l, j, a) if loaded => copy_short(out, &r.reactions[l][j].1.as_slice()[a..a + n]),
            Fill::Force(..) | Fill::Moment(..) => out.fill(f64::NAN),
            Fill::Cond => out.fill(if reachable { r.cond } else { f64::NAN }),
            Fill::Exact(i) => from(r.exact.as_ref().map(|e| &e[..]), i, out),
        }
    }
}

/// The `poses` columns of a custom run for one column set.
pub struct CustomSchema {
    schema: SchemaRef,
    /// The float columns, in spans of consecutive components.
    spans: Vec<Span>,
    /// How many float columns the spans hold.
    floats: usize,
    /// The `dominant` column's values, by group, when the set has the column.
    dominant: Option<Vec<String>>,
}

/// The unit of a group's magnitude and of its deciding load.
fn group_units(joint: JointType, group: Group) -> (&'static str, &'static str) {
    match (joint, group) {
        (_, Group::Angular) => ("rad", "N*m"),
        (JointType::R, Group::Backlash) => ("rad", "N*m"),
        _ => ("m", "N"),
    }
}

impl CustomSchema {
    /// The columns of `set` for `model`, plus the exact-error columns when `exact` is on.
    pub fn new(model: &CustomModel, set: ColumnSet, exact: bool) -> Self {
        let mut names: Vec<(String, &'static str)> = Vec::new();
        let mut floats: Vec<Fill> = Vec::new();
        let mut push = |name: String, unit: &'static str, f: Fill| {
            names.push((name, unit));
            floats.push(f);
        };
        let geom = &model.geom;
        // Minimal: the inputs and the total errors; standard adds the parasitic coordinates.
        for &k in &geom.inputs {
            push(COORDINATES[k].to_string(), INPUT_UNITS[k], Fill::Coord(k));
        }
        for (i, (c, unit)) in ERR_PARTS.iter().enumerate() {
            push(format!("err_{c}"), unit, Fill::Err(i));
        }
        if set >= ColumnSet::Standard {
            for &k in &geom.parasitic {
                // Known wherever the closure was solved (a joint out of its range too).
                push(COORDINATES[k].to_string(), INPUT_UNITS[k], Fill::Coord(k));
            }
            let actuators = model.actuators();
            for (i, &(l, j)) in actuators.iter().enumerate() {
                let unit = if geom.limbs[l].joints[j].joint == JointType::R { "rad" } else { "m" };
                push(format!("q{}", i + 1), unit, Fill::Q(i));
            }
            for (i, &(l, j)) in actuators.iter().enumerate() {
                let unit = if geom.limbs[l].joints[j].joint == JointType::R { "N*m" } else { "N" };
                push(format!("tau{}", i + 1), unit, Fill::Tau(i));
            }
            for (k, kind) in model.kinds.iter().enumerate() {
                for (i, (c, unit)) in ERR_PARTS.iter().enumerate() {
                    push(format!("err_{kind}_{c}"), unit, Fill::KindErr(k, i));
                }
            }
            // Margins limb by limb, joint by joint, group by group.
            let mut order: Vec<usize> = (0..model.groups.len()).collect();
            order.sort_by_key(|&g| (model.groups[g].limb, model.groups[g].joint, model.groups[g].group));
            for g in order {
                let def = &model.groups[g];
                let joint = &geom.limbs[def.limb].joints[def.joint];
                let (_, unit) = group_units(joint.joint, def.group);
                push(format!("margin_{}", def.label), unit, Fill::Margin(g));
            }
            let kinds = std::iter::once(None).chain(model.kinds.iter().enumerate().map(Some));
            for kind in kinds {
                for (c, (part, unit)) in ENVELOPE_PARTS.iter().enumerate() {
                    let (name, f) = match kind {
                        None => (format!("env_{part}"), Fill::Env(c)),
                        Some((k, kind)) => (format!("env_{kind}_{part}"), Fill::KindEnv(k, c)),
                    };
                    push(name, unit, f);
                }
            }
        }
        if set >= ColumnSet::Full {
            for (l, limb) in geom.limbs.iter().enumerate() {
                for (j, joint) in limb.joints.iter().enumerate() {
                    let n = format!("{}{}", joint.name, l + 1);
                    for (a, c) in ["x", "y", "z"].into_iter().enumerate() {
                        push(format!("f_{n}_{c}"), "N", Fill::Force(l, j, a));
                    }
                    for (a, c) in ["x", "y", "z"].into_iter().enumerate() {
                        push(format!("m_{n}_{c}"), "N*m", Fill::Moment(l, j, a));
                    }
                }
            }
            push("cond_a".into(), "1", Fill::Cond);
            push("cond_jp".into(), "1", Fill::Cond);
        }
        if exact {
            for (i, (c, unit)) in ERR_PARTS[..6].iter().enumerate() {
                push(format!("exact_err_{c}"), unit, Fill::Exact(i));
            }
        }
        let unit = |u: &str| HashMap::from([("unit".to_string(), u.to_string())]);
        let mut fields = vec![
            Field::new("mode", DataType::Utf8, false).with_metadata(unit("")),
            Field::new("sample", DataType::UInt64, false).with_metadata(unit("1")),
            Field::new("t", DataType::Float64, true).with_metadata(unit("s")),
            Field::new("status", DataType::Utf8, false).with_metadata(unit("")),
        ];
        let dominant = (set >= ColumnSet::Standard).then(|| model.groups.iter().map(|g| g.label.clone()).collect());
        if dominant.is_some() {
            fields.push(Field::new("dominant", DataType::Utf8, true).with_metadata(unit("")));
        }
        fields.extend(names.iter().map(|(n, u)| Field::new(n, DataType::Float64, true).with_metadata(unit(u))));
        Self { schema: Arc::new(Schema::new(fields)), spans: Span::of(&floats), floats: floats.len(), dominant }
    }

    pub fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// The record batch of one mode's rows (`rows` and `results` of the same length).
    #[track_caller]
    pub fn batch(&self, mode: Mode, rows: &[CustomRow], results: &[CustomResult]) -> RecordBatch {
        let mut part = self.part(mode, rows.len());
        self.fill(&mut part, rows, results);
        self.finish(part)
    }

    /// A part of `len` rows of `mode` to be filled a run of rows at a time
    /// ([`CustomSchema::fill`]), then made a record batch ([`CustomSchema::finish`]): the
    /// batch of [`CustomSchema::batch`], without the part's results all at hand at once.
    pub fn part(&self, mode: Mode, len: usize) -> CustomPart {
        CustomPart {
            mode,
            len,
            sample: Vec::with_capacity(len),
            t: Vec::with_capacity(len),
            status: Vec::with_capacity(len),
            dominant: Vec::with_capacity(if self.dominant.is_some() { len } else { 0 }),
            floats: FiniteRows::new(len, self.floats),
        }
    }

    /// The part's next rows (`rows` and `results` of the same length).
    #[track_caller]
    pub fn fill(&self, part: &mut CustomPart, rows: &[CustomRow], results: &[CustomResult]) {
        assert_eq!(rows.len(), results.len(), "one result per row");
        let start = part.sample.len();
        assert!(start + rows.len() <= part.len, "rows beyond the part's length");
        self.labels((&mut part.sample, &mut part.status, &mut part.dominant), rows, results);
        part.t.extend(rows.iter().map(|s| s.t.filter(|t| t.is_finite())));
        self.floats_of(&mut part.floats, start, results);
    }

    /// Appends the `sample`, `status` and (where the set has it) `dominant` of `rows`.
    fn labels(
        &self,
        (sample, status, dominant): (&mut Vec<u64>, &mut Vec<Status>, &mut Vec<Option<usize>>),
        rows: &[CustomRow],
        results: &[CustomResult],
    ) {
        sample.extend(rows.iter().map(|s| s.sample));
        status.extend(results.iter().map(|r| r.status));
        if self.dominant.is_some() {
            dominant.extend(results.iter().map(|r| (r.status == Status::Ok).then_some(r.dominant).flatten()));
        }
    }

    /// Fills rows `start..` of `floats` with the float columns of `results`.
    fn floats_of(&self, floats: &mut FiniteRows, start: usize, results: &[CustomResult]) {
        let spans = &self.spans;
        floats.fill(start..start + results.len(), |i, mut out| {
            let r = &results[i - start];
            let loaded = r.loaded();
            for span in spans {
                let (values, rest) = out.split_at_mut(span.len);
                span.put(r, loaded, values);
                out = rest;
            }
        });
    }

    /// A part of `len` rows of `mode` whose pages are encoded with `codec` as their rows
    /// come ([`CustomSchema::fill_pages`]), its error, envelope and margin columns as
    /// `precision` stores them.
    pub fn pages(&self, mode: Mode, len: usize, codec: Codec, precision: Precision) -> CustomPages {
        let fields: Vec<Field> = self.schema.fields().iter().map(|f| stored_field(f, precision)).collect();
        let single = fields
            .iter()
            .skip(self.schema.fields().len() - self.floats)
            .map(|f| f.data_type() == &DataType::Float32)
            .collect();
        CustomPages {
            mode,
            len,
            codec,
            schema: Arc::new(Schema::new_with_metadata(fields, self.schema.metadata().clone())),
            single,
            names: self.dominant.clone(),
            sample: Vec::with_capacity(len),
            status: Vec::with_capacity(len),
            dominant: Vec::with_capacity(if self.dominant.is_some() { len } else { 0 }),
            stage: FiniteRows::unflagged(0, self.floats),
            stage_t: Vec::new(),
            staged: 0,
            pages: Vec::with_capacity(len.div_ceil(PAGE_ROWS)),
            failed: None,
        }
    }

    /// The part's next rows (`rows` and `results` of the same length), as
    /// [`CustomSchema::fill`] puts them; each page whose rows are all in is encoded.
    #[track_caller]
    pub fn fill_pages(&self, part: &mut CustomPages, rows: &[CustomRow], results: &[CustomResult]) {
        assert_eq!(rows.len(), results.len(), "one result per row");
        assert!(part.sample.len() + rows.len() <= part.len, "rows beyond the part's length");
        self.labels((&mut part.sample, &mut part.status, &mut part.dominant), rows, results);
        let start = part.staged;
        let end = start + rows.len();
        for v in &mut part.stage.values {
            v.resize(end, 0.0);
        }
        part.stage_t.truncate(start);
        part.stage_t.extend(rows.iter().map(|s| s.t.unwrap_or(f64::NAN)));
        self.floats_of(&mut part.stage, start, results);
        part.staged = end;
        let ready = if part.sample.len() == part.len { end } else { end / PAGE_ROWS * PAGE_ROWS };
        if ready > 0 {
            part.encode(ready);
        }
    }

    /// The part's record batch, once every row is filled.
    #[track_caller]
    pub fn finish(&self, part: CustomPart) -> RecordBatch {
        assert_eq!(part.sample.len(), part.len, "every row of the part filled");
        let mut out: Vec<ArrayRef> = vec![
            Arc::new(StringArray::from_iter_values(part.sample.iter().map(|_| part.mode.name()))),
            Arc::new(UInt64Array::from(part.sample)),
            Arc::new(Float64Array::from_iter(part.t)),
            Arc::new(StringArray::from_iter_values(part.status.iter().map(|s| s.name()))),
        ];
        if let Some(names) = &self.dominant {
            out.push(Arc::new(StringArray::from_iter(part.dominant.iter().map(|g| g.map(|g| names[g].as_str())))));
        }
        out.extend(part.floats.finish());
        RecordBatch::try_new(self.schema.clone(), out).expect("columns match the schema")
    }
}

/// A part's rows being filled ([`CustomSchema::part`]).
pub struct CustomPart {
    mode: Mode,
    len: usize,
    sample: Vec<u64>,
    t: Vec<Option<f64>>,
    status: Vec<Status>,
    /// Each row's dominant group (where the set has the column).
    dominant: Vec<Option<usize>>,
    floats: FiniteRows,
}

/// A part file's rows of a custom run whose double columns are encoded a page at a
/// time as their rows come ([`CustomSchema::pages`], [`CustomSchema::fill_pages`]),
/// then written by [`write_custom_part`](crate::write_custom_part), as a 3-limb run's
/// [`PartPages`](crate::PartPages) are: a part's columns whole (35 MB of doubles for
/// 40 000 rows of a described 3-PRS) came as fresh memory, a page fault every 4 kB,
/// and left the caches before they were encoded.
pub struct CustomPages {
    pub(crate) mode: Mode,
    pub(crate) len: usize,
    pub(crate) codec: Codec,
    /// The schema as the file stores it (`--precision`).
    pub(crate) schema: SchemaRef,
    /// Per float column, whether it is stored as `float32`.
    single: Vec<bool>,
    /// The `dominant` column's values, by group, when the set has the column.
    names: Option<Vec<String>>,
    pub(crate) sample: Vec<u64>,
    pub(crate) status: Vec<Status>,
    dominant: Vec<Option<usize>>,
    /// The rows filled but not yet encoded, the part's last ones: fewer than a page
    /// once a fill returns, unless the part is complete.
    stage: FiniteRows,
    stage_t: Vec<f64>,
    pub(crate) staged: usize,
    /// Each page of [`PAGE_ROWS`] rows (the last one shorter), per double column (`t`
    /// first) its bytes and what the column chunk needs of it.
    pub(crate) pages: Vec<Vec<(Vec<u8>, PageStats)>>,
    /// The first error met encoding a page (reported where the part is written).
    pub(crate) failed: Option<parquet::errors::ParquetError>,
}

impl CustomPages {
    /// The double columns: `t` and the floats.
    pub(crate) fn doubles(&self) -> usize {
        1 + self.single.len()
    }

    /// The `dominant` column, where the set has it.
    pub(crate) fn dominant_column(&self) -> Option<ArrayRef> {
        let names = self.names.as_ref()?;
        Some(Arc::new(StringArray::from_iter(self.dominant.iter().map(|g| g.map(|g| names[g].as_str())))))
    }

    /// Encodes the first `rows` staged rows, whole pages but at the part's end, and
    /// moves the rest to the front of the stage.
    fn encode(&mut self, rows: usize) {
        let doubles = self.doubles();
        let pages: Vec<(usize, usize)> =
            (0..rows).step_by(PAGE_ROWS).map(|first| (first, PAGE_ROWS.min(rows - first))).collect();
        let (stage, stage_t, single, codec) = (&self.stage, &self.stage_t, &self.single, self.codec);
        // Every column of every page on the pool: on many cores a block's pages alone
        // would be too few tasks.
        let encoded: Vec<Result<(Vec<u8>, PageStats), parquet::errors::ParquetError>> = (0..pages.len() * doubles)
            .into_par_iter()
            .map(|k| {
                let ((first, n), c) = (pages[k / doubles], k % doubles);
                let values = if c == 0 { &stage_t[first..first + n] } else { &stage.values[c - 1][first..first + n] };
                let mut bytes = Vec::with_capacity(n * 8 + n / 8 + 64);
                let encode = if c > 0 && single[c - 1] { encode_page_single } else { encode_page };
                encode(values, codec, &mut bytes).map(|stats| (bytes, stats))
            })
            .collect();
        let mut encoded = encoded.into_iter();
        for _ in &pages {
            let page: Result<Vec<_>, _> = encoded.by_ref().take(doubles).collect();
            match page {
                Ok(page) => self.pages.push(page),
                Err(e) => {
                    self.failed.get_or_insert(e);
                }
            }
        }
        let rest = self.staged - rows;
        for v in &mut self.stage.values {
            v.copy_within(rows..self.staged, 0);
        }
        self.stage_t.copy_within(rows..self.staged, 0);
        self.staged = rest;
    }
}

/// The partial statistics of a set of custom poses of one (variant, mode).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CustomStats {
    pub samples: u64,
    /// Counts per status, in the order of `Status::ALL`.
    pub status: [u64; 4],
    pub dp: Series,
    pub dalpha: Series,
    /// Per kind, the poses where that kind is determinate.
    pub dp_kind: Vec<Series>,
    pub dalpha_kind: Vec<Series>,
    pub cond_max: f64,
    pub env_p: Series,
    pub env_alpha: Series,
    /// Per group (`CustomModel::groups`), over `ok` poses: how often it dominates, and
    /// the sum of squares of its own contribution to |Δp|.
    pub dominant: Vec<u64>,
    pub joint_sum_sq: Vec<f64>,
}

fn norm3(a: f64, b: f64, c: f64) -> f64 {
    (a * a + b * b + c * c).sqrt()
}

impl CustomStats {
    /// Empty statistics for `kinds` kinds and `groups` groups.
    pub fn new(kinds: usize, groups: usize) -> Self {
        Self {
            dp_kind: vec![Series::default(); kinds],
            dalpha_kind: vec![Series::default(); kinds],
            dominant: vec![0; groups],
            joint_sum_sq: vec![0.0; groups],
            ..Default::default()
        }
    }

    pub fn push(&mut self, r: &CustomResult) {
        self.samples += 1;
        self.status[r.status.index()] += 1;
        if r.status != Status::Unreachable && r.cond.is_finite() {
            self.cond_max = self.cond_max.max(r.cond);
        } else if r.status == Status::NearSingular {
            self.cond_max = f64::INFINITY;
        }
        if r.status == Status::Ok {
            if let Some(e) = r.total {
                self.dp.push(norm3(e[0], e[1], e[2]));
                self.dalpha.push(norm3(e[3], e[4], e[5]));
            }
            if let Some(g) = r.dominant {
                self.dominant[g] += 1;
            }
            for (sum, t) in self.joint_sum_sq.iter_mut().zip(&r.takes) {
                if t.dp.is_finite() {
                    *sum += t.dp * t.dp;
                }
            }
        }
        if r.loaded() {
            if r.env_total[6].is_finite() && r.env_total[7].is_finite() {
                self.env_p.push(r.env_total[6]);
                self.env_alpha.push(r.env_total[7]);
            }
            for (k, e) in r.kind_errors.iter().enumerate() {
                if let Some(e) = e {
                    self.dp_kind[k].push(norm3(e[0], e[1], e[2]));
                    self.dalpha_kind[k].push(norm3(e[3], e[4], e[5]));
                }
            }
        }
    }

    pub fn flush(&mut self) {
        let totals = [&mut self.dp, &mut self.dalpha, &mut self.env_p, &mut self.env_alpha];
        for s in totals.into_iter().chain(&mut self.dp_kind).chain(&mut self.dalpha_kind) {
            s.flush();
        }
    }

    pub fn merge(&mut self, o: &CustomStats) {
        self.samples += o.samples;
        for i in 0..4 {
            self.status[i] += o.status[i];
        }
        for (a, b) in self.dp_kind.iter_mut().zip(&o.dp_kind) {
            a.merge(b);
        }
        for (a, b) in self.dalpha_kind.iter_mut().zip(&o.dalpha_kind) {
            a.merge(b);
        }
        self.dp.merge(&o.dp);
        self.dalpha.merge(&o.dalpha);
        self.env_p.merge(&o.env_p);
        self.env_alpha.merge(&o.env_alpha);
        for (a, b) in self.dominant.iter_mut().zip(&o.dominant) {
            *a += b;
        }
        for (a, b) in self.joint_sum_sq.iter_mut().zip(&o.joint_sum_sq) {
            *a += b;
        }
        self.cond_max = self.cond_max.max(o.cond_max);
    }
}

/// One row of a custom `summary.parquet`.
pub struct CustomSummaryRow {
    pub variant: u64,
    pub mode: &'static str,
    pub params: Vec<f64>,
    pub stats: CustomStats,
    /// Switch counts per kind (`CustomModel::kinds`).
    pub switches: Vec<u64>,
}

/// A custom `summary.parquet`: the columns of the built-in kinds', for this
/// mechanism's kinds and joint groups.
pub fn custom_summary_batch(model: &CustomModel, param_names: &[String], rows: &[CustomSummaryRow]) -> RecordBatch {
    let mut t = SummaryTable::new(rows);
    t.head(param_names, |r| (r.variant, r.mode, &r.params, r.stats.samples, r.stats.status));
    t.series("dp", "m", |r| &r.stats.dp);
    t.series("dalpha", "rad", |r| &r.stats.dalpha);
    for (k, kind) in model.kinds.iter().enumerate() {
        t.series(&format!("dp_{kind}"), "m", move |r| &r.stats.dp_kind[k]);
        t.series(&format!("dalpha_{kind}"), "rad", move |r| &r.stats.dalpha_kind[k]);
    }
    t.series("env_p", "m", |r| &r.stats.env_p);
    t.series("env_alpha", "rad", |r| &r.stats.env_alpha);
    let joints = model.groups.iter().enumerate().map(|(g, def)| (def.label.clone(), g, 0));
    let ok = Status::Ok.index();
    t.joints(joints, |r, g, _| (r.stats.status[ok], r.stats.dominant[g], r.stats.joint_sum_sq[g]));
    let kinds: Vec<&str> = model.kinds.iter().map(String::as_str).collect();
    t.switches(&kinds, |r| &r.switches);
    t.conditions(|r| (r.stats.cond_max, r.stats.cond_max));
    t.finish()
}

/// One refined switch of a joint group's take-up (`kind` an index into
/// `CustomModel::kinds`, `limb` 1..).
pub type CustomSwitch = SixSwitch;

/// A custom `discontinuities.parquet`: every platform coordinate, `limb` 1.., `kind`
/// `<name>_<group>`.
pub fn custom_discontinuity_batch(model: &CustomModel, rows: &[CustomSwitch]) -> RecordBatch {
    let kinds: Vec<&str> = model.kinds.iter().map(String::as_str).collect();
    six_coordinate_switch_batch(rows, &kinds, true, "N or N*m")
}

#[cfg(test)]
mod tests {
    use super::*;
    use clearance_solver::custom::{GroupTake, Reactions};
    use nalgebra::Vector3;

    /// Every kind of column, in the orders `CustomSchema::new` writes them (runs of
    /// consecutive components, and columns that merge with no neighbour).
    fn columns() -> Vec<Fill> {
        let mut f = vec![Fill::Coord(2), Fill::Coord(4), Fill::Coord(5)];
        f.extend((0..9).map(Fill::Err));
        f.extend([Fill::Coord(0), Fill::Coord(1), Fill::Coord(3)]);
        f.extend((0..3).map(Fill::Q));
        f.extend((0..3).map(Fill::Tau));
        for k in 0..2 {
            f.extend((0..9).map(|i| Fill::KindErr(k, i)));
        }
        f.extend([0, 1, 3, 2, 4].map(Fill::Margin));
        f.extend((0..8).map(Fill::Env));
        for k in 0..2 {
            f.extend((0..8).map(|c| Fill::KindEnv(k, c)));
        }
        for (l, j) in [(0, 0), (0, 1), (1, 0)] {
            f.extend((0..3).map(|a| Fill::Force(l, j, a)));
            f.extend((0..3).map(|a| Fill::Moment(l, j, a)));
        }
        f.extend([Fill::Cond, Fill::Cond]);
        f.extend((0..6).map(Fill::Exact));
        f
    }

    /// A result whose every value is distinct, with `status`, some lists shorter than
    /// the columns read and a kind without an error.
    fn result(status: Status, seed: f64) -> CustomResult {
        let v = |k: usize| seed + k as f64;
        let arr = |k: usize| -> [f64; 9] { std::array::from_fn(|i| v(10 * k + i)) };
        let pair = |k: usize| (Vector3::new(v(k), v(k + 1), v(k + 2)), Vector3::new(v(k + 3), v(k + 4), v(k + 5)));
        CustomResult {
            status,
            coords: std::array::from_fn(|i| v(200 + i)),
            q: vec![v(300), v(301)],
            tau: vec![v(310), v(311), v(312)],
            reactions: Reactions::of(&[vec![pair(400), pair(410)], vec![pair(420)]]),
            takes: (0..4).map(|g| GroupTake { margin: v(500 + g), ..Default::default() }).collect(),
            kind_errors: vec![Some(arr(60)), None],
            total: (seed > 1.0).then(|| arr(70)),
            envelope: vec![std::array::from_fn(|c| v(800 + c))],
            env_total: std::array::from_fn(|c| v(810 + c)),
            dominant: Some(1),
            cond: v(900),
            exact: (seed > 2.0).then(|| std::array::from_fn(|i| v(910 + i))),
        }
    }

    #[test]
    fn spans_fill_what_each_column_reads() {
        let floats = columns();
        let spans = Span::of(&floats);
        // Runs merged: fewer spans than columns, and every column in one span.
        assert!(spans.len() < floats.len() / 3, "{} spans", spans.len());
        assert_eq!(spans.iter().map(|s| s.len).sum::<usize>(), floats.len());
        for status in [Status::Ok, Status::IndeterminateContact, Status::NearSingular, Status::Unreachable] {
            for seed in [0.5, 1.5, 2.5] {
                let mut r = result(status, seed);
                if status == Status::Unreachable {
                    // As the solver leaves an unreachable pose: no reactions.
                    r.reactions = Reactions::default();
                }
                let loaded = r.loaded();
                let mut row = vec![0.0; floats.len()];
                let mut out = &mut row[..];
                for span in &spans {
                    let (values, rest) = out.split_at_mut(span.len);
                    span.put(&r, loaded, values);
                    out = rest;
                }
                for (c, (f, got)) in floats.iter().zip(&row).enumerate() {
                    let want = f.of(&r, loaded).unwrap_or(f64::NAN);
                    assert_eq!(got.to_bits(), want.to_bits(), "column {c} ({f:?}), {status:?}, seed {seed}");
                }
            }
        }
    }
}
