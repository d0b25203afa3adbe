//! Small run directories made in the test with the engine's own library, the way
//! `clearance run` lays them out, so the plot tests do not depend on the CLI.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::Arc;

use arrow::array::{Float64Array, StringArray, UInt32Array, UInt64Array};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::record_batch::RecordBatch;
use clearance_grid::SampleSource;
use clearance_model::JobSpec;
use clearance_parquet::{ColumnSet, PoseSchema, WriteOptions, write_parquet};
use clearance_solver::{Model, Workspace, solve_pose};

/// Writes `job_text` as a complete run under `dir`: job.toml, one part file per
/// (variant, mode), _SUCCESS.
pub fn make_run(dir: &Path, job_text: &str, columns: ColumnSet) -> JobSpec {
    let job = JobSpec::from_toml_str(job_text, "test.toml").expect("test job is valid");
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("job.toml"), job.to_toml_string()).unwrap();
    let schema = PoseSchema::new(columns, job.analysis.exact);
    for variant in job.variants("test.toml").unwrap() {
        let mut model = Model::from_job(&variant.job);
        model.envelope = columns >= ColumnSet::Standard;
        let source = SampleSource::new(&variant.job);
        let mut ws = Workspace::new();
        for &mode in &job.analysis.modes {
            let rows: Vec<_> = (0..source.len())
                .map(|i| {
                    let s = source.sample(i);
                    (s, solve_pose(&model, &s, mode, &mut ws))
                })
                .collect();
            let batch = schema.batch(mode, &rows);
            let part = dir
                .join("poses")
                .join(format!("variant={}", variant.index))
                .join(format!("part-{}-000000.parquet", mode.name()));
            std::fs::create_dir_all(part.parent().unwrap()).unwrap();
            write_parquet(&part, schema.schema(), &[batch], &WriteOptions::default(), &[]).unwrap();
        }
    }
    std::fs::write(dir.join("_SUCCESS"), b"").unwrap();
    job
}

/// Writes the 6-UPS `job_text` as a complete run under `dir`, its poses solved by the
/// engine's [`clearance_engine::solve`] (the rows of a run's part files): job.toml,
/// one part file per (variant, mode), each batch passed through `edit` first, and
/// _SUCCESS. Returns the job and the batches written.
pub fn make_ups_run(
    dir: &Path,
    job_text: &str,
    edit: impl Fn(RecordBatch) -> RecordBatch,
) -> (JobSpec, Vec<RecordBatch>) {
    let job = JobSpec::from_toml_str(job_text, "test.toml").expect("test job is valid");
    assert_eq!(job.mechanism.kind, clearance_model::MechanismKind::Ups6);
    std::fs::create_dir_all(dir).unwrap();
    std::fs::write(dir.join("job.toml"), job.to_toml_string()).unwrap();
    let mut written = Vec::new();
    for batch in clearance_engine::solve(&job, "test.toml", &clearance_engine::SolveOptions::default()).unwrap() {
        let variant = batch.column(0).as_any().downcast_ref::<UInt64Array>().unwrap().value(0);
        let part = edit(batch.project(&(1..batch.num_columns()).collect::<Vec<_>>()).unwrap());
        let mode = strings(&part, "mode").value(0).to_string();
        let path = dir.join("poses").join(format!("variant={variant}")).join(format!("part-{mode}-000000.parquet"));
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        write_parquet(&path, part.schema(), std::slice::from_ref(&part), &WriteOptions::default(), &[]).unwrap();
        written.push(part);
    }
    std::fs::write(dir.join("_SUCCESS"), b"").unwrap();
    (job, written)
}

/// A float column of `batch` by name.
pub fn floats<'a>(batch: &'a RecordBatch, name: &str) -> &'a Float64Array {
    batch.column_by_name(name).unwrap_or_else(|| panic!("no column {name}")).as_any().downcast_ref().unwrap()
}

/// A string column of `batch` by name.
pub fn strings<'a>(batch: &'a RecordBatch, name: &str) -> &'a StringArray {
    batch.column_by_name(name).unwrap_or_else(|| panic!("no column {name}")).as_any().downcast_ref().unwrap()
}

/// A 6-UPS `discontinuities.parquet` with the engine's own table
/// ([`clearance_parquet::ups_discontinuity_batch`]): one switch per `(mode, kind,
/// t, inputs x, y, z, phi, psi, theta)`, `kind` 0 for `s_radial`, 1 for `u_radial`.
pub fn write_ups_switches(dir: &Path, rows: &[(clearance_model::Mode, usize, Option<f64>, [f64; 6])]) -> PathBuf {
    let rows: Vec<clearance_parquet::UpsSwitch> = rows
        .iter()
        .map(|&(mode, kind, t, inputs)| clearance_parquet::UpsSwitch {
            variant: 0,
            mode,
            limb: 2,
            kind,
            along: if t.is_some() { "t" } else { "x" },
            t,
            coords: inputs,
            margin: 1.0,
            jump: [1e-5; 6],
        })
        .collect();
    let batch = clearance_parquet::ups_discontinuity_batch(&rows);
    let path = dir.join("discontinuities.parquet");
    write_parquet(&path, batch.schema(), &[batch], &WriteOptions::default(), &[]).unwrap();
    path
}

