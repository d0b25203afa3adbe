//! The scalar rule of docs/model.md §8 is one rule for every mechanism: the 3-PRS
//! described as a custom job (`clearance describe`) has the built-in kind's `r_axial`
//! switches, at the same places (to the root finders' tolerances: 2.5e-9 rad) with the
//! same jumps (to 1e-12 of their scale). Two cases the custom search missed before:
//!
//! - limb 1's axial load is zero on the symmetry plane Ψ = 0, a sample of each Ψ-line
//!   here: that sample is indeterminate and left out, so the samples either side of it
//!   are consecutive, and their loads' signs differ: a switch at Ψ = 0 (a sampling
//!   with no sample at Ψ = 0 finds it too, between two samples);
//! - along Θ at Ψ = −0.08, limb 2's axial load crosses zero twice between the samples
//!   Θ = −0.05 and −0.04, both of one sign: two switches, found by looking in the
//!   intervals beside the sampled minimum of its magnitude for a point of the other
//!   sign.

mod common;

use common::column;

use arrow::array::{Array, Float64Array, StringArray, UInt32Array};
use clearance_engine::{JobSpec, Layout, describe, run};

const JOB: &str = "[clearance]\nr_axial = 1e-4\n[grid]\nz = 2.05\n\
    psi = { start = -0.08, stop = 0.08, n = PSI }\ntheta = { start = -0.5, stop = 0.0, n = 51 }\n";

/// One switch: limb, along, Ψ, Θ, jump (`None` where it is null).
type Switch = (u32, String, f64, f64, Option<[f64; 6]>);

/// The `r_axial` switches of the job with `psi` samples along Ψ, built in or described.
fn switches(psi: usize, described: bool) -> Vec<Switch> {
    let mut job = JobSpec::from_toml_str(&JOB.replace("PSI", &psi.to_string()), "prs.toml").unwrap();
    if described {
        // Its general path (as `describe` writes it, the 3-PRS kernel would solve it).
        job = common::general_path(&describe(&job, "prs.toml").unwrap());
    }
    let dir = tempfile::tempdir().unwrap();
    run(&job, "prs.toml", &common::options(dir.path())).unwrap();
    let d = common::read(&Layout::new(dir.path()).discontinuities());
    let f = |name: &str| column::<Float64Array>(&d, name);
    let (along, kind) = (column::<StringArray>(&d, "along"), column::<StringArray>(&d, "kind"));
    let limb = column::<UInt32Array>(&d, "limb");
    let jump = ["x", "y", "z", "rx", "ry", "rz"].map(|c| f(&format!("jump_{c}")));
    let mut out: Vec<Switch> = (0..d.num_rows())
        .filter(|&i| kind.value(i) == "r_axial")
        .map(|i| {
            let j = jump.iter().all(|c| c.is_valid(i)).then(|| jump.map(|c| c.value(i)));
            (limb.value(i), along.value(i).to_string(), f("psi").value(i), f("theta").value(i), j)
        })
        .collect();
    // By limb, then line (its fixed coordinate, a sample's), then along it.
    let key = |s: &Switch| if s.1 == "psi" { (s.3, s.2) } else { (s.2, s.3) };
    out.sort_by(|a, b| (a.0, &a.1, key(a)).partial_cmp(&(b.0, &b.1, key(b))).unwrap());
    out
}

/// The switches of limb `l` along `along` at the line's fixed coordinate `fixed`.
fn on_line<'a>(all: &'a [Switch], l: u32, along: &str, fixed: f64) -> Vec<&'a Switch> {
    all.iter()
        .filter(|s| s.0 == l && s.1 == along && (if along == "psi" { s.3 } else { s.2 } - fixed).abs() < 1e-12)
        .collect()
}

#[test]
fn the_described_3prs_has_the_builtin_axial_switches() {
    let builtin = switches(3, false);
    let custom = switches(3, true);
    // The premises: a switch at Ψ = 0 on each Ψ-line (51), and two of limb 2 along Θ
    // at Ψ = −0.08 between Θ = −0.05 and −0.04.
    let at_zero = builtin.iter().filter(|s| s.0 == 1 && s.1 == "psi" && s.2.abs() < 1e-9).count();
    assert_eq!(at_zero, 51);
    let pair: Vec<_> =
        on_line(&builtin, 2, "theta", -0.08).into_iter().filter(|s| s.3 > -0.05 && s.3 < -0.04).collect();
    assert_eq!(pair.len(), 2, "{pair:?}");
    let scale = builtin.iter().flat_map(|s| s.4.into_iter().flatten()).fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 1e-5);
    assert_eq!(builtin.len(), custom.len(), "{} built-in switches, {} described", builtin.len(), custom.len());
    let mut compared = 0;
    for (b, c) in builtin.iter().zip(&custom) {
        assert_eq!((b.0, &b.1), (c.0, &c.1));
        // The built-in search brackets a root to 1e-9 rad, the custom one to 1e-10 of
        // a step (each bracket up to twice its tolerance wide): within 2.5e-9 rad.
        assert!((b.2 - c.2).abs() <= 2.5e-9 && (b.3 - c.3).abs() <= 2.5e-9, "{b:?} against {c:?}");
        // A jump read at a sample on Ψ = 0, where limb 1's take-up and so the kind's
        // error are undefined, is null in the custom run (the built-in one reads the
        // error there with the sign the round-off of limb 1's load gives): a switch
        // along Ψ off Ψ = 0 (3 samples: Ψ = 0 is one end of its interval), and every
        // switch of the Θ-line at Ψ = 0. A switch at Ψ = 0 is read at Ψ = ±0.08.
        let on_plane = (b.1 == "psi" && b.2.abs() > 1e-6) || (b.1 == "theta" && b.2 == 0.0);
        match (b.4, c.4) {
            (_, None) => assert!(on_plane, "a null jump off the plane: {c:?}"),
            (Some(x), Some(y)) => {
                assert!(!on_plane, "a jump read on the plane: {c:?}");
                compared += 1;
                for i in 0..6 {
                    assert!((x[i] - y[i]).abs() <= 1e-12 * scale, "jump {i}: {b:?} against {c:?}");
                }
            }
            (None, Some(_)) => panic!("{b:?} against {c:?}"),
        }
    }
    assert!(compared > 50, "{compared} jumps compared");
}

/// With 4 samples along Ψ none lies at Ψ = 0: the switch of limb 1 is found between
/// two samples, at the place where 3 samples found it.
#[test]
fn the_switch_on_the_symmetry_plane_does_not_depend_on_a_sample_there() {
    let (three, four) = (switches(3, true), switches(4, true));
    let at_zero = |all: &[Switch]| -> Vec<f64> {
        all.iter().filter(|s| s.0 == 1 && s.1 == "psi" && s.2.abs() < 0.01).map(|s| s.2).collect()
    };
    let (a, b) = (at_zero(&three), at_zero(&four));
    assert_eq!(a.len(), 51);
    assert_eq!(b.len(), 51);
    for (x, y) in a.iter().zip(&b) {
        assert!(x.abs() < 1e-11 && y.abs() < 1e-11, "{x} {y}");
    }
}
