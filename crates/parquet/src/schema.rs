//! The `poses` columns and how each is filled.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt64Array};
use arrow::buffer::{BooleanBuffer, NullBuffer, ScalarBuffer};
use arrow::datatypes::{DataType, Field, Schema, SchemaRef};
use arrow::record_batch::RecordBatch;
use clearance_grid::Sample;
use clearance_model::{KINDS, Mode};
use clearance_solver::{PoseError, PoseResult, Status};
use rayon::prelude::*;

use crate::pages::{self, PAGE_ROWS, PageStats};
use crate::precision::{Precision, stored_field, with_precision};
use crate::writer::Codec;

/// Which columns to write (docs/interface.md `--columns`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum ColumnSet {
    /// Identity, inputs, status and the total errors.
    Minimal,
    /// Adds per-kind errors, parasitic motions, actuators, margins, the worst-case
    /// envelope and the dominant joint (the default).
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

/// The value slots of one row, every column set's columns among them
/// ([`row_values`] fills those of the set at once; a column reads its slot).
mod slot {
    pub const Z: usize = 0;
    pub const PSI: usize = 1;
    pub const THETA: usize = 2;
    pub const X: usize = 3;
    pub const Y: usize = 4;
    pub const PHI: usize = 5;
    /// `q1..q3`.
    pub const Q: usize = 6;
    /// The nine parts of the total error.
    pub const TOTAL: usize = 9;
    /// Nine parts per kind.
    pub const KIND: usize = 18;
    /// Per limb: r_radial, r_axial, r_angular, s.
    pub const MARGIN: usize = 54;
    /// Per limb: f_r, m_r, f_s (three components each).
    pub const REACTION: usize = 66;
    pub const COND_A: usize = 93;
    pub const COND_JP: usize = 94;
    /// Δp then Δα.
    pub const EXACT: usize = 95;
    /// The envelope of all kinds, then of each kind: x, y, z, rx, ry, rz, p, alpha.
    pub const ENVELOPE: usize = 101;
    pub const COUNT: usize = 141;
}

struct FloatColumn {
    name: String,
    unit: &'static str,
    slot: usize,
}

/// The `poses` schema of one column set, and the batch builder for it.
pub struct PoseSchema {
    /// The columns as the part files store them.
    schema: SchemaRef,
    /// The columns as computed: every float a double.
    computed: SchemaRef,
    precision: Precision,
    /// Per float column: stored as `float32` ([`PoseSchema::with_precision`]).
    single: Vec<bool>,
    floats: Vec<FloatColumn>,
    /// The slot of each float column, in column order.
    slots: Vec<usize>,
    /// Whether the `dominant` column (after `status`) is in the set.
    dominant: bool,
    /// The slots the columns read.
    fill: Fill,
}

/// The envelope's parts: each component of `[Δp; Δα]`, then bounds on `|Δp|`, `|Δα|`.
pub(crate) const ENVELOPE_PARTS: [(&str, &str); 8] =
    [("x", "m"), ("y", "m"), ("z", "m"), ("rx", "rad"), ("ry", "rad"), ("rz", "rad"), ("p", "m"), ("alpha", "rad")];

/// The nine components of an error column: `[Δp; Δα]`, then the Euler-angle errors.
pub(crate) const ERR_PARTS: [(&str, &str); 9] = [
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

/// One row's slots, in column `k` of a [`Tile`].
struct Row<'t> {
    tile: &'t mut Tile,
    k: usize,
}

impl Row<'_> {
    #[inline(always)]
    fn set(&mut self, slot: usize, v: f64) {
        self.tile[slot][self.k] = v;
    }

    #[inline(always)]
    fn set_all(&mut self, first: usize, values: &[f64]) {
        for (i, &v) in values.iter().enumerate() {
            self.set(first + i, v);
        }
    }

    #[inline(always)]
    fn set_error(&mut self, first: usize, e: &PoseError) {
        for i in 0..3 {
            self.set(first + i, e.dp[i]);
            self.set(first + 3 + i, e.dalpha[i]);
            self.set(first + 6 + i, e.euler[i]);
        }
    }
}

/// Which slots [`row_values`] fills: those a column set reads, and the exact
/// error's when the job computes it.
#[derive(Clone, Copy)]
struct Fill {
    /// Per-kind errors, margins and the envelope (the standard set).
    standard: bool,
    /// Reactions (the full set).
    full: bool,
    exact: bool,
}

