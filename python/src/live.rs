//! `agvsim.Sim` and `agvsim.VecSim`'s native halves: a scene's simulation held in memory
//! ([`agvsim::live`]), stepped with the GIL released; arrays cross as little-endian f64
//! bytes that the Python layer views with `numpy.frombuffer`.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyBytes;

use agvsim::live::{Command, LiveError, LiveFleet, LiveSim, Saved, STATE_NAMES};

use crate::recording::f64_bytes;
use crate::{to_py, AgvsimError, InputError};

/// The error as Python sees it: a command the scene does not take is input to mend.
fn live_err(e: LiveError) -> PyErr {
    match e {
        LiveError::Command(w) => InputError::new_err(format!("step(command=...): {w}")),
        e @ LiveError::Count { .. } => InputError::new_err(e.to_string()),
        LiveError::Sim(e) => AgvsimError::new_err(e.to_string()),
    }
}

/// The command for the steps: the scene's own (`None`), or a pair read per the scene's
/// controller (demands for a wire-following scene, `cmd_vel` for a velocity base).
fn command_of(live: &LiveSim, pair: Option<(f64, f64)>) -> PyResult<Command> {
    let Some((a, b)) = pair else {
        return Ok(Command::Scene);
    };
    if !(a.is_finite() && b.is_finite()) {
        return Err(InputError::new_err(format!(
            "step(command=({a}, {b})): expected two finite numbers ({})",
            live.command_names().join(", ")
        )));
    }
    Ok(if live.is_velocity_base() {
        Command::Velocity {
            linear_m_s: a,
            angular_rad_s: b,
        }
    } else {
        Command::Demand {
            forward_pct: a,
            turn_pct: b,
        }
    })
}

/// Loads a scene as `agvsim run` loads it, held in memory.
fn load(scene: PathBuf, set: Vec<String>, seed: Option<u64>) -> PyResult<(LiveSim, String)> {
    agvsim::commands::run::live_sim(scene, set, seed)
        .map_err(|e| to_py((e.to_string(), e.exit_code())))
}

/// A saved instant of a simulation (`Sim.snapshot()`).
#[pyclass(module = "agvsim._native", frozen)]
pub struct NativeSaved {
    saved: Saved,
    time_s: f64,
}

#[pymethods]
impl NativeSaved {
    /// The simulated time it was saved at, s.
    #[getter]
    fn time_s(&self) -> f64 {
        self.time_s
    }
}

/// One scene's simulation in memory.
#[pyclass(module = "agvsim._native")]
pub struct NativeSim {
    live: LiveSim,
    warnings: String,
}

#[pymethods]
impl NativeSim {
    #[new]
    #[pyo3(signature = (scene, set, seed=None))]
    fn new(py: Python<'_>, scene: PathBuf, set: Vec<String>, seed: Option<u64>) -> PyResult<Self> {
        let (live, warnings) = py.allow_threads(|| load(scene, set, seed))?;
        Ok(NativeSim { live, warnings })
    }

    /// What loading the scene said (its warnings), possibly empty.
    #[getter]
    fn warnings(&self) -> String {
        self.warnings.clone()
    }

    #[pyo3(signature = (seed=None))]
    fn reset(&mut self, py: Python<'_>, seed: Option<u64>) -> PyResult<()> {
        let live = &mut self.live;
        py.allow_threads(|| live.reset(seed)).map_err(live_err)
    }

    #[pyo3(signature = (command, n))]
    fn step(&mut self, py: Python<'_>, command: Option<(f64, f64)>, n: u64) -> PyResult<()> {
        let c = command_of(&self.live, command)?;
        let live = &mut self.live;
        py.allow_threads(|| live.step(c, n)).map_err(live_err)
    }

    fn outputs(&self, py: Python<'_>) -> Py<PyBytes> {
        f64_bytes(py, self.live.outputs().into_iter())
    }

    fn state(&self, py: Python<'_>) -> Py<PyBytes> {
        f64_bytes(py, self.live.state().into_iter())
    }

    #[getter]
    fn output_names(&self) -> Vec<&'static str> {
        self.live.output_names()
    }

    #[getter]
    fn output_decimals(&self) -> Vec<usize> {
        self.live.output_decimals()
    }

    #[getter]
    fn state_names(&self) -> Vec<&'static str> {
        STATE_NAMES.to_vec()
    }

    #[getter]
    fn command_names(&self) -> Vec<&'static str> {
        self.live.command_names().to_vec()
    }

    #[getter]
    fn is_velocity_base(&self) -> bool {
        self.live.is_velocity_base()
    }

    #[getter]
    fn time_s(&self) -> f64 {
        self.live.time_s()
    }

    #[getter]
    fn dt_s(&self) -> f64 {
        self.live.dt_s()
    }

    #[getter]
    fn duration_s(&self) -> f64 {
        self.live.scene().sim.duration_s
    }

    #[getter]
    fn record_interval_s(&self) -> f64 {
        self.live.scene().sim.record_interval_s
    }

    #[getter]
    fn top_speed_m_s(&self) -> f64 {
        self.live.top_speed_m_s()
    }

    #[getter]
    fn track_m(&self) -> f64 {
        self.live.track_m()
    }

    #[getter]
    fn dcmc_fault(&self) -> Option<&'static str> {
        self.live.dcmc_fault()
    }

    #[getter]
    fn dcmc_enable_delay_s(&self) -> f64 {
        self.live.dcmc_enable_delay_s()
    }

    #[getter]
    fn lost_wire(&self) -> bool {
        self.live.lost_wire()
    }

    fn manoeuvre_command(&self, t_s: f64) -> Option<(f64, f64)> {
        self.live.manoeuvre_command(t_s)
    }

    fn save(&self) -> NativeSaved {
        NativeSaved {
            saved: self.live.save(),
            time_s: self.live.time_s(),
        }
    }

    fn restore(&mut self, saved: &NativeSaved) {
        self.live.restore(&saved.saved);
    }
}

