//! # clearance-plot
//!
//! PNG figures from a finished `clearance run` directory, the figures of the
//! paper's sections 3–4 (cited by title in docs/model.md), one set per variant `K` of the job:
//!
//! | run | file under `OUT/variant=K/` | pixels | paper |
//! |---|---|---|---|
//! | grid | `total_<mode>.png`, `<kind>_<mode>.png` for each enabled kind: six colour maps over Ψ–Θ at the first `z` (ΔX, ΔY, ΔZ in µm; ΔΨ, ΔΘ, ΔΦ in µrad), each with its colour bar, nulls grey, the switch locus as black dots | [`MAP_SIZE`] 1680 × 1040 | Figs. 6–12 |
//! | grid | `envelope_<mode>.png`: the same six maps of the worst case over every take-up (`env_*`) | [`MAP_SIZE`] | beyond the paper |
//! | grid | `dominant_<mode>.png`: the joint whose own take-up moves P most (`dominant`), one colour per joint ([`dominant_colour`]), each joint's share of the poses in the legend, the switch locus as black dots | [`MAP_SIZE`] | beyond the paper |
//! | trajectory | `inputs_motion.png`: the moving inputs (Θ) with velocity and acceleration against t | 1680 × (100 + 300 per input) | Fig. 13 |
//! | trajectory | `parasitic_motion.png`: X, Y, Φ with velocities and accelerations against t | 1680 × 1000 | Fig. 14 |
//! | trajectory | `total_trajectory.png`, `<kind>_trajectory.png`: the six errors against Θ (else the input that moves), kinetostatics black, dynamics blue, switches dashed | [`ERROR_SIZE`] 1680 × 1000 | Figs. 15–17 |
//!
//! A 6-UPS run (docs/model.md §10.3) gets the same figures over its own inputs,
//! kinds and limbs: its grid maps lie on the plane of the first two swept inputs in
//! the order `x, y, z, phi, psi, theta` at the first value of the others (a grid with
//! fewer than two swept inputs is refused, [`PlotError::Unsupported`]), with only the
//! switches on that plane; its 18 joints have their own [`dominant_colour`]s; along a
//! trajectory its moving inputs are drawn with their rates, and its errors against t
//! (it has no parasitic motion).
//!
//! Every figure has a 100-pixel header: the job's name and what is shown, then the
//! variant's swept values, the clearances, and how nulls and switches are drawn.
//! Grids finer than 800 lines per axis and trajectories longer than 20 000 samples
//! are decimated while reading (every k-th line or sample): a figure cannot show
//! more, and a run of millions of poses plots in bounded memory.
//!
//! A kind is enabled when its clearance is non-zero and its per-kind columns are in
//! the files (`--columns minimal` runs get only the total). The switches come from
//! `discontinuities.parquet` when the run has one; without it the figures have no
//! switch overlay and say so. Rates along trajectories are not stored in the run:
//! they are recomputed from `job.toml` with the engine's kinematics, so the
//! figures need nothing but the run directory.
//!
//! Text is drawn with an embedded DejaVu Sans (`data/fonts`, ab_glyph), so plotting
//! works on machines without fontconfig or any installed font.
//!
//! ```no_run
//! use std::path::Path;
//! let written = clearance_plot::plot_run(Path::new("out/fig08"), Path::new("out/fig08/plots"))?;
//! for png in &written {
//!     println!("{}", png.display());
//! }
//! # Ok::<(), clearance_plot::PlotError>(())
//! ```

mod dominant_map;
mod error;
mod error_map;
mod figure;
mod run_dir;
mod switches;
mod tradeoff;
mod trajectory;

use std::path::{Path, PathBuf};

use clearance_grid::SampleSource;
use clearance_model::{MechanismKind, Variant};

pub use dominant_map::dominant_colour;
pub use error::PlotError;
pub use error_map::MAP_SIZE;
pub use tradeoff::{TRADEOFF_SIZE, plot_tradeoff};
pub use trajectory::ERROR_SIZE;

