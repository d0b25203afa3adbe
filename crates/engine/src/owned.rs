//! Sharded runs without a serial tail: right after computing its work, each shard
//! searches the grid lines (or the trajectory) it owns for switches and writes them to
//! [`Layout::shard_switches`]; the step that finishes the run merges those files in
//! path order ([`read_owned`]), which gives the switches of one run, in its order.
//!
//! Who owns a path of a (group, mode): a path whose samples lie in one chunk belongs
//! to the shard that computed that chunk for the group's first member (the traces it
//! needs are its own); a path across chunks belongs to the shards in turn, counted
//! over the run, and its owner solves the samples it did not compute
//! ([`search_untraced`]). Both are functions of the job, the chunk size and the shard
//! count, so every shard agrees on them without talking to the others.

use std::collections::HashMap;

use clearance_discontinuity::{Along, Discontinuity, paths, search_path, search_untraced};
use clearance_grid::SampleSource;
use clearance_model::{ClearanceKind, JobSpec, KINDS, Mode, Variant};
use clearance_parquet::{WriteOptions, write_bytes};
use clearance_solver::{Model, Workspace};
use rayon::prelude::*;

use crate::error::EngineError;
use crate::groups::Group;
use crate::layout::Layout;
use crate::run::{RunOptions, search_options, unit_traces, works};

type Result<T, E = EngineError> = std::result::Result<T, E>;
/// The switches of each (group, mode).
pub(crate) type Found = HashMap<(usize, Mode), Vec<Discontinuity>>;

/// First bytes of a switches file: its format, version 1.
const MAGIC: &[u8; 8] = b"CLSWv1\n\0";

/// One switch of a shard: its (group, mode), the index of its path among
/// [`paths`], and the switch.
struct Owned {
    group: usize,
    mode: Mode,
    path: u64,
    switch: Discontinuity,
}

/// Searches the paths shard `me` of `n` owns and writes their switches.
#[allow(clippy::too_many_arguments)]
pub(crate) fn search_owned(
    layout: &Layout,
    job: &JobSpec,
    variants: &[Variant],
    groups: &[Group],
    models: &[(Model, SampleSource)],
    opts: &RunOptions,
    (me, n): (u64, u64),
) -> Result<()> {
    // The shard of each (group, mode, chunk), and the unit whose traces its paths are
    // searched from: the work holding the group's first member.
    let mut owner = HashMap::new();
    for w in works(job, groups, opts.chunk_size) {
        for u in w.units.iter().filter(|u| u.variant == groups[w.group].first()) {
            owner.insert((w.group, u.mode, u.chunk), (w.number % n, u.clone()));
        }
    }
    let chunk_of = |i: u64| i / opts.chunk_size;
    let mut across_count = 0u64;
    let mut out = Vec::new();
    for (g, (group, (model, source))) in groups.iter().zip(models).enumerate() {
        let search = search_options(&variants[group.first() as usize]);
        let all = paths(source);
        for &mode in &job.analysis.modes {
            // This shard's paths, by chunk where they lie in one, and those across chunks.
            let mut within: std::collections::BTreeMap<u64, Vec<usize>> = Default::default();
            let mut across = Vec::new();
            for (k, p) in all.iter().enumerate() {
                let (a, b) = (chunk_of(p.sample_index(0)), chunk_of(p.sample_index(p.len() - 1)));
                if a == b {
                    if owner[&(g, mode, a)].0 == me {
                        within.entry(a).or_default().push(k);
                    }
                } else {
                    if across_count % n == me {
                        across.push(k);
                    }
                    across_count += 1;
                }
            }
            let found = |k: usize, switches: Vec<Discontinuity>| {
                switches.into_iter().map(move |switch| Owned { group: g, mode, path: k as u64, switch })
            };
            for (chunk, ks) in within {
                let unit = &owner[&(g, mode, chunk)].1;
                let traces = unit_traces(layout, model, source, unit, &search, opts)?;
                let at = |i: u64| traces[(i - unit.range.start) as usize];
                out.par_extend(
                    ks.par_iter()
                        .map_init(Workspace::new, |ws, &k| {
                            found(k, search_path(model, source, &all[k], mode, &search, at, ws))
                        })
                        .flatten_iter(),
                );
            }
            out.par_extend(
                across
                    .par_iter()
                    .map_init(Workspace::new, |ws, &k| {
                        found(k, search_untraced(model, source, &all[k], mode, &search, ws))
                    })
                    .flatten_iter(),
            );
        }
    }
    // On the disk before the shard's marker says it is done. A shard that owns no
    // unit has written nothing before, and may run before the others have made the
    // directory.
    let opts = WriteOptions { durable: true, direct_io: opts.direct_io, ..WriteOptions::default() };
    let path = layout.shard_switches(me, n);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(EngineError::io("create", dir))?;
    }
    write_bytes(&path, &encode(&out, &job.analysis.modes), &opts)?;
    Ok(())
}

