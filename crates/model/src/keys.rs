//! Unknown keys, found before typed parsing so that the message can give the
//! dotted path and suggest the key that was probably meant.

use crate::error::JobError;

/// The allowed keys of each table, by dotted path with list indices as `*`.
fn allowed(path: &str) -> Option<&'static [&'static str]> {
    Some(match path {
        "" => &["name", "mechanism", "mass", "load", "clearance", "analysis", "grid", "trajectory", "sweep"],
        "mechanism" => &["base_radius", "platform_radius", "leg_length", "gravity"],
        "mass" => &["platform", "leg", "platform_inertia", "points"],
        "mass.points.*" => &["mass", "at"],
        "load" => &["force", "moment", "at"],
        "clearance" => &["s_radial", "r_radial", "r_axial", "r_angular"],
        "analysis" => {
            &["modes", "exact", "discontinuity_load_fraction", "indeterminate_load_fraction", "singular_cond"]
        }
        "grid" => &["z", "psi", "theta"],
        "grid.z" | "grid.psi" | "grid.theta" | "trajectory.time" => &["start", "stop", "n"],
        "trajectory" => &["time", "z", "psi", "theta"],
        "trajectory.z" | "trajectory.psi" | "trajectory.theta" => &["offset", "harmonics"],
        "trajectory.z.harmonics.*" | "trajectory.psi.harmonics.*" | "trajectory.theta.harmonics.*" => {
            &["amplitude", "period", "phase"]
        }
        "sweep.*" => &["param", "values"],
        _ => return None,
    })
}

/// Edit distance, for suggestions.
fn distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The closest allowed key, if it is close enough to be a typo.
pub fn suggest<'a>(key: &str, options: &[&'a str]) -> Option<&'a str> {
    options.iter().map(|o| (distance(key, o), *o)).filter(|(d, o)| *d <= 2.max(o.len() / 3)).min().map(|(_, o)| o)
}

/// Checks every key of the parsed file against the tables it may appear in.
pub fn check_keys(file: &str, table: &toml::Table) -> Result<(), JobError> {
    walk(file, table, "", "")
}

fn walk(file: &str, table: &toml::Table, path: &str, pattern: &str) -> Result<(), JobError> {
    let Some(options) = allowed(pattern) else { return Ok(()) };
    for (key, value) in table {
        let here = if path.is_empty() { key.clone() } else { format!("{path}.{key}") };
        if !options.contains(&key.as_str()) {
            let hint = match suggest(key, options) {
                Some(s) => format!("; did you mean `{s}`?"),
                None => format!(
                    "; expected one of {}",
                    options.iter().map(|o| format!("`{o}`")).collect::<Vec<_>>().join(", ")
                ),
            };
            return Err(JobError::new(file, here, format!("unknown key{hint}")));
        }
        let sub = if pattern.is_empty() { key.clone() } else { format!("{pattern}.{key}") };
        match value {
            toml::Value::Table(t) => walk(file, t, &here, &sub)?,
            toml::Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    if let toml::Value::Table(t) = item {
                        walk(file, t, &format!("{here}.{i}"), &format!("{sub}.*"))?;
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_close_keys_only() {
        assert_eq!(suggest("platfrom", &["platform", "leg"]), Some("platform"));
        assert_eq!(suggest("mas", &["mass", "load"]), Some("mass"));
        assert_eq!(suggest("velocity", &["mass", "load"]), None);
    }

    #[test]
    fn unknown_keys_are_named_by_dotted_path() {
        let t: toml::Table = toml::from_str("[mass]\npoints = [{ mass = 1.0, at = [0,0,0], att = 1 }]\n").unwrap();
        let e = check_keys("j.toml", &t).unwrap_err();
        assert_eq!(e.key, "mass.points.0.att");
        assert!(e.reason.contains("did you mean `at`"), "{}", e.reason);
    }
}
