//! The `clearance` binary end to end: exit codes, the output directory contract
//! (docs/interface.md), nulls instead of NaN, and reproducibility across threads,
//! chunk sizes and shards.

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use arrow::array::{Array, Float64Array, StringArray, UInt64Array};
use arrow::record_batch::RecordBatch;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_clearance"))
}

fn write_job(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().unwrap()
}

/// The rows of `out/discontinuities.parquet`, in order, as one batch (its row
/// groups follow `--chunk-size`).
fn read_switches(out: &Path) -> RecordBatch {
    let file = File::open(out.join("discontinuities.parquet")).unwrap();
    let builder = ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
    let schema = builder.schema().clone();
    let batches: Vec<RecordBatch> = builder.build().unwrap().map(|b| b.unwrap()).collect();
    arrow::compute::concat_batches(&schema, &batches).unwrap()
}

/// Every row of every part file under `out/poses`, keyed by (variant dir, mode, sample).
fn read_rows(out: &Path) -> BTreeMap<(String, String, u64), Vec<Option<u64>>> {
    let mut rows = BTreeMap::new();
    let mut parts: Vec<PathBuf> = Vec::new();
    for v in std::fs::read_dir(out.join("poses")).unwrap() {
        for f in std::fs::read_dir(v.unwrap().path()).unwrap() {
            parts.push(f.unwrap().path());
        }
    }
    for path in parts {
        let variant = path.parent().unwrap().file_name().unwrap().to_string_lossy().into_owned();
        let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(&path).unwrap()).unwrap().build().unwrap();
        for batch in reader {
            let batch: RecordBatch = batch.unwrap();
            let mode = batch.column_by_name("mode").unwrap().as_any().downcast_ref::<StringArray>().unwrap().clone();
            let sample =
                batch.column_by_name("sample").unwrap().as_any().downcast_ref::<UInt64Array>().unwrap().clone();
            for i in 0..batch.num_rows() {
                // Bit patterns, so that equality is bitwise and nulls are distinct.
                let mut bits = Vec::new();
                for c in batch.columns() {
                    if let Some(f) = c.as_any().downcast_ref::<Float64Array>() {
                        bits.push(f.is_valid(i).then(|| f.value(i).to_bits()));
                    }
                }
                rows.insert((variant.clone(), mode.value(i).to_string(), sample.value(i)), bits);
            }
        }
    }
    rows
}

const GRID_JOB: &str = "[mechanism]\nbase_radius = 0.6\nleg_length = 0.3\n[mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
[analysis]\nexact = true\n\
[grid]\nz = { start = 1.2, stop = 2.05, n = 3 }\npsi = { start = -0.5, stop = 0.5, n = 9 }\ntheta = { start = -0.9, stop = 0.9, n = 13 }\n";

#[test]
fn bad_job_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "bad.toml", "[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n[mass]\nplatfrom = 3.0\n");
    let out = dir.path().join("out");
    let o = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("bad.toml") && err.contains("platfrom"), "{err}");
    assert!(!out.exists());
    let missing = run(&["run", "no/such/job.toml", "--out", out.to_str().unwrap()]);
    assert_eq!(missing.status.code(), Some(2));
    assert!(!out.exists());
}

