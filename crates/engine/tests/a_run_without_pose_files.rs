//! `--columns none` (`RunOptions::poses = false`): no pose file, and the same
//! `summary.parquet` and `discontinuities.parquet` as a run with the standard
//! columns, for a 3-limb grid (two writers, two parts), a 3-limb clearance sweep
//! (members sharing one solve), a 6-UPS grid and a custom mechanism; `--resume` of a
//! finished run keeps everything.

mod common;

use clearance_engine::{ColumnSet, JobSpec, Layout, RunOptions, RunStatus, Writer, run, status};

const PRS: &str = "[clearance]\nr_axial = 1e-4\nr_radial = 1e-4\ns_radial = 5e-5\n\
    [mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
    [grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 21 }\ntheta = { start = -0.5, stop = 0.5, n = 21 }\n\
    [[sweep]]\nparam = \"mass.platform\"\nvalues = [9.8, 30.0]\n";

/// Masses crossed with `r_radial` magnitudes: groups of members that share a solve.
const PRS_CLEARANCES: &str = "[clearance]\nr_axial = 1e-4\nr_radial = 1e-4\ns_radial = 5e-5\n\
    [mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
    [grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 21 }\ntheta = { start = -0.5, stop = 0.5, n = 21 }\n\
    [[sweep]]\nparam = \"mass.platform\"\nvalues = [9.8, 30.0]\n\
    [[sweep]]\nparam = \"clearance.r_radial\"\nvalues = [0.0, 1e-4, 3e-4]\n";

const UPS: &str = "[mechanism]\nkind = \"6-UPS\"\n[mass]\npoints = [ { mass = 5.0, at = [0.05, 0.0, 0.3] } ]\n\
    [clearance]\ns_radial = 1e-4\nu_radial = 1e-4\n\
    [grid]\nx = { start = -0.15, stop = 0.15, n = 9 }\ny = { start = -0.15, stop = 0.15, n = 9 }\nz = 0.7\n\
    phi = 0.05\npsi = 0.1\ntheta = -0.1\n";

fn poses_files(layout: &Layout) -> usize {
    fn count(dir: &std::path::Path) -> usize {
        std::fs::read_dir(dir)
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| if e.path().is_dir() { count(&e.path()) } else { 1 })
            .sum()
    }
    count(&layout.root().join("poses"))
}

#[test]
fn the_summary_and_the_switches_are_those_of_a_standard_run() {
    let custom = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../jobs/custom_3rrs_grid.toml"))
        .unwrap()
        .replace("n = 61", "n = 9");
    for (text, writer, chunk) in [
        (PRS, Writer::Engine, 200),
        (PRS, Writer::Arrow, 65536),
        (PRS_CLEARANCES, Writer::Engine, 150),
        (UPS, Writer::Engine, 65536),
        (&custom, Writer::Engine, 40),
    ] {
        let job = JobSpec::from_toml_str(text, "job.toml").unwrap();
        let (with, without) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let base = |dir: &std::path::Path| RunOptions {
            columns: ColumnSet::Standard,
            chunk_size: chunk,
            writer,
            precision: clearance_engine::Precision::Double,
            ..common::options(dir)
        };
        run(&job, "job.toml", &base(with.path())).unwrap();
        let none = RunOptions { poses: false, ..base(without.path()) };
        let report = run(&job, "job.toml", &none).unwrap();
        assert!(report.complete && report.computed == report.total);
        let (a, b) = (Layout::new(with.path()), Layout::new(without.path()));
        assert!(poses_files(&a) > 0);
        assert_eq!(poses_files(&b), 0, "no pose file");
        // Equal but for the files' metadata, which says `clearance.columns = none`.
        for (x, y) in [(a.summary(), b.summary()), (a.discontinuities(), b.discontinuities())] {
            let (x, y) = (common::read(&x), common::read(&y));
            assert_eq!(x.schema().fields(), y.schema().fields());
            assert_eq!(x.columns(), y.columns());
            assert_eq!(y.schema().metadata()["clearance.columns"], "none");
        }
        assert_eq!(status(without.path()), RunStatus::Complete);
        // Resumed, a finished run without pose files keeps its units.
        let again = run(&job, "job.toml", &RunOptions { resume: true, ..none.clone() }).unwrap();
        assert_eq!(again.computed, 0);
        assert_eq!(poses_files(&b), 0);
    }
}
