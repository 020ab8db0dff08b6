//! Which cells a matrix runs: groups (variants x scenes x sweeps), the naive baselines
//! their speed-ups need, and a deterministic slice of them for `--shard`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::scene::SceneParams;
use crate::sequence::SequenceSpec;
use crate::variant::{self, ListUpdate, LoadedVariant, Pipeline, Variant};

/// One swept parameter and its values.
#[derive(Clone, Debug, PartialEq)]
pub enum Sweep {
    Lights(Vec<u32>),
    /// Light radius ranges (min, max).
    Radius(Vec<(f32, f32)>),
    /// Cluster grids; applies to clustered variants only.
    Grid(Vec<(u32, u32, u32)>),
    /// `skip_unneeded` on and off: what skipping saves on the same frame.
    Skipping(Vec<bool>),
    /// Fractions of spot lights, each in 0..=1.
    Spots(Vec<f32>),
    /// MSAA sample counts (`msaa.samples`).
    Msaa(Vec<u32>),
    /// Fractions of the lights that move with time, each in 0..=1 (sequences).
    Moving(Vec<f32>),
}

/// Parse `lights=64,256`, `radius=1,2..4` (a single value r means r..r),
/// `grid=16x9x24,32x18x48`, `skipping=on,off`, `spots=0,0.5,1`, `msaa=1,4` or
/// `moving=0.1,1`.
pub fn parse_sweep(s: &str) -> Result<Sweep, String> {
    let (name, values) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}` is not NAME=V1,V2,...; e.g. lights=64,256,1024"))?;
    let items: Vec<&str> = values.split(',').map(str::trim).collect();
    if items.iter().any(|v| v.is_empty()) {
        return Err(format!("`{s}`: a value is empty"));
    }
    let bad = |v: &str, what: &str| format!("`{v}` in `{s}` is not {what}");
    match name.trim() {
        "lights" => items
            .iter()
            .map(|v| {
                if v.is_empty() || !v.bytes().all(|b| b.is_ascii_digit()) {
                    return Err(bad(v, "a whole number"));
                }
                // A whole number too large even for u64 is still too many lights.
                let n = v.parse::<u64>().unwrap_or(u64::MAX);
                if n > crate::scene::MAX_LIGHTS as u64 {
                    return Err(format!(
                        "`{v}` in `{s}`: at most {} lights",
                        crate::scene::MAX_LIGHTS
                    ));
                }
                Ok(n as u32)
            })
            .collect::<Result<_, _>>()
            .map(Sweep::Lights),
        "radius" => items
            .iter()
            .map(|v| {
                let num = |x: &str| {
                    let r = x
                        .trim()
                        .parse::<f32>()
                        .map_err(|_| bad(v, "a radius or a range MIN..MAX"))?;
                    match crate::scene::radius_problem(r) {
                        Some(p) => Err(format!("`{v}` in `{s}`: {p}")),
                        None => Ok(r),
                    }
                };
                let (a, b) = match v.split_once("..") {
                    Some((a, b)) => (num(a)?, num(b)?),
                    None => (num(v)?, num(v)?),
                };
                if a > b {
                    return Err(format!("`{v}` in `{s}`: MIN is above MAX"));
                }
                Ok((a, b))
            })
            .collect::<Result<_, _>>()
            .map(Sweep::Radius),
        "grid" => items
            .iter()
            .map(|v| {
                let dims: Vec<u32> = v
                    .split(['x', 'X'])
                    .map(|d| d.parse::<u32>().ok().filter(|&d| d >= 1))
                    .collect::<Option<_>>()
                    .ok_or_else(|| bad(v, "a grid XxYxZ of whole numbers >= 1"))?;
                match dims[..] {
                    [x, y, z] => Ok((x, y, z)),
                    _ => Err(bad(v, "a grid XxYxZ")),
                }
            })
            .collect::<Result<_, _>>()
            .map(Sweep::Grid),
        "skipping" => items
            .iter()
            .map(|v| match *v {
                "on" => Ok(true),
                "off" => Ok(false),
                _ => Err(bad(v, "on or off")),
            })
            .collect::<Result<_, _>>()
            .map(Sweep::Skipping),
        "spots" | "moving" => items
            .iter()
            .map(|v| {
                v.parse::<f32>()
                    .ok()
                    .filter(|f| (0.0..=1.0).contains(f))
                    .ok_or_else(|| bad(v, "a fraction in 0..=1"))
            })
            .collect::<Result<_, _>>()
            .map(|f| match name.trim() {
                "spots" => Sweep::Spots(f),
                _ => Sweep::Moving(f),
            }),
        "msaa" => items
            .iter()
            .map(|v| {
                v.parse::<u32>()
                    .ok()
                    .filter(|n| variant::SAMPLE_COUNTS.contains(n))
                    .ok_or_else(|| {
                        bad(
                            v,
                            &format!("a sample count of {:?}", variant::SAMPLE_COUNTS),
                        )
                    })
            })
            .collect::<Result<_, _>>()
            .map(Sweep::Msaa),
        other => Err(format!(
            "`{other}` cannot be swept; sweep lights, radius, grid, skipping, spots, msaa or moving"
        )),
    }
}

/// A variant as a group names it: loaded, or the reason it would not load.
#[derive(Clone, Debug)]
pub struct VariantEntry {
    pub name: String,
    pub path: PathBuf,
    pub loaded: Result<LoadedVariant, String>,
}

impl VariantEntry {
    fn load(path: &Path) -> Self {
        let name = path
            .file_stem()
            .map_or("variant".into(), |s| s.to_string_lossy().into_owned());
        Self {
            name,
            path: path.to_path_buf(),
            loaded: variant::load(path).map_err(|e| e.to_string()),
        }
    }
}

/// Variant files from arguments: files, folders of them, or names in `variants/`.
pub fn find_variants(args: &[String]) -> Result<Vec<VariantEntry>, String> {
    let mut out = Vec::new();
    for arg in args {
        let path = variant::locate(arg)?;
        let files = variant::find_files(&path)?;
        if files.is_empty() {
            return Err(format!("{}: no .ron variant files there", path.display()));
        }
        out.extend(files.iter().map(|f| VariantEntry::load(f)));
    }
    Ok(out)
}

/// A set of cells: every variant on every scene at every combination of the sweeps.
#[derive(Clone, Debug)]
pub struct Group {
    pub name: String,
    pub variants: Vec<VariantEntry>,
    pub scenes: Vec<String>,
    pub sweeps: Vec<Sweep>,
    /// Image size for every cell (default: each scene's).
    pub size: Option<(u32, u32)>,
    /// Each cell a sequence of frames rather than one frame rendered again.
    pub sequence: Option<GroupSequence>,
}

/// How a group's cells run as sequences: how many frames, which are checked, and what
/// moves (a `moving` sweep sets the fraction per cell).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroupSequence {
    pub spec: SequenceSpec,
    /// Fraction of the lights that move; None: all of them, none where they cannot
    /// (`scene::lights_fixed`).
    pub moving: Option<f32>,
    pub still_camera: bool,
}

/// The pipelines of the default matrix's MSAA group: naive forward, Forward+ and clustered
/// deferred, tiled and two-level both ways.
pub const MSAA_GROUP: [&str; 7] = [
    "naive_forward",
    "forward_plus",
    "clustered_deferred_16x16x24",
    "forward_plus_tiled",
    "clustered_deferred_tiled",
    "forward_plus_two_level",
    "clustered_deferred_two_level",
];

/// The default matrix's transparency group (and `study transparency`): every pipeline and
/// culling method on the glass scene.
pub const TRANSPARENCY_GROUP: [&str; 14] = [
    "naive_forward",
    "deferred_scissor",
    "forward_plus",
    "clustered_deferred_16x16x24",
    "forward_plus_tiled",
    "forward_plus_olsson",
    "clustered_deferred_active",
    "forward_plus_olsson_2_5d",
    "clustered_deferred_tiled_2_5d",
    "forward_plus_two_level",
    "forward_plus_zbinning",
    "forward_plus_rasterised",
    "forward_plus_bvh",
    "forward_plus_cpu_assignment",
];

/// The default matrix: every variant (but the sampled and list-strategy ones, which have
/// groups of their own) on every built-in scene but the glass one, a
/// light-count sweep of naive forward, Forward+ and clustered deferred on the atrium, those
/// with 1 and 4 samples (`MSAA_GROUP`), and every pipeline and culling method on the glass
/// scene (`TRANSPARENCY_GROUP`, at a quarter of its pixels), the sampled light loops beside
/// exact ones where lists are long (`SAMPLING_EXACT`), the shadowed variants beside their
/// twins (`SHADOW_TWINS`), and the list strategies in sequences.
/// The image size of the default matrix's group of every variant on every scene, and of its
/// sequences: small enough that the matrix stays within about two minutes on a 2-core
/// machine without a GPU while most cells time the 6 frames a 95% interval needs.
pub const VARIANTS_SIZE: (u32, u32) = (320, 180);

pub fn default_groups() -> Result<Vec<Group>, String> {
    let glass = crate::scene::TRANSPARENCY_SCENE;
    let scenes = crate::scene::SCENES
        .iter()
        .filter(|s| s.name != glass)
        .map(|s| s.name.to_string())
        .collect();
    let variants = find_variants(&["variants".into()])?;
    Ok(vec![
        // Strategies for moving lights are for the sequence group: a frame rendered again
        // has no change to follow.
        Group {
            name: "variants".into(),
            variants: variants
                .iter()
                .filter(|e| !updates(e) && !samples(e) && !shadows(e))
                .cloned()
                .collect(),
            scenes,
            sweeps: vec![],
            // Small enough that most cells time the frames a 95% interval needs within
            // their budget (`measure::MIN_FRAMES`).
            size: Some(VARIANTS_SIZE),
            sequence: None,
        },
        Group {
            name: "lights".into(),
            variants: find_variants(&[
                "naive_forward".into(),
                "forward_plus".into(),
                "clustered_deferred_16x16x24".into(),
            ])?,
            scenes: vec!["atrium".into()],
            // 16384 lights and more belong to `study scale` (naive forward's frame there
            // alone took 8 s).
            sweeps: vec![Sweep::Lights(vec![64, 256, 1024, 5000])],
            size: Some((256, 144)),
            sequence: None,
        },
        // Where Forward+ and deferred trade places (Billeter et al. 2013, at 4x MSAA).
        Group {
            name: "msaa".into(),
            variants: find_variants(&MSAA_GROUP.map(String::from))?,
            scenes: vec!["atrium".into()],
            sweeps: vec![Sweep::Lights(vec![1024]), Sweep::Msaa(vec![1, 4])],
            size: Some((640, 360)),
            sequence: None,
        },
        // What deferred cannot do: blended panes, shaded forward in every pipeline.
        Group {
            name: "transparency".into(),
            variants: find_variants(&TRANSPARENCY_GROUP.map(String::from))?,
            scenes: vec![glass.into()],
            sweeps: vec![],
            size: Some((320, 180)),
            sequence: None,
        },
        // Time against error: the sampled light loops beside the exact ones, where lists
        // grow long.
        Group {
            name: "sampling".into(),
            variants: sampling_variants(&variants)?,
            scenes: vec!["atrium".into()],
            sweeps: vec![
                Sweep::Lights(vec![SAMPLING_LIGHTS]),
                Sweep::Radius(vec![SAMPLING_RADIUS]),
            ],
            size: Some(SAMPLING_SIZE),
            sequence: None,
        },
        // What shadows cost: every shadowed variant beside its unshadowed twins.
        Group {
            name: "shadows".into(),
            variants: shadow_variants(&variants)?,
            scenes: SHADOW_SCENES.map(String::from).to_vec(),
            sweeps: vec![],
            size: Some(VARIANTS_SIZE),
            sequence: None,
        },
        // Lights that move: every list strategy, frame after frame.
        Group {
            name: "sequence".into(),
            variants: sequence_variants(&variants)?,
            scenes: vec!["atrium".into()],
            sweeps: vec![Sweep::Lights(vec![1024]), Sweep::Moving(vec![0.1, 1.0])],
            size: Some(VARIANTS_SIZE),
            sequence: Some(GroupSequence {
                spec: SequenceSpec {
                    frames: 30,
                    check_every: 10,
                },
                moving: Some(1.0),
                still_camera: true,
            }),
        },
    ])
}

/// The rebuilding variants whose lists the sequence group's strategies start from.
pub const SEQUENCE_REBUILDS: [&str; 3] = [
    "forward_plus",
    "clustered_deferred_16x16x24",
    "forward_plus_bvh",
];

/// The default matrix's sequence group: `SEQUENCE_REBUILDS` and every variant of
/// `variants` with another list strategy (`clusters.update`), which only sequences tell
/// apart.
fn sequence_variants(variants: &[VariantEntry]) -> Result<Vec<VariantEntry>, String> {
    let mut out = find_variants(&SEQUENCE_REBUILDS.map(String::from))?;
    out.extend(variants.iter().filter(|e| updates(e)).cloned());
    Ok(out)
}

/// The exact variants the sampling group's samplers are set beside.
pub const SAMPLING_EXACT: [&str; 3] = [
    "forward_plus",
    "clustered_deferred_16x16x24",
    "forward_plus_zbinning",
];
/// The sampling group's lights, radii and size: lists of about 700 lights a pixel.
pub const SAMPLING_LIGHTS: u32 = 4096;
pub const SAMPLING_RADIUS: (f32, f32) = (4.0, 8.0);
pub const SAMPLING_SIZE: (u32, u32) = (256, 144);

/// The default matrix's sampling group: `SAMPLING_EXACT` and every sampled variant of
/// `variants`.
fn sampling_variants(variants: &[VariantEntry]) -> Result<Vec<VariantEntry>, String> {
    let mut out = find_variants(&SAMPLING_EXACT.map(String::from))?;
    out.extend(variants.iter().filter(|e| samples(e)).cloned());
    Ok(out)
}

/// Whether a variant's light loop samples (`shading.lights`).
/// The unshadowed variants the shadows group times beside the shadowed ones: the same
/// Forward+ and deferred frames without rays.
pub const SHADOW_TWINS: [&str; 2] = ["forward_plus", "deferred_3_targets"];

/// The scenes of the shadows group: the hall of columns (`study shadows` and
/// `tests/shadows.rs` take the others).
pub const SHADOW_SCENES: [&str; 1] = ["atrium"];

/// The default matrix's shadows group: `SHADOW_TWINS` and every variant of `variants` that
/// traces shadow rays.
fn shadow_variants(variants: &[VariantEntry]) -> Result<Vec<VariantEntry>, String> {
    let mut out = find_variants(&SHADOW_TWINS.map(String::from))?;
    out.extend(variants.iter().filter(|e| shadows(e)).cloned());
    Ok(out)
}

/// Whether a variant traces shadow rays.
fn shadows(e: &VariantEntry) -> bool {
    e.loaded
        .as_ref()
        .is_ok_and(|v| v.variant.shading.shadows.traced())
}

fn samples(e: &VariantEntry) -> bool {
    e.loaded
        .as_ref()
        .is_ok_and(|v| v.variant.shading.lights.sampling().is_some())
}

/// Whether a variant follows moving lights otherwise than by rebuilding its lists.
fn updates(e: &VariantEntry) -> bool {
    e.loaded.as_ref().is_ok_and(|v| updates_lists(&v.variant))
}

fn updates_lists(v: &Variant) -> bool {
    v.pipeline.is_clustered() && v.clusters().update != ListUpdate::Rebuild
}

/// Scene parameters as results record them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamsRecord {
    pub width: u32,
    pub height: u32,
    pub lights: u32,
    pub radius: [f32; 2],
    pub seed: u64,
    pub time: f64,
    /// Fraction of spot lights (absent in results written before spots: 0).
    #[serde(default)]
    pub spots: f32,
    /// Fraction of the lights that move with time (absent in results written before
    /// sequences: all of them).
    #[serde(default = "every_light")]
    pub moving: f32,
    /// Whether the camera moves with time (absent: it does).
    #[serde(default = "moves")]
    pub camera_moves: bool,
    /// The time still lights and a still camera keep.
    #[serde(default)]
    pub still_at: f64,
}

fn every_light() -> f32 {
    1.0
}

fn moves() -> bool {
    true
}

impl From<SceneParams> for ParamsRecord {
    fn from(p: SceneParams) -> Self {
        Self {
            width: p.width,
            height: p.height,
            lights: p.lights,
            radius: [p.radius_range.0, p.radius_range.1],
            seed: p.seed,
            time: p.time,
            spots: p.spots,
            moving: p.motion.lights,
            camera_moves: p.motion.camera,
            still_at: p.motion.still_at,
        }
    }
}

impl From<ParamsRecord> for SceneParams {
    fn from(p: ParamsRecord) -> Self {
        Self {
            width: p.width,
            height: p.height,
            lights: p.lights,
            radius_range: (p.radius[0], p.radius[1]),
            seed: p.seed,
            time: p.time,
            spots: p.spots,
            motion: crate::scene::Motion {
                lights: p.moving,
                camera: p.camera_moves,
                still_at: p.still_at,
            },
        }
    }
}

/// What identifies a cell and how to run it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CellSpec {
    /// `variant@scene`, with the swept values in brackets: `forward_plus@atrium[lights=1024]`.
    pub id: String,
    /// The group of the matrix the cell belongs to ("variants", "lights", "baseline", ...;
    /// `study` in results written before the rename).
    #[serde(alias = "study")]
    pub group: String,
    pub variant: String,
    pub variant_path: PathBuf,
    pub scene: String,
    /// SHA-256 of a file scene (its file, buffers and images): two files are two scenes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scene_sha256: Option<String>,
    pub params: ParamsRecord,
    /// Swept values by parameter.
    pub sweep: BTreeMap<String, String>,
    /// The cluster grid the cell ran with (clustered variants).
    pub grid: Option<[u32; 3]>,
    /// Pipeline name (absent when the variant did not load).
    pub pipeline: Option<String>,
    /// Whether the image is a debug view rather than the shaded scene.
    pub debug_view: bool,
    /// Whether the variant has post effects.
    pub post: bool,
    /// A sequence of frames (absent: one frame, rendered again for timing).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sequence: Option<SequenceSpec>,
    /// A sequence cell whose variant follows moving lights otherwise than by rebuilding:
    /// the cell of its group whose variant is the same but rebuilds (what its frames are
    /// compared with), where the matrix has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rebuild_cell: Option<String>,
}

impl CellSpec {
    /// The parameters a cell's speed-up and Pareto front are compared within.
    pub fn group(&self) -> String {
        let p = &self.params;
        let motion = match &self.sequence {
            Some(s) => format!(
                " {} frames, {} moving, camera {}",
                s.frames,
                p.moving,
                if p.camera_moves { "moving" } else { "still" }
            ),
            None => String::new(),
        };
        format!(
            "{}{} {}x{} {} lights r{}..{} seed {} t{} spots {}{motion}",
            self.scene,
            self.scene_sha256
                .as_deref()
                .map(|h| format!(" sha256:{}", &h[..h.len().min(12)]))
                .unwrap_or_default(),
            p.width,
            p.height,
            p.lights,
            p.radius[0],
            p.radius[1],
            p.seed,
            p.time,
            p.spots
        )
    }

    /// A plain naive forward cell: the speed-up baseline of its group.
    pub fn is_naive_baseline(&self) -> bool {
        self.pipeline.as_deref() == Some("NaiveForward") && !self.post && !self.debug_view
    }

    /// The id as a file name.
    pub fn file_stem(&self) -> String {
        crate::run::safe_file_name(&self.id)
    }
}

/// A cell ready to run.
#[derive(Clone, Debug)]
pub struct PlannedCell {
    pub spec: CellSpec,
    pub variant: Result<LoadedVariant, String>,
}

/// Expand groups into cells, in a fixed order; add a naive forward baseline for every
/// group of parameters that has none, from `baseline` (when there is no naive variant in
/// the groups, the one in variants/ or the built-in default).
pub fn expand(groups: &[Group]) -> Result<Vec<PlannedCell>, String> {
    let mut cells: Vec<PlannedCell> = Vec::new();
    for group in groups {
        check_distinct_names(&group.variants)?;
        let swept = group.sweeps.iter().any(|s| matches!(s, Sweep::Moving(_)));
        if swept && group.sequence.is_none() {
            return Err(
                "--sweep moving=...: a frame rendered again has no moving lights, so every point would run the same frame; sweep moving with --sequence N"
                    .into(),
            );
        }
        for scene in &group.scenes {
            let mut base = crate::scene::defaults(scene).map_err(|e| e.to_string())?;
            let file = crate::scene::file_of(scene).map_err(|e| e.to_string())?;
            if let Some((w, h)) = group.size {
                (base.width, base.height) = (w, h);
            }
            if let Some(s) = &group.sequence {
                base.motion = crate::scene::Motion {
                    lights: s.moving.unwrap_or(1.0),
                    camera: !s.still_camera,
                    still_at: base.time,
                };
            }
            for entry in &group.variants {
                for point in sweep_points(&group.sweeps) {
                    let mut cell = make_cell(&group.name, entry, scene, base, &point);
                    cell.spec.scene_sha256 = file.as_ref().map(|f| f.sha256.clone());
                    if let Some(s) = &group.sequence {
                        fixed_lights_stay(&mut cell.spec, s, point.moving.is_some())?;
                        cell.spec.sequence = Some(s.spec);
                        cell.spec.id = sequence_id(&cell.spec.id, s);
                    }
                    if !cells.iter().any(|c| c.spec.id == cell.spec.id) {
                        cells.push(cell);
                    }
                }
            }
        }
    }
    find_rebuilds(&mut cells);
    add_baselines(&mut cells);
    check_distinct_cells(&cells)?;
    Ok(cells)
}

/// A sequence cell on a scene whose lights cannot move (a glTF file's own): none move when
/// no fraction was asked for; a fraction asked for (`--moving`, a `moving=` sweep) is
/// refused, as it would report lights moving that stand still.
fn fixed_lights_stay(spec: &mut CellSpec, s: &GroupSequence, swept: bool) -> Result<(), String> {
    let params: SceneParams = spec.params.into();
    if !crate::scene::lights_fixed(&spec.scene, &params).map_err(|e| e.to_string())? {
        return Ok(());
    }
    if (s.moving.is_some() || swept) && spec.params.moving > 0.0 {
        return Err(format!(
            "scene `{}`: its lights are the file's own, which stand where it puts them, so a fraction {} of them moving cannot be run; leave out --moving (and the moving sweep) for this scene, or ask for another number of lights (seeded in its bounds, and moving)",
            spec.scene, spec.params.moving
        ));
    }
    spec.params.moving = 0.0;
    Ok(())
}

/// A sequence cell's id: its frames and camera after the sweep's values, `@scene[...]`.
fn sequence_id(id: &str, s: &GroupSequence) -> String {
    let camera = if s.still_camera { "still" } else { "moving" };
    let what = format!("frames={},camera={camera}", s.spec.frames);
    match id.strip_suffix(']') {
        Some(head) => format!("{head},{what}]"),
        None => format!("{id}[{what}]"),
    }
}

/// Two cells never share an id or an image file name (two file scenes whose paths differ
/// only in characters a file name cannot hold would).
fn check_distinct_cells(cells: &[PlannedCell]) -> Result<(), String> {
    let mut seen: BTreeMap<String, &CellSpec> = BTreeMap::new();
    for c in cells {
        for key in [c.spec.id.clone(), c.spec.file_stem()] {
            if let Some(other) = seen.insert(key, &c.spec)
                && !std::ptr::eq(other, &c.spec)
            {
                return Err(format!(
                    "cells `{}` ({}) and `{}` ({}) would share the image file `{}.png`: rename one of the variant files or scenes",
                    other.id,
                    other.variant_path.display(),
                    c.spec.id,
                    c.spec.variant_path.display(),
                    c.spec.file_stem()
                ));
            }
        }
    }
    Ok(())
}

/// A cell's id starts with its variant's file stem: two different files with one stem
/// would share ids, and one would silently replace the other.
fn check_distinct_names(variants: &[VariantEntry]) -> Result<(), String> {
    for (i, a) in variants.iter().enumerate() {
        for b in &variants[i + 1..] {
            let same_file = match (
                std::fs::canonicalize(&a.path),
                std::fs::canonicalize(&b.path),
            ) {
                (Ok(x), Ok(y)) => x == y,
                _ => a.path == b.path,
            };
            if a.name == b.name && !same_file {
                return Err(format!(
                    "two variant files are both named `{}`: {} and {}; cells are named after the file, so rename one",
                    a.name,
                    a.path.display(),
                    b.path.display()
                ));
            }
        }
    }
    Ok(())
}

/// One value per sweep.
#[derive(Clone, Debug, Default)]
struct Point {
    lights: Option<u32>,
    radius: Option<(f32, f32)>,
    grid: Option<(u32, u32, u32)>,
    skipping: Option<bool>,
    spots: Option<f32>,
    msaa: Option<u32>,
    moving: Option<f32>,
}

fn sweep_points(sweeps: &[Sweep]) -> Vec<Point> {
    let mut points = vec![Point::default()];
    for sweep in sweeps {
        let mut next = Vec::new();
        for p in &points {
            match sweep {
                Sweep::Lights(v) => next.extend(v.iter().map(|&n| Point {
                    lights: Some(n),
                    ..p.clone()
                })),
                Sweep::Radius(v) => next.extend(v.iter().map(|&r| Point {
                    radius: Some(r),
                    ..p.clone()
                })),
                Sweep::Grid(v) => next.extend(v.iter().map(|&g| Point {
                    grid: Some(g),
                    ..p.clone()
                })),
                Sweep::Skipping(v) => next.extend(v.iter().map(|&on| Point {
                    skipping: Some(on),
                    ..p.clone()
                })),
                Sweep::Spots(v) => next.extend(v.iter().map(|&f| Point {
                    spots: Some(f),
                    ..p.clone()
                })),
                Sweep::Msaa(v) => next.extend(v.iter().map(|&n| Point {
                    msaa: Some(n),
                    ..p.clone()
                })),
                Sweep::Moving(v) => next.extend(v.iter().map(|&f| Point {
                    moving: Some(f),
                    ..p.clone()
                })),
            }
        }
        points = next;
    }
    points
}

fn make_cell(
    group: &str,
    entry: &VariantEntry,
    scene: &str,
    base: SceneParams,
    point: &Point,
) -> PlannedCell {
    let mut params = base;
    let mut sweep = BTreeMap::new();
    if let Some(n) = point.lights {
        params.lights = n;
        sweep.insert("lights".to_string(), n.to_string());
    }
    if let Some((a, b)) = point.radius {
        params.radius_range = (a, b);
        sweep.insert("radius".to_string(), format!("{a}..{b}"));
    }
    if let Some(f) = point.spots {
        params.spots = f;
        sweep.insert("spots".to_string(), f.to_string());
    }
    if let Some(f) = point.moving {
        params.motion.lights = f;
        sweep.insert("moving".to_string(), f.to_string());
    }
    let mut loaded = entry.loaded.clone();
    let mut grid = None;
    if let Some(on) = point.skipping {
        sweep.insert("skipping".into(), if on { "on" } else { "off" }.into());
        if let Ok(v) = &mut loaded {
            v.variant.skip_unneeded = on;
        }
    }
    if let Some(n) = point.msaa {
        sweep.insert("msaa".into(), n.to_string());
        if let Ok(v) = &mut loaded {
            v.variant.msaa.samples = n;
            if let Some(p) = variant::check(&v.variant).first() {
                loaded = Err(format!("msaa {n}: {} {}", p.field, p.message));
            }
        }
    }
    // A grid sweep leaves unclustered variants alone: their cells for every grid share one
    // id, and `expand` keeps the first.
    if let Ok(v) = &mut loaded
        && v.variant.pipeline.is_clustered()
        && let Some(g) = point.grid
    {
        let mut clusters = v.variant.clusters();
        clusters.grid = g;
        v.variant.clusters = Some(clusters);
        sweep.insert("grid".to_string(), format!("{}x{}x{}", g.0, g.1, g.2));
        if let Some(p) = variant::check(&v.variant).first() {
            loaded = Err(format!(
                "grid {}x{}x{}: {} {}",
                g.0, g.1, g.2, p.field, p.message
            ));
        }
    }
    if let Ok(v) = &loaded
        && v.variant.pipeline.is_clustered()
    {
        let g = v.variant.clusters().grid;
        grid = Some([g.0, g.1, g.2]);
    }
    let variant_info = loaded.as_ref().ok().map(|v| &v.variant);
    let mut id = format!("{}@{scene}", entry.name);
    if !sweep.is_empty() {
        let parts: Vec<String> = sweep.iter().map(|(k, v)| format!("{k}={v}")).collect();
        id.push_str(&format!("[{}]", parts.join(",")));
    }
    PlannedCell {
        spec: CellSpec {
            id,
            group: group.to_string(),
            variant: entry.name.clone(),
            variant_path: entry.path.clone(),
            scene: scene.to_string(),
            scene_sha256: None,
            params: params.into(),
            sweep,
            grid,
            pipeline: variant_info.map(|v| format!("{:?}", v.pipeline)),
            debug_view: variant_info.is_some_and(|v| v.debug_view != variant::DebugView::Off),
            post: variant_info.is_some_and(|v| v.post.any()),
            sequence: None,
            rebuild_cell: None,
        },
        variant: loaded,
    }
}

/// Name each sequence cell's rebuilding twin (`CellSpec::rebuild_cell`): the cell of the
/// same group whose variant differs only in rebuilding its lists (and its description).
fn find_rebuilds(cells: &mut [PlannedCell]) {
    let rebuilding = |v: &Variant| {
        let mut v = v.clone();
        v.description.clear();
        if let Some(c) = v.clusters.as_mut() {
            c.update = ListUpdate::Rebuild;
        }
        v
    };
    for i in 0..cells.len() {
        let c = &cells[i];
        let Ok(v) = &c.variant else { continue };
        if c.spec.sequence.is_none() || !updates_lists(&v.variant) {
            continue;
        }
        let want = rebuilding(&v.variant);
        let twin = cells.iter().find(|o| {
            o.spec.group() == c.spec.group()
                && o.variant
                    .as_ref()
                    .is_ok_and(|ov| !updates_lists(&ov.variant) && rebuilding(&ov.variant) == want)
        });
        cells[i].spec.rebuild_cell = twin.map(|o| o.spec.id.clone());
    }
}

fn add_baselines(cells: &mut Vec<PlannedCell>) {
    let naive = cells
        .iter()
        .find(|c| c.spec.is_naive_baseline() && c.spec.variant == "naive_forward")
        .or_else(|| cells.iter().find(|c| c.spec.is_naive_baseline()))
        .map(|c| {
            (
                c.spec.variant.clone(),
                c.spec.variant_path.clone(),
                c.variant.clone(),
            )
        });
    let (name, path, loaded) = naive.unwrap_or_else(|| {
        let path = PathBuf::from("variants/naive_forward.ron");
        match variant::load(&path) {
            Ok(v) => ("naive_forward".into(), path, Ok(v)),
            Err(_) => (
                "naive_forward".into(),
                PathBuf::from("built-in"),
                Ok(LoadedVariant {
                    name: "naive_forward".into(),
                    path: PathBuf::from("built-in"),
                    variant: Variant {
                        description: "Naive forward: every fragment loops over every light".into(),
                        pipeline: Pipeline::NaiveForward,
                        ..Default::default()
                    },
                }),
            ),
        }
    });
    let mut missing: Vec<CellSpec> = Vec::new();
    // A sequence compares its strategies with each other: naive forward would take most of
    // its time for a figure no sequence needs.
    for c in cells.iter().filter(|c| c.spec.sequence.is_none()) {
        let group = c.spec.group();
        let has = cells
            .iter()
            .any(|o| o.spec.group() == group && o.spec.is_naive_baseline());
        if !has && !missing.iter().any(|m| m.group() == group) {
            missing.push(c.spec.clone());
        }
    }
    for spec in missing {
        let mut id = format!("{name}@{}", spec.scene);
        if !spec.sweep.is_empty() {
            let parts: Vec<String> = spec
                .sweep
                .iter()
                .filter(|(k, _)| *k != "grid")
                .map(|(k, v)| format!("{k}={v}"))
                .collect();
            if !parts.is_empty() {
                id.push_str(&format!("[{}]", parts.join(",")));
            }
        }
        // A variant of the user's may already go by the baseline's name (a naive_forward.ron
        // of their own with post effects, say): the added baseline then says what it is.
        if cells.iter().any(|c| c.spec.id == id) {
            id = format!("baseline-{id}");
        }
        let mut sweep = spec.sweep.clone();
        sweep.remove("grid");
        cells.push(PlannedCell {
            spec: CellSpec {
                id,
                group: "baseline".into(),
                variant: name.clone(),
                variant_path: path.clone(),
                scene: spec.scene.clone(),
                scene_sha256: spec.scene_sha256.clone(),
                params: spec.params,
                sweep,
                grid: None,
                pipeline: Some("NaiveForward".into()),
                debug_view: false,
                post: false,
                sequence: None,
                rebuild_cell: None,
            },
            variant: loaded.clone(),
        });
    }
}

/// Parse `K/N` (1-based).
pub fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let (k, n) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}` is not K/N, e.g. 2/4"))?;
    let (k, n): (u32, u32) = (
        k.trim()
            .parse()
            .map_err(|_| format!("`{k}` in `{s}` is not a whole number"))?,
        n.trim()
            .parse()
            .map_err(|_| format!("`{n}` in `{s}` is not a whole number"))?,
    );
    if n == 0 || k == 0 || k > n {
        return Err(format!("shard `{s}`: K must be in 1..=N and N at least 1"));
    }
    Ok((k, n))
}