/// The slots of one row that `fill` names into `v`; NaN where the status leaves a
/// value undefined (docs/conventions.md), which the batch turns into a null. The
/// other slots keep whatever they held: no column reads them.
fn row_values(s: &Sample, r: &PoseResult, v: &mut Row<'_>, fill: Fill) {
    if !(r.status == Status::Ok && r.kind_ok == [true; 4]) {
        for slot in 0..slot::COUNT {
            v.set(slot, f64::NAN);
        }
    } else if fill.exact {
        // Every other slot of an `ok` row with every kind determinate is written below.
        for slot in slot::EXACT..slot::EXACT + 6 {
            v.set(slot, f64::NAN);
        }
    }
    v.set(slot::Z, s.z[0]);
    v.set(slot::PSI, s.psi[0]);
    v.set(slot::THETA, s.theta[0]);
    v.set(slot::X, r.x);
    v.set(slot::Y, r.y);
    v.set(slot::PHI, r.phi);
    if r.status == Status::Unreachable {
        return;
    }
    v.set_all(slot::Q, &r.q);
    v.set(slot::COND_A, r.cond_a);
    v.set(slot::COND_JP, r.cond_jp);
    if !matches!(r.status, Status::Ok | Status::IndeterminateContact) {
        return;
    }
    if r.status == Status::Ok {
        v.set_error(slot::TOTAL, &r.total);
    }
    if fill.standard {
        for k in 0..4 {
            if r.kind_ok[k] {
                v.set_error(slot::KIND + 9 * k, &r.errors[k]);
            }
        }
        let m = &r.margins;
        for j in 0..3 {
            v.set_all(slot::MARGIN + 4 * j, &[m.r_radial[j], m.r_axial[j], m.r_angular[j], m.s[j]]);
        }
        let total = r.envelope_total();
        v.set_all(slot::ENVELOPE, &total);
        for (k, env) in r.envelope.iter().enumerate() {
            v.set_all(slot::ENVELOPE + 8 * (k + 1), env);
        }
    }
    if fill.full {
        for j in 0..3 {
            let base = slot::REACTION + 9 * j;
            for i in 0..3 {
                v.set(base + i, r.reactions.f_r[j][i]);
                v.set(base + 3 + i, r.reactions.m_r[j][i]);
                v.set(base + 6 + i, r.reactions.f_s[j][i]);
            }
        }
    }
    if fill.exact
        && let Some(e) = r.exact
    {
        // The stored exact error is [Δα; Δp]; columns follow the err_* order (Δp first).
        v.set_all(slot::EXACT, &e[3..]);
        v.set_all(slot::EXACT + 3, &e[..3]);
    }
}

fn float(name: impl Into<String>, unit: &'static str, slot: usize) -> FloatColumn {
    FloatColumn { name: name.into(), unit, slot }
}

impl PoseSchema {
    /// The columns of `set`, plus the exact-error columns when `exact` is on.
    pub fn new(set: ColumnSet, exact: bool) -> Self {
        let mut f: Vec<FloatColumn> = Vec::new();
        f.push(float("z", "m", slot::Z));
        f.push(float("psi", "rad", slot::PSI));
        f.push(float("theta", "rad", slot::THETA));
        if set >= ColumnSet::Standard {
            f.push(float("x", "m", slot::X));
            f.push(float("y", "m", slot::Y));
            f.push(float("phi", "rad", slot::PHI));
            for j in 0..3 {
                f.push(float(format!("q{}", j + 1), "m", slot::Q + j));
            }
        }
        for (i, (c, unit)) in ERR_PARTS.iter().enumerate() {
            f.push(float(format!("err_{c}"), unit, slot::TOTAL + i));
        }
        if set >= ColumnSet::Standard {
            for kind in KINDS {
                let k = kind.index();
                for (i, (c, unit)) in ERR_PARTS.iter().enumerate() {
                    f.push(float(format!("err_{}_{c}", kind.name()), unit, slot::KIND + 9 * k + i));
                }
            }
            for j in 0..3 {
                let (l, base) = (j + 1, slot::MARGIN + 4 * j);
                f.push(float(format!("margin_r{l}_radial"), "N", base));
                f.push(float(format!("margin_r{l}_axial"), "N", base + 1));
                f.push(float(format!("margin_r{l}_angular"), "N*m", base + 2));
                f.push(float(format!("margin_s{l}"), "N", base + 3));
            }
            let kinds = std::iter::once(String::new()).chain(KINDS.iter().map(|k| format!("{}_", k.name())));
            for (k, kind) in kinds.enumerate() {
                for (i, (c, unit)) in ENVELOPE_PARTS.iter().enumerate() {
                    f.push(float(format!("env_{kind}{c}"), unit, slot::ENVELOPE + 8 * k + i));
                }
            }
        }
        if set >= ColumnSet::Full {
            for j in 0..3 {
                let (l, base) = (j + 1, slot::REACTION + 9 * j);
                for (b, (name, unit)) in [("f_r", "N"), ("m_r", "N*m"), ("f_s", "N")].into_iter().enumerate() {
                    for (i, c) in ["x", "y", "z"].iter().enumerate() {
                        f.push(float(format!("{name}{l}_{c}"), unit, base + 3 * b + i));
                    }
                }
            }
            f.push(float("cond_a", "1", slot::COND_A));
            f.push(float("cond_jp", "1", slot::COND_JP));
        }
        if exact {
            for (i, (c, unit)) in ERR_PARTS[..6].iter().enumerate() {
                f.push(float(format!("exact_err_{c}"), unit, slot::EXACT + i));
            }
        }

        let unit = |u: &str| HashMap::from([("unit".to_string(), u.to_string())]);
        let mut fields = vec![
            Field::new("mode", DataType::Utf8, false).with_metadata(unit("")),
            Field::new("sample", DataType::UInt64, false).with_metadata(unit("1")),
            Field::new("t", DataType::Float64, true).with_metadata(unit("s")),
            Field::new("status", DataType::Utf8, false).with_metadata(unit("")),
        ];
        let dominant = set >= ColumnSet::Standard;
        if dominant {
            fields.push(Field::new("dominant", DataType::Utf8, true).with_metadata(unit("")));
        }
        fields.extend(f.iter().map(|c| Field::new(&c.name, DataType::Float64, true).with_metadata(unit(c.unit))));
        let slots = f.iter().map(|c| c.slot).collect();
        let fill = Fill { standard: set >= ColumnSet::Standard, full: set >= ColumnSet::Full, exact };
        let schema = Arc::new(Schema::new(fields));
        let single = vec![false; f.len()];
        Self {
            schema: schema.clone(),
            computed: schema,
            precision: Precision::Double,
            single,
            floats: f,
            slots,
            dominant,
            fill,
        }
    }

