//! The headless subcommands. Each prints a readable report, or one JSON object with `--json`.

mod bench;
mod deform;
mod export;
mod export_bones;
mod info;
mod render;
mod subdivide;

use clap::{Parser, Subcommand, ValueEnum};
use solver::animation::scene::{LoadedScene, SceneError};
use std::path::{Path, PathBuf};

/// BS-ARAP mesh deformation: editor and headless tools.
#[derive(Debug, Parser)]
#[command(name = "bsarap", version, about)]
pub struct Cli {
    /// Without a subcommand, `bsarap` opens the editor on the default mesh.
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Read the files a mesh refers to (glTF buffers and images, OBJ material libraries) even
    /// outside the mesh's folder: absolute paths, `..` out of it, links out of it. Off by
    /// default, so that a downloaded asset cannot carry another of your files into an export.
    #[arg(long, global = true)]
    pub allow_outside_references: bool,
}

/// `--allow-outside-references`, set once by [`run`] before any subcommand loads a file.
static ALLOW_OUTSIDE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The reference policy the command line asked for.
pub fn reference_policy() -> solver::io::ReferencePolicy {
    let allow_outside = ALLOW_OUTSIDE.load(std::sync::atomic::Ordering::Relaxed);
    solver::io::ReferencePolicy { allow_outside }
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Open the interactive editor (on the default mesh in assets/ when MESH is omitted).
    Edit(EditArgs),
    /// Mesh statistics after loading and cleaning (for a scene: its method, handles and timeline,
    /// then its mesh).
    Info(info::InfoArgs),
    /// Solve one pose from rest (a mesh's from --move and --rotate, or a scene's at a time) and
    /// write it as OBJ, glTF, PLY or OFF.
    Deform(deform::DeformArgs),
    /// The paper's animation benchmark: the first handle group moves on a circle.
    Bench(bench::BenchArgs),
    /// Play a scene's timeline headless (or a mesh's circle, --mesh) and write the recording:
    /// glTF with morph targets or a skin (--bones), a PC2 point cache, or an OBJ sequence.
    Export(export::ExportArgs),
    /// A dense test mesh: 1-to-4 midpoint subdivision, written as OBJ, PLY or OFF.
    Subdivide(subdivide::SubdivideArgs),
    /// Render a scene's timeline (or a turntable) offscreen to DIR/frame_0000.png, …
    Render(render::RenderArgs),
}

/// `bsarap edit [MESH]`.
#[derive(Debug, clap::Args)]
pub struct EditArgs {
    /// Mesh to open (OBJ, OFF, PLY, STL, glTF).
    pub mesh: Option<PathBuf>,
}

/// `--method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MethodArg {
    /// ARAP on the mesh.
    Arap,
    /// The paper's BS-ARAP (bi-harmonic base).
    Bsarap,
    /// BS-ARAP on a faired base (bi-Laplacian with a data term).
    BsarapFaired,
    /// BS-ARAP with ARAP on a decimated faired base.
    BsarapCoarse,
}

impl From<MethodArg> for solver::Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Arap => solver::Method::Arap,
            MethodArg::Bsarap => solver::Method::BsArap,
            MethodArg::BsarapFaired => solver::Method::BsArapFaired,
            MethodArg::BsarapCoarse => solver::Method::BsArapCoarse,
        }
    }
}

/// `--energy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum EnergyArg {
    SpokesAndRims,
    Spokes,
    /// Spokes plus rotation smoothness (SR-ARAP) with `--bending-length`.
    SmoothRotations,
}

impl From<EnergyArg> for solver::Energy {
    fn from(e: EnergyArg) -> Self {
        match e {
            EnergyArg::SpokesAndRims => solver::Energy::SpokesAndRims,
            EnergyArg::Spokes => solver::Energy::Spokes,
            EnergyArg::SmoothRotations => solver::Energy::SmoothRotations,
        }
    }
}

