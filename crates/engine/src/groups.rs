//! Variants that differ only in their clearance magnitudes share one solve.
//!
//! For a fixed mechanism, masses, loads and pose, the reactions, the take-up
//! directions, which loads are too small to decide a take-up and where the take-ups
//! switch do not depend on the clearance magnitudes (docs/model.md §§4, 5, 8); each
//! kind's linear error, its envelope, its joints' contributions and its switch jumps
//! are proportional to its magnitude (§6). So the planner puts the variants of a
//! sweep that differ only in `[clearance]` into one [`Group`], solves the group once
//! with one non-zero magnitude per kind, and derives each member by scaling
//! ([`Group::scales`], `PoseResult::scaled`): the same numbers as solving it alone, to
//! round-off. The exact error (§7) is not linear in the magnitudes: a job with
//! `analysis.exact` solves every variant alone. A custom mechanism's members (its
//! magnitudes are per joint group, per limb) share each pose's kinematics and
//! reactions, and each takes up its own clearances: the same bits as alone, exact
//! error included; `clearance`/`scales` are not used for them.

use std::collections::HashMap;

use clearance_discontinuity::Discontinuity;
use clearance_model::{ClearanceSpec, JobSpec, Variant};

/// Variants solved together, with what each member is of the group's solve.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Group {
    /// Variant indices, ascending; the first names the group.
    pub members: Vec<u64>,
    /// The magnitudes the group is solved with ([`magnitudes`]): per kind, the
    /// first member's non-zero one, or zero when no member has that kind.
    pub clearance: [f64; 4],
    /// Per member: its magnitude over the group's, per kind (zero where the member
    /// has none of that kind; exactly one where the member set the group's).
    pub scales: Vec<[f64; 4]>,
}

impl Group {
    /// The group's first variant, whose job (but for its clearances) the group's is.
    pub fn first(&self) -> u64 {
        self.members[0]
    }

    /// Whether the group is a single variant solved as itself.
    pub fn alone(&self) -> bool {
        self.members.len() == 1
    }

    /// The member index of `variant`, one of the group's.
    #[track_caller]
    pub fn member(&self, variant: u64) -> usize {
        self.members.binary_search(&variant).expect("a member of the group")
    }

    /// The job the group is solved as: its first variant's, with the group's
    /// magnitudes ([`magnitudes`] in reverse).
    pub fn job(&self, variants: &[Variant]) -> JobSpec {
        let mut job = variants[self.first() as usize].job.clone();
        let c = &mut job.clearance;
        let [a, b, d, e] = self.clearance;
        if c.ups {
            [c.s_radial, c.u_radial, c.u_angular] = [a, b, d];
        } else {
            [c.s_radial, c.r_radial, c.r_axial, c.r_angular] = [a, b, d, e];
        }
        job
    }

    /// Member `m`'s switches from the group's: the kinds it has, jumps scaled.
    pub fn switches(&self, m: usize, found: &[Discontinuity]) -> Vec<Discontinuity> {
        let scale = &self.scales[m];
        found
            .iter()
            .filter(|d| scale[d.kind.index()] != 0.0)
            .map(|d| {
                let s = scale[d.kind.index()];
                Discontinuity { jump: d.jump.map(|v| v * s), ..d.clone() }
            })
            .collect()
    }
}

/// A variant's clearance magnitudes as a group keeps them: the order of `KINDS` for
/// the 3-limb kinds, `s_radial, u_radial, u_angular` (then 0) for the 6-UPS.
pub(crate) fn magnitudes(c: &ClearanceSpec) -> [f64; 4] {
    if c.ups {
        let [s, u, a] = c.ups_array();
        [s, u, a, 0.0]
    } else {
        c.as_array()
    }
}

/// Each variant's group and member index, by variant index.
pub(crate) fn membership(groups: &[Group], variants: usize) -> Vec<(usize, usize)> {
    let mut out = vec![(0, 0); variants];
    for (g, group) in groups.iter().enumerate() {
        for (m, &v) in group.members.iter().enumerate() {
            out[v as usize] = (g, m);
        }
    }
    out
}