    /// The same columns stored with `precision`: with [`Precision::Single`] those that
    /// [`stored_single`](crate::stored_single) names are `float32` in the schema, the pages and the batches.
    pub fn with_precision(mut self, precision: Precision) -> Self {
        self.precision = precision;
        let fields: Vec<Field> = self.computed.fields().iter().map(|f| stored_field(f, precision)).collect();
        // The float columns are the last fields.
        let first = fields.len() - self.floats.len();
        self.single = fields[first..].iter().map(|f| f.data_type() == &DataType::Float32).collect();
        self.schema = Arc::new(Schema::new(fields));
        self
    }

    pub fn schema(&self) -> SchemaRef {
        self.schema.clone()
    }

    /// Column names in order.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.schema.fields().iter().map(|f| f.name().as_str())
    }

    /// Empty column buffers for `rows` rows, to be filled block by block.
    pub fn columns(&self, rows: usize) -> UnitColumns {
        UnitColumns {
            sample: vec![0; rows],
            t: vec![0.0; rows],
            status: vec![Status::Unreachable; rows],
            dominant: vec![NO_JOINT; rows],
            floats: self.slots.iter().map(|_| vec![0.0; rows]).collect(),
            nulls: (0..=self.slots.len()).map(|_| AtomicBool::new(false)).collect(),
        }
    }

    /// Empty pages for a part file of `rows` rows of `mode`.
    pub fn part(&self, mode: Mode, rows: usize) -> PartPages {
        PartPages {
            mode,
            sample: vec![0; rows],
            status: vec![Status::Unreachable; rows],
            dominant: vec![NO_JOINT; rows],
            pages: pages::page_spans(rows).iter().map(|_| None).collect(),
        }
    }

    /// The double columns: `t` and the floats.
    pub(crate) fn doubles(&self) -> usize {
        self.slots.len() + 1
    }

    /// The buffer a thread fills pages of a [`PartPages`] in.
    pub fn page_buffer(&self) -> PageBuffer {
        PageBuffer { t: Vec::new(), floats: Vec::new(), first_t: Vec::new(), first_floats: Vec::new() }
    }

    /// The record batch of filled column buffers.
    pub fn finish(&self, mode: Mode, cols: UnitColumns) -> RecordBatch {
        // A column gets a validity bitmap only if `put` saw a value that is not
        // finite in it: most columns of most parts have none, and are not read again.
        let float = |(v, nulls): (Vec<f64>, &AtomicBool)| -> ArrayRef {
            let nulls = nulls.load(Ordering::Relaxed).then(|| null_where_not_finite(&v));
            Arc::new(Float64Array::new(ScalarBuffer::from(v), nulls))
        };
        let (t_nulls, float_nulls) = cols.nulls.split_first().expect("t has a flag");
        let rows = cols.sample.len();
        let [mode, sample, status] = label_columns(mode, cols.sample, &cols.status);
        let mut out: Vec<ArrayRef> = Vec::with_capacity(self.floats.len() + 5);
        out.extend([mode, sample, float((cols.t, t_nulls)), status]);
        if self.dominant {
            out.push(dominant_column(&cols.dominant));
        }
        // Columns on the pool: a serial pass over a whole unit would leave it idle.
        // A few thousand rows are done before the pool's threads would wake.
        if rows < 1 << 14 {
            out.extend(cols.floats.into_iter().zip(float_nulls).map(float));
        } else {
            out.par_extend(cols.floats.into_par_iter().zip(float_nulls).map(float));
        }
        let batch = RecordBatch::try_new(self.computed.clone(), out).expect("columns match the schema");
        with_precision(&batch, self.precision)
    }

    /// One record batch from the rows of one mode.
    pub fn batch(&self, mode: Mode, rows: &[(Sample, PoseResult)]) -> RecordBatch {
        let mut cols = self.columns(rows.len());
        if let Some(mut sink) = cols.blocks(self, rows.len().max(1)).pop() {
            for (i, (s, r)) in rows.iter().enumerate() {
                sink.put(i, s, r);
            }
        }
        self.finish(mode, cols)
    }
}

/// A column's validity: null where its value is not finite.
fn null_where_not_finite(v: &[f64]) -> NullBuffer {
    NullBuffer::new(BooleanBuffer::collect_bool(v.len(), |i| v[i].is_finite()))
}

/// `dominant` of a row without one (not `ok`, or every clearance zero).
pub(crate) const NO_JOINT: u8 = u8::MAX;

/// The names of the `dominant` column's values, by `3·kind + limb`.
pub(crate) fn joint_names() -> [String; 12] {
    std::array::from_fn(|i| clearance_solver::joint_name(i / 3, i % 3))
}

/// Float columns of `len` rows from a function that writes every column's value of a
/// row at once (`row`, and a slice of `columns` values), null where a value is not
/// finite (NaN for one that has none): the arrays `Float64Array::from_iter` makes of the
/// finite values (0 under a null, a validity bitmap only where there is a null). For
/// tables whose columns share work within a row. A block of rows at a time on the rayon
/// pool, every column of a row while its result is in the cache (column by column, each
/// pass over a unit's results, some 1 kB a row, read a cache line a row for one value:
/// a sixth of a 6-UPS run), gathered a tile of rows at a time and copied into the
/// columns' buffers, which become the arrays without a copy.
pub(crate) fn finite_rows(len: usize, columns: usize, fill: impl Fn(usize, &mut [f64]) + Sync) -> Vec<ArrayRef> {
    let mut rows = FiniteRows::new(len, columns);
    rows.fill(0..len, fill);
    rows.finish()
}

/// [`finite_rows`] a run of rows at a time: the columns' buffers of the whole table,
/// each run of rows filled when its values are at hand ([`FiniteRows::fill`]), then the
/// arrays ([`FiniteRows::finish`]): the same arrays, whatever the runs.
pub(crate) struct FiniteRows {
    /// Each column's values, written in place.
    pub(crate) values: Vec<Vec<f64>>,
    /// Whether each column holds a value that is not finite.
    nulls: Vec<AtomicBool>,
}

