//! The command line: clap structures, their parsers, and the key paths the integrator flags
//! write in the integrator settings (see `octolux_io::settings`).

use clap::builder::PossibleValue;
use clap::{Parser, Subcommand};
use octolux::accel::BackendKind;
use octolux::film::Reconstruction;
use octolux::integrators::IntegratorSettings;
use octolux::sampling::SamplerKind;
use octolux_io::job;
use octolux_io::settings::FlagSetting;
use serde_json::{json, Value};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "octolux",
    version,
    long_version = long_version(),
    about = "Offline renderer with a photon-built octree of incident radiance (Pacanowski, Granier & Schlick 2005)"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// `octolux --version`: the version and the level of the hot kernels (`octolux::cpu`).
fn long_version() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| format!("{}\n{}", env!("CARGO_PKG_VERSION"), octolux::cpu::describe()))
}

#[derive(Subcommand)]
pub enum Command {
    /// Render a scene to OUT.exr, OUT.png and OUT.json.
    Render(Box<RenderArgs>),
    /// Trace the photons and build the `octree` integrator's global and caustic octrees, and
    /// write them to a lighting cache file (`render --cache` renders any camera from it).
    Bake(Box<BakeArgs>),
    /// Serve a page that draws the scene in a browser (WebGL2), lit by the octree's indirect
    /// light evaluated on the GPU, the octree streamed coarse to fine (docs/guide/viewer.md).
    View(Box<ViewArgs>),
    /// Write a scene as Mitsuba 3 XML (meshes as PLY files in a `meshes/` folder beside it).
    Export(ExportArgs),
    /// List the built-in scenes.
    Scenes,
    /// List an integrator's settings: every key with its default, type and doc (the keys of
    /// `--set`, of `--settings` files and of Python's settings dict).
    Settings {
        /// The integrator (path, octree, photonmap, ward, christensen); none: list them.
        #[arg(value_parser = clap::builder::PossibleValuesParser::new(IntegratorSettings::NAMES))]
        integrator: Option<String>,
        /// Print the reference page of every integrator's settings (docs/guide/settings.md).
        #[arg(long, conflicts_with = "integrator")]
        markdown: bool,
    },
    /// Write one self-contained HTML page comparing images: side by side with an exposure
    /// control, a split slider, error maps (relative squared error, FLIP) and a metrics table
    /// against `--reference`, and error-against-time plots of `--bench` results.
    Report {
        /// The images to compare (EXR or HDR; PNG or JPEG decoded from sRGB).
        #[arg(required = true)]
        images: Vec<PathBuf>,
        /// The reference the errors are measured against (EXR or HDR; PNG or JPEG decoded from sRGB).
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
    /// frames of static points' values (JSON on stdout; docs/guide/baking.md).
    Flicker(FlickerArgs),
    /// Compare an image with a reference: relMSE, RMSE and channel means (JSON on stdout).
    /// Images are EXR or HDR (linear), or PNG or JPEG (8 bits, decoded from sRGB to linear:
    /// clamped to [0, 1], so the errors of bright pixels are lost).
    Compare {
        /// The image to judge (EXR, HDR, PNG or JPEG).
        image: PathBuf,
        /// The reference (EXR, HDR, PNG or JPEG).
        reference: PathBuf,
    },
}

/// A clap value parser for a library enum, read through serde: the values and their help
/// come from the enum itself (`octolux::type_docs`), so each enum is defined once; `-` may
/// stand for `_` (`importance-sampled`), as in every settings value.
#[derive(Clone)]
pub struct SerdeEnum<T>(std::marker::PhantomData<fn() -> T>);

/// The parser of the enum `T` ([`SerdeEnum`]).
pub fn serde_enum<T>() -> SerdeEnum<T> {
    SerdeEnum(std::marker::PhantomData)
}

/// The serde names of the enums called `types` (last path segment), and each variant's first
/// sentence of doc; a name met twice is listed once.
pub fn enum_values(types: &[&str]) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    for name in types {
        for t in octolux::type_docs::find(name.rsplit("::").next().unwrap_or(name)) {
            if let octolux::type_docs::TypeKind::Enum(vs) = t.kind {
                for v in vs {
                    let n = t.serde_name(v.name, v.rename);
                    if !out.iter().any(|(o, _)| *o == n) {
                        let doc = v.doc.split(". ").next().unwrap_or("").trim_end_matches('.').replace('\n', " ");
                        out.push((n, doc));
                    }
                }
            }
        }
    }
    out
}