/// One row of `discontinuities.parquet` (the columns of docs/interface.md).
pub struct SwitchRow {
    pub variant: u64,
    pub mode: &'static str,
    pub kind: &'static str,
    pub along: &'static str,
    pub t: Option<f64>,
    pub z: f64,
    pub psi: f64,
    pub theta: f64,
}

pub fn write_switches(dir: &Path, rows: &[SwitchRow]) -> PathBuf {
    let f64s = |f: &dyn Fn(&SwitchRow) -> Option<f64>| Arc::new(rows.iter().map(f).collect::<Float64Array>()) as _;
    let mut fields = vec![
        Field::new("variant", DataType::UInt64, false),
        Field::new("mode", DataType::Utf8, false),
        Field::new("limb", DataType::UInt32, false),
        Field::new("kind", DataType::Utf8, false),
        Field::new("along", DataType::Utf8, false),
        Field::new("t", DataType::Float64, true),
    ];
    for name in ["z", "psi", "theta", "margin"] {
        fields.push(Field::new(name, DataType::Float64, false));
    }
    for c in ["x", "y", "z", "rx", "ry", "rz"] {
        fields.push(Field::new(format!("jump_{c}"), DataType::Float64, false));
    }
    let mut columns: Vec<arrow::array::ArrayRef> = vec![
        Arc::new(rows.iter().map(|r| r.variant).collect::<UInt64Array>()),
        Arc::new(rows.iter().map(|r| Some(r.mode)).collect::<StringArray>()),
        Arc::new(rows.iter().map(|_| 1u32).collect::<UInt32Array>()),
        Arc::new(rows.iter().map(|r| Some(r.kind)).collect::<StringArray>()),
        Arc::new(rows.iter().map(|r| Some(r.along)).collect::<StringArray>()),
        f64s(&|r| r.t),
        f64s(&|r| Some(r.z)),
        f64s(&|r| Some(r.psi)),
        f64s(&|r| Some(r.theta)),
        f64s(&|_| Some(1.0)),
    ];
    for _ in 0..6 {
        columns.push(f64s(&|_| Some(1e-5)));
    }
    let schema = Arc::new(Schema::new(fields));
    let batch = RecordBatch::try_new(schema.clone(), columns).unwrap();
    let path = dir.join("discontinuities.parquet");
    write_parquet(&path, schema, &[batch], &WriteOptions::default(), &[]).unwrap();
    path
}

/// Figures share a 100-pixel header (title, subtitle); the panels are below it.
pub const HEADER: u32 = 100;

/// The pixels that differ below the header (the subtitle counts the switches).
pub fn body_difference(a: &Png, b: &Png) -> usize {
    let skip = (HEADER * a.width) as usize;
    a.pixels[skip..].iter().zip(&b.pixels[skip..]).filter(|(p, q)| p != q).count()
}

/// A decoded figure.
pub struct Png {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[u8; 3]>,
}

impl Png {
    pub fn open(path: &Path) -> Png {
        let img = image::open(path).unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display())).to_rgb8();
        Png { width: img.width(), height: img.height(), pixels: img.pixels().map(|p| p.0).collect() }
    }

    pub fn distinct_colours(&self) -> usize {
        let mut c: Vec<[u8; 3]> = self.pixels.clone();
        c.sort_unstable();
        c.dedup();
        c.len()
    }

    /// The fraction of pixels that are not the white background.
    pub fn ink(&self) -> f64 {
        self.pixels.iter().filter(|p| **p != [255, 255, 255]).count() as f64 / self.pixels.len() as f64
    }

    pub fn at(&self, x: u32, y: u32) -> [u8; 3] {
        self.pixels[(y * self.width + x) as usize]
    }

    pub fn count(&self, colour: [u8; 3]) -> usize {
        self.pixels.iter().filter(|p| **p == colour).count()
    }

    pub fn differs_from(&self, other: &Png) -> usize {
        self.pixels.iter().zip(&other.pixels).filter(|(a, b)| a != b).count()
    }
}

/// The files under `dir`, relative to it, sorted.
pub fn files_under(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            let sub = path.file_name().unwrap().to_string_lossy().into_owned();
            out.extend(files_under(&path).into_iter().map(|f| format!("{sub}/{f}")));
        } else {
            out.push(path.file_name().unwrap().to_string_lossy().into_owned());
        }
    }
    out.sort();
    out
}