impl FiniteRows {
    /// `columns` columns of `len` rows, to be filled.
    pub(crate) fn new(len: usize, columns: usize) -> Self {
        FiniteRows {
            values: (0..columns).map(|_| vec![0.0; len]).collect(),
            nulls: (0..columns).map(|_| AtomicBool::new(false)).collect(),
        }
    }

    /// [`FiniteRows::new`] without the null flags, for columns whose encoder finds
    /// its nulls itself (a page's, [`encode_page`](crate::pages::encode_page)): checking
    /// every value was a tenth of filling a custom row (callgrind).
    pub(crate) fn unflagged(len: usize, columns: usize) -> Self {
        FiniteRows { values: (0..columns).map(|_| vec![0.0; len]).collect(), nulls: Vec::new() }
    }

    /// Fills rows `range` (`fill(row, values)` as for [`finite_rows`]).
    pub(crate) fn fill(&mut self, range: std::ops::Range<usize>, fill: impl Fn(usize, &mut [f64]) + Sync) {
        const BLOCK: usize = 1024;
        /// Rows gathered before they go to the columns: a row's values go to a tile that
        /// stays in the cache, column by column, and each column's run of the tile to its
        /// buffer in one copy (each value stored straight into its column, a row touched
        /// as many lines of memory as it has columns).
        const TILE: usize = 32;
        let columns = self.values.len();
        if columns == 0 || range.is_empty() {
            return;
        }
        // Every block of rows, on the pool, gets its rows' slice of every column.
        let mut blocks: Vec<Vec<&mut [f64]>> =
            (0..range.len().div_ceil(BLOCK)).map(|_| Vec::with_capacity(columns)).collect();
        for v in &mut self.values {
            for (block, slice) in blocks.iter_mut().zip(v[range.clone()].chunks_mut(BLOCK)) {
                block.push(slice);
            }
        }
        let nulls = &self.nulls;
        blocks.into_par_iter().enumerate().for_each(|(b, mut block)| {
            let mut row_values = vec![0.0; columns];
            // Column-major: column c's rows at `c·TILE..`.
            let mut tile = vec![0.0; columns * TILE];
            let n = block[0].len();
            for start in (0..n).step_by(TILE) {
                let rows = TILE.min(n - start);
                for k in 0..rows {
                    fill(range.start + b * BLOCK + start + k, &mut row_values);
                    for (c, &x) in row_values.iter().enumerate() {
                        tile[c * TILE + k] = x;
                    }
                }
                for (c, (column, run)) in block.iter_mut().zip(tile.chunks_exact(TILE)).enumerate() {
                    let run = &run[..rows];
                    column[start..start + rows].copy_from_slice(run);
                    if let Some(null) = nulls.get(c)
                        && !run.iter().all(|x| x.is_finite())
                    {
                        flag(null);
                    }
                }
            }
        });
    }

    /// The arrays: a validity bitmap only for a column that holds a value that is not
    /// finite, 0 under each null.
    pub(crate) fn finish(self) -> Vec<ArrayRef> {
        assert_eq!(self.nulls.len(), self.values.len(), "the arrays need the null flags (not unflagged)");
        self.values
            .into_par_iter()
            .zip(self.nulls)
            .map(|(mut v, null)| -> ArrayRef {
                let nulls = null.into_inner().then(|| {
                    let nulls = null_where_not_finite(&v);
                    for x in v.iter_mut().filter(|x| !x.is_finite()) {
                        *x = 0.0;
                    }
                    nulls
                });
                Arc::new(Float64Array::new(ScalarBuffer::from(v), nulls))
            })
            .collect()
    }
}

/// The `dominant` column from each row's `3·kind + limb` ([`NO_JOINT`]: null).
pub(crate) fn dominant_column(index: &[u8]) -> ArrayRef {
    let names = joint_names();
    Arc::new(StringArray::from_iter(index.iter().map(|&i| names.get(i as usize).map(String::as_str))))
}

impl PoseSchema {
    /// Whether the set has the `dominant` column.
    pub(crate) fn has_dominant(&self) -> bool {
        self.dominant
    }
}

/// The `mode`, `sample` and `status` columns of rows of `mode`, which come first
/// in a batch as `mode`, `sample`, `t`, `status`, then the floats.
pub(crate) fn label_columns(mode: Mode, sample: Vec<u64>, status: &[Status]) -> [ArrayRef; 3] {
    [
        Arc::new(StringArray::from_iter_values(std::iter::repeat_n(mode.name(), status.len()))),
        Arc::new(UInt64Array::from(sample)),
        Arc::new(StringArray::from_iter_values(status.iter().map(|s| s.name()))),
    ]
}

/// A part file's rows, encoded a page at a time as they are computed
/// ([`PoseSchema::part`], [`PageWriter::write`]), then written by [`write_part`](crate::write_part).
///
/// A unit's columns, put whole into buffers and encoded afterwards, were 35 MB of
/// doubles for 65 536 standard rows, which left the cores' caches between the two
/// passes (a third of a run's CPU, `perf`). A page of [`PAGE_ROWS`] rows of every
/// column stays in the cache of the thread that computes it until it is encoded.
pub struct PartPages {
    pub(crate) mode: Mode,
    pub(crate) sample: Vec<u64>,
    pub(crate) status: Vec<Status>,
    /// Each row's dominant joint, `3·kind + limb` ([`NO_JOINT`]: none).
    pub(crate) dominant: Vec<u8>,
    /// Each page's bytes, every double column's page in schema order (`t` first).
    pub(crate) pages: Vec<Option<EncodedPage>>,
}

