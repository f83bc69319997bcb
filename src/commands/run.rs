//! `agvsim run`: simulate a scene, write its recording and the scene as run, print the
//! summary and check the scene's claims; optionally watch it in Rerun.

use std::path::PathBuf;

use super::flags::{positive_seconds, Overrides, RerunFlags};
use super::{overrides, CommandError, Say};
use crate::output::file_stem_or;
use crate::record::channels as chan;
use crate::run::{render_expectations, render_summary, run_scene, RunOptions, Watcher};
use crate::scene::Scene;
use crate::sim::SimParams;
use crate::viz::{RerunRecorder, RerunTarget};

/// What `agvsim run` was asked (its command line).
#[derive(Debug, Clone, clap::Args)]
pub struct RunRequest {
    /// Scene file (TOML), e.g. scenes/lab_offset_120mm.toml.
    pub scene: PathBuf,
    /// Output folder [default: runs/SCENE_NAME].
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Scene overrides (`--set`).
    #[command(flatten)]
    pub set: Overrides,
    /// Simulated time, s (overrides sim.duration_s).
    #[arg(long = "duration", value_name = "DURATION", value_parser = positive_seconds)]
    pub duration_s: Option<f64>,
    /// Seed of the sensor noise (overrides sim.seed).
    #[arg(long, value_parser = super::flags::seed)]
    pub seed: Option<u64>,
    /// Where the run goes in Rerun, if anywhere.
    #[command(flatten)]
    pub rerun: RerunFlags,
    /// Interval between Rerun frames, s.
    #[arg(long = "rerun-interval", value_name = "RERUN_INTERVAL", default_value_t = 0.02, value_parser = positive_seconds)]
    pub rerun_interval_s: f64,
}

/// The commands a velocity-commanded scene's manoeuvre reads from its CSV (`manoeuvre.kind
/// = "commands"`: `manoeuvre.commands`, relative to the scene's folder), each row's
/// command held to the next, with what is said of them; `None` for every other scene. The
/// run's length becomes the commands' unless `length_given`
/// ([`super::run_commands::fit_run_to_commands`]).
fn commands_of(
    scene_path: &std::path::Path,
    scene: &mut Scene,
    length_given: bool,
) -> Result<Option<(crate::model::manoeuvre::Manoeuvre, String)>, CommandError> {
    use crate::firmware::ControllerKind;
    let m = &scene.manoeuvre;
    if scene.controller.kind != ControllerKind::Velocity || m.kind != "commands" {
        return Ok(None);
    }
    let path = scene_path
        .parent()
        .unwrap_or(std::path::Path::new("."))
        .join(&m.commands);
    let rec = crate::record::Recording::load_commands(&path)?;
    let (Some(v), Some(w)) = (
        rec.column(chan::CMD_LINEAR_M_S),
        rec.column(chan::CMD_ANGULAR_RAD_S),
    ) else {
        return Err(CommandError::Contract {
            what: format!("{} (manoeuvre.commands)", path.display()),
            message: "expected the columns cmd_linear_m_s and cmd_angular_rad_s".into(),
        });
    };
    let rows: Vec<_> = rec
        .t_s
        .iter()
        .zip(v.iter().zip(w))
        .filter_map(|(t, (v, w))| Some((*t, (*v)?, (*w)?)))
        .collect();
    let said = super::run_commands::fit_run_to_commands(scene, &rows, &path, length_given)?;
    Ok(Some((
        crate::model::manoeuvre::Manoeuvre::Commands(rows),
        said,
    )))
}