#[test]
fn output_directory_contract() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "grid.toml", GRID_JOB);
    let out = dir.path().join("out");
    let o = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "--columns", "full", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for name in ["_SUCCESS", "job.toml", "summary.parquet", "discontinuities.parquet"] {
        assert!(out.join(name).exists(), "{name}");
    }
    let summary = ParquetRecordBatchReaderBuilder::try_new(File::open(out.join("summary.parquet")).unwrap())
        .unwrap()
        .build()
        .unwrap()
        .next()
        .unwrap()
        .unwrap();
    assert_eq!(summary.num_rows(), 1);
    let share =
        |name: &str| summary.column_by_name(name).unwrap().as_any().downcast_ref::<Float64Array>().unwrap().value(0);
    let total =
        share("share_ok") + share("share_unreachable") + share("share_near_singular") + share("share_indeterminate");
    assert!((total - 1.0).abs() < 1e-12, "status shares add up to 1");
    assert!(share("dp_max") >= share("dp_p95") && share("dp_p95") > 0.0);
    let part = out.join("poses/variant=0/part-kinetostatic-000000.parquet");
    let reader = ParquetRecordBatchReaderBuilder::try_new(File::open(&part).unwrap()).unwrap();
    let kv = reader.metadata().file_metadata().key_value_metadata().unwrap().clone();
    assert!(kv.iter().any(|k| k.key == "clearance.job" && k.value.as_deref().unwrap().contains("[grid")));
    assert!(kv.iter().any(|k| k.key == "clearance.version"));
    let schema = reader.schema().clone();
    for name in [
        "mode",
        "sample",
        "t",
        "z",
        "psi",
        "theta",
        "x",
        "y",
        "phi",
        "q1",
        "q3",
        "status",
        "err_x",
        "err_rz",
        "err_phi",
        "err_theta",
        "err_r_axial_psi",
        "err_s_radial_x",
        "f_r1_x",
        "m_r2_z",
        "f_s3_y",
        "margin_r1_radial",
        "margin_r2_axial",
        "margin_r3_angular",
        "margin_s1",
        "cond_a",
        "cond_jp",
        "exact_err_x",
        "exact_err_rz",
    ] {
        let f = schema.field_with_name(name).unwrap_or_else(|_| panic!("column {name}"));
        assert!(f.metadata().contains_key("unit"), "unit of {name}");
    }
    assert!(schema.field_with_name("variant").is_err(), "variant comes from the hive path");
    let batch = reader.build().unwrap().next().unwrap().unwrap();
    let status = batch.column_by_name("status").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
    let err_x = batch.column_by_name("err_x").unwrap().as_any().downcast_ref::<Float64Array>().unwrap();
    let q1 = batch.column_by_name("q1").unwrap().as_any().downcast_ref::<Float64Array>().unwrap();
    let x = batch.column_by_name("x").unwrap().as_any().downcast_ref::<Float64Array>().unwrap();
    let t = batch.column_by_name("t").unwrap();
    assert_eq!(t.null_count(), batch.num_rows(), "t is null on grids");
    let mut seen = BTreeMap::new();
    for i in 0..batch.num_rows() {
        let s = status.value(i);
        *seen.entry(s.to_string()).or_insert(0) += 1;
        assert!(x.is_valid(i), "parasitic motions are always filled");
        assert_eq!(err_x.is_valid(i), s == "ok", "err_x null exactly when the status is not ok");
        assert_eq!(q1.is_valid(i), s != "unreachable");
    }
    // Sliders outside the platform with 0.3 m legs: large tilts are out of reach; Ψ = 0 is
    // indeterminate (limb 1's axial load vanishes).
    assert!(
        seen.contains_key("ok") && seen.contains_key("unreachable") && seen.contains_key("indeterminate_contact"),
        "{seen:?}"
    );
    for c in batch.columns() {
        if let Some(f) = c.as_any().downcast_ref::<Float64Array>() {
            assert!(f.iter().flatten().all(|v| v.is_finite()), "no NaN or infinity is written");
        }
    }

    // A finished directory is not overwritten by accident.
    let again = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--overwrite"));
    let over = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q", "--overwrite"]);
    assert!(over.status.success());
    let status = run(&["status", out.to_str().unwrap()]);
    assert!(status.status.success());
}

/// Resuming a run with another `--precision` or `--columns` than its part files were
/// written with is refused (exit 2, the option and both values named, nothing
/// written), also when its first part is torn: the dataset's parts would not share a
/// schema. With the run's own options it finishes, the parts it lacked written as the
/// others were.
#[test]
fn resume_with_other_columns_or_precision_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "grid.toml", GRID_JOB);
    let out = dir.path().join("out");
    let (job, out_s) = (job.to_str().unwrap(), out.to_str().unwrap());
    let first = run(&["run", job, "--out", out_s, "-q", "--chunk-size", "100", "--precision", "single"]);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    let lost = out.join("poses/variant=0/part-kinetostatic-000001.parquet");
    let kept = std::fs::read(&lost).unwrap();
    std::fs::remove_file(&lost).unwrap();
    std::fs::remove_file(out.join("_SUCCESS")).unwrap();
    // The first part torn (a power cut): the next one still says how the run was written.
    let first = out.join("poses/variant=0/part-kinetostatic-000000.parquet");
    let whole = std::fs::read(&first).unwrap();
    std::fs::write(&first, &whole[..whole.len() / 2]).unwrap();
    let listing = |dir: &Path| {
        let mut names: Vec<_> =
            walk(dir).into_iter().map(|p| (p.clone(), std::fs::metadata(&p).unwrap().modified().unwrap())).collect();
        names.sort();
        names
    };
    let before = listing(&out);
    for (extra, option, was, now) in [
        (&["--precision", "double"][..], "--precision", "single", "double"),
        (&["--columns", "minimal", "--precision", "single"][..], "--columns", "standard", "minimal"),
        (&["--columns", "none", "--precision", "single"][..], "--columns", "standard", "none"),
    ] {
        let o = run(&[&["run", job, "--out", out_s, "-q", "--chunk-size", "100", "--resume"][..], extra].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains(&format!("{option} {was}")) && err.contains(now), "{extra:?}: {err}");
        assert_eq!(listing(&out), before, "{extra:?}: nothing written");
    }
    let o = run(&["run", job, "--out", out_s, "-q", "--chunk-size", "100", "--resume", "--precision", "single"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(&lost).unwrap() == kept, "the lost part written again as before");
    assert!(std::fs::read(&first).unwrap() == whole, "the torn part written again as before");
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let path = e.unwrap().path();
        if path.is_dir() {
            out.extend(walk(&path));
        } else {
            out.push(path);
        }
    }
    out
}