use figure::{COMPONENTS, ENVELOPE_COMPONENTS, Source, clearance_of};
use run_dir::{Layout, ModeData, Plane, RunDir};
use switches::Switch;

static FONT_BYTES: &[u8] = include_bytes!("../../../data/fonts/DejaVuSans.ttf");

/// Registers the embedded font as plotters' `sans-serif` (once per process).
fn register_font() -> Result<(), PlotError> {
    static REGISTERED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(figure::FONT, plotters::style::FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// Reads the finished run in `run_dir` and writes its figures under `out_dir`
/// (created if needed; existing figures of the same name are replaced). Returns
/// the files written, variant by variant.
pub fn plot_run(run_dir: &Path, out_dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    register_font()?;
    let run = RunDir::open(run_dir)?;
    if !run_dir.join("poses").is_dir() && run.layout.success().exists() {
        return Err(PlotError::Unsupported {
            dir: run_dir.to_path_buf(),
            why: "the run was written with --columns none: it has no pose files to draw (its summary.parquet and \
                  discontinuities.parquet hold what it computed)"
                .into(),
        });
    }
    let switches = switches::read_switches(&run.layout.discontinuities())?;
    let mut written = Vec::new();
    for variant in &run.variants {
        let poses = run.layout.variant_dir(variant.index);
        if !poses.is_dir() {
            return Err(PlotError::NotARun {
                dir: run_dir.to_path_buf(),
                why: format!("{} is missing", poses.display()),
            });
        }
        let source = SampleSource::new(&variant.job);
        let layout = Layout::of(&source, variant.job.mechanism.kind, variant.job.mechanism.inputs.as_deref())
            .map_err(|why| PlotError::Unsupported { dir: run_dir.to_path_buf(), why })?;
        let dir = out_dir.join(format!("variant={}", variant.index));
        std::fs::create_dir_all(&dir).map_err(PlotError::io(&dir))?;
        let data = run_dir::read_variant(&run, variant.index, &layout)?;
        let mine: Option<Vec<&Switch>> =
            switches.as_ref().map(|all| all.iter().filter(|s| s.variant == variant.index).collect());
        let ctx = Context { run: &run, variant, dir: &dir, switches: mine.as_deref() };
        match &layout {
            Layout::Grid(plane) => ctx.grid_figures(&data, plane, &mut written)?,
            Layout::Trajectory { samples, .. } => ctx.trajectory_figures(&source, samples, &data, &mut written)?,
        }
    }
    Ok(written)
}

/// One variant's figures.
struct Context<'a> {
    run: &'a RunDir,
    variant: &'a Variant,
    dir: &'a Path,
    /// This variant's switches; `None` when the run has no discontinuities.parquet.
    switches: Option<&'a [&'a Switch]>,
}