fn invalid(cmd: &clap::Command, arg: Option<&clap::Arg>, value: &str, valid: &[(String, String)]) -> clap::Error {
    let names: Vec<&str> = valid.iter().map(|(n, _)| n.as_str()).collect();
    let arg = arg.map_or_else(|| "the value".to_string(), |a| format!("'{a}'"));
    clap::Error::raw(
        clap::error::ErrorKind::InvalidValue,
        format!("invalid value '{value}' for {arg}: expected one of {}\n", names.join(", ")),
    )
    .with_cmd(cmd)
}

impl<T: serde::de::DeserializeOwned + Clone + Send + Sync + 'static> clap::builder::TypedValueParser for SerdeEnum<T> {
    type Value = T;
    fn parse_ref(&self, cmd: &clap::Command, arg: Option<&clap::Arg>, value: &std::ffi::OsStr) -> Result<T, clap::Error> {
        let s = value.to_string_lossy();
        serde_json::from_value(Value::String(s.replace('-', "_")))
            .map_err(|_| invalid(cmd, arg, &s, &enum_values(&[std::any::type_name::<T>()])))
    }
    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        let values = enum_values(&[std::any::type_name::<T>()]);
        Some(Box::new(values.into_iter().map(|(n, d)| PossibleValue::new(n).help(d))))
    }
}

/// A value of any of the enums called `types`, kept as the string the settings then read (a
/// key whose enum differs between integrators: `view`).
#[derive(Clone)]
pub struct EnumNames(pub &'static [&'static str]);

impl clap::builder::TypedValueParser for EnumNames {
    type Value = String;
    fn parse_ref(&self, cmd: &clap::Command, arg: Option<&clap::Arg>, value: &std::ffi::OsStr) -> Result<String, clap::Error> {
        let s = value.to_string_lossy().replace('-', "_");
        let valid = enum_values(self.0);
        if valid.iter().any(|(n, _)| *n == s) {
            Ok(s)
        } else {
            Err(invalid(cmd, arg, &value.to_string_lossy(), &valid))
        }
    }
    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(enum_values(self.0).into_iter().map(|(n, d)| PossibleValue::new(n).help(d))))
    }
}

/// The settings keys most renders set. Every other key is given with `--set KEY=VALUE`, a
/// `--settings` file or Python's settings dict (`octolux settings INTEGRATOR` lists them).
#[derive(clap::Args)]
pub struct CommonKeys {
    /// Photon paths emitted from the lights (`photons.photons`; octree and the baselines;
    /// default 1000000).
    #[arg(long)]
    pub photons: Option<u64>,
    /// What to write into the image (`view`; default: render; `leaves` for octree only).
    #[arg(long, value_parser = EnumNames(&["OctreeView", "CacheView"]))]
    pub view: Option<String>,
}

impl CommonKeys {
    /// The settings keys the given flags write.
    pub fn settings(&self) -> Vec<FlagSetting> {
        let mut f = Vec::new();
        if let Some(n) = self.photons {
            f.push(FlagSetting { flag: "--photons", only: None, keys: vec![keys::PHOTON_COUNT.into()], value: json!(n), at_most: false });
        }
        if let Some(v) = &self.view {
            f.push(FlagSetting { flag: "--view", only: None, keys: vec!["view".into()], value: json!(v), at_most: false });
        }
        f
    }
}

/// Flags that were removed, and what replaced them: refused with that message before the
/// command line is parsed (so that an old command says what to type, not only "unexpected
/// argument").
pub const REMOVED_FLAGS: &[(&str, &str)] = &[
    (
        "--gather",
        "the octree now reads its cache one bounce from the camera where the path is wide enough (the default, `--set \
         mode=terminate`; docs/guide/octree.md, \"Ending paths in the cache\"); `--set mode=paper` reads it at the first surface, \
         as the paper did",
    ),
    ("--h-max", "use `--set global.h_max=N` (and `caustic.h_max`)"),
    ("--n-min", "use `--set global.n_min=N` (and `caustic.n_min`)"),
    ("--n-max", "use `--set global.n_max=N` (and `caustic.n_max`)"),
    ("--epsilon", "use `--set global.epsilon=X` (and `caustic.epsilon`)"),
    ("--alpha", "use `--set global.alpha=X` (and `caustic.alpha`)"),
    ("--estimator", "use `--set global.estimator=NAME` (and `caustic.estimator`)"),
    ("--split", "use `--set global.split=NAME` (and `caustic.split`)"),
    ("--uncompressed", "use `--set global.storage=full --set caustic.storage=full`"),
    ("--every", "use `--set every=N` (christensen)"),
    ("--added", "use `--set added=NAME` (christensen)"),
    ("--caustic-h-max", "use `--set caustic.h_max=N`"),
    ("--caustic-n-max", "use `--set caustic.n_max=N` (and `caustic.n_min` at most that)"),
];

