//! Error statistics of one (variant, mode): mergeable partial sums, so that each
//! part file carries its own and a resumed or sharded run adds them up.
//!
//! Percentiles come from a log-spaced histogram (2¹¹ bins per octave, a bin 0.05 %
//! wide), reported at the geometric centre of the bin where the rank falls.

use std::collections::BTreeMap;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::record_batch::RecordBatch;
use clearance_model::KINDS;
use clearance_solver::{PoseError, PoseResult, Status};
use serde::{Deserialize, Serialize};

/// Values at or below this count as zeros (a rigid kind's exact zeros).
const ZERO: f64 = 1e-18;
/// A bin is a positive double's bit pattern shifted right by this: its exponent
/// and top 11 mantissa bits, 2¹¹ bins per octave, each 0.05 % wide, found without
/// a logarithm.
const BIN_SHIFT: u32 = 41;

fn bin_of(v: f64) -> u32 {
    (v.to_bits() >> BIN_SHIFT) as u32
}

/// Lower and upper edges of a bin.
fn bin_edges(b: u32) -> (f64, f64) {
    (f64::from_bits(u64::from(b) << BIN_SHIFT), f64::from_bits(u64::from(b + 1) << BIN_SHIFT))
}

/// Max, RMS and percentiles of one non-negative series.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "SeriesFile", into = "SeriesFile")]
pub struct Series {
    pub count: u64,
    pub sum_sq: f64,
    pub max: f64,
    /// Values at or below 1e-18 (a rigid kind's exact zeros).
    pub zeros: u64,
    /// Sparse histogram: (bin, count), in ascending bin order, each bin once. A
    /// sorted vector, merged in one pass: a `BTreeMap` took a lookup per bin for
    /// every part merged (a tenth of a sweep's time outside the pass and search).
    bins: Vec<(u32, u64)>,
    /// Bins of values pushed since the last [`Series::flush`]; pushing stays cheap,
    /// and a whole part's worth is counted at once.
    pending: Vec<u32>,
}

/// A [`Series`] as stored in a part's statistics file.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SeriesFile {
    count: u64,
    sum_sq: f64,
    max: f64,
    zeros: u64,
    /// Named for its binning, so that statistics of an engine that binned
    /// otherwise are refused, not mixed.
    bins_log2_2048: BTreeMap<u32, u64>,
}

impl From<SeriesFile> for Series {
    fn from(f: SeriesFile) -> Self {
        Self {
            count: f.count,
            sum_sq: f.sum_sq,
            max: f.max,
            zeros: f.zeros,
            bins: f.bins_log2_2048.into_iter().collect(),
            pending: Vec::new(),
        }
    }
}

impl From<Series> for SeriesFile {
    fn from(mut s: Series) -> Self {
        s.flush();
        let bins_log2_2048 = s.bins.into_iter().collect();
        Self { count: s.count, sum_sq: s.sum_sq, max: s.max, zeros: s.zeros, bins_log2_2048 }
    }
}

impl Series {
    pub fn push(&mut self, v: f64) {
        self.count += 1;
        self.sum_sq += v * v;
        self.max = self.max.max(v);
        if v <= ZERO {
            self.zeros += 1;
        } else {
            self.pending.push(bin_of(v));
        }
    }

    /// Moves the pending bins into the histogram, counting them in a dense array
    /// over their range (or sorted, if the range is much wider than their number).
    pub fn flush(&mut self) {
        let (Some(&lo), Some(&hi)) = (self.pending.iter().min(), self.pending.iter().max()) else {
            return;
        };
        let range = (hi - lo) as usize + 1;
        let counted: Vec<(u32, u64)> = if range > 4 * self.pending.len() + (1 << 16) {
            self.pending.sort_unstable();
            self.pending.chunk_by(|a, b| a == b).map(|run| (run[0], run.len() as u64)).collect()
        } else {
            let mut dense = vec![0u64; range];
            for &b in &self.pending {
                dense[(b - lo) as usize] += 1;
            }
            dense.iter().enumerate().filter(|(_, c)| **c > 0).map(|(i, &c)| (lo + i as u32, c)).collect()
        };
        self.pending.clear();
        self.add_bins(&counted);
    }