/// `--coarse-energy`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum CoarseEnergyArg {
    /// ARAP on the decimated base (the default).
    #[default]
    Decimated,
    /// The full mesh's energy restricted to the coarse space (needs --energy smooth-rotations).
    Galerkin,
}

impl From<CoarseEnergyArg> for solver::CoarseEnergy {
    fn from(e: CoarseEnergyArg) -> Self {
        match e {
            CoarseEnergyArg::Decimated => solver::CoarseEnergy::Decimated,
            CoarseEnergyArg::Galerkin => solver::CoarseEnergy::Galerkin,
        }
    }
}

/// Runs one subcommand; `matches` are the arguments as parsed (which flags were given).
pub fn run(cli: Cli, matches: &clap::ArgMatches) -> anyhow::Result<()> {
    if !matches!(cli.command, None | Some(Command::Edit(_))) {
        end_quietly_on_closed_pipe();
    }
    ALLOW_OUTSIDE.store(cli.allow_outside_references, std::sync::atomic::Ordering::Relaxed);
    match cli.command {
        None => app::editor::run(None, reference_policy()),
        Some(Command::Edit(a)) => app::editor::run(a.mesh, reference_policy()),
        Some(Command::Info(a)) => info::run(&a),
        Some(Command::Deform(a)) => {
            let given = matches.subcommand_matches("deform").unwrap_or(matches);
            deform::run(&a, given)
        }
        Some(Command::Bench(a)) => bench::run(&a),
        Some(Command::Export(a)) => export::run(&a),
        Some(Command::Subdivide(a)) => subdivide::run(&a),
        Some(Command::Render(a)) => render::run(&a),
    }
}

