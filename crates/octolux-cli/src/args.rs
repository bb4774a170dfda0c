//! The command line: clap structures, their parsers, and the key paths the integrator flags
//! write in the integrator settings (see [`crate::settings`]).

use crate::settings::FlagSetting;
use clap::{Parser, Subcommand, ValueEnum};
use octolux::integrators::IntegratorSettings;
use serde_json::{json, Value};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "octolux",
    version,
    about = "Offline renderer with a photon-built octree of incident radiance (Pacanowski, Granier & Schlick 2005)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene to OUT.exr, OUT.png and OUT.json.
    Render(Box<RenderArgs>),
    /// Trace the photons and build the `octree` integrator's global and caustic octrees, and
    /// write them to a lighting cache file (`render --cache` renders any camera from it).
    Bake(Box<BakeArgs>),
    /// Write a scene as Mitsuba 3 XML (meshes as PLY files in a `meshes/` folder beside it).
    Export(ExportArgs),
    /// List the built-in scenes.
    Scenes,
    /// Write one self-contained HTML page comparing images: side by side with an exposure
    /// control, a split slider, error maps (relative squared error, FLIP) and a metrics table
    /// against `--reference`, and error-against-time plots of `--bench` results.
    Report {
        /// The images to compare (EXR).
        #[arg(required = true)]
        images: Vec<PathBuf>,
        /// The reference the errors are measured against (EXR).
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Benchmark results to plot: JSON `{"title": ..., "series": [{"name", "time_s": [..], "rel_mse": [..]}]}`.
        #[arg(long)]
        bench: Vec<PathBuf>,
        /// The HTML file to write.
        #[arg(short, long, default_value = "report.html")]
        output: PathBuf,
    },
    /// Measure the flicker of numbered frames (NAME_0001.exr, ...) against reference frames:
    /// temporal relMSE of frame differences, and with --scene and --camera-path the spread over
    /// frames of static points' values (JSON on stdout; docs/baking.md).
    Flicker(FlickerArgs),
    /// Compare an image with a reference: relMSE, RMSE and channel means (JSON on stdout).
    Compare {
        /// The image to judge (EXR).
        image: PathBuf,
        /// The reference (EXR).
        reference: PathBuf,
    },
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum ViewArg {
    /// The rendered image.
    Render,
    /// Irradiance from the global cache at the first diffuse/glossy hit (paper fig. 2).
    Irradiance,
    /// Irradiance from the global and caustic caches.
    IrradianceAll,
    /// octree: the octree's leaves (depth as colour, borders dark, atmospheric cells black).
    Leaves,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum AddedArg {
    /// Christensen's method alone.
    None,
    /// Configuration C: added samples take the nearest irradiance photon's value.
    Precomputed,
    /// Configuration C: added samples take the global map's density estimate.
    Density,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum EstimatorArg {
    Paper,
    Cosine,
    GeometryArea,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum SplitArg {
    Direction,
    Normal,
}

/// The serde name of a clap value (`geometry-area` -> `geometry_area`): the settings enums are
/// `rename_all = "snake_case"`, clap's values kebab-case.
fn serde_name<T: ValueEnum>(v: T) -> Value {
    let name = v.to_possible_value().map(|p| p.get_name().replace('-', "_")).unwrap_or_default();
    Value::String(name)
}

/// Options of the cache integrators. Each is a shortcut for one or more settings keys
/// (`--set KEY=VALUE` reaches every key; see [`OctreeArgs::settings`]).
#[derive(clap::Args)]
pub struct OctreeArgs {
    /// Photon paths emitted from the lights (octree and the baselines; default 1000000).
    #[arg(long)]
    pub photons: Option<u64>,
    /// Removed: the octree reads its cache one bounce away by default now (`mode = terminate`);
    /// `--set mode=paper` reads it at the first surface, as the paper did.
    #[arg(long, hide = true)]
    pub gather: bool,
    /// octree: maximum octree depth h_max, a number or `auto` (the global tree's default: from
    /// the photon count, n_max and the scene's surface area).
    #[arg(long)]
    pub h_max: Option<String>,
    /// octree: wanted least photons per leaf.
    #[arg(long)]
    pub n_min: Option<u32>,
    /// octree: photons above which a cell is split.
    #[arg(long)]
    pub n_max: Option<u32>,
    /// octree: cell enlargement for photon gathering.
    #[arg(long)]
    pub epsilon: Option<f32>,
    /// octree: query box side in units of the smallest leaf.
    #[arg(long)]
    pub alpha: Option<f32>,
    /// octree: estimator of the leaf matrices.
    #[arg(long, value_enum)]
    pub estimator: Option<EstimatorArg>,
    /// octree: how photons go to the six axis matrices: `direction` (the paper's, by the sign
    /// of the incident direction) or `normal` (by the side of the surface they landed on; the
    /// integrator's default, exact for planes of any orientation).
    #[arg(long, value_enum)]
    pub split: Option<SplitArg>,
    /// octree: store full f32 matrices instead of the paper's 36-byte compressed leaves.
    #[arg(long)]
    pub uncompressed: bool,
    /// What to write into the image (default: render; `leaves` for octree only).
    #[arg(long, value_enum)]
    pub view: Option<ViewArg>,
    /// Trace the photons and build the cache on this scene instead (same -D defines), then
    /// render SCENE with it: e.g. a cache built on simplified geometry, rendered on detailed
    /// geometry (the paper's figure 4).
    #[arg(long, value_name = "SCENE")]
    pub cache_scene: Option<String>,
    /// christensen: precompute irradiance at every N-th global photon (default 4).
    #[arg(long, value_name = "N")]
    pub every: Option<u32>,
    /// christensen: samples added during rendering (the paper's configuration C; default none).
    #[arg(long, value_enum)]
    pub added: Option<AddedArg>,
    /// octree: h_max of the caustic octree (default: the integrator's).
    #[arg(long)]
    pub caustic_h_max: Option<u32>,
    /// octree: n_max of the caustic octree (default: the integrator's; lowers its n_min to
    /// at most this).
    #[arg(long)]
    pub caustic_n_max: Option<u32>,
}

/// A depth flag's value: a number stays a number (so that it is checked as a depth), any other
/// word a string (`auto`, or an error naming the key when the settings are read).
fn depth_value(v: &str) -> Value {
    v.parse::<u64>().map_or_else(|_| Value::from(v), |n| json!(n))
}

impl OctreeArgs {
    /// Refuse the flags that were removed, saying what replaced them.
    pub fn check_removed(&self) -> anyhow::Result<()> {
        if self.gather {
            anyhow::bail!(
                "--gather was removed: the octree now reads its cache one bounce from the camera where the path is wide enough \
                 (the default, `--set mode=terminate`; docs/octree.md, \"Ending paths in the cache\"); `--set mode=paper` reads it at \
                 the first surface, as the paper did"
            );
        }
        Ok(())
    }

    /// The settings keys the given flags write, in the order given above. A flag scoped to one
    /// integrator (`octree:` in its help) warns with any other; an unscoped one warns with an
    /// integrator that has none of its keys.
    pub fn settings(&self) -> Vec<FlagSetting> {
        fn both_trees(k: &str) -> Vec<String> {
            vec![format!("global.{k}"), format!("caustic.{k}")]
        }
        let mut f = Vec::new();
        let mut add = |flag: &'static str, only: Option<&'static str>, keys: Vec<String>, value: Option<Value>| {
            if let Some(value) = value {
                f.push(FlagSetting { flag, only, keys, value, at_most: false });
            }
        };
        let oct = Some("octree");
        add("--photons", None, vec![keys::PHOTON_COUNT.into()], self.photons.map(|v| json!(v)));
        add("--h-max", oct, both_trees("h_max"), self.h_max.as_deref().map(depth_value));
        add("--n-min", oct, both_trees("n_min"), self.n_min.map(|v| json!(v)));
        add("--n-max", oct, both_trees("n_max"), self.n_max.map(|v| json!(v)));
        add("--epsilon", oct, both_trees("epsilon"), self.epsilon.map(|v| json!(v)));
        add("--alpha", oct, both_trees("alpha"), self.alpha.map(|v| json!(v)));
        add("--estimator", oct, both_trees("estimator"), self.estimator.map(serde_name));
        add("--split", oct, both_trees("split"), self.split.map(serde_name));
        add("--uncompressed", oct, both_trees("storage"), self.uncompressed.then(|| Value::from("full")));
        add("--view", None, vec!["view".into()], self.view.map(serde_name));
        add("--every", Some("christensen"), vec!["every".into()], self.every.map(|v| json!(v)));
        add("--added", Some("christensen"), vec!["added".into()], self.added.map(serde_name));
        add("--caustic-h-max", oct, vec!["caustic.h_max".into()], self.caustic_h_max.map(|v| json!(v)));
        add("--caustic-n-max", oct, vec!["caustic.n_max".into()], self.caustic_n_max.map(|v| json!(v)));
        if let Some(v) = self.caustic_n_max {
            // a caustic tree split at n_max keeps n_min <= n_max
            f.push(FlagSetting { flag: "--caustic-n-max", only: oct, keys: vec!["caustic.n_min".into()], value: json!(v), at_most: true });
        }
        f
    }
}

/// Settings keys the CLI itself names (the flags above, and the values it derives from the
/// scene and the render: `max_depth`, the photon seed).
pub use octolux_io::settings::keys;

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum ReconstructionArg {
    Splat,
    Importance,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum SamplerArg {
    Independent,
    Sobol,
}

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum BackendArg {
    Auto,
    Embree,
    Bvh,
}

#[derive(clap::Args)]
pub struct SceneArgs {
    /// Built-in scene name (cornell-box, cornell-spheres), Mitsuba XML file, or OBJ/PLY mesh.
    #[arg(default_value = "cornell-box")]
    pub scene: String,
    /// Override a Mitsuba `<default>` parameter: -D name=value (repeatable; the last of a
    /// name wins, with a warning).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<String>,
    /// glTF: let buffer and image URIs name files outside the glTF file's folder (absolute
    /// paths, `../`); refused by default.
    #[arg(long)]
    pub allow_outside_uris: bool,
}

#[derive(clap::Args)]
pub struct RenderArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// path: path tracing with NEE and MIS (the reference); octree: the paper's ray tracer over
    /// a global and a caustic incident-radiance octree; photonmap: Jensen's photon map with
    /// final gathering; ward: Ward's irradiance cache, samples from the photons; christensen:
    /// Christensen's precomputed irradiance photons. Default: the settings file's `type`, else
    /// path.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(IntegratorSettings::NAMES))]
    pub integrator: Option<String>,
    /// Integrator settings as JSON or TOML (by extension; the `integrator_settings` of an
    /// out.json works): keys as in `--set`, an optional `type` naming the integrator.
    #[arg(long, value_name = "FILE")]
    pub settings: Option<PathBuf>,
    /// Set one integrator setting: a dotted key and a value, parsed as JSON when it parses,
    /// else taken as a string (e.g. `--set photons.photons=2000000`, `--set view=irradiance`).
    /// Repeatable; wins over the flags, which win over --settings.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Samples per pixel (default: the scene's sampler, else 64). With --time-budget: per pass.
    #[arg(long)]
    pub spp: Option<u32>,
    /// Image size WxH (default: the scene's film).
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// Longest path in vertices, Mitsuba's meaning (default: the scene's, else -1 = unbounded).
    #[arg(long, allow_negative_numbers = true)]
    pub max_depth: Option<i32>,
    /// Seed of the render and of the photon pass.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Keep adding passes of --spp samples until this many seconds have passed.
    #[arg(long)]
    pub time_budget: Option<f64>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Memory limit for sizes read from the input (film, photons, meshes, images): bytes with
    /// an optional K, M, G or T suffix. Default: $OCTOLUX_MEMORY_LIMIT, else 3/4 of the
    /// machine's memory.
    #[arg(long, value_name = "SIZE")]
    pub memory_limit: Option<String>,
    /// Ray-intersection backend.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendArg,
    /// How the film's filter is applied: `splat` (uniform positions in the pixel, weighted into
    /// the neighbours, as Mitsuba 3 does; about 2.25x less pixel noise with a tent) or
    /// `importance` (positions drawn from the filter, one pixel per sample).
    #[arg(long, value_enum, default_value = "splat")]
    pub reconstruction: ReconstructionArg,
    /// The numbers behind every sample: `sobol` (Owen-scrambled Sobol' points, stratified per
    /// pixel: 1.2-2.5x lower relMSE at equal spp for path and octree, docs/performance.md) or
    /// `independent` (uniform random, as Mitsuba's `independent`).
    #[arg(long, value_enum, default_value = "sobol")]
    pub sampler: SamplerArg,
    #[command(flatten)]
    pub octree: OctreeArgs,
    /// Render from a lighting cache written by `octolux bake` (the `octree` integrator, no
    /// photon traced). Refused when the scene's geometry, materials or emitters differ from
    /// the bake's; camera and film may change.
    #[arg(long, value_name = "FILE.oxc")]
    pub cache: Option<PathBuf>,
    /// With --cache: render even when the scene's geometry, materials or emitters changed
    /// since the bake (a warning says which).
    #[arg(long, requires = "cache")]
    pub allow_stale_cache: bool,
    /// Render the frames of a camera path (JSON or TOML keyframes: time, position, target,
    /// up, fov; `fps`) to OUT_0001.exr, OUT_0002.exr, ... from one cache.
    #[arg(long, value_name = "FILE", conflicts_with = "sensors")]
    pub camera_path: Option<PathBuf>,
    /// Render every <sensor> of the scene file as a frame, OUT_0001.exr, ... from one cache.
    #[arg(long)]
    pub sensors: bool,
    /// With --camera-path, --sensors or --insert-path: render frames A to B only (from 1, both
    /// included).
    #[arg(long, value_name = "A..B", value_parser = parse_frames)]
    pub frames: Option<(u64, u64)>,
    /// Insert an object absent from the lighting (OBJ, PLY, or the shapes of a Mitsuba XML
    /// file): with the octree integrator its indirect light comes from the baked volume
    /// (docs/baking.md); the cache's fingerprint is checked without it.
    #[arg(long, value_name = "OBJECT")]
    pub insert: Option<String>,
    /// Move the inserted object over frames: JSON keyframes (time, position, rotate_y, scale;
    /// fps). Without --camera-path or --sensors it makes the frames (the scene's camera).
    #[arg(long, value_name = "PATH.json", requires = "insert")]
    pub insert_path: Option<PathBuf>,
    /// Ambient-occlusion correction of the baked indirect light around the inserted object:
    /// rays per shading point (default 0: none).
    #[arg(long, value_name = "RAYS", requires = "insert")]
    pub insert_ao: Option<u32>,
    /// Length of those rays (default: the object's bounding-box diagonal).
    #[arg(long, value_name = "LENGTH", requires = "insert")]
    pub insert_ao_distance: Option<f32>,
    /// Output image path; `.exr` (and `.png`, `.json` beside it).
    #[arg(short, long, default_value = "out.exr")]
    pub output: PathBuf,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(clap::Args)]
pub struct FlickerArgs {
    /// Folder of the frames to judge (NAME_0001.exr, NAME_0002.exr, ...).
    pub frames: PathBuf,
    /// Folder of the reference frames, with the same frame numbers.
    #[arg(long)]
    pub reference: PathBuf,
    /// The scene the frames show: static points are followed through it (needs --camera-path).
    #[arg(long)]
    pub scene: Option<String>,
    /// Override a Mitsuba `<default>` parameter of --scene: -D name=value (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<String>,
    /// The camera path the frames were rendered along (frame numbers are its frames).
    #[arg(long, value_name = "FILE")]
    pub camera_path: Option<PathBuf>,
    /// About this many static points, seen through a grid of the first frame's pixels.
    #[arg(long, default_value_t = 4096)]
    pub points: u32,
    /// Pixels left out on every side of every frame.
    #[arg(long, default_value_t = 0)]
    pub border: u32,
}

#[derive(clap::Args)]
pub struct BakeArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The lighting cache to write (e.g. lighting.oxc).
    #[arg(short, long)]
    pub output: PathBuf,
    /// `octree` settings as JSON or TOML (as for `render --settings`).
    #[arg(long, value_name = "FILE")]
    pub settings: Option<PathBuf>,
    /// Set one `octree` setting (as for `render --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Longest path in vertices, Mitsuba's meaning (default: the scene's, else -1).
    #[arg(long, allow_negative_numbers = true)]
    pub max_depth: Option<i32>,
    /// Seed of the photon pass (a render reproduces an uncached one with the same --seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Memory limit for sizes read from the input (as for `render`).
    #[arg(long, value_name = "SIZE")]
    pub memory_limit: Option<String>,
    /// Ray-intersection backend.
    #[arg(long, value_enum, default_value = "auto")]
    pub backend: BackendArg,
    #[command(flatten)]
    pub octree: OctreeArgs,
    /// No statistics on the log.
    #[arg(long, short)]
    pub quiet: bool,
}

/// `A..B` (both included, from 1) or `A`.
fn parse_frames(s: &str) -> Result<(u64, u64), String> {
    let num = |t: &str| t.trim().parse::<u64>().map_err(|_| format!("'{s}' is not a frame range A..B (e.g. 2..5)"));
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (num(a)?, num(b.trim_start_matches('='))?),
        None => (num(s)?, num(s)?),
    };
    if a == 0 || b < a {
        return Err(format!("frame range {a}..{b}: frames count from 1 and B must not be below A"));
    }
    Ok((a, b))
}

#[derive(clap::Args)]
pub struct ExportArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Output XML path.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    #[arg(long, default_value_t = -1, allow_negative_numbers = true)]
    pub max_depth: i32,
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WxH (e.g. 512x512)"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 || w > 32768 || h > 32768 {
        return Err(format!("resolution {w}x{h} is out of range 1..32768"));
    }
    Ok((w, h))
}