#[test]
fn same_data_for_any_threads_chunks_shards_and_resume() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "grid.toml", GRID_JOB);
    let j = job.to_str().unwrap();
    let reference = dir.path().join("ref");
    let r = reference.to_str().unwrap();
    assert!(run(&["run", j, "--out", r, "--threads", "1", "-q"]).status.success());
    let want = read_rows(&reference);
    assert_eq!(want.len(), 3 * 9 * 13);

    let multi = dir.path().join("multi");
    let m = multi.to_str().unwrap();
    assert!(run(&["run", j, "--out", m, "--threads", "2", "--chunk-size", "17", "-q"]).status.success());
    assert_eq!(read_rows(&multi), want, "2 threads and 17-sample chunks");
    // 12 threads write with 3 writer threads, which finish parts in any order.
    let writers = dir.path().join("writers");
    let w = writers.to_str().unwrap();
    assert!(run(&["run", j, "--out", w, "--threads", "12", "--chunk-size", "17", "-q"]).status.success());
    assert_eq!(read_rows(&writers), want, "12 threads (3 writers) and 17-sample chunks");
    assert_eq!(read_switches(&writers), read_switches(&reference), "switches with 3 writers");

    let sharded = dir.path().join("sharded");
    let s = sharded.to_str().unwrap();
    for i in 0..3 {
        let o = run(&["run", j, "--out", s, "--chunk-size", "40", "--shard", &format!("{i}/3"), "-q"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let done = run(&["status", s]).status.success();
        assert_eq!(done, i == 2, "complete only after the last shard");
    }
    assert_eq!(read_rows(&sharded), want, "union of shards");
    // The sharded run's search reads the trace files back at the end; the single
    // run's followed the computation in memory: the same switches.
    let switches = read_switches(&reference);
    assert!(switches.num_rows() > 0, "the job has switches to compare");
    assert_eq!(read_switches(&sharded), switches, "switches of shards");

    // Resume after losing a part file and the success marker.
    std::fs::remove_file(sharded.join("_SUCCESS")).unwrap();
    for e in std::fs::read_dir(&sharded).unwrap() {
        let p = e.unwrap().path();
        if p.file_name().unwrap().to_string_lossy().starts_with("_SUCCESS") {
            std::fs::remove_file(p).unwrap();
        }
    }
    std::fs::remove_file(sharded.join("poses/variant=0/part-kinetostatic-000002.parquet")).unwrap();
    assert!(!run(&["status", s]).status.success());
    let o = run(&["run", j, "--out", s, "--chunk-size", "40", "--resume", "-q"]);
    assert!(o.status.success());
    assert_eq!(read_rows(&sharded), want, "resumed");
    assert_eq!(read_switches(&sharded), switches, "switches, resumed");

    // After a power cut a part can exist under its name and be empty or torn (parts
    // reach the disk after their rename): `--resume` computes it again. A missing
    // discontinuity trace is computed again too, and the switches stay the same.
    std::fs::remove_file(sharded.join("_SUCCESS")).unwrap();
    let torn = sharded.join("poses/variant=0/part-kinetostatic-000001.parquet");
    let len = std::fs::metadata(&torn).unwrap().len();
    std::fs::OpenOptions::new().write(true).open(&torn).unwrap().set_len(len / 2).unwrap();
    std::fs::write(sharded.join("poses/variant=0/part-kinetostatic-000000.parquet"), b"").unwrap();
    std::fs::remove_file(sharded.join("_stats/variant=0/kinetostatic-000002.trace4")).unwrap();
    // A whole part whose statistics file was torn is computed again too.
    std::fs::write(sharded.join("_stats/variant=0/kinetostatic-000003.json"), b"{\"samp").unwrap();
    let o = run(&["run", j, "--out", s, "--chunk-size", "40", "--resume", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(read_rows(&sharded), want, "resumed over torn parts");
    assert_eq!(read_switches(&sharded), switches, "switches, resumed over torn parts");
}

#[test]
fn unwritable_output_fails_with_exit_1_and_no_final_file() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "grid.toml", GRID_JOB);
    // A regular file where the output directory's parent should be: nothing can be
    // created below it, whoever runs the test (root included).
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, b"not a directory").unwrap();
    let out = blocker.join("out");
    let o = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "-q"]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("out") && err.lines().count() <= 2, "{err}");
    assert_eq!(std::fs::read(&blocker).unwrap(), b"not a directory");
}