/// One page of rows of every double column, encoded.
pub(crate) struct EncodedPage {
    pub(crate) bytes: Vec<u8>,
    /// One per double column, in schema order.
    pub(crate) stats: Vec<PageStats>,
}

impl PartPages {
    pub fn rows(&self) -> usize {
        self.sample.len()
    }

    /// The buffers of the encoded pages, to encode others into
    /// ([`PageWriter::write`]): fresh memory would cost a page fault every 4 KiB.
    pub fn into_buffers(self) -> impl Iterator<Item = Vec<u8>> {
        self.pages.into_iter().flatten().map(|p| p.bytes)
    }

    /// One writer for each page ([`page_spans`](crate::page_spans): of [`PAGE_ROWS`]
    /// rows, the last few shorter), to fill in parallel.
    pub fn pages<'a>(&'a mut self, schema: &'a PoseSchema) -> Vec<PageWriter<'a>> {
        let (mut sample, mut status) = (&mut self.sample[..], &mut self.status[..]);
        let mut dominant = &mut self.dominant[..];
        pages::page_spans(sample.len())
            .into_iter()
            .zip(&mut self.pages)
            .map(|((first, rows), out)| {
                let (page_sample, rest) = std::mem::take(&mut sample).split_at_mut(rows);
                sample = rest;
                let (page_status, rest) = std::mem::take(&mut status).split_at_mut(rows);
                status = rest;
                let (page_dominant, rest) = std::mem::take(&mut dominant).split_at_mut(rows);
                dominant = rest;
                PageWriter { schema, first, sample: page_sample, status: page_status, dominant: page_dominant, out }
            })
            .collect()
    }
}

/// The rows of one page of a [`PartPages`].
pub struct PageWriter<'a> {
    schema: &'a PoseSchema,
    /// The part's row that is the page's first.
    first: usize,
    sample: &'a mut [u64],
    status: &'a mut [Status],
    dominant: &'a mut [u8],
    out: &'a mut Option<EncodedPage>,
}

/// The double columns of one page before they are encoded: one per thread, reused
/// from page to page ([`PoseSchema::page_buffer`]).
pub struct PageBuffer {
    t: Vec<f64>,
    /// Column c at `floats[c·PAGE_ROWS..]`.
    floats: Vec<f64>,
    /// The first member's `t` and `floats` while the other members of a group are
    /// written ([`PageWriter::write_members`]).
    first_t: Vec<f64>,
    first_floats: Vec<f64>,
}

/// Whether two columns hold the same values bit for bit (so the same encoding).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).fold(true, |same, (x, y)| same & (x.to_bits() == y.to_bits()))
}

/// A page's `t` and float columns, as [`PageBuffer`] holds them.
type PageColumns<'p> = (&'p [f64], &'p [f64]);

