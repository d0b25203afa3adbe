//! Error statistics of one (variant, mode): mergeable partial sums, so that each
//! part file carries its own and a resumed or sharded run adds them up.
//!
//! Percentiles come from a log-spaced histogram (2¹⁶ bins over 1e-18 … 1e2, a bin
//! 0.07 % wide), reported at the geometric centre of the bin where the rank falls.

use std::collections::BTreeMap;
use std::sync::Arc;

use arrow::array::{ArrayRef, Float64Array, StringArray, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::record_batch::RecordBatch;
use clearance_model::KINDS;
use clearance_solver::{PoseError, PoseResult, Status};
use serde::{Deserialize, Serialize};

const BINS: u32 = 1 << 16;
const LOG_MIN: f64 = -18.0;
const LOG_MAX: f64 = 2.0;

/// Max, RMS and percentiles of one non-negative series.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Series {
    pub count: u64,
    pub sum_sq: f64,
    pub max: f64,
    /// Values at or below 1e-18 (a rigid kind's exact zeros).
    pub zeros: u64,
    /// Sparse histogram: bin → count.
    pub bins: BTreeMap<u32, u64>,
}

impl Series {
    pub fn push(&mut self, v: f64) {
        self.count += 1;
        self.sum_sq += v * v;
        self.max = self.max.max(v);
        if v <= 10f64.powf(LOG_MIN) {
            self.zeros += 1;
        } else {
            let x = ((v.log10() - LOG_MIN) / (LOG_MAX - LOG_MIN) * BINS as f64).floor();
            *self.bins.entry(x.clamp(0.0, (BINS - 1) as f64) as u32).or_insert(0) += 1;
        }
    }

    pub fn merge(&mut self, o: &Series) {
        self.count += o.count;
        self.sum_sq += o.sum_sq;
        self.max = self.max.max(o.max);
        self.zeros += o.zeros;
        for (b, c) in &o.bins {
            *self.bins.entry(*b).or_insert(0) += c;
        }
    }

    pub fn rms(&self) -> Option<f64> {
        (self.count > 0).then(|| (self.sum_sq / self.count as f64).sqrt())
    }

    pub fn maximum(&self) -> Option<f64> {
        (self.count > 0).then_some(self.max)
    }

    /// The `q`-quantile by nearest rank.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        if self.count == 0 {
            return None;
        }
        let rank = ((q * self.count as f64).ceil() as u64).clamp(1, self.count);
        if rank <= self.zeros {
            return Some(0.0);
        }
        let mut seen = self.zeros;
        for (b, c) in &self.bins {
            seen += c;
            if seen >= rank {
                let lo = LOG_MIN + (*b as f64) / BINS as f64 * (LOG_MAX - LOG_MIN);
                let width = (LOG_MAX - LOG_MIN) / BINS as f64;
                return Some(10f64.powf(lo + 0.5 * width).min(self.max));
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
}

fn norms(e: &PoseError) -> (f64, f64) {
    (e.dp.norm(), e.dalpha.norm())
}

impl SummaryStats {
    pub fn push(&mut self, r: &PoseResult) {
        self.samples += 1;
        let si = Status::ALL.iter().position(|s| *s == r.status).expect("a known status");
        self.status[si] += 1;
        if r.status != Status::Unreachable {
            // Infinite for an exactly singular matrix; the maximum stays meaningful.
            self.cond_a_max = self.cond_a_max.max(r.cond_a);
            self.cond_jp_max = self.cond_jp_max.max(r.cond_jp);
        }
        if r.status == Status::Ok {
            let (p, a) = norms(&r.total);
            self.dp.push(p);
            self.dalpha.push(a);
        }
        if matches!(r.status, Status::Ok | Status::IndeterminateContact) {
            for k in 0..4 {
                if r.kind_ok[k] {
                    let (p, a) = norms(&r.errors[k]);
                    self.dp_kind[k].push(p);
                    self.dalpha_kind[k].push(a);
                }
            }
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
    let mut fields = vec![field("variant", DataType::UInt64, false, "1"), field("mode", DataType::Utf8, false, "")];
    let mut cols: Vec<ArrayRef> = vec![
        Arc::new(UInt64Array::from_iter_values(rows.iter().map(|r| r.variant))),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|r| r.mode))),
    ];
    for (i, name) in param_names.iter().enumerate() {
        fields.push(field(name, DataType::Float64, false, "as in the job"));
        cols.push(Arc::new(Float64Array::from_iter_values(rows.iter().map(|r| r.params[i]))));
    }
    fields.push(field("samples", DataType::UInt64, false, "1"));
    cols.push(Arc::new(UInt64Array::from_iter_values(rows.iter().map(|r| r.stats.samples))));
    for (i, s) in Status::ALL.iter().enumerate() {
        let name = match s {
            Status::IndeterminateContact => "share_indeterminate".to_string(),
            other => format!("share_{}", other.name()),
        };
        fields.push(field(&name, DataType::Float64, false, "1"));
        cols.push(Arc::new(Float64Array::from_iter_values(
            rows.iter().map(|r| r.stats.status[i] as f64 / r.stats.samples.max(1) as f64),
        )));
    }
    let mut stat_cols = |prefix: String, unit: &'static str, get: &dyn Fn(&SummaryStats) -> &Series| {
        for (suffix, f) in [
            ("max", &Series::maximum as &dyn Fn(&Series) -> Option<f64>),
            ("rms", &Series::rms),
            ("p95", &|s: &Series| s.quantile(0.95)),
        ] {
            fields.push(field(&format!("{prefix}_{suffix}"), DataType::Float64, true, unit));
            cols.push(Arc::new(Float64Array::from_iter(rows.iter().map(|r| f(get(&r.stats))))));
        }
    };
    stat_cols("dp".into(), "m", &|s| &s.dp);
    stat_cols("dalpha".into(), "rad", &|s| &s.dalpha);
    for kind in KINDS {
        let k = kind.index();
        stat_cols(format!("dp_{}", kind.name()), "m", &move |s| &s.dp_kind[k]);
        stat_cols(format!("dalpha_{}", kind.name()), "rad", &move |s| &s.dalpha_kind[k]);
    }
    fields.push(field("switches", DataType::UInt64, false, "1"));
    cols.push(Arc::new(UInt64Array::from_iter_values(rows.iter().map(|r| r.switches.iter().sum()))));
    for kind in KINDS {
        fields.push(field(&format!("switches_{}", kind.name()), DataType::UInt64, false, "1"));
        cols.push(Arc::new(UInt64Array::from_iter_values(rows.iter().map(|r| r.switches[kind.index()]))));
    }
    for (name, get) in
        [("cond_a_max", &|s: &SummaryStats| s.cond_a_max), ("cond_jp_max", &|s: &SummaryStats| s.cond_jp_max)]
            as [(&str, &dyn Fn(&SummaryStats) -> f64); 2]
    {
        fields.push(field(name, DataType::Float64, true, "1"));
        cols.push(Arc::new(Float64Array::from_iter(
            rows.iter().map(|r| Some(get(&r.stats)).filter(|v| v.is_finite() && *v > 0.0)),
        )));
    }
    RecordBatch::try_new(Arc::new(Schema::new(fields)), cols).expect("columns match the schema")
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
}