/// The scene as `run` runs it (overrides, checks, a velocity base's commands read from
/// their CSV and the run's length fitted to them), and the manoeuvre it drives if the
/// scene names a commands CSV; what is said of them goes to `say`.
fn scene_to_run(
    req: &RunRequest,
    say: Say,
) -> Result<(Scene, Option<crate::model::manoeuvre::Manoeuvre>), CommandError> {
    let set = overrides(&req.set, req.duration_s, req.seed);
    let checked = Scene::load_checked(&req.scene, &set)
        .map_err(|e| super::name_own_options(e, &req.set, req.duration_s, req.seed))?;
    say(&checked.render_warnings());
    let mut scene = checked.scene;
    let length_given = req.duration_s.is_some()
        || req
            .set
            .iter()
            .any(|a| a.split('=').next().unwrap_or("").trim() == "sim.duration_s");
    if scene.controller.kind == crate::firmware::ControllerKind::Velocity {
        super::run_commands::check_shape_speeds(&scene)?;
    }
    let commands = commands_of(&req.scene, &mut scene, length_given)?;
    let manoeuvre = commands.map(|(m, said_of_it)| {
        say(&said_of_it);
        m
    });
    Ok((scene, manoeuvre))
}

/// The scene's simulation held in memory, loaded as `run` loads it (Python's
/// `agvsim.Sim`): the scene, its `--set` overrides and seed, and what was said of them
/// (the scene's warnings, a commands CSV's fit).
pub fn live_sim(
    scene: PathBuf,
    set: Vec<String>,
    seed: Option<u64>,
) -> Result<(crate::live::LiveSim, String), CommandError> {
    let req = RunRequest {
        scene,
        out: None,
        set: set.into(),
        duration_s: None,
        seed,
        rerun: Default::default(),
        rerun_interval_s: 0.02,
    };
    let said = std::cell::RefCell::new(String::new());
    let (scene, manoeuvre) = scene_to_run(&req, &|s: &str| said.borrow_mut().push_str(s))?;
    let live = crate::live::LiveSim::new(scene, manoeuvre)?;
    Ok((live, said.into_inner()))
}

/// Runs the scene and prints its summary, its claims' check and the files written.
pub fn run(req: &RunRequest, say: Say) -> Result<(), CommandError> {
    let (scene, manoeuvre) = scene_to_run(req, say)?;
    for arg in req.set.iter() {
        let key = arg.split('=').next().unwrap_or("").trim();
        if let Some(why) = crate::scene::inert::inert_reason(&scene, key) {
            say(&format!(
                "warning: --set {arg}: no effect on this run: {why}\n"
            ));
        }
    }
    let name = file_stem_or(&req.scene, "run");
    let opts = RunOptions {
        out_dir: req
            .out
            .clone()
            .unwrap_or_else(|| PathBuf::from("runs").join(&name)),
        name: name.clone(),
        manoeuvre,
    };
    let _lock = super::lock_out("--out", &opts.out_dir)?;
    // An earlier run's recording there is replaced: said, not done in silence.
    let earlier = opts.out_dir.join(format!("{name}.csv")).exists();
    // The Rerun target first: a file that cannot be written (or a viewer that cannot be
    // reached) stops the run before any output is left behind.
    let rerun = req.rerun.target();
    let mut recorder = match &rerun {
        Some(t) => Some(RerunRecorder::new(
            t,
            &name,
            &SimParams::from_scene(&scene)?,
            req.rerun_interval_s,
        )?),
        None => None,
    };
    let out = run_scene(
        &scene,
        &opts,
        recorder.as_mut().map(|r| r as &mut dyn Watcher),
    )?;
    if let Some(r) = recorder {
        r.finish()?;
    }
    say(&render_summary(&req.scene, &scene, &out.summary));
    say(&render_expectations(
        &scene,
        &out.summary,
        !overrides(&req.set, req.duration_s, req.seed).is_empty(),
    ));
    say(&format!(
        "recording  {}{}\n",
        out.recording.display(),
        if earlier {
            " (replaces the earlier run's; --out DIR keeps both)"
        } else {
            ""
        }
    ));
    if let Some(RerunTarget::Save(p)) = &rerun {
        say(&format!("rerun      {}\n", p.display()));
    }
    Ok(())
}