/// Many simulations in memory, stepped together on the library's worker threads.
#[pyclass(module = "agvsim._native")]
pub struct NativeVecSim {
    fleet: LiveFleet,
    warnings: String,
}

#[pymethods]
impl NativeVecSim {
    /// One simulation per (scene, set, seed).
    #[new]
    fn new(py: Python<'_>, members: Vec<(PathBuf, Vec<String>, Option<u64>)>) -> PyResult<Self> {
        let loaded = py.allow_threads(|| {
            members
                .into_iter()
                .map(|(scene, set, seed)| load(scene, set, seed))
                .collect::<PyResult<Vec<_>>>()
        })?;
        let kinds: Vec<bool> = loaded.iter().map(|(l, _)| l.is_velocity_base()).collect();
        if kinds.iter().any(|k| *k != kinds[0]) {
            return Err(InputError::new_err(
                "VecSim: the scenes mix velocity-commanded bases and wire-following vehicles; their commands differ, so one VecSim holds one kind",
            ));
        }
        let mut warnings = String::new();
        for (i, (_, w)) in loaded.iter().enumerate() {
            if !w.is_empty() {
                warnings.push_str(&format!("simulation {i}: {w}"));
            }
        }
        let fleet = LiveFleet::new(loaded.into_iter().map(|(l, _)| l).collect());
        Ok(NativeVecSim { fleet, warnings })
    }

    #[getter]
    fn warnings(&self) -> String {
        self.warnings.clone()
    }

    fn __len__(&self) -> usize {
        self.fleet.sims().len()
    }

    /// Steps every simulation `n` steps; `commands`: one pair per simulation, flattened
    /// (`None`: each drives as its scene does).
    #[pyo3(signature = (commands, n))]
    fn step(&mut self, py: Python<'_>, commands: Option<Vec<f64>>, n: u64) -> PyResult<()> {
        let sims = self.fleet.sims();
        let cmds: Vec<Command> = match commands {
            None => vec![Command::Scene; sims.len()],
            Some(v) => {
                if v.len() != 2 * sims.len() {
                    return Err(InputError::new_err(format!(
                        "step(commands=...): {} numbers, expected shape ({}, 2)",
                        v.len(),
                        sims.len()
                    )));
                }
                sims.iter()
                    .zip(v.chunks(2))
                    .map(|(s, c)| command_of(s, Some((c[0], c[1]))))
                    .collect::<PyResult<_>>()?
            }
        };
        let fleet = &mut self.fleet;
        py.allow_threads(|| fleet.step(&cmds, n)).map_err(|e| {
            let text = e.to_string();
            match e.source {
                LiveError::Command(_) | LiveError::Count { .. } => InputError::new_err(text),
                LiveError::Sim(_) => AgvsimError::new_err(text),
            }
        })
    }

    #[pyo3(signature = (seeds=None))]
    fn reset(&mut self, py: Python<'_>, seeds: Option<Vec<u64>>) -> PyResult<()> {
        if let Some(s) = &seeds {
            if s.len() != self.fleet.sims().len() {
                return Err(InputError::new_err(format!(
                    "reset(seeds=...): {} seeds, expected one per simulation ({})",
                    s.len(),
                    self.fleet.sims().len()
                )));
            }
        }
        let fleet = &mut self.fleet;
        py.allow_threads(|| fleet.reset(seeds.as_deref()))
            .map_err(|e| AgvsimError::new_err(e.to_string()))
    }

    /// Every simulation's outputs, row by row (shape (n, outputs)).
    fn outputs(&self, py: Python<'_>) -> Py<PyBytes> {
        f64_bytes(py, self.fleet.sims().iter().flat_map(|s| s.outputs()))
    }

    /// Every simulation's state, row by row (shape (n, 20)).
    fn state(&self, py: Python<'_>) -> Py<PyBytes> {
        f64_bytes(py, self.fleet.sims().iter().flat_map(|s| s.state()))
    }

    fn times_s(&self) -> Vec<f64> {
        self.fleet.sims().iter().map(|s| s.time_s()).collect()
    }
}