/// Encodes a page's columns (`t`, then the float columns of `floats`, `PAGE_ROWS`
/// apart, `rows` each) into `bytes`, with their statistics. A column whose values
/// are bit for bit those of the same column of `like` (another member's page of the
/// same rows, its values and its encoding) is copied from `like`'s encoding.
fn encode_columns(
    schema: &PoseSchema,
    codec: Codec,
    rows: usize,
    (t, floats): PageColumns<'_>,
    like: Option<(PageColumns<'_>, &EncodedPage)>,
    mut bytes: Vec<u8>,
) -> Result<EncodedPage, parquet::errors::ParquetError> {
    let n = schema.slots.len();
    bytes.clear();
    // Room for every page uncompressed, headers and levels included: reserved
    // memory is not touched, and the buffer never grows while encoding.
    bytes.reserve((n + 1) * (rows * 8 + rows / 8 + 64));
    let mut stats = Vec::with_capacity(n + 1);
    let columns = std::iter::once((&t[..rows], false))
        .chain(floats.chunks(PAGE_ROWS).zip(&schema.single).map(|(c, &single)| (&c[..rows], single)));
    let mut like_at = 0;
    for (c, (values, single)) in columns.enumerate() {
        if let Some(((like_t, like_floats), page)) = like {
            let same = if c == 0 { &like_t[..rows] } else { &like_floats[(c - 1) * PAGE_ROWS..][..rows] };
            let encoded = page.stats[c];
            if same_bits(values, same) {
                bytes.extend_from_slice(&page.bytes[like_at..like_at + encoded.bytes]);
                stats.push(encoded);
                like_at += encoded.bytes;
                continue;
            }
            like_at += encoded.bytes;
        }
        let encode = if single { pages::encode_page_single } else { pages::encode_page };
        stats.push(encode(values, codec, &mut bytes)?);
    }
    Ok(EncodedPage { bytes, stats })
}

impl<'a> PageWriter<'a> {
    pub fn rows(&self) -> usize {
        self.sample.len()
    }

    /// The row of the part that is the page's first.
    pub fn first(&self) -> usize {
        self.first
    }

    /// Lets `fill` put every row of the page (row 0 is the page's first), then
    /// encodes the page's double columns with `codec` into `bytes` (cleared first;
    /// a buffer from [`PartPages::into_buffers`] spares fresh memory): a value
    /// that is not finite is written as a null.
    pub fn write<R>(
        self,
        buf: &mut PageBuffer,
        codec: Codec,
        bytes: Vec<u8>,
        fill: impl FnOnce(&mut BlockSink<'_>) -> R,
    ) -> Result<R, parquet::errors::ParquetError> {
        let (schema, out, rows, result) = self.fill(buf, fill);
        *out = Some(encode_columns(schema, codec, rows, (&buf.t, &buf.floats), None, bytes)?);
        Ok(result)
    }

    /// Lets `fill` put every row of the page, as [`PageWriter::write`] does, and
    /// encodes nothing: for a run without pose files, whose rows give only their
    /// sample, status and statistics. The part's page stays unwritten (`None`).
    pub fn discard<R>(self, buf: &mut PageBuffer, fill: impl FnOnce(&mut BlockSink<'_>) -> R) -> R {
        self.fill(buf, |sink| {
            sink.values = false;
            fill(sink)
        })
        .3
    }

    /// [`PageWriter::write`] for the same page of each member of a group (the same
    /// rows, `fill(m, sink)` putting member m's), each encoded into a buffer from
    /// `bytes`. The first member's page is encoded whole; of each other member's, a
    /// column whose values are the first member's bit for bit is copied from its
    /// encoding instead of encoded again: a member that changes one clearance
    /// changes only that kind's errors, envelope and contributions, and the totals.
    /// The same bytes as writing each page alone.
    pub fn write_members<R>(
        writers: Vec<PageWriter<'a>>,
        buf: &mut PageBuffer,
        codec: Codec,
        mut bytes: impl FnMut() -> Vec<u8>,
        mut fill: impl FnMut(usize, &mut BlockSink<'_>) -> R,
    ) -> Vec<Result<R, parquet::errors::ParquetError>> {
        let mut first: Option<&'a EncodedPage> = None;
        let mut results = Vec::with_capacity(writers.len());
        for (m, writer) in writers.into_iter().enumerate() {
            let (schema, out, rows, result) = writer.fill(buf, |sink| fill(m, sink));
            let like = first.map(|page| ((&buf.first_t[..], &buf.first_floats[..]), page));
            match encode_columns(schema, codec, rows, (&buf.t, &buf.floats), like, bytes()) {
                Ok(page) => *out = Some(page),
                Err(e) => {
                    results.push(Err(e));
                    continue;
                }
            }
            results.push(Ok(result));
            if first.is_none() {
                let out: &'a Option<EncodedPage> = out;
                first = out.as_ref();
                std::mem::swap(&mut buf.t, &mut buf.first_t);
                std::mem::swap(&mut buf.floats, &mut buf.first_floats);
            }
        }
        results
    }

    /// Lets `fill` put the page's rows into `buf`: the schema, the page's slot and
    /// rows, and what `fill` returned.
    fn fill<R>(
        self,
        buf: &mut PageBuffer,
        fill: impl FnOnce(&mut BlockSink<'_>) -> R,
    ) -> (&'a PoseSchema, &'a mut Option<EncodedPage>, usize, R) {
        let PageWriter { schema, sample, status, dominant, out, .. } = self;
        let rows = sample.len();
        buf.t.resize(PAGE_ROWS, 0.0);
        buf.floats.resize(schema.slots.len() * PAGE_ROWS, 0.0);
        let floats = buf.floats.chunks_mut(PAGE_ROWS).map(|c| &mut c[..rows]).collect();
        // No null flags: each page's encoder finds its nulls from the values' range.
        let mut sink = BlockSink::new(schema, sample, &mut buf.t[..rows], status, dominant, floats, None);
        let result = fill(&mut sink);
        drop(sink);
        (schema, out, rows, result)
    }
}

/// The column buffers of one part file, before they become a record batch.
pub struct UnitColumns {
    sample: Vec<u64>,
    t: Vec<f64>,
    status: Vec<Status>,
    dominant: Vec<u8>,
    floats: Vec<Vec<f64>>,
    /// Whether `t` (first), then each float column, holds a value that is not finite.
    nulls: Vec<AtomicBool>,
}

impl UnitColumns {
    /// Disjoint writers for consecutive blocks of `block` rows, to fill in parallel.
    pub fn blocks<'a>(&'a mut self, schema: &'a PoseSchema, block: usize) -> Vec<BlockSink<'a>> {
        let mut sinks: Vec<BlockSink<'a>> = self
            .sample
            .chunks_mut(block)
            .zip(self.t.chunks_mut(block))
            .zip(self.status.chunks_mut(block))
            .zip(self.dominant.chunks_mut(block))
            .map(|(((sample, t), status), dominant)| {
                BlockSink::new(schema, sample, t, status, dominant, Vec::new(), Some(&self.nulls))
            })
            .collect();
        for col in &mut self.floats {
            for (sink, part) in sinks.iter_mut().zip(col.chunks_mut(block)) {
                sink.floats.push(part);
            }
        }
        sinks
    }
}

/// Rows a [`BlockSink`] gathers before writing them to the column buffers.
const TILE: usize = 32;

/// `tile[slot][k]`: slot `slot` of the `k`-th row gathered.
type Tile = [[f64; TILE]; slot::COUNT];

thread_local! {
    /// The tile of this thread's last sink: a fresh one is 36 KB to allocate and
    /// zero, once for each block of a loop of small `solve` calls.
    static SPARE_TILE: std::cell::Cell<Option<Box<Tile>>> = const { std::cell::Cell::new(None) };
}

/// Writes the rows of one block into their column buffers.
///
/// Rows go first to a small slot-major tile (26 KB, in the core's first-level
/// cache), which is copied to the column buffers 32 values at a time: a row
/// written straight to its 71 columns touched 71 cache lines far apart, more write
/// streams than the hardware follows, and cost a quarter of a run's CPU (`perf`).
/// `row_values` writes each slot of a row into the tile once; gathering the
/// columns' slots from a row written whole first took a thousand instructions a
/// row (callgrind). The tile is written out when full, when rows stop being
/// consecutive, and when the sink is dropped.
pub struct BlockSink<'a> {
    sample: &'a mut [u64],
    t: &'a mut [f64],
    status: &'a mut [Status],
    dominant: &'a mut [u8],
    floats: Vec<&'a mut [f64]>,
    slots: &'a [usize],
    fill: Fill,
    /// The unit's flags of columns with a value that is not finite (`t` first), for
    /// [`PoseSchema::finish`]; pages need none.
    nulls: Option<&'a [AtomicBool]>,
    /// Taken by the first `put`, on the thread that fills the block.
    tile: Option<Box<Tile>>,
    tile_start: usize,
    tile_len: usize,
    /// Whether the rows' values are kept (not for a page that nothing writes: its
    /// sample, status and dominant joint are all that is read of it).
    values: bool,
}

/// Sets a column's null flag. Read first: once set, the flag's cache line stays
/// shared between the threads filling the unit instead of bouncing on each store.
fn flag(f: &AtomicBool) {
    if !f.load(Ordering::Relaxed) {
        f.store(true, Ordering::Relaxed);
    }
}

impl Drop for BlockSink<'_> {
    fn drop(&mut self) {
        self.flush();
        if let Some(tile) = self.tile.take() {
            SPARE_TILE.set(Some(tile));
        }
    }
}

impl<'a> BlockSink<'a> {
    fn new(
        schema: &'a PoseSchema,
        sample: &'a mut [u64],
        t: &'a mut [f64],
        status: &'a mut [Status],
        dominant: &'a mut [u8],
        floats: Vec<&'a mut [f64]>,
        nulls: Option<&'a [AtomicBool]>,
    ) -> Self {
        BlockSink {
            sample,
            t,
            status,
            dominant,
            floats,
            slots: &schema.slots,
            fill: schema.fill,
            nulls,
            tile: None,
            tile_start: 0,
            tile_len: 0,
            values: true,
        }
    }

    /// Row `i` of the block.
    pub fn put(&mut self, i: usize, s: &Sample, r: &PoseResult) {
        self.sample[i] = s.index;
        let t = s.t.unwrap_or(f64::NAN);
        self.t[i] = t;
        self.status[i] = r.status;
        self.dominant[i] = r.dominant.map_or(NO_JOINT, |(k, j)| (3 * k + j) as u8);
        if !self.values {
            return;
        }
        if self.tile_len == TILE || (self.tile_len > 0 && i != self.tile_start + self.tile_len) {
            self.flush();
        }
        if self.tile_len == 0 {
            self.tile_start = i;
        }
        let k = self.tile_len;
        // Slots a row does not write are never read: a used tile serves as well.
        let tile =
            self.tile.get_or_insert_with(|| SPARE_TILE.take().unwrap_or_else(|| Box::new([[0.0; TILE]; slot::COUNT])));
        row_values(s, r, &mut Row { tile, k }, self.fill);
        self.tile_len += 1;
        let Some(nulls) = self.nulls else { return };
        // `t` is null on every row of a grid: flagged on its own, it does not send
        // grid rows down the per-column loop below.
        if !t.is_finite() {
            flag(&nulls[0]);
        }
        let tile = self.tile.as_deref().expect("allocated above");
        if !self.slots.iter().all(|&slot| tile[slot][k].is_finite()) {
            // Rare: flag the columns this row leaves null.
            for (f, &slot) in nulls[1..].iter().zip(self.slots) {
                if !tile[slot][k].is_finite() {
                    flag(f);
                }
            }
        }
    }

    /// Copies the tile's rows to the column buffers.
    fn flush(&mut self) {
        let (start, len) = (self.tile_start, self.tile_len);
        let Some(tile) = self.tile.as_deref() else { return };
        for (col, &slot) in self.floats.iter_mut().zip(self.slots) {
            col[start..start + len].copy_from_slice(&tile[slot][..len]);
        }
        self.tile_len = 0;
    }

    pub fn len(&self) -> usize {
        self.sample.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sample.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The arrays `Float64Array::from_iter` makes of the finite values (0 under a
    /// null, a validity bitmap only in a column with a null), for tables of one block
    /// and of several, their last tile and block partial, with NaN and infinities
    /// at rows spread over the tiles in some columns and none in others.
    #[test]
    fn rows_filled_a_tile_at_a_time_give_the_arrays_of_their_finite_values() {
        use arrow::array::Array;
        let value = |row: usize, c: usize| match (row * 7 + c * 13) % 97 {
            0 if c.is_multiple_of(3) => f64::NAN,
            1 if c.is_multiple_of(3) => f64::INFINITY,
            2 if c == 3 => f64::NEG_INFINITY,
            k => (row as f64 + 0.25) * (c as f64 - 2.5) + k as f64,
        };
        let (mut with_nulls, mut without) = (0, 0);
        for (len, columns) in [(0, 4), (1, 1), (31, 5), (33, 6), (1024, 3), (2_600, 7)] {
            let arrays = finite_rows(len, columns, |row, out| {
                for (c, o) in out.iter_mut().enumerate() {
                    *o = value(row, c);
                }
            });
            assert_eq!(arrays.len(), columns);
            // The same table filled in runs of uneven length (within and across tiles
            // and blocks, one row, none), as a custom part is filled a block at a time.
            let mut runs = FiniteRows::new(len, columns);
            let (mut start, mut steps) = (0, [1, 700, 0, 33, 1024].into_iter().cycle());
            loop {
                let end = (start + steps.next().expect("endless")).min(len);
                runs.fill(start..end, |row, out| {
                    for (c, o) in out.iter_mut().enumerate() {
                        *o = value(row, c);
                    }
                });
                start = end;
                if start == len {
                    break;
                }
            }
            let runs = runs.finish();
            assert_eq!(runs.len(), columns);
            for (c, array) in arrays.iter().enumerate() {
                let (ours, theirs) = (
                    array.as_any().downcast_ref::<Float64Array>().unwrap(),
                    runs[c].as_any().downcast_ref::<Float64Array>().unwrap(),
                );
                assert!(
                    ours.values().iter().zip(theirs.values().iter()).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{len} rows, column {c}: runs' values"
                );
                assert_eq!(
                    (ours.len(), ours.nulls()),
                    (theirs.len(), theirs.nulls()),
                    "{len} rows, column {c}: runs' validity"
                );
            }
            for (c, array) in arrays.iter().enumerate() {
                let ours = array.as_any().downcast_ref::<Float64Array>().expect("doubles");
                let expected =
                    Float64Array::from_iter((0..len).map(|row| Some(value(row, c)).filter(|v| v.is_finite())));
                let bits = |a: &Float64Array| a.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(ours), bits(&expected), "{len} rows, column {c}: values");
                assert_eq!(ours.nulls(), expected.nulls(), "{len} rows, column {c}: validity");
                if ours.null_count() > 0 {
                    with_nulls += 1;
                } else {
                    without += 1;
                }
            }
        }
        assert!(with_nulls >= 5 && without >= 5, "{with_nulls} columns with nulls, {without} without");
    }

    /// Rows of every status with distinct values, put in an order that breaks the
    /// sink's runs of consecutive rows (and fills its tile more than once), give the
    /// batch of the same rows put in order.
    #[test]
    fn rows_put_in_any_order_give_the_same_batch() {
        let n = 3 * TILE + 5;
        let rows: Vec<(Sample, PoseResult)> = (0..n)
            .map(|i| {
                let f = i as f64;
                let s = Sample {
                    index: i as u64,
                    t: (i % 4 != 0).then_some(0.1 * f),
                    z: [1.0 + f, 0.0, 0.0],
                    psi: [0.01 * f, 0.0, 0.0],
                    theta: [-0.02 * f, 0.0, 0.0],
                };
                let mut r = PoseResult { x: f, y: -f, phi: 2.0 * f, ..PoseResult::default() };
                r.status = Status::ALL[i % 4];
                r.q = [f + 0.5, f + 0.25, f + 0.125];
                r.kind_ok = [i % 3 != 0, true, i % 5 != 0, true];
                for (k, e) in r.errors.iter_mut().enumerate() {
                    e.dp.x = f * 1e-6 + k as f64;
                    e.euler[2] = -f * 1e-7 - k as f64;
                }
                r.total.dalpha.y = f * 3e-6;
                r.margins.r_axial[1] = f * 7.0;
                r.reactions.m_r[2].z = -f;
                (s, r)
            })
            .collect();
        for set in [ColumnSet::Minimal, ColumnSet::Standard, ColumnSet::Full] {
            let schema = PoseSchema::new(set, false);
            let expected = schema.batch(Mode::Kinetostatic, &rows);
            let mut order: Vec<usize> = (0..n).collect();
            order.swap(3, 40);
            order.reverse();
            order.swap(0, 7);
            let mut cols = schema.columns(n);
            {
                let mut sink = cols.blocks(&schema, n).pop().unwrap();
                for i in order {
                    sink.put(i, &rows[i].0, &rows[i].1);
                }
            }
            let got = schema.finish(Mode::Kinetostatic, cols);
            assert_eq!(got, expected, "{set:?}");
            assert!(expected.columns().iter().any(|c| c.null_count() > 0), "{set:?}: some nulls");
        }
    }

    /// A set fills only the slots its columns read: each column of the minimal and
    /// standard sets equals the same column of the full set (which fills every
    /// slot), with rows of every status, and the exact error's columns likewise.
    #[test]
    fn each_set_fills_the_slots_its_columns_read() {
        let rows: Vec<(Sample, PoseResult)> = (0..2 * TILE + 3)
            .map(|i| {
                let f = 1.0 + i as f64;
                let s = Sample {
                    index: i as u64,
                    t: None,
                    z: [f, 0.0, 0.0],
                    psi: [0.5 * f, 0.0, 0.0],
                    theta: [-f, 0.0, 0.0],
                };
                let mut r = PoseResult { x: f, y: 2.0 * f, phi: 3.0 * f, ..PoseResult::default() };
                r.status = Status::ALL[i % 4];
                r.kind_ok = [i % 3 != 1, true, true, i % 7 != 2];
                r.q = [f, -f, 2.0 * f];
                r.total.dp.y = 1e-6 * f;
                for (k, e) in r.errors.iter_mut().enumerate() {
                    e.dalpha.z = f + k as f64;
                }
                r.margins.s[2] = 5.0 * f;
                r.envelope = [[f; 8], [2.0 * f; 8], [3.0 * f; 8], [4.0 * f; 8]];
                r.exact = (i % 5 != 0).then_some([f, 2.0 * f, 3.0 * f, 4.0 * f, 5.0 * f, 6.0 * f]);
                (s, r)
            })
            .collect();
        for exact in [false, true] {
            let full = PoseSchema::new(ColumnSet::Full, exact).batch(Mode::Kinetostatic, &rows);
            if exact {
                let column = full.column_by_name("exact_err_x").expect("exact columns");
                for (i, (_, r)) in rows.iter().enumerate() {
                    if r.exact.is_none() {
                        assert!(column.is_null(i), "row {i} has no exact error");
                    }
                }
            }
            for set in [ColumnSet::Minimal, ColumnSet::Standard] {
                let batch = PoseSchema::new(set, exact).batch(Mode::Kinetostatic, &rows);
                assert!(batch.num_columns() < full.num_columns());
                for (field, column) in batch.schema().fields().iter().zip(batch.columns()) {
                    let want = full.column_by_name(field.name()).expect("a full column");
                    assert_eq!(column, want, "{set:?}, exact {exact}: {}", field.name());
                }
            }
        }
    }
}