/// A headless subcommand whose reader has gone (`bsarap info MESH | head -3`) ends as other
/// Unix tools do, by the default action of `SIGPIPE`, instead of a panic in `println!` (Rust
/// ignores the signal, so a write to a closed pipe fails and `println!` panics on the error).
/// Not for the editor, whose log lines must never end it.
fn end_quietly_on_closed_pipe() {
    #[cfg(unix)]
    // SAFETY: `signal` with `SIG_DFL` only resets one disposition; called before any thread
    // of ours is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Loads and cleans a mesh, with the path in the error; its references under
/// [`reference_policy`].
pub fn load(path: &std::path::Path) -> anyhow::Result<solver::io::LoadedMesh> {
    Ok(solver::io::load_mesh_with(path, reference_policy())?)
}

/// Loads a handle selection (.dmat or sphere .json) for `mesh`.
pub fn load_handles(
    path: &std::path::Path,
    loaded: &solver::io::LoadedMesh,
) -> anyhow::Result<solver::Handles> {
    Ok(solver::deform::selection::load_selection_for(path, loaded)?)
}

/// The bending length for `--energy` and `--bending-length` (a fraction of the bounding-box
/// diagonal), shared by deform and bench: for smooth rotations (default
/// [`solver::deform::arap::DEFAULT_BENDING_LENGTH`]; its range is [`check_config`]'s), refused
/// with the other energies.
pub fn bending_length(energy: EnergyArg, fraction: Option<f64>) -> anyhow::Result<f64> {
    match (energy, fraction) {
        (EnergyArg::SmoothRotations, f) => {
            Ok(f.unwrap_or(solver::deform::arap::DEFAULT_BENDING_LENGTH))
        }
        (_, Some(_)) => anyhow::bail!("--bending-length applies to --energy smooth-rotations only"),
        (_, None) => Ok(solver::deform::arap::DEFAULT_BENDING_LENGTH),
    }
}

/// The `--energy` line of a report: the name, and for smooth rotations the bending length as a
/// fraction of the diagonal and in world units.
pub fn energy_summary(energy: solver::Energy, fraction: f64, diagonal: f64) -> String {
    match energy {
        solver::Energy::SpokesAndRims => "spokes-and-rims".to_string(),
        solver::Energy::Spokes => "spokes".to_string(),
        solver::Energy::SmoothRotations => format!(
            "smooth-rotations, bending length {fraction} of the diagonal = {:.6} world units",
            fraction * diagonal
        ),
    }
}

/// [`solver::ArapConfig::validate`] for deform and bench, the field named by its flag.
pub fn check_config(config: &solver::ArapConfig) -> anyhow::Result<()> {
    config.validate().map_err(|e| {
        let flag = match e {
            solver::ArapConfigError::Tolerance(_) => "--tol",
            solver::ArapConfigError::MaxIterations(_) => "--max-iters",
            solver::ArapConfigError::AndersonWindow(_) => "--anderson",
            solver::ArapConfigError::EnergyThreshold(_) => "--threshold",
            solver::ArapConfigError::Membrane(_) => "--membrane",
            solver::ArapConfigError::BendingLength(_) => "--bending-length",
        };
        anyhow::anyhow!(e.renamed(flag))
    })
}

pub type PathArg = PathBuf;

/// Refuses a recording of `frames` frames of `vertices` vertices that would not fit in the
/// available memory, with the editor's rule (`jobs::recording_fits`), before it is solved:
/// the kernel's out-of-memory kill came after hours, with no error line.
pub fn recording_fits(source: &str, frames: usize, vertices: usize) -> anyhow::Result<()> {
    let available = app::memory::available_mib();
    app::editor::jobs::recording_fits(frames, vertices, available)
        .map_err(|e| anyhow::anyhow!("{source}: {e}"))
}

/// The value parser of the flags that count (frames, iterations, vertices, pixels): a whole
/// number ≥ 0. With `allow_negative_numbers` on the flag, `-1` reaches it (instead of being
/// taken for a flag) and is refused by this message, not by the integer parser's "invalid
/// digit found in string".
pub fn count<T: std::str::FromStr>(s: &str) -> Result<T, String> {
    let s = s.trim();
    s.parse().map_err(|_| match s.bytes().all(|b| b.is_ascii_digit()) && !s.is_empty() {
        // (a whole number past the type's limit: the integer parser's "number too large")
        true => "too large a number".to_string(),
        false => "expected a whole number ≥ 0".to_string(),
    })
}

/// Base-surface options shared by deform and bench.
#[derive(Debug, Clone, clap::Args)]
pub struct BaseArgs {
    /// Smoothing length of the faired base (bsarap-faired, bsarap-coarse), as a fraction of the
    /// bounding-box diagonal.
    #[arg(long, default_value_t = solver::BaseConfig::default().smoothing, allow_negative_numbers = true)]
    pub smoothing: f64,
    /// Vertices of the coarse base (bsarap-coarse). Default: min(3000, 30 % of the mesh).
    #[arg(long, value_parser = count::<usize>, allow_negative_numbers = true)]
    pub coarse_vertices: Option<usize>,
    /// ARAP iterations on the full mesh after each coarse solve (bsarap-coarse; 0: none).
    #[arg(long, default_value_t = solver::BaseConfig::default().fine_iterations,
          value_parser = count::<usize>, allow_negative_numbers = true)]
    pub fine_iterations: usize,
    /// Fair the coarse base on the whole mesh even where a decimated level would do
    /// (bsarap-coarse on dense meshes): the comparison for the level fairing.
    #[arg(long)]
    pub direct_fairing: bool,
    /// The coarse level's membrane share (bsarap-coarse): the part of its energy in cells of
    /// single triangles, which resist no bending, in [0, 1].
    #[arg(long, default_value_t = solver::BaseConfig::default().membrane, allow_negative_numbers = true)]
    pub membrane: f64,
    /// The energy the coarse level minimizes (bsarap-coarse).
    #[arg(long, value_enum, default_value_t = CoarseEnergyArg::default())]
    pub coarse_energy: CoarseEnergyArg,
}