    /// Adds the counts of `other` (ascending, each bin once) to the histogram.
    fn add_bins(&mut self, other: &[(u32, u64)]) {
        if other.is_empty() {
            return;
        }
        if self.bins.is_empty() {
            self.bins.extend_from_slice(other);
            return;
        }
        let mine = std::mem::take(&mut self.bins);
        let mut merged = Vec::with_capacity(mine.len() + other.len());
        let (mut i, mut j) = (0, 0);
        while i < mine.len() && j < other.len() {
            let ((x, m), (y, n)) = (mine[i], other[j]);
            merged.push(match x.cmp(&y) {
                std::cmp::Ordering::Less => (x, m),
                std::cmp::Ordering::Greater => (y, n),
                std::cmp::Ordering::Equal => (x, m + n),
            });
            i += usize::from(x <= y);
            j += usize::from(y <= x);
        }
        merged.extend_from_slice(&mine[i..]);
        merged.extend_from_slice(&other[j..]);
        self.bins = merged;
    }

    pub fn merge(&mut self, o: &Series) {
        self.count += o.count;
        self.sum_sq += o.sum_sq;
        self.max = self.max.max(o.max);
        self.zeros += o.zeros;
        self.add_bins(&o.bins);
        self.pending.extend_from_slice(&o.pending);
    }

    pub fn rms(&self) -> Option<f64> {
        (self.count > 0).then(|| (self.sum_sq / self.count as f64).sqrt())
    }

    pub fn maximum(&self) -> Option<f64> {
        (self.count > 0).then_some(self.max)
    }

    /// The `q`-quantile by nearest rank, at the geometric centre of its bin.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        if self.count == 0 {
            return None;
        }
        let mut flushed = self.clone();
        flushed.flush();
        let rank = ((q * self.count as f64).ceil() as u64).clamp(1, self.count);
        if rank <= self.zeros {
            return Some(0.0);
        }
        let mut seen = self.zeros;
        for &(b, c) in &flushed.bins {
            seen += c;
            if seen >= rank {
                let (lo, hi) = bin_edges(b);
                return Some((lo * hi).sqrt().min(self.max));
            }
        }
        Some(self.max)
    }
}

/// The partial statistics of a set of poses of one (variant, mode).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SummaryStats {
    pub samples: u64,
    /// Counts per status, in the order of `Status::ALL`.
    pub status: [u64; 4],
    /// |Δp| and |Δα| of the total error (`ok` poses).
    pub dp: Series,
    pub dalpha: Series,
    /// The same per kind (poses where that kind is determinate), order of `KINDS`.
    pub dp_kind: [Series; 4],
    pub dalpha_kind: [Series; 4],
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
    pub dominant: [[u64; 3]; 4],
    #[serde(default)]
    pub joint_sum_sq: [[f64; 3]; 4],
}

fn norms(e: &PoseError) -> (f64, f64) {
    (e.dp.norm(), e.dalpha.norm())
}

impl SummaryStats {
    /// Empty statistics with room for `n` poses' values before a flush, so that
    /// pushing them never grows a buffer.
    pub fn with_capacity(n: usize) -> Self {
        let mut s = Self::default();
        for series in s.series_mut() {
            series.pending.reserve_exact(n);
        }
        s
    }

    /// Every series: total, then per kind.
    fn series_mut(&mut self) -> impl Iterator<Item = &mut Series> {
        [&mut self.dp, &mut self.dalpha, &mut self.env_p, &mut self.env_alpha]
            .into_iter()
            .chain(&mut self.dp_kind)
            .chain(&mut self.dalpha_kind)
    }