/// The message for a removed flag among `args`, if any.
pub fn removed_flag(args: &[String]) -> Option<String> {
    // only the arguments before a `--` (none of octolux's commands take one)
    args.iter().skip(1).take_while(|a| *a != "--").find_map(|a| {
        let name = a.split('=').next().unwrap_or(a);
        REMOVED_FLAGS
            .iter()
            .find(|(f, _)| *f == name)
            .map(|(f, what)| format!("{f} was removed: {what}; `octolux settings INTEGRATOR` lists every key"))
    })
}

/// Settings keys the CLI itself names (the flags above, and the values it derives from the
/// scene and the render: `max_depth`, the photon seed).
pub use octolux_io::settings::keys;

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
    #[arg(long, value_parser = serde_enum::<BackendKind>(), default_value = "auto")]
    pub backend: BackendKind,
    /// How the film's filter is applied: `splat` (uniform positions in the pixel, weighted into
    /// the neighbours, as Mitsuba 3 does; about 2.25x less pixel noise with a tent) or
    /// `importance_sampled` (positions drawn from the filter, one pixel per sample).
    #[arg(long, value_parser = serde_enum::<Reconstruction>(), default_value = "splat")]
    pub reconstruction: Reconstruction,
    /// The numbers behind every sample: `sobol` (Owen-scrambled Sobol' points, stratified per
    /// pixel: 1.2-2.5x lower relMSE at equal spp for path and octree, docs/guide/performance.md)
    /// or `independent` (uniform random, as Mitsuba's `independent`).
    #[arg(long, value_parser = serde_enum::<SamplerKind>(), default_value = "sobol")]
    pub sampler: SamplerKind,
    #[command(flatten)]
    pub keys: CommonKeys,
    /// Trace the photons and build the cache on this scene instead (same -D defines), then
    /// render SCENE with it: e.g. a cache built on simplified geometry, rendered on detailed
    /// geometry (the paper's figure 4). The leak test runs in SCENE, where the rays are.
    #[arg(long, value_name = "SCENE")]
    pub cache_scene: Option<String>,
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
    /// Render every `<sensor>` of the scene file as a frame, OUT_0001.exr, ... from one cache.
    #[arg(long)]
    pub sensors: bool,
    /// With --camera-path, --sensors or --insert-path: render frames A to B only (from 1, both
    /// included).
    #[arg(long, value_name = "A..B", value_parser = parse_frames)]
    pub frames: Option<(u64, u64)>,
    /// Insert an object absent from the lighting (OBJ, PLY, or the shapes of a Mitsuba XML
    /// file): with the octree integrator its indirect light comes from the baked volume
    /// (docs/guide/baking.md); the cache's fingerprint is checked without it.
    #[arg(long, value_name = "OBJECT")]
    pub insert: Option<String>,
    /// Move the inserted object over frames: JSON keyframes (time, position, rotate_y, scale;
    /// fps). Without --camera-path or --sensors it makes the frames (the scene's camera).
    #[arg(long, value_name = "PATH.json", requires = "insert")]
    pub insert_path: Option<PathBuf>,
    /// Where the inserted object's light comes from with the octree integrator: `rebake`
    /// (default: the photon paths it meets are traced again each frame, so it casts its
    /// indirect shadow and bleeds its colour) or `volume` (the baked volumetric values, read on
    /// the object; the scene's light stays as baked).
    #[arg(long, value_name = "rebake|volume", requires = "insert", value_parser = ["rebake", "volume"])]
    pub insert_light: Option<String>,
    /// Ambient-occlusion correction of the baked indirect light around the inserted object:
    /// rays per shading point (default 0: none).
    #[arg(long, value_name = "RAYS", requires = "insert")]
    pub insert_ao: Option<u32>,
    /// Length of those rays (default: the object's bounding-box diagonal).
    #[arg(long, value_name = "LENGTH", requires = "insert", allow_negative_numbers = true)]
    pub insert_ao_distance: Option<f32>,
    /// Output image path; `.exr` (and `.png`, `.json` beside it).
    #[arg(short, long, default_value = "out.exr")]
    pub output: PathBuf,
    /// Warnings and errors only: no log and no progress. Without -q the progress is a bar on a
    /// terminal, else a line on stderr every 5 seconds (`$OCTOLUX_PROGRESS_SECONDS`).
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
    /// Also store the volumetric solution that `render --insert-light volume` reads: a
    /// free-space tree valued by the photons' flights (without it such a render computes it at
    /// its start). About 1.9 times the bytes on the cornell-box.
    #[arg(long)]
    pub volume: bool,
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
    #[arg(long, value_parser = serde_enum::<BackendKind>(), default_value = "auto")]
    pub backend: BackendKind,
    #[command(flatten)]
    pub keys: CommonKeys,
    /// Warnings and errors only: no log.
    #[arg(long, short)]
    pub quiet: bool,
}