/// `bench --json` prints one JSON object with docs/interface.md's keys, every rate a
/// positive number and the Parquet size per pose that of the standard columns
/// (at least a byte a column, at most eight and some overhead uncompressed).
#[test]
fn bench_json_has_the_interface_keys() {
    let o = run(&["bench", "--json", "--poses", "3000", "--threads", "1", "--compression", "none", "--repeat", "2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    for key in ["kernel_poses_per_s", "kernel_general_poses_per_s", "end_to_end_poses_per_s"] {
        let rate = v[key].as_f64().unwrap_or_else(|| panic!("{key} missing: {v}"));
        assert!(rate.is_finite() && rate > 0.0, "{key} = {rate}");
    }
    // The reported rate is the fastest of the runs listed.
    for (key, runs) in [("kernel_poses_per_s", "kernel_runs"), ("end_to_end_poses_per_s", "end_to_end_runs")] {
        let runs: Vec<f64> = v[runs].as_array().unwrap().iter().map(|r| r.as_f64().unwrap()).collect();
        assert_eq!(runs.len(), 2, "{key}: {v}");
        let fastest = runs.iter().copied().fold(0.0, f64::max);
        assert!((v[key].as_f64().unwrap() - fastest).abs() <= 0.1, "{key} is not the fastest run: {v}");
    }
    assert_eq!(v["threads"], 1);
    assert_eq!(v["compression"], "none");
    assert!(["portable", "avx2", "avx512"].contains(&v["isa"].as_str().unwrap_or("")), "isa: {v}");
    let bytes = v["bytes_per_pose"].as_f64().unwrap();
    assert!((111.0..=9.0 * 111.0).contains(&bytes), "{bytes} bytes a pose for 111 columns");
}

/// `bench --scaling --json`: a row per thread count asked for, in order, with
/// docs/interface.md's keys, positive rates, end to end over kernel their ratio, and
/// stage shares between 0 and 2 (busy times that overlap); `--threads` is refused
/// beside it.
#[test]
fn bench_scaling_has_a_row_per_thread_count() {
    let o = run(&["bench", "--scaling", "--json", "--poses", "2000", "--repeat", "1", "--thread-counts", "1,2"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let rows = v["scaling"].as_array().unwrap();
    assert_eq!(rows.iter().map(|r| r["threads"].as_u64().unwrap()).collect::<Vec<_>>(), [1, 2]);
    for r in rows {
        let (k, e) = (r["kernel_poses_per_s"].as_f64().unwrap(), r["end_to_end_poses_per_s"].as_f64().unwrap());
        assert!(k > 0.0 && e > 0.0, "{r}");
        assert!((r["end_to_end_over_kernel"].as_f64().unwrap() - e / k).abs() <= 1e-3 * e / k + 1e-4, "{r}");
        for key in ["share_pose_pass", "share_search", "share_writing", "share_finish"] {
            let share = r[key].as_f64().unwrap();
            assert!((0.0..=2.0).contains(&share), "{key} = {share}");
        }
        // The bench job is a 3-PRS: its pool's time in tasks is counted, a share of
        // the pool's thread time; waiting on the writers is part of it.
        let (tasks, queue) = (r["pool_in_tasks"].as_f64().unwrap(), r["share_queue_wait"].as_f64().unwrap());
        assert!(tasks > 0.0 && tasks <= 1.0 + 1e-6, "pool_in_tasks = {tasks}");
        assert!((0.0..=tasks * r["threads"].as_f64().unwrap()).contains(&queue), "share_queue_wait = {queue}");
    }
    assert_eq!(v["columns"], "standard");
    let o = run(&["bench", "--scaling", "--threads", "2"]);
    assert_eq!(o.status.code(), Some(2));
}

/// The keys of `bench --json` stay those scripts parse (docs/interface.md), whatever
/// `--writer` measured: no key added, none dropped.
#[test]
fn bench_json_keys_do_not_change() {
    let o = run(&["bench", "--json", "--poses", "500", "--threads", "1", "--repeat", "1", "--writer", "arrow"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
    let mut keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    keys.sort_unstable();
    let mut expected = vec![
        "job",
        "mechanism",
        "kernel_poses_per_s",
        "kernel_general_poses_per_s",
        "end_to_end_poses_per_s",
        "threads",
        "poses",
        "solver",
        "compression",
        "bytes_per_pose",
        "isa",
        "repeat",
        "kernel_runs",
        "end_to_end_runs",
    ];
    expected.sort_unstable();
    assert_eq!(keys, expected);
}

/// `bench --suite --json` runs every job of the suite, in its order, each with a
/// positive rate, shares of wall time that a stage can have (pose pass and writing
/// never zero), the column set, threads, vector instructions and writer asked for,
/// and leaves nothing in the temporary directory.
#[test]
fn bench_suite_reports_every_job_and_cleans_up() {
    for writer in ["engine", "arrow"] {
        let tmp = tempfile::tempdir().unwrap();
        let o = bin()
            .args(["bench", "--suite", "--json", "--scale", "0.002", "--repeat", "2", "--threads", "1"])
            .args(["--writer", writer, "--compression", "lz4"])
            .env("TMPDIR", tmp.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON object");
        let jobs = v["suite"].as_array().unwrap();
        let names: Vec<&str> = jobs.iter().map(|j| j["job"].as_str().unwrap()).collect();
        assert_eq!(
            names,
            [
                "grid_2d",
                "grid_2d_minimal",
                "grid_2d_full",
                "grid_3d",
                "sweep_16",
                "sweep_masses_4",
                "sweep_masses_clearances_12",
                "trajectory_dynamic",
                "prs_inclined",
                "rps_grid",
                "ups_grid",
                "prs_builtin",
                "prs_described",
                "ups_described",
                "custom_3rrs",
                "custom_6pus"
            ]
        );
        let columns: Vec<&str> = jobs.iter().map(|j| j["columns"].as_str().unwrap()).collect();
        assert_eq!(columns[..4], ["standard", "minimal", "full", "standard"]);
        // The clearance sweep's cost: its wall time over its mass-only counterpart's.
        let seconds = |name: &str| jobs.iter().find(|j| j["job"] == name).unwrap()["seconds"].as_f64().unwrap();
        let cost = v["clearance_sweep_cost"].as_f64().expect("a number");
        let expected = seconds("sweep_masses_clearances_12") / seconds("sweep_masses_4");
        assert!((cost - expected).abs() <= 0.05 * expected, "{cost} against {expected} (both rounded)");
        // Each described preset's cost: its wall time over its built-in twin's.
        for (kind, described, builtin) in
            [("3-PRS", "prs_described", "prs_builtin"), ("6-UPS", "ups_described", "ups_grid")]
        {
            let cost = v["described_cost"][kind].as_f64().expect("a number");
            let expected = seconds(described) / seconds(builtin);
            assert!((cost - expected).abs() <= 0.05 * expected, "{kind}: {cost} against {expected} (both rounded)");
        }
        for j in jobs {
            let rate = j["poses_per_s"].as_f64().unwrap();
            let runs: Vec<f64> = j["runs"].as_array().unwrap().iter().map(|r| r.as_f64().unwrap()).collect();
            assert_eq!(runs.len(), 2, "{j}");
            assert!(rate > 0.0 && (rate - runs.iter().copied().fold(0.0, f64::max)).abs() <= 0.1, "{j}");
            // The pose pass and the search run on the calling thread, each at most the
            // whole run; writing is the writer thread's busy time plus the final files the
            // calling thread writes meanwhile, so up to twice it (StageTimes::writing).
            for (key, most) in [("share_pose_pass", 1.001), ("share_search", 1.001), ("share_writing", 2.001)] {
                let share = j[key].as_f64().unwrap();
                assert!((0.0..=most).contains(&share), "{key} {share}: {j}");
            }
            assert_eq!(j["stages_timed"], true, "every kind times its stages: {j}");
            // The search's share of the CPU time: the least CPU seconds of the runs
            // without it against the least of the runs with it (both the process's).
            let (cpu, without) =
                (j["cpu_seconds"].as_f64().unwrap(), j["cpu_seconds_without_search"].as_f64().unwrap());
            assert!(cpu > 0.0 && without > 0.0, "{j}");
            let share = j["share_search_cpu"].as_f64().unwrap();
            assert!((share - (1.0 - without / cpu)).abs() < 2e-3 && share < 1.0, "share_search_cpu {share}: {j}");
            assert!(j["share_pose_pass"].as_f64().unwrap() > 0.0 && j["share_writing"].as_f64().unwrap() > 0.0);
            assert!(j["poses"].as_u64().unwrap() > 0 && j["bytes_per_pose"].as_f64().unwrap() > 10.0, "{j}");
            assert_eq!(j["threads"], 1);
            assert_eq!(j["writer"], writer);
            assert_eq!(j["isa"], v["isa"]);
            assert!(j["file"].as_str().unwrap().starts_with("benches/suite/"), "{j}");
        }
        assert!(["portable", "avx2", "avx512"].contains(&v["isa"].as_str().unwrap_or("")), "isa: {v}");
        let by_name = |n: &str| jobs.iter().find(|j| j["job"] == n).unwrap();
        assert_eq!(by_name("sweep_16")["variants"], 16);
        assert_eq!(by_name("trajectory_dynamic")["modes"], 2);
        assert_eq!(by_name("rps_grid")["mechanism"], "3-RPS");
        assert_eq!(by_name("ups_grid")["mechanism"], "6-UPS");
        assert!(v["kernel"]["poses_per_s"].as_f64().unwrap() > 0.0);
        let left: Vec<_> = std::fs::read_dir(tmp.path()).unwrap().collect();
        assert!(left.is_empty(), "{left:?} left in the temporary directory");
    }
}

/// A writer that does not exist is a bad command line (exit 2), and `--suite` does
/// not take `--poses`.
#[test]
fn bad_writer_or_suite_flags_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "j.toml", "[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n");
    let out = dir.path().join("out");
    let o = run(&["run", job.to_str().unwrap(), "--out", out.to_str().unwrap(), "--writer", "pyarrow"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.exists());
    let o = run(&["bench", "--suite", "--poses", "1000"]);
    assert_eq!(o.status.code(), Some(2));
    let o = run(&["bench", "--scale", "0.5"]);
    assert_eq!(o.status.code(), Some(2));
}

/// `check` estimates the wall time from real runs of the job: a small job runs whole
/// (and the estimate is that run), a larger one from two or more scaled-down runs
/// whose rows grow; either way nothing is left in the scratch directory.
#[test]
fn check_estimates_from_calibration_runs_and_leaves_no_scratch() {
    let dir = tempfile::tempdir().unwrap();
    let scratch = tempfile::tempdir().unwrap();
    let grid = |n: u32| {
        format!(
            "[clearance]\nr_radial = 1e-4\n[grid]\nz = {{ start = 1.95, stop = 2.05, n = 4 }}\n\
             psi = {{ start = -0.3, stop = 0.3, n = {n} }}\ntheta = {{ start = -0.3, stop = 0.3, n = {n} }}\n"
        )
    };
    for (name, n) in [("small.toml", 10), ("large.toml", 400)] {
        let job = write_job(dir.path(), name, &grid(n));
        let o = bin()
            .args(["check", job.to_str().unwrap(), "--threads", "1"])
            .env("TMPDIR", scratch.path())
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        let line = out.lines().find(|l| l.starts_with("estimated wall time: ")).expect("an estimate");
        assert!(line.contains("1 threads") && line.contains("standard columns"), "{line}");
        if n == 10 {
            assert!(line.contains("the whole job ran"), "{line}");
        } else {
            let runs: usize = line.split("from ").nth(1).and_then(|r| r.split(' ').next()).unwrap().parse().unwrap();
            let rows: u64 = line.split("poses, ").nth(1).and_then(|r| r.split(' ').next()).unwrap().parse().unwrap();
            assert!(runs >= 2 && rows < 4 * 400 * 400, "{line}");
        }
        let seconds: f64 = line["estimated wall time: ".len()..].split(' ').next().unwrap().parse().unwrap();
        assert!(seconds > 0.0 && seconds.is_finite(), "{line}");
        assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "calibration runs left files");
    }
}
