//! `[[sweep]]`: the cartesian product of swept parameters is the list of variants.

use crate::error::JobError;
use crate::job::JobSpec;

/// One concrete job of a sweep: its index `K` (the `variant=K` partition), the
/// swept values that made it, and the job with those values set.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    pub index: u64,
    pub params: Vec<(String, f64)>,
    pub job: JobSpec,
}

/// The most variants a job's sweeps may make. Each is a job expanded in memory
/// before anything runs and a `variant=K` partition of the output; a study beyond
/// this is several jobs.
pub const MAX_VARIANTS: u64 = 10_000;

impl JobSpec {
    /// Number of variants: the product of the sweeps' lengths (1 without sweeps),
    /// `u64::MAX` if that overflows (validation refuses more than [`MAX_VARIANTS`]).
    pub fn variant_count(&self) -> u64 {
        self.sweep.iter().fold(1u64, |n, s| n.saturating_mul(s.values.len() as u64))
    }

    /// Expands the sweeps. Variant `K` enumerates the product row-major, the first
    /// `[[sweep]]` slowest. Each variant is validated as a job of its own.
    pub fn variants(&self, file: &str) -> Result<Vec<Variant>, JobError> {
        let count = self.variant_count();
        let mut base = self.clone();
        base.sweep.clear();
        let table = toml::Table::try_from(&base).expect("a job always serialises");
        // Check every path once, against the job after defaults.
        let mut table = table;
        for (i, s) in self.sweep.iter().enumerate() {
            // A key whose default follows another (platform angles, stroke limits)
            // is written out when a sweep names it.
            if let Some(("mechanism", rest)) = s.param.split_once('.') {
                let key = rest.split('.').next().unwrap_or(rest);
                if let (Some(toml::Value::Table(m)), Some(v)) =
                    (table.get_mut("mechanism"), base.mechanism.implied(key))
                {
                    m.entry(key).or_insert(v);
                }
            }
            let mut probe = table.clone();
            set_path(&mut probe, &s.param, 0.0).map_err(|why| JobError::new(file, format!("sweep.{i}.param"), why))?;
        }
        let mut out = Vec::with_capacity(count as usize);
        for index in 0..count {
            let mut rest = index;
            let mut params = vec![(String::new(), 0.0); self.sweep.len()];
            for (i, s) in self.sweep.iter().enumerate().rev() {
                let n = s.values.len() as u64;
                params[i] = (s.param.clone(), s.values[(rest % n) as usize]);
                rest /= n;
            }
            let mut t = table.clone();
            for (i, (path, v)) in params.iter().enumerate() {
                set_path(&mut t, path, *v).map_err(|why| JobError::new(file, format!("sweep.{i}.param"), why))?;
            }
            let mut job: JobSpec = t.try_into().map_err(|e: toml::de::Error| {
                JobError::new(file, "sweep", format!("variant {index}: {}", e.message().trim()))
            })?;
            job.clearance.settle(job.mechanism.kind);
            job.validate(file).map_err(|mut e| {
                let what = params.iter().map(|(p, v)| format!("{p} = {v}")).collect::<Vec<_>>().join(", ");
                e.reason = format!("{} (in the sweep variant {index}: {what})", e.reason);
                e
            })?;
            out.push(Variant { index, params, job });
        }
        Ok(out)
    }
}

/// Sets the number at a dotted path (`mass.points.0.mass`); the path must exist
/// and hold a number.
fn set_path(table: &mut toml::Table, path: &str, value: f64) -> Result<(), String> {
    let parts: Vec<&str> = path.split('.').collect();
    if path.is_empty() || parts.iter().any(|p| p.is_empty()) {
        return Err(format!("\"{path}\" is not a dotted path such as \"mass.platform\""));
    }
    if parts[0] == "sweep" || parts[0] == "name" {
        return Err(format!("\"{path}\" cannot be swept"));
    }
    let mut node: &mut toml::Value =
        table.get_mut(parts[0]).ok_or_else(|| format!("\"{path}\": the job has no key \"{}\"", parts[0]))?;
    for (depth, part) in parts.iter().enumerate().skip(1) {
        let here = parts[..depth].join(".");
        node = match node {
            toml::Value::Table(t) => {
                t.get_mut(*part).ok_or_else(|| format!("\"{path}\": \"{here}\" has no key \"{part}\""))?
            }
            toml::Value::Array(a) => {
                let i: usize = part
                    .parse()
                    .map_err(|_| format!("\"{path}\": \"{here}\" is a list; index it with a number, not \"{part}\""))?;
                let len = a.len();
                a.get_mut(i).ok_or_else(|| format!("\"{path}\": \"{here}\" has {len} entries, no index {i}"))?
            }
            _ => return Err(format!("\"{path}\": \"{here}\" is a value, not a table")),
        };
    }
    match node {
        toml::Value::Float(_) | toml::Value::Integer(_) => {
            *node = toml::Value::Float(value);
            Ok(())
        }
        _ => Err(format!("\"{path}\" is not a number (a table, list, string or flag cannot be swept)")),
    }
}

#[cfg(test)]
mod tests {
    use crate::JobSpec;

    const GRID: &str = "[grid]\nz = 2.0\npsi = 0.0\ntheta = 0.0\n";

    fn sweeps(count: usize, values: &str) -> String {
        let one = format!("[[sweep]]\nparam = \"mass.leg\"\nvalues = [{values}]\n");
        format!("{GRID}{}", one.repeat(count))
    }

    #[test]
    fn too_many_variants_are_refused_before_expanding() {
        // 10^7 variants: was minutes and gigabytes; 2^64: was a multiply overflow.
        for text in [sweeps(7, "1,2,3,4,5,6,7,8,9,10"), sweeps(64, "1, 2")] {
            let e = JobSpec::from_toml_str(&text, "j.toml").unwrap_err();
            assert_eq!(e.key, "sweep");
            assert!(e.reason.contains("split the study"), "{}", e.reason);
        }
        assert_eq!(
            JobSpec::from_toml_str(&sweeps(4, "1,2,3,4,5,6,7,8,9,10"), "j.toml").unwrap().variant_count(),
            10_000
        );
    }
}