impl Context<'_> {
    /// The mechanism's clearance kinds (`s_radial`, `r_radial`, …).
    fn kinds(&self) -> &'static [&'static str] {
        self.variant.job.mechanism.kind.clearance_keys()
    }

    /// Total first, then each enabled kind whose columns some mode holds.
    fn sources(&self, data: &[ModeData]) -> Vec<Source> {
        let has = |s: Source| data.iter().any(|d| COMPONENTS.iter().any(|&c| d.column(&s.column(c)).is_some()));
        let clearance = &self.variant.job.clearance;
        std::iter::once(Source::Total)
            .chain(self.kinds().iter().map(|&k| Source::Kind(k)))
            .filter(|&s| match s {
                Source::Total => has(s),
                Source::Kind(k) => clearance_of(clearance, k) != 0.0 && has(s),
            })
            .collect()
    }

    fn title(&self) -> String {
        self.run.job.name().to_string()
    }

    /// `variant K: param = value · ` when the job has sweeps, else nothing.
    fn variant_note(&self) -> String {
        if self.run.variants.len() <= 1 && self.variant.params.is_empty() {
            return String::new();
        }
        let params: Vec<String> = self.variant.params.iter().map(|(p, v)| format!("{p} = {v}")).collect();
        format!("variant {}: {} · ", self.variant.index, params.join(", "))
    }

    /// The clearances a figure of `source` includes, as `r_radial = 100 µm, ...`.
    fn clearances(&self, source: Source) -> String {
        let c = &self.variant.job.clearance;
        if c.custom {
            // A custom mechanism's kinds are its joint groups, as the job names them.
            let list: Vec<String> = c
                .given
                .iter()
                .filter(|(_, m)| m.max() != 0.0)
                .map(|(k, m)| {
                    // Angular play, and an R joint's backlash, are rotations.
                    let joint = k.rsplit_once('_').map_or("", |(j, _)| j);
                    let revolute = self
                        .variant
                        .job
                        .mechanism
                        .limb
                        .iter()
                        .flatten()
                        .flat_map(|l| &l.joints)
                        .any(|j| j.name() == joint && j.joint == clearance_model::custom::JointType::R);
                    let rotation = k.ends_with("_angular") || (k.ends_with("_backlash") && revolute);
                    let unit = if rotation { "µrad" } else { "µm" };
                    format!("{k} = {} {unit}", short(m.max() * 1e6))
                })
                .collect();
            return if list.is_empty() { "no clearance (rigid joints)".to_string() } else { list.join(", ") };
        }
        let list: Vec<String> = self
            .kinds()
            .iter()
            .filter(|&&k| source.shows(k) && clearance_of(c, k) != 0.0)
            .map(|&k| {
                let unit = if k.ends_with("_angular") { "µrad" } else { "µm" };
                format!("{k} = {} {unit}", short(clearance_of(c, k) * 1e6))
            })
            .collect();
        if list.is_empty() { "no clearance (rigid joints)".to_string() } else { list.join(", ") }
    }

    /// The switches of `mode` a figure of `source` marks, and the subtitle's note on them.
    fn switches_for(&self, source: Source, mode: Option<&str>) -> (Vec<&Switch>, String) {
        let Some(all) = self.switches else {
            return (Vec::new(), "no discontinuities.parquet: switches not drawn".into());
        };
        let chosen: Vec<&Switch> =
            all.iter().copied().filter(|s| source.shows(&s.kind) && mode.is_none_or(|m| s.mode == m)).collect();
        let n = chosen.len();
        (chosen, format!("{n} switch{}", if n == 1 { "" } else { "es" }))
    }

    /// The switches of `mode` a map of `source` on `plane` marks, as `(across, up)`,
    /// and the subtitle's note on them.
    fn switches_on(&self, source: Source, mode: &str, plane: &Plane) -> (Vec<(f64, f64)>, String) {
        let (switches, note) = self.switches_for(source, Some(mode));
        let on_plane: Vec<(f64, f64)> = switches
            .iter()
            .filter(|s| s.on(plane))
            .filter_map(|s| Some((s.coordinate(plane.across.input)?, s.coordinate(plane.up.input)?)))
            .collect();
        let note = match self.switches {
            Some(_) => format!("black dots: switch locus ({} {})", on_plane.len(), plane.here()),
            None => note,
        };
        (on_plane, note)
    }

    fn grid_figures(&self, data: &[ModeData], plane: &Plane, written: &mut Vec<PathBuf>) -> Result<(), PlotError> {
        let at = plane.fixed_desc();
        let slots = plane.across.values.len() * plane.up.values.len();
        for source in self.sources(data) {
            for mode in data {
                let columns = trajectory::error_columns(mode, source);
                if columns.iter().all(Option::is_none) {
                    continue;
                }
                let (on_plane, note) = self.switches_on(source, &mode.mode, plane);
                let map = error_map::ErrorMap {
                    title: format!("{} — {}, {}", self.title(), source.describe(), mode.mode),
                    subtitle: format!(
                        "{}pose error at {at} · {} · grey: no value (status ≠ ok) · {note}",
                        self.variant_note(),
                        self.clearances(source),
                    ),
                    plane,
                    panels: error_map::panels(columns, slots),
                    switches: on_plane,
                };
                let path = self.dir.join(format!("{}_{}.png", source.stem(), mode.mode));
                map.write(&path)?;
                written.push(path);
            }
        }
        // Beside the error map of all clearances, the worst case over every take-up.
        for mode in data {
            let columns = ENVELOPE_COMPONENTS.map(|c| mode.column(&format!("env_{}", c.suffix)));
            if columns.iter().all(Option::is_none) {
                continue;
            }
            let map = error_map::ErrorMap {
                title: format!("{} — worst case over every take-up, {}", self.title(), mode.mode),
                subtitle: format!(
                    "{}envelope at {at} · {} · grey: no value (unreachable or near-singular)",
                    self.variant_note(),
                    self.clearances(Source::Total),
                ),
                plane,
                panels: error_map::panels_of(&ENVELOPE_COMPONENTS, columns, slots),
                switches: Vec::new(),
            };
            let path = self.dir.join(format!("envelope_{}.png", mode.mode));
            map.write(&path)?;
            written.push(path);
        }
        // The joint to tighten, with every switch of the mode on this plane.
        let joints = run_dir::joints(self.variant.job.mechanism.kind);
        for mode in data {
            let Some(values) = mode.column(run_dir::DOMINANT) else { continue };
            if values.iter().all(|v| !v.is_finite()) {
                continue;
            }
            let (on_plane, note) = self.switches_on(Source::Total, &mode.mode, plane);
            let map = dominant_map::DominantMap {
                title: format!("{} — the joint to tighten, {}", self.title(), mode.mode),
                subtitle: format!(
                    "{}largest contribution to |Δp| at {at} · {} · grey: none (status ≠ ok) · {note}",
                    self.variant_note(),
                    self.clearances(Source::Total),
                ),
                plane,
                values,
                names: &joints,
                switches: on_plane,
            };
            let path = self.dir.join(format!("dominant_{}.png", mode.mode));
            map.write(&path)?;
            written.push(path);
        }
        Ok(())
    }

    fn trajectory_figures(
        &self,
        sample_source: &SampleSource,
        samples: &[u64],
        data: &[ModeData],
        written: &mut Vec<PathBuf>,
    ) -> Result<(), PlotError> {
        let title = self.title();
        let kind = self.variant.job.mechanism.kind;
        let inputs = self.dir.join("inputs_motion.png");
        // A 6-UPS has no parasitic motion.
        let parasitic = (kind != MechanismKind::Ups6).then(|| self.dir.join("parasitic_motion.png"));
        let rates = if parasitic.is_some() {
            "nominal inverse kinematics, exact rates (automatic differentiation)"
        } else {
            "the inputs with the exact rates of their harmonics"
        };
        trajectory::write_motions(
            &self.variant.job,
            samples,
            &title,
            &format!("{}{rates}", self.variant_note()),
            &inputs,
            parasitic.as_deref(),
        )?;
        written.push(inputs);
        written.extend(parasitic);

        let (along, x_desc, x) = trajectory::abscissa(sample_source, samples, kind);
        for source in self.sources(data) {
            let (switches, note) = self.switches_for(source, None);
            let modes: Vec<&str> = data.iter().map(|d| d.mode.as_str()).collect();
            let figure = trajectory::TrajectoryErrors {
                title: format!("{title} — error along the trajectory, {}", source.describe()),
                subtitle: format!(
                    "{}{} · {} · gaps: no value (status ≠ ok) · {note}",
                    self.variant_note(),
                    modes.join(" vs "),
                    self.clearances(source),
                ),
                x_desc,
                x: &x,
                modes: data.iter().map(|d| (d.mode.as_str(), trajectory::error_columns(d, source))).collect(),
                switches: trajectory::switch_marks(&switches, along),
            };
            let path = self.dir.join(format!("{}_trajectory.png", source.stem()));
            figure.write(&path)?;
            written.push(path);
        }
        Ok(())
    }
}

/// A number in at most four significant decimals, without trailing zeros.
fn short(v: f64) -> String {
    let s = format!("{:.4}", v);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}