impl RenderArgs {
    /// The library's render job these arguments ask for (`warnings`: those of the flags).
    pub fn job(&self, warnings: Vec<String>) -> anyhow::Result<job::RenderJob> {
        let insert = match &self.insert {
            Some(file) => Some(job::insert::InsertRequest {
                file: file.clone(),
                path: self.insert_path.clone(),
                ao: self.insert_ao,
                ao_distance: self.insert_ao_distance,
                light: match self.insert_light.as_deref() {
                    Some("volume") => job::insert::InsertLight::Volume,
                    _ => job::insert::InsertLight::Rebake,
                },
            }),
            None => {
                if self.insert_path.is_some()
                    || self.insert_ao.is_some()
                    || self.insert_ao_distance.is_some()
                    || self.insert_light.is_some()
                {
                    anyhow::bail!("--insert-path, --insert-light and --insert-ao need --insert OBJECT");
                }
                None
            }
        };
        Ok(job::RenderJob {
            scene: crate::scene_spec(&self.scene)?,
            integrator: job::IntegratorRequest {
                integrator: self.integrator.clone(),
                settings_file: self.settings.clone(),
                flags: self.keys.settings(),
                sets: self.set.clone(),
                seed: self.seed,
                spelling: Default::default(),
            },
            spp: self.spp,
            resolution: self.resolution,
            max_depth: self.max_depth,
            time_budget_s: self.time_budget,
            backend: self.backend,
            reconstruction: self.reconstruction,
            sampler: self.sampler,
            cache: self.cache.clone(),
            allow_stale_cache: self.allow_stale_cache,
            cache_scene: self.cache_scene.clone(),
            camera_path: self.camera_path.clone(),
            sensors: self.sensors,
            frames: self.frames,
            insert,
            output: self.output.clone(),
            command_line: std::env::args().collect(),
            warnings,
        })
    }
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

#[derive(clap::Args)]
pub struct ViewArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The lighting cache to show (`octolux bake`); without it the photons are traced and the
    /// octrees built first, as a bake would.
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Show a cache whose scene's lighting changed since the bake (a warning).
    #[arg(long)]
    pub allow_stale_cache: bool,
    /// The port to listen on (0: any free port, printed).
    #[arg(long, default_value_t = 8377)]
    pub port: u16,
    /// The address to listen on: 127.0.0.1 unless given (another address lets other machines
    /// load the page and the scene's data).
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: std::net::IpAddr,
    /// Do not open the page in the default browser.
    #[arg(long)]
    pub no_open: bool,
    /// Canvas width in pixels (default: the film's, at most 640); the height keeps its aspect.
    #[arg(long)]
    pub width: Option<u32>,
    /// Also serve the CPU query's irradiance image, which the page compares its own with (the
    /// result goes to `data-*` attributes of its body and to the log).
    #[arg(long)]
    pub compare_cpu: bool,
    /// Stop once the page has drawn the whole octree and reported (tests, scripts).
    #[arg(long)]
    pub exit_when_done: bool,
    /// `octree` settings as JSON or TOML (without --cache).
    #[arg(long, value_name = "FILE")]
    pub settings: Option<PathBuf>,
    /// Set one `octree` setting (without --cache).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Seed of the photon pass (without --cache).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Photon paths emitted from the lights (without --cache; default 1000000).
    #[arg(long)]
    pub photons: Option<u64>,
    /// Ray-intersection backend.
    #[arg(long, value_parser = serde_enum::<BackendKind>(), default_value = "auto")]
    pub backend: BackendKind,
    /// Warnings and errors only: no log.
    #[arg(long, short)]
    pub quiet: bool,
}