impl BaseArgs {
    /// Validated settings.
    pub fn config(&self) -> anyhow::Result<solver::BaseConfig> {
        let config = solver::BaseConfig {
            smoothing: self.smoothing,
            coarse_vertices: self.coarse_vertices,
            fine_iterations: self.fine_iterations,
            // Settling refines a pose whose handles have stopped: an interactive notion.
            settle_iterations: 0,
            level_fairing: !self.direct_fairing,
            membrane: self.membrane,
            coarse_energy: self.coarse_energy.into(),
        };
        config.validate().map_err(|e| {
            // The message begins with the field's name: name the flag instead.
            let message = e.to_string();
            let flag = e.field().replace('_', "-");
            anyhow::anyhow!("--{flag}{}", &message[e.field().len()..])
        })?;
        Ok(config)
    }
}

/// Refuses a base-surface flag set to other than its default that none of `methods` uses
/// (`--coarse-vertices` with `--method arap`): it would be ignored without a word, as other
/// flags that do not apply are refused.
pub fn check_base_flags(base: &BaseArgs, methods: &[solver::Method]) -> anyhow::Result<()> {
    use solver::Method::{BsArapCoarse, BsArapFaired};
    let default = solver::BaseConfig::default();
    let energy = solver::CoarseEnergy::from(base.coarse_energy);
    let flags = [
        ("--smoothing", base.smoothing != default.smoothing, &[BsArapFaired, BsArapCoarse][..]),
        ("--coarse-vertices", base.coarse_vertices.is_some(), &[BsArapCoarse]),
        ("--fine-iterations", base.fine_iterations != default.fine_iterations, &[BsArapCoarse]),
        ("--direct-fairing", base.direct_fairing, &[BsArapCoarse]),
        ("--membrane", base.membrane != default.membrane, &[BsArapCoarse]),
        ("--coarse-energy", energy != default.coarse_energy, &[BsArapCoarse]),
    ];
    for (flag, set, users) in flags {
        if set && !methods.iter().any(|m| users.contains(m)) {
            let names: Vec<&str> = users.iter().map(|m| m.name()).collect();
            anyhow::bail!("{flag} applies to {} only: it would be ignored", names.join(" and "));
        }
    }
    Ok(())
}

/// Refuses `--coarse-energy galerkin` without `--energy smooth-rotations` before anything is
/// loaded, for deform and bench alike (the coarse solver refuses it only once built, and the
/// other methods ignore it).
pub fn check_coarse_energy(energy: EnergyArg, coarse: CoarseEnergyArg) -> anyhow::Result<()> {
    anyhow::ensure!(
        coarse != CoarseEnergyArg::Galerkin || energy == EnergyArg::SmoothRotations,
        "--coarse-energy galerkin restricts the smooth-rotations energy: add --energy \
         smooth-rotations, or use --coarse-energy decimated"
    );
    Ok(())
}

/// Refuses a mesh given where `command` (export, render) takes a scene: by its extension, before
/// the JSON parser calls it malformed. `hint` says what the subcommand does with a mesh.
pub fn refuse_mesh_as_scene(path: &Path, command: &str, hint: &str) -> anyhow::Result<()> {
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned());
    if ext.as_deref().and_then(solver::io::Format::from_extension).is_some() {
        anyhow::bail!("{}: a mesh; {command} takes a scene (.json){hint}", path.display());
    }
    Ok(())
}

/// A scene's load error as the command line says it: a file that is no JSON at all and not
/// named .json says that `command` takes a scene.
pub fn scene_error(e: anyhow::Error, path: &Path, command: &str) -> anyhow::Error {
    match e.downcast::<SceneError>() {
        Ok(parse @ SceneError::Parse { .. })
            if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json")) =>
        {
            anyhow::anyhow!("{parse}: {command} takes a scene (.json)")
        }
        Ok(other) => other.into(),
        Err(e) => e,
    }
}

/// Reads a scene for `command` ([`refuse_mesh_as_scene`], [`scene_error`]), its mesh's
/// references under [`reference_policy`].
pub fn load_scene(path: &Path, command: &str, hint: &str) -> anyhow::Result<LoadedScene> {
    refuse_mesh_as_scene(path, command, hint)?;
    solver::animation::scene::Scene::load_with(path, reference_policy())
        .map_err(|e| scene_error(e.into(), path, command))
}