/// The cells of shard `k` of `n`: every n-th cell from the k-th, so each shard gets a mix
/// of cheap and expensive cells. Deterministic for the same plan.
pub fn shard(cells: Vec<PlannedCell>, (k, n): (u32, u32)) -> Vec<PlannedCell> {
    cells
        .into_iter()
        .enumerate()
        .filter(|(i, _)| *i as u32 % n == k - 1)
        .map(|(_, c)| c)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(name: &str) -> VariantEntry {
        VariantEntry::load(&PathBuf::from(format!("variants/{name}.ron")))
    }

    fn group(variants: &[&str], sweeps: Vec<Sweep>) -> Group {
        Group {
            name: "test".into(),
            variants: variants.iter().map(|v| entry(v)).collect(),
            scenes: vec!["one_light".into()],
            sweeps,
            size: Some((32, 18)),
            sequence: None,
        }
    }

    #[test]
    fn sweeps_parse_and_bad_ones_say_what_is_valid() {
        assert_eq!(
            parse_sweep("lights=64, 256"),
            Ok(Sweep::Lights(vec![64, 256]))
        );
        assert_eq!(
            parse_sweep("radius=1,2..4"),
            Ok(Sweep::Radius(vec![(1.0, 1.0), (2.0, 4.0)]))
        );
        assert_eq!(
            parse_sweep("grid=16x9x24"),
            Ok(Sweep::Grid(vec![(16, 9, 24)]))
        );
        for (bad, says) in [
            ("lights", "NAME=V1,V2"),
            ("lights=ten", "`ten` in `lights=ten` is not a whole number"),
            ("lights=1,,2", "a value is empty"),
            ("radius=4..2", "MIN is above MAX"),
            ("grid=16x9", "is not a grid XxYxZ"),
            ("grid=0x1x1", "whole numbers >= 1"),
            (
                "fov=60",
                "sweep lights, radius, grid, skipping, spots, msaa or moving",
            ),
            ("msaa=3", "is not a sample count of [1, 2, 4, 8]"),
            ("skipping=maybe", "is not on or off"),
            (
                "spots=1.5",
                "`1.5` in `spots=1.5` is not a fraction in 0..=1",
            ),
        ] {
            let e = parse_sweep(bad).unwrap_err();
            assert!(e.contains(says), "{bad}: {e}");
        }
    }

    #[test]
    fn cells_cover_the_sweeps_and_every_group_gets_a_naive_baseline() {
        let s = group(
            &["forward_plus", "deferred_scissor"],
            vec![
                Sweep::Lights(vec![4, 8]),
                Sweep::Grid(vec![(8, 8, 8), (4, 4, 4)]),
            ],
        );
        let cells = expand(&[s]).unwrap();
        let ids: Vec<&str> = cells.iter().map(|c| c.spec.id.as_str()).collect();
        assert_eq!(
            ids,
            [
                "forward_plus@one_light[grid=8x8x8,lights=4]",
                "forward_plus@one_light[grid=4x4x4,lights=4]",
                "forward_plus@one_light[grid=8x8x8,lights=8]",
                "forward_plus@one_light[grid=4x4x4,lights=8]",
                // Not clustered: one cell per light count, whatever the grid.
                "deferred_scissor@one_light[lights=4]",
                "deferred_scissor@one_light[lights=8]",
                "naive_forward@one_light[lights=4]",
                "naive_forward@one_light[lights=8]",
            ]
        );
        assert_eq!(cells[1].spec.grid, Some([4, 4, 4]));
        assert_eq!(cells[1].spec.params.lights, 4);
        assert_eq!(cells[6].spec.group, "baseline");
        assert!(cells[6].spec.is_naive_baseline());
    }

    #[test]
    fn a_group_with_naive_forward_needs_no_extra_baseline_and_a_bad_scene_is_named() {
        let cells = expand(&[group(&["naive_forward", "forward_plus"], vec![])]).unwrap();
        assert_eq!(cells.len(), 2);
        let mut s = group(&["forward_plus"], vec![]);
        s.scenes = vec!["moon".into()];
        let e = expand(&[s]).unwrap_err();
        assert!(
            e.contains("unknown scene `moon`") && e.contains("atrium"),
            "{e}"
        );
    }

    #[test]
    fn shards_split_the_cells_without_overlap() {
        let s = group(
            &[
                "forward_plus",
                "clustered_deferred_16x16x24",
                "naive_forward",
            ],
            vec![Sweep::Lights(vec![1, 2, 3])],
        );
        let all: Vec<String> = expand(std::slice::from_ref(&s))
            .unwrap()
            .into_iter()
            .map(|c| c.spec.id)
            .collect();
        let mut seen = Vec::new();
        for k in 1..=4 {
            let part = shard(expand(std::slice::from_ref(&s)).unwrap(), (k, 4));
            seen.extend(part.into_iter().map(|c| c.spec.id));
        }
        seen.sort();
        let mut expected = all.clone();
        expected.sort();
        assert_eq!(seen, expected);
        assert_eq!(parse_shard("2/4"), Ok((2, 4)));
        assert!(parse_shard("5/4").is_err());
        assert!(parse_shard("0/4").is_err());
        assert!(parse_shard("1-4").is_err());
    }
}