/// The switches of every (group, mode) from the files of all `n` shards, each list in
/// path order and, within a path, in the order its search found them: the order of
/// one run. `None` when a shard's file is missing or unreadable (a shard run by an
/// engine from before these files): the run is then searched again from its traces.
pub(crate) fn read_owned(layout: &Layout, modes: &[Mode], n: u64) -> Option<Found> {
    let mut all = Vec::new();
    for i in 0..n {
        all.extend(decode(&std::fs::read(layout.shard_switches(i, n)).ok()?, modes)?);
    }
    // Each path is one shard's, its switches consecutive in that shard's file: a
    // stable sort by path restores one run's order.
    all.sort_by_key(|o| o.path);
    let mut found = Found::new();
    for o in all {
        found.entry((o.group, o.mode)).or_default().push(o.switch);
    }
    Some(found)
}

const ALONG: [Along; 4] = [Along::T, Along::Z, Along::Psi, Along::Theta];

fn encode(owned: &[Owned], modes: &[Mode]) -> Vec<u8> {
    let mut b = MAGIC.to_vec();
    b.extend((owned.len() as u64).to_le_bytes());
    for Owned { group, mode, path, switch: d } in owned {
        b.extend((*group as u64).to_le_bytes());
        b.push(modes.iter().position(|m| m == mode).expect("a mode of the job") as u8);
        b.extend(path.to_le_bytes());
        b.push(d.limb as u8);
        b.push(d.kind.index() as u8);
        b.push(ALONG.iter().position(|a| *a == d.along).expect("every axis listed") as u8);
        b.push(u8::from(d.t.is_some()));
        for v in [d.param, d.t.unwrap_or(0.0), d.z, d.psi, d.theta, d.margin].into_iter().chain(d.jump) {
            b.extend(v.to_le_bytes());
        }
    }
    b
}

/// The bytes of one record: group, mode, path, limb, kind, along, has-t, 12 numbers.
const RECORD: usize = 8 + 1 + 8 + 4 + 12 * 8;

fn decode(bytes: &[u8], modes: &[Mode]) -> Option<Vec<Owned>> {
    let rest = bytes.strip_prefix(MAGIC.as_slice())?;
    let (count, mut rest) = rest.split_first_chunk::<8>()?;
    let count = u64::from_le_bytes(*count) as usize;
    if rest.len() != count.checked_mul(RECORD)? {
        return None;
    }
    let mut out = Vec::with_capacity(count);
    let u64_at = |b: &[u8], at: usize| u64::from_le_bytes(b[at..at + 8].try_into().expect("eight bytes"));
    for _ in 0..count {
        let (r, next) = rest.split_at(RECORD);
        rest = next;
        let number = |i: usize| f64::from_bits(u64_at(r, 21 + 8 * i));
        let kind: ClearanceKind = *KINDS.get(r[18] as usize)?;
        out.push(Owned {
            group: u64_at(r, 0) as usize,
            mode: *modes.get(r[8] as usize)?,
            path: u64_at(r, 9),
            switch: Discontinuity {
                mode: *modes.get(r[8] as usize)?,
                limb: r[17] as usize,
                kind,
                along: *ALONG.get(r[19] as usize)?,
                param: number(0),
                t: (r[20] == 1).then(|| number(1)),
                z: number(2),
                psi: number(3),
                theta: number(4),
                margin: number(5),
                jump: std::array::from_fn(|i| number(6 + i)),
            },
        });
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every field of a switch comes back bit for bit, NaN margins and missing
    /// times included; a truncated file is refused.
    #[test]
    fn switches_files_round_trip() {
        let modes = [Mode::Kinetostatic, Mode::Dynamic];
        let switch = |limb, t, margin| Discontinuity {
            mode: Mode::Dynamic,
            limb,
            kind: ClearanceKind::RRadial,
            along: Along::Psi,
            param: 0.1 + 1e-17,
            t,
            z: 2.05,
            psi: -0.3,
            theta: 1e-300,
            margin,
            jump: [1.0, -2.0, 3e-9, f64::MIN_POSITIVE, -0.0, 7.0],
        };
        let owned = vec![
            Owned { group: 3, mode: Mode::Dynamic, path: 1 << 40, switch: switch(2, Some(1.25), f64::NAN) },
            Owned { group: 0, mode: Mode::Dynamic, path: 7, switch: switch(3, None, 0.5) },
        ];
        let bytes = encode(&owned, &modes);
        let back = decode(&bytes, &modes).unwrap();
        assert_eq!(back.len(), 2);
        for (a, b) in owned.iter().zip(&back) {
            assert_eq!((a.group, a.mode, a.path), (b.group, b.mode, b.path));
            let (x, y) = (&a.switch, &b.switch);
            assert_eq!(
                (x.mode, x.limb, x.kind, x.along, x.t.map(f64::to_bits)),
                (y.mode, y.limb, y.kind, y.along, y.t.map(f64::to_bits))
            );
            let bits = |d: &Discontinuity| {
                [d.param, d.z, d.psi, d.theta, d.margin].into_iter().chain(d.jump).map(f64::to_bits).collect::<Vec<_>>()
            };
            assert_eq!(bits(x), bits(y));
        }
        assert!(decode(&bytes[..bytes.len() - 1], &modes).is_none());
        assert!(decode(b"nonsense", &modes).is_none());
    }
}