    pub fn push(&mut self, r: &PoseResult) {
        self.samples += 1;
        self.status[r.status.index()] += 1;
        if r.status != Status::Unreachable {
            // Infinite for an exactly singular matrix; the maximum stays meaningful.
            self.cond_a_max = self.cond_a_max.max(r.cond_a);
            self.cond_jp_max = self.cond_jp_max.max(r.cond_jp);
        }
        if r.status == Status::Ok {
            let (p, a) = norms(&r.total);
            self.dp.push(p);
            self.dalpha.push(a);
            if let Some((k, j)) = r.dominant {
                self.dominant[k][j] += 1;
            }
            for (sums, limbs) in self.joint_sum_sq.iter_mut().zip(&r.contribution) {
                for (sum, v) in sums.iter_mut().zip(limbs) {
                    if v.is_finite() {
                        *sum += v * v;
                    }
                }
            }
        }
        if matches!(r.status, Status::Ok | Status::IndeterminateContact) {
            let total = r.envelope_total();
            let (env_p, env_alpha) = (total[6], total[7]);
            if env_p.is_finite() && env_alpha.is_finite() {
                self.env_p.push(env_p);
                self.env_alpha.push(env_alpha);
            }
            for k in 0..4 {
                if r.kind_ok[k] {
                    let (p, a) = norms(&r.errors[k]);
                    self.dp_kind[k].push(p);
                    self.dalpha_kind[k].push(a);
                }
            }
        }
    }

    /// Moves every series' pending values into its histogram ([`Series::flush`]):
    /// statistics merged part after part then hold one count per bin, not one
    /// entry per pose. The numbers they give do not change.
    pub fn flush(&mut self) {
        for series in self.series_mut() {
            series.flush();
        }
    }

    pub fn merge(&mut self, o: &SummaryStats) {
        self.samples += o.samples;
        for i in 0..4 {
            self.status[i] += o.status[i];
            self.dp_kind[i].merge(&o.dp_kind[i]);
            self.dalpha_kind[i].merge(&o.dalpha_kind[i]);
        }
        self.dp.merge(&o.dp);
        self.dalpha.merge(&o.dalpha);
        self.cond_a_max = self.cond_a_max.max(o.cond_a_max);
        self.cond_jp_max = self.cond_jp_max.max(o.cond_jp_max);
        self.env_p.merge(&o.env_p);
        self.env_alpha.merge(&o.env_alpha);
        for k in 0..4 {
            for j in 0..3 {
                self.dominant[k][j] += o.dominant[k][j];
                self.joint_sum_sq[k][j] += o.joint_sum_sq[k][j];
            }
        }
    }
}

/// One row of `summary.parquet`.
pub struct SummaryRow {
    pub variant: u64,
    pub mode: &'static str,
    /// The swept parameters' values, in the order of the job's `[[sweep]]`.
    pub params: Vec<f64>,
    pub stats: SummaryStats,
    /// Switch counts per kind (order of `KINDS`).
    pub switches: [u64; 4],
}

/// `summary.parquet`: one row per (variant, mode).
pub fn summary_batch(param_names: &[String], rows: &[SummaryRow]) -> RecordBatch {
    let mut t = SummaryTable::new(rows);
    t.head(param_names, |r| (r.variant, r.mode, &r.params, r.stats.samples, r.stats.status));
    t.series("dp", "m", |r| &r.stats.dp);
    t.series("dalpha", "rad", |r| &r.stats.dalpha);
    for kind in KINDS {
        let k = kind.index();
        t.series(&format!("dp_{}", kind.name()), "m", move |r| &r.stats.dp_kind[k]);
        t.series(&format!("dalpha_{}", kind.name()), "rad", move |r| &r.stats.dalpha_kind[k]);
    }
    t.series("env_p", "m", |r| &r.stats.env_p);
    t.series("env_alpha", "rad", |r| &r.stats.env_alpha);
    let joints = (0..4).flat_map(|k| (0..3).map(move |j| (clearance_solver::joint_name(k, j), k, j)));
    let ok = Status::Ok.index();
    t.joints(joints, |r, k, j| (r.stats.status[ok], r.stats.dominant[k][j], r.stats.joint_sum_sq[k][j]));
    t.switches(&KINDS.map(|k| k.name()), |r| &r.switches);
    t.conditions(|r| (r.stats.cond_a_max, r.stats.cond_jp_max));
    t.finish()
}

/// The columns of a `summary.parquet` of any kind, built column by column from its rows.
pub(crate) struct SummaryTable<'a, R> {
    rows: &'a [R],
    fields: Vec<Field>,
    cols: Vec<ArrayRef>,
}

impl<'a, R> SummaryTable<'a, R> {
    pub(crate) fn new(rows: &'a [R]) -> Self {
        Self { rows, fields: Vec::new(), cols: Vec::new() }
    }

