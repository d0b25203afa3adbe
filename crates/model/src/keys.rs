//! Unknown keys, found before typed parsing so that the message can give the
//! dotted path and suggest the key that was probably meant.

use crate::error::JobError;
use crate::mechanism::{MECHANISM_KINDS, MechanismKind};

/// The allowed keys of each table, by dotted path with list indices as `*`.
fn allowed(path: &str) -> Option<&'static [&'static str]> {
    Some(match path {
        "" => {
            &["name", "mechanism", "mass", "load", "clearance", "analysis", "grid", "trajectory", "sweep", "allocate"]
        }
        // Every kind's keys; a key of another kind than the job's is refused after.
        "mechanism" => &[
            "kind",
            "base_radius",
            "platform_radius",
            "leg_length",
            "gravity",
            "rail_angle_deg",
            "limb_angles_deg",
            "platform_angles_deg",
            "base_angles_deg",
            "cylinder_length",
            "piston_length",
            "min_length",
            "max_length",
            "base_points",
            "platform_points",
            "u_axes",
            "inputs",
            "home",
            "limb",
        ],
        "mechanism.limb.*" => &["repeat", "rotate_deg", "joints", "bodies"],
        "mechanism.limb.*.joints.*" => &["type", "name", "at", "axis", "axes", "actuated", "range"],
        "mechanism.limb.*.bodies.*" => &["mass", "com", "inertia"],
        "mass" => &["platform", "leg", "cylinder", "piston", "platform_inertia", "points"],
        "mass.points.*" => &["mass", "at"],
        "load" => &["force", "moment", "at"],
        "clearance" => &["s_radial", "r_radial", "r_axial", "r_angular", "u_radial", "u_angular"],
        "analysis" => {
            &["modes", "exact", "discontinuity_load_fraction", "indeterminate_load_fraction", "singular_cond"]
        }
        // Every kind's inputs; x, y, phi are refused after for the 3-limb kinds.
        "grid" => &["x", "y", "z", "phi", "psi", "theta"],
        "grid.x" | "grid.y" | "grid.z" | "grid.phi" | "grid.psi" | "grid.theta" | "trajectory.time" => {
            &["start", "stop", "n"]
        }
        "trajectory" => &["time", "x", "y", "z", "phi", "psi", "theta"],
        "trajectory.x" | "trajectory.y" | "trajectory.z" | "trajectory.phi" | "trajectory.psi" | "trajectory.theta" => {
            &["offset", "harmonics"]
        }
        "trajectory.x.harmonics.*"
        | "trajectory.y.harmonics.*"
        | "trajectory.z.harmonics.*"
        | "trajectory.phi.harmonics.*"
        | "trajectory.psi.harmonics.*"
        | "trajectory.theta.harmonics.*" => &["amplitude", "period", "phase"],
        "sweep.*" => &["param", "values"],
        "allocate" => &["kinds", "weights", "min", "max"],
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

/// Checks every key of the parsed file against the tables it may appear in, and
/// the keys of `[mechanism]`, `[mass]`, `[clearance]`, `[grid]` and `[trajectory]`
/// against the mechanism kind.
pub fn check_keys(file: &str, table: &toml::Table) -> Result<(), JobError> {
    let kind = kind_of(file, table)?;
    walk(file, table, "", "", kind)?;
    // A custom mechanism's grid and trajectory take its inputs; its clearance keys are
    // its joint groups, checked against the description.
    let custom_inputs: Vec<&str> = match table.get("mechanism").and_then(|m| m.get("inputs")) {
        Some(toml::Value::Array(a)) => a.iter().filter_map(|v| v.as_str()).collect(),
        _ => Vec::new(),
    };
    let mut foreign = Vec::new();
    for section in SECTIONS {
        let custom_keys: Vec<&str>;
        let keys = match (kind, section) {
            (MechanismKind::Custom, "clearance") => continue,
            (MechanismKind::Custom, "grid") => &custom_inputs[..],
            (MechanismKind::Custom, "trajectory") => {
                custom_keys = std::iter::once("time").chain(custom_inputs.iter().copied()).collect();
                &custom_keys[..]
            }
            _ => kind.section_keys(section),
        };
        if let Some(toml::Value::Table(t)) = table.get(section) {
            foreign.extend(t.keys().filter(|k| !keys.contains(&k.as_str())).map(|k| format!("{section}.{k}")));
        }
    }
    match foreign.first() {
        None => Ok(()),
        Some(first)
            if kind == MechanismKind::Custom && (first.starts_with("grid.") || first.starts_with("trajectory.")) =>
        {
            Err(JobError::new(
                file,
                first.clone(),
                format!(
                    "is not an input of this mechanism (its inputs are {}; the other platform coordinates are parasitic, solved at every pose)",
                    custom_inputs.join(", ")
                ),
            ))
        }
        Some(first) => {
            let names: Vec<&str> = foreign.iter().map(String::as_str).collect();
            Err(JobError::new(file, first.clone(), foreign_reason(kind, &names)))
        }
    }
}

/// The sections whose keys depend on the mechanism kind.
const SECTIONS: [&str; 5] = ["mechanism", "mass", "clearance", "grid", "trajectory"];

/// The mechanism kind named by `mechanism.kind` (the default when absent).
pub(crate) fn kind_of(file: &str, table: &toml::Table) -> Result<MechanismKind, JobError> {
    let Some(value) = table.get("mechanism").and_then(|m| m.get("kind")) else { return Ok(MechanismKind::default()) };
    let names = MECHANISM_KINDS.map(|k| format!("\"{}\"", k.name())).join(", ");
    match value.as_str() {
        Some(name) => MechanismKind::from_name(name).ok_or_else(|| {
            JobError::new(file, "mechanism.kind", format!("unknown mechanism kind {name:?}; expected one of {names}"))
        }),
        None => Err(JobError::new(file, "mechanism.kind", format!("must be a string, one of {names}"))),
    }
}

/// Why keys of another kind are refused, naming every one of them.
pub(crate) fn foreign_reason(kind: MechanismKind, keys: &[&str]) -> String {
    let owners = |key: &str| {
        let (section, name) = key.split_once('.').unwrap_or(("", key));
        let owners: Vec<&str> = MECHANISM_KINDS
            .into_iter()
            .filter(|k| k.section_keys(section).contains(&name))
            .map(MechanismKind::name)
            .collect();
        if owners.is_empty() { format!("`{key}`") } else { format!("`{key}` (a key of {})", owners.join(", ")) }
    };
    let listed: Vec<String> = keys.iter().map(|k| owners(k)).collect();
    let (noun, verb) = if keys.len() == 1 { ("key", "does") } else { ("keys", "do") };
    let inputs = if keys.iter().any(|k| k.starts_with("grid.") || k.starts_with("trajectory.")) {
        format!(" (its inputs are {})", kind.inputs().join(", "))
    } else {
        String::new()
    };
    format!(
        "the {noun} {} {verb} not belong to a {} mechanism{inputs}; remove {} or set `mechanism.kind`",
        listed.join(", "),
        kind.name(),
        if keys.len() == 1 { "it" } else { "them" }
    )
}

fn walk(file: &str, table: &toml::Table, path: &str, pattern: &str, kind: MechanismKind) -> Result<(), JobError> {
    if kind == MechanismKind::Custom && pattern == "clearance" {
        return Ok(());
    }
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
            toml::Value::Table(t) => walk(file, t, &here, &sub, kind)?,
            toml::Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    if let toml::Value::Table(t) = item {
                        walk(file, t, &format!("{here}.{i}"), &format!("{sub}.*"), kind)?;
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
    fn keys_of_another_kind_are_named() {
        let t: toml::Table =
            toml::from_str("[mechanism]\nkind = \"3-RPS\"\nleg_length = 1.0\nrail_angle_deg = 3.0\n").unwrap();
        let e = check_keys("j.toml", &t).unwrap_err();
        assert_eq!(e.key, "mechanism.leg_length");
        assert!(e.reason.contains("`mechanism.rail_angle_deg` (a key of 3-PRS)"), "{}", e.reason);
        assert!(e.reason.contains("3-RPS"), "{}", e.reason);
        let t: toml::Table = toml::from_str("[mechanism]\nkind = \"4-PRS\"\n").unwrap();
        let e = check_keys("j.toml", &t).unwrap_err();
        assert_eq!(e.key, "mechanism.kind");
        assert!(e.reason.contains("\"3-RPS\""), "{}", e.reason);
        let t: toml::Table = toml::from_str("[mass]\ncylinder = 2.0\n").unwrap();
        assert_eq!(check_keys("j.toml", &t).unwrap_err().key, "mass.cylinder");
    }

    #[test]
    fn unknown_keys_are_named_by_dotted_path() {
        let t: toml::Table = toml::from_str("[mass]\npoints = [{ mass = 1.0, at = [0,0,0], att = 1 }]\n").unwrap();
        let e = check_keys("j.toml", &t).unwrap_err();
        assert_eq!(e.key, "mass.points.0.att");
        assert!(e.reason.contains("did you mean `at`"), "{}", e.reason);
    }
}
