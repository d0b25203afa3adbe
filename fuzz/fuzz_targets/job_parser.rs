//! Fuzzes the job parser, `JobSpec::from_toml_str`, with arbitrary text.
//!
//! The property (README "Bad input"): whatever the text, the parser never panics,
//! hangs or exhausts memory. A job it refuses gets a message of one or two lines
//! naming the file. A job it accepts has a plan `clearance check`/`run` can compute
//! without panicking: a sample count, its sweep variants (each a valid job with the
//! same samples), finite inputs at the ends of every range, and a provenance
//! `job.toml` that parses back to the same job.
//!
//! Run it with `bash scripts/fuzz.sh [seconds]`.

#![no_main]

use clearance_model::{InputSpec, JobSpec, RangeSpec, SamplesSpec};
use libfuzzer_sys::fuzz_target;

const FILE: &str = "fuzz.toml";

fuzz_target!(|data: &[u8]| {
    // `JobSpec::from_path` reads with `read_to_string`: text that is not UTF-8 is
    // refused there and never reaches the parser.
    let Ok(text) = std::str::from_utf8(data) else { return };
    match JobSpec::from_toml_str(text, FILE) {
        Ok(job) => check_plan(&job),
        Err(e) => check_message(&e.to_string()),
    }
});

fn check_message(message: &str) {
    assert!(message.starts_with("fuzz.toml: "), "the message does not name the file: {message:?}");
    assert!(message.lines().count() <= 2, "the message is longer than two lines: {message:?}");
}

fn check_plan(job: &JobSpec) {
    let n = job.sample_count();
    assert!(n >= 1, "a valid job has no samples");
    let variants = job.variants(FILE).unwrap_or_else(|e| panic!("a parsed job does not expand: {e}"));
    assert_eq!(variants.len() as u64, job.variant_count());
    for (k, v) in variants.iter().enumerate() {
        assert_eq!(v.index, k as u64);
        assert_eq!(v.params.len(), job.sweep.len());
        if let Err(e) = v.job.validate(FILE) {
            panic!("variant {k} of a parsed job is invalid: {e}");
        }
        assert_eq!(v.job.sample_count(), n, "a sweep changed the samples of variant {k}");
        check_inputs(&v.job);
    }
    // `clearance run` writes this as DIR/job.toml and compares it on --resume.
    let toml = job.to_toml_string();
    match JobSpec::from_toml_str(&toml, FILE) {
        Ok(back) => assert_eq!(&back, job, "job.toml does not parse back to the same job:\n{toml}"),
        Err(e) => panic!("the job.toml of a valid job is refused: {e}\n{toml}"),
    }
}

/// The inputs at the ends and the middle of every range are finite numbers: they
/// are output columns, which never hold NaN.
fn check_inputs(job: &JobSpec) {
    let ends = |r: &RangeSpec| {
        let n = r.len();
        [0, n / 2, n - 1].map(|i| r.value(i))
    };
    match job.samples() {
        SamplesSpec::Grid(g) => {
            for (name, r) in [("z", &g.z), ("psi", &g.psi), ("theta", &g.theta)] {
                for v in ends(r) {
                    assert!(v.is_finite(), "grid.{name} has the value {v}");
                }
            }
        }
        SamplesSpec::Trajectory(t) => {
            for time in ends(&t.time) {
                assert!(time.is_finite(), "trajectory.time has the value {time}");
                for (name, input) in [("z", &t.z), ("psi", &t.psi), ("theta", &t.theta)] {
                    let value = input.eval(time);
                    let kind = if matches!(input, InputSpec::Constant(_)) { "constant" } else { "harmonics" };
                    assert!(
                        value.iter().all(|x| x.is_finite()),
                        "trajectory.{name} ({kind}) at t = {time}: value and rates {value:?}"
                    );
                }
            }
        }
    }
}