    fn push(&mut self, field: Field, col: ArrayRef) {
        self.fields.push(field);
        self.cols.push(col);
    }

    fn u64(&mut self, name: &str, unit: &str, get: impl Fn(&R) -> u64) {
        let col = Arc::new(UInt64Array::from_iter_values(self.rows.iter().map(get)));
        self.push(field(name, DataType::UInt64, false, unit), col);
    }

    fn float(&mut self, name: &str, unit: &str, get: impl Fn(&R) -> Option<f64>) {
        let col = Arc::new(Float64Array::from_iter(self.rows.iter().map(get)));
        self.push(field(name, DataType::Float64, true, unit), col);
    }

    /// `variant`, `mode`, the swept parameters, `samples` and the share of each status;
    /// `get` gives a row's variant, mode, parameter values, samples and status counts.
    pub(crate) fn head(&mut self, param_names: &[String], get: impl Fn(&R) -> (u64, &str, &Vec<f64>, u64, [u64; 4])) {
        self.u64("variant", "1", |r| get(r).0);
        let modes = Arc::new(StringArray::from_iter_values(self.rows.iter().map(|r| get(r).1)));
        self.push(field("mode", DataType::Utf8, false, ""), modes);
        for (i, name) in param_names.iter().enumerate() {
            let col = Arc::new(Float64Array::from_iter_values(self.rows.iter().map(|r| get(r).2[i])));
            self.push(field(name, DataType::Float64, false, "as in the job"), col);
        }
        self.u64("samples", "1", |r| get(r).3);
        for (i, s) in Status::ALL.iter().enumerate() {
            let name = match s {
                Status::IndeterminateContact => "share_indeterminate".to_string(),
                other => format!("share_{}", other.name()),
            };
            let col = Arc::new(Float64Array::from_iter_values(self.rows.iter().map(|r| {
                let (.., samples, status) = get(r);
                status[i] as f64 / samples.max(1) as f64
            })));
            self.push(field(&name, DataType::Float64, false, "1"), col);
        }
    }

    /// `<prefix>_max`, `_rms` and `_p95` of one series.
    pub(crate) fn series(&mut self, prefix: &str, unit: &str, get: impl Fn(&R) -> &Series) {
        self.float(&format!("{prefix}_max"), unit, |r| get(r).maximum());
        self.float(&format!("{prefix}_rms"), unit, |r| get(r).rms());
        self.float(&format!("{prefix}_p95"), unit, |r| get(r).quantile(0.95));
    }

    /// Per joint `(name, kind, limb)`: the share of ok poses it dominates
    /// (`dominant_share_<name>`) and the RMS of its own |Δp| over them (`rms_dp_<name>`);
    /// `get` gives a row's count of ok poses, how many of them the joint dominates, and
    /// the sum of squares of its contribution.
    pub(crate) fn joints(
        &mut self,
        joints: impl Iterator<Item = (String, usize, usize)>,
        get: impl Fn(&R, usize, usize) -> (u64, u64, f64),
    ) {
        for (name, k, j) in joints {
            self.float(&format!("dominant_share_{name}"), "1", |r| {
                let (ok, dominated, _) = get(r, k, j);
                (ok > 0).then(|| dominated as f64 / ok as f64)
            });
            self.float(&format!("rms_dp_{name}"), "m", |r| {
                let (ok, _, sum_sq) = get(r, k, j);
                (ok > 0).then(|| (sum_sq / ok as f64).sqrt())
            });
        }
    }

    /// `switches` and `switches_<kind>` for the kinds that can switch.
    pub(crate) fn switches(&mut self, kinds: &[&str], get: impl Fn(&R) -> &[u64]) {
        self.u64("switches", "1", |r| get(r).iter().sum());
        for (k, kind) in kinds.iter().enumerate() {
            self.u64(&format!("switches_{kind}"), "1", |r| get(r)[k]);
        }
    }

    /// `cond_a_max`, `cond_jp_max` (null where no pose had one).
    pub(crate) fn conditions(&mut self, get: impl Fn(&R) -> (f64, f64)) {
        let positive = |v: f64| Some(v).filter(|v| v.is_finite() && *v > 0.0);
        self.float("cond_a_max", "1", |r| positive(get(r).0));
        self.float("cond_jp_max", "1", |r| positive(get(r).1));
    }

