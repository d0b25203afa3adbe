//! A run killed with SIGKILL mid-way and resumed gives the same data as an
//! uninterrupted one, and never leaves a part file that looks complete but is not.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_clearance"))
}

fn parts(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir.join("poses/variant=0")) {
        for e in rd.flatten() {
            out.push(e.path());
        }
    }
    out.sort();
    out
}

#[test]
fn kill_9_then_resume_equals_an_uninterrupted_run() {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job.toml");
    std::fs::write(
        &job,
        "[clearance]\ns_radial = 1e-4\nr_radial = 1e-4\nr_axial = 1e-4\nr_angular = 1e-4\n\
         [grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 161 }\ntheta = { start = -0.5, stop = 0.5, n = 161 }\n",
    )
    .unwrap();
    let (j, killed, whole) = (job.to_str().unwrap(), dir.path().join("killed"), dir.path().join("whole"));
    let args = |out: &Path| {
        vec![
            "run".to_string(),
            j.to_string(),
            "--out".into(),
            out.display().to_string(),
            "--chunk-size".into(),
            "2000".into(),
            "-q".into(),
            "--threads".into(),
            "1".into(),
        ]
    };

    let mut child = bin().args(args(&killed)).stderr(Stdio::null()).spawn().unwrap();
    let start = Instant::now();
    // Kill as soon as a few parts are complete, well before the end.
    while parts(&killed).iter().filter(|p| p.extension().is_some_and(|e| e == "parquet")).count() < 3 {
        assert!(start.elapsed() < Duration::from_secs(120), "no part appeared");
        assert!(child.try_wait().unwrap().is_none(), "the run finished before it could be killed");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(!killed.join("_SUCCESS").exists());
    let status = bin().args(["status", killed.to_str().unwrap()]).output().unwrap();
    assert_eq!(status.status.code(), Some(1), "a killed run is incomplete");
    // Files under final names are complete Parquet files (temporaries start with '.').
    for p in parts(&killed) {
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        if !name.starts_with('.') {
            let bytes = std::fs::read(&p).unwrap();
            assert_eq!(&bytes[bytes.len() - 4..], b"PAR1", "{name} is complete");
        }
    }

    let resumed = bin().args(args(&killed)).arg("--resume").output().unwrap();
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert!(bin().args(args(&whole)).status().unwrap().success());

    let finals = |d: &Path| -> Vec<String> {
        parts(d)
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .filter(|n| !n.starts_with('.'))
            .collect()
    };
    assert_eq!(finals(&killed), finals(&whole));
    for name in finals(&whole) {
        let read = |d: &Path| {
            let f = std::fs::File::open(d.join("poses/variant=0").join(&name)).unwrap();
            let reader =
                parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f).unwrap().build().unwrap();
            reader.map(|b| b.unwrap()).collect::<Vec<_>>()
        };
        assert_eq!(read(&killed), read(&whole), "{name}");
    }
    for name in ["summary.parquet", "discontinuities.parquet"] {
        let read = |d: &Path| {
            let f = std::fs::File::open(d.join(name)).unwrap();
            let reader =
                parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f).unwrap().build().unwrap();
            reader.map(|b| b.unwrap()).collect::<Vec<_>>()
        };
        assert_eq!(read(&killed), read(&whole), "{name}");
    }
}
