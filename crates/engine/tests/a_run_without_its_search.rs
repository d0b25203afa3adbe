//! `RunOptions::search = false`, what `clearance bench --suite` measures the search's
//! cost with: the same parts as a run that searches, and no switch, for a 3-limb
//! grid and a 6-UPS grid.

mod common;

use clearance_engine::{JobSpec, Layout, RunOptions, run};

const PRS: &str = "[clearance]\nr_axial = 1e-4\nr_radial = 1e-4\n\
    [mass]\npoints = [ { mass = 30.0, at = [0.0, 0.0, 1.0] } ]\n\
    [grid]\nz = 2.05\npsi = { start = -0.5, stop = 0.5, n = 21 }\ntheta = { start = -0.5, stop = 0.5, n = 21 }\n";

const UPS: &str = "[mechanism]\nkind = \"6-UPS\"\n[mass]\npoints = [ { mass = 5.0, at = [0.05, 0.0, 0.3] } ]\n\
    [clearance]\ns_radial = 1e-4\nu_radial = 1e-4\n\
    [grid]\nx = { start = -0.15, stop = 0.15, n = 9 }\ny = { start = -0.15, stop = 0.15, n = 9 }\nz = 0.7\n\
    phi = 0.05\npsi = 0.1\ntheta = -0.1\n";

#[test]
fn the_parts_are_the_same_and_there_is_no_switch() {
    for text in [PRS, UPS] {
        let job = JobSpec::from_toml_str(text, "job.toml").unwrap();
        let (with, without) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        run(&job, "job.toml", &common::options(with.path())).unwrap();
        run(&job, "job.toml", &RunOptions { search: false, ..common::options(without.path()) }).unwrap();
        let (a, b) = (Layout::new(with.path()), Layout::new(without.path()));
        assert!(common::read(&a.discontinuities()).num_rows() > 10);
        assert_eq!(common::read(&b.discontinuities()).num_rows(), 0);
        let part = |l: &Layout| common::read(&l.part(0, clearance_model::Mode::Kinetostatic, 0));
        assert_eq!(part(&a), part(&b));
        assert!(b.success().exists());
    }
}