    pub(crate) fn finish(self) -> RecordBatch {
        RecordBatch::try_new(Arc::new(Schema::new(self.fields)), self.cols).expect("columns match the schema")
    }
}

pub(crate) fn field(name: &str, t: DataType, nullable: bool, unit: &str) -> Field {
    Field::new(name, t, nullable)
        .with_metadata(std::collections::HashMap::from([("unit".to_string(), unit.to_string())]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against exact statistics of a known sample.
    #[test]
    fn series_statistics() {
        let mut s = Series::default();
        let mut other = Series::default();
        let values: Vec<f64> = (1..=1000).map(|i| i as f64 * 1e-6).collect();
        for (i, v) in values.iter().enumerate() {
            if i % 2 == 0 { s.push(*v) } else { other.push(*v) }
        }
        s.merge(&other);
        assert_eq!(s.count, 1000);
        assert_eq!(s.maximum(), Some(1e-3));
        let rms = (values.iter().map(|v| v * v).sum::<f64>() / 1000.0).sqrt();
        assert!((s.rms().unwrap() - rms).abs() < 1e-15);
        let p95 = s.quantile(0.95).unwrap();
        assert!((p95 / 950e-6 - 1.0).abs() < 1e-3, "p95 {p95}");
        let mut zeros = Series::default();
        for _ in 0..10 {
            zeros.push(0.0);
        }
        assert_eq!(zeros.quantile(0.95), Some(0.0));
        assert_eq!(Series::default().quantile(0.5), None);
    }

    /// The histogram, flushed and merged part after part in any order, holds the
    /// count of every bin that a plain map of every pushed value holds: one entry a
    /// bin, ascending (a merge that dropped a tail, doubled a bin or broke the order
    /// fails it).
    #[test]
    fn merged_histograms_count_every_value_once() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(23);
        let mut total = Series::default();
        let mut reference = BTreeMap::<u32, u64>::new();
        for part in 0..40 {
            let mut s = Series::default();
            // Narrow parts (the dense count) and parts over 80 decades (the sorted one).
            let (lo, span) = if part % 3 == 0 { (-40.0, 80.0) } else { (-6.0 - rng.random::<f64>(), 0.3) };
            for _ in 0..rng.random_range(0..3000) {
                let v = 10f64.powf(lo + span * rng.random::<f64>());
                s.push(v);
                if v > ZERO {
                    *reference.entry(bin_of(v)).or_insert(0) += 1;
                }
            }
            if part % 2 == 0 {
                s.flush();
            }
            total.merge(&s);
            if part % 5 == 4 {
                total.flush();
            }
        }
        total.flush();
        let reference: Vec<(u32, u64)> = reference.into_iter().collect();
        assert_eq!(total.bins.len(), reference.len());
        assert!(total.bins == reference, "the merged histogram differs from the reference");
        assert!(total.pending.is_empty());
    }

    /// A part's statistics file holds every pushed value, whichever way the
    /// pending bins are counted, and files of another binning are refused.
    #[test]
    fn statistics_files_round_trip() {
        let mut wide = Series::default();
        let mut narrow = Series::default();
        for i in 0..2000 {
            // 1e-17 .. 1e100 (sorted path) and 1e-3 .. 2e-3 (dense path).
            wide.push(10f64.powf(-17.0 + 117.0 * i as f64 / 1999.0));
            narrow.push(1e-3 * (1.0 + i as f64 / 1999.0));
        }
        for s in [wide, narrow] {
            let text = serde_json::to_string(&s).unwrap();
            let back: Series = serde_json::from_str(&text).unwrap();
            let mut flushed = s.clone();
            flushed.flush();
            assert_eq!(back, flushed);
            assert_eq!(back.bins.iter().map(|(_, c)| c).sum::<u64>(), 2000);
            assert_eq!(back.quantile(0.5), s.quantile(0.5));
        }
        let old = r#"{"count":1,"sum_sq":1.0,"max":1.0,"zeros":0,"bins":{"40000":1}}"#;
        assert!(serde_json::from_str::<Series>(old).is_err());
    }
}