/// The groups of `variants` (in the order of their first members): variants whose
/// jobs are equal but for their clearance magnitudes; each variant alone when the
/// job asks for exact errors.
pub(crate) fn groups(variants: &[Variant]) -> Vec<Group> {
    let mut out: Vec<Group> = Vec::new();
    let mut by_key: HashMap<String, usize> = HashMap::new();
    // Per group, its members' own magnitudes.
    let mut own_of: Vec<Vec<[f64; 4]>> = Vec::new();
    for v in variants {
        let own = magnitudes(&v.job.clearance);
        // A custom mechanism's members share the kinematics and the reactions and each
        // takes its own clearances up (its magnitudes are per joint group, and its
        // exact error too is its own): they need the same clearance keys, so that they
        // have the same columns.
        let custom = v.job.mechanism.kind == clearance_model::MechanismKind::Custom;
        let g = if !v.job.analysis.exact || custom {
            let mut key = v.job.clone();
            key.clearance = ClearanceSpec { ups: key.clearance.ups, ..ClearanceSpec::default() };
            let mut key = key.to_toml_string();
            if custom {
                let names: Vec<&str> = v.job.clearance.given.iter().map(|(k, _)| k.as_str()).collect();
                key.push_str(&format!("\n# clearance keys {names:?}"));
            }
            let next = out.len();
            *by_key.entry(key).or_insert(next)
        } else {
            out.len()
        };
        if g == out.len() {
            out.push(Group { members: Vec::new(), clearance: [0.0; 4], scales: Vec::new() });
            own_of.push(Vec::new());
        }
        let group = &mut out[g];
        for (c, own) in group.clearance.iter_mut().zip(own) {
            if *c == 0.0 {
                *c = own;
            }
        }
        group.members.push(v.index);
        own_of[g].push(own);
    }
    for (group, own_of) in out.iter_mut().zip(own_of) {
        group.scales = own_of
            .iter()
            .map(|own| std::array::from_fn(|k| if own[k] == 0.0 { 0.0 } else { own[k] / group.clearance[k] }))
            .collect();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn variants(sweeps: &str, extra: &str) -> Vec<Variant> {
        let text = format!("[clearance]\nr_radial = 1e-4\n{extra}[grid]\nz = 2.05\npsi = 0.0\ntheta = 0.0\n{sweeps}");
        JobSpec::from_toml_str(&text, "j.toml").unwrap().variants("j.toml").unwrap()
    }

    const MASS_X_CLEARANCE: &str = "[[sweep]]\nparam = \"mass.platform\"\nvalues = [5.0, 10.0]\n\
        [[sweep]]\nparam = \"clearance.s_radial\"\nvalues = [0.0, 2e-4, 1e-4]\n";

    #[test]
    fn variants_that_differ_only_in_clearances_share_a_group() {
        let vs = variants(MASS_X_CLEARANCE, "");
        let g = groups(&vs);
        assert_eq!(g.len(), 2);
        assert_eq!(g[0].members, [0, 1, 2]);
        assert_eq!(g[1].members, [3, 4, 5]);
        // s_radial is zero in the first member: the group takes the second's.
        assert_eq!(g[0].clearance, [2e-4, 1e-4, 0.0, 0.0]);
        assert_eq!(g[0].scales, [[0.0, 1.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0], [0.5, 1.0, 0.0, 0.0]]);
        assert_eq!(membership(&g, vs.len()), [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2)]);
        assert_eq!(g[1].member(5), 2);
        // The group's job is its first member's with the group's magnitudes.
        let job = g[0].job(&vs);
        assert_eq!(magnitudes(&job.clearance), g[0].clearance);
        assert_eq!(job.mass, vs[0].job.mass);
    }

    #[test]
    fn a_six_ups_group_keeps_its_own_kinds() {
        let text = "[mechanism]\nkind = \"6-UPS\"\n[clearance]\nu_angular = 1e-3\n\
            [grid]\nx = 0.0\ny = 0.0\nz = 0.8\nphi = 0.0\npsi = 0.0\ntheta = 0.0\n\
            [[sweep]]\nparam = \"clearance.u_radial\"\nvalues = [0.0, 3e-4]\n\
            [[sweep]]\nparam = \"clearance.s_radial\"\nvalues = [1e-4, 2e-4]\n";
        let vs = JobSpec::from_toml_str(text, "j.toml").unwrap().variants("j.toml").unwrap();
        let g = groups(&vs);
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].clearance, [1e-4, 3e-4, 1e-3, 0.0]);
        assert_eq!(g[0].scales[3], [2.0, 1.0, 1.0, 0.0]);
        let c = g[0].job(&vs).clearance;
        assert_eq!([c.s_radial, c.u_radial, c.u_angular], [1e-4, 3e-4, 1e-3]);
    }

    #[test]
    fn exact_errors_keep_every_variant_alone() {
        let g = groups(&variants(MASS_X_CLEARANCE, "[analysis]\nexact = true\n"));
        assert_eq!(g.len(), 6);
        assert!(g.iter().enumerate().all(|(i, g)| g.members == [i as u64] && g.alone()));
    }

    #[test]
    fn a_sweep_of_anything_else_groups_nothing() {
        let g = groups(&variants("[[sweep]]\nparam = \"mass.leg\"\nvalues = [1.0, 2.0, 3.0]\n", ""));
        assert_eq!(g.len(), 3);
        assert!(g.iter().all(|g| g.alone() && g.scales == [[0.0, 1.0, 0.0, 0.0]]));
    }
}
