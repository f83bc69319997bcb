"""The machine analysed and experimented on: its plant linearised (``linearize``), the tyre
presets (``presets``), the thesis's lab experiments (``experiment``) and the shipped
studies (``study``), each as the ``agvsim`` command of the same name runs it, returned as
typed values rather than printed."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Dict, List, Optional, Tuple, Union

import numpy as np

from . import _native, _speaks_python

if TYPE_CHECKING:  # pragma: no cover - imported for the annotations only
    from . import PathLike, Recording, Scene, _Scratch

__all__ = ["Linearisation", "TyrePreset", "Surface", "Presets", "Experiment", "Study",
           "linearize", "presets", "experiment", "study", "EXPERIMENTS", "STUDIES"]

#: The experiments ``experiment`` runs (the CLI's ``agvsim experiment KIND``).
EXPERIMENTS = ("lifted-random-demand", "falling-weight", "coast-down", "floor-run")
#: The studies ``study`` runs (the CLI's ``agvsim study NAME``).
STUDIES = ("tyre-compounds", "thesis-figures", "backlash-tolerance", "reversing", "thesis-dcmc")


def _complex(pairs: Optional[List[List[float]]]) -> Optional[np.ndarray]:
    return None if pairs is None else np.array([complex(re_, im) for re_, im in pairs], dtype=complex)


@dataclass(frozen=True, eq=False)
class Linearisation:
    """The plant linearised about straight running on the wire, discrete-time over one
    step: ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k] + D u[k]``; the states, inputs
    (motor voltages) and outputs (the coil pair's readings) named, units in the names.

    ``poles`` are the continuous-time poles of its zero-order-hold equivalent, 1/s
    (``ln(z)/Ts`` of each pole ``z`` of A); ``closed_loop_poles`` those of the P-D wire
    loop closed around it (``None`` where the scene's controller is not a P-D law)."""

    #: State matrix (n x n).
    A: np.ndarray
    #: Input matrix (n x 2), per V.
    B: np.ndarray
    #: Output matrix (2 x n).
    C: np.ndarray
    #: Feedthrough (2 x 2), zero.
    D: np.ndarray
    #: The step, s.
    Ts_s: float
    #: State names (units in the names).
    states: List[str]
    #: Input names.
    inputs: List[str]
    #: Output names.
    outputs: List[str]
    #: The operating point in words.
    operating_point: str
    #: Rank of controllability from the motor voltages.
    controllable_rank: int
    #: Rank of observability from the coil pair.
    observable_rank: int
    #: Each state's share (0-1) outside the controllable subspace.
    uncontrollable_share: Dict[str, float]
    #: Each state's share (0-1) the coil readings cannot see.
    unobservable_share: Dict[str, float]
    #: Open-loop continuous-time poles, 1/s.
    poles: np.ndarray
    #: Closed-loop continuous-time poles, 1/s (``None``: no P-D law to close).
    closed_loop_poles: Optional[np.ndarray]
    #: Whether every closed-loop pole is in the open left half-plane (``None``: no loop).
    closed_loop_stable: Optional[bool]
    #: What ``agvsim linearize`` prints.
    report: str = ""
    #: The export's JSON (``agvsim linearize --export FILE.json``) and the analysis.
    data: Dict[str, Any] = field(default_factory=dict)

    @property
    def n_states(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    def __repr__(self) -> str:
        loop = "" if self.closed_loop_stable is None else (", closed loop stable" if self.closed_loop_stable else ", closed loop UNSTABLE")
        return f"Linearisation({self.n_states} states, Ts {self.Ts_s} s{loop})"


@_speaks_python
def linearize(scene: Union["Scene", "PathLike"]) -> Linearisation:
    """Linearises the scene's plant about straight running on the wire, as ``agvsim
    linearize``: matrices as numpy arrays, controllability and observability, and the
    open- and closed-loop poles."""
    from . import _scene

    s = _scene(scene)
    path, values = s._args()
    report, text = _native.linearize(path, values)
    d = json.loads(text)
    a = d["analysis"]
    states = [x["name"] for x in d["states"]]
    return Linearisation(
        A=np.array(d["A"], dtype=float), B=np.array(d["B"], dtype=float),
        C=np.array(d["C"], dtype=float), D=np.array(d["D"], dtype=float),
        Ts_s=float(d["Ts_s"]), states=states,
        inputs=[x["name"] for x in d["inputs"]], outputs=[x["name"] for x in d["outputs"]],
        operating_point=d["operating_point"],
        controllable_rank=a["controllable_rank"], observable_rank=a["observable_rank"],
        uncontrollable_share=dict(zip(states, a["uncontrollable_share"])),
        unobservable_share=dict(zip(states, a["unobservable_share"])),
        poles=_complex(a["poles"]),  # type: ignore[arg-type]
        closed_loop_poles=_complex(a["closed_loop_poles"]),
        closed_loop_stable=a["closed_loop_stable"],
        report=report, data=d,
    )


@dataclass(frozen=True)
class TyrePreset:
    """A tyre compound on a floor surface and the tyre values they combine into (the
    scene's ``tyre.compound`` and ``floor.surface``)."""

    compound: str
    surface: str
    #: Peak friction coefficient.
    peak_mu: float
    #: Sliding friction coefficient.
    sliding_mu: float
    #: Longitudinal slip stiffness per newton of load, 1/N per unit slip.
    long_stiffness_per_N: float
    #: Lateral stiffness per newton of load, 1/N per rad.
    lat_stiffness_per_N: float
    #: Relaxation length, m.
    relaxation_length_m: float


@dataclass(frozen=True)
class Surface:
    """A floor surface: its friction relative to bare concrete, and what it is."""

    friction_factor: float
    note: str


@dataclass(frozen=True)
class Presets:
    """Every tyre compound on every floor surface, as ``agvsim presets``."""

    #: One row per compound on a surface.
    pairs: List[TyrePreset]
    #: Each compound and what it is.
    compounds: Dict[str, str]
    #: Each surface.
    surfaces: Dict[str, Surface]
    #: The table ``agvsim presets`` prints.
    table: str

    def get(self, compound: str, surface: str) -> TyrePreset:
        """The values of ``compound`` on ``surface``."""
        for p in self.pairs:
            if (p.compound, p.surface) == (compound, surface):
                return p
        raise KeyError(
            f"{compound} on {surface}: compounds are {', '.join(self.compounds)}; surfaces {', '.join(self.surfaces)}"
        )

    def to_pandas(self):
        """The pairs as a DataFrame (needs pandas)."""
        from .results import _frame

        return _frame(self.pairs)


@_speaks_python
def presets() -> Presets:
    """The tyre compounds and floor surfaces and the values they combine into."""
    rows, compounds, surfaces, table = _native.presets()
    return Presets(
        pairs=[TyrePreset(*r) for r in rows],
        compounds=dict(compounds),
        surfaces={name: Surface(factor, note) for name, factor, note in surfaces},
        table=table,
    )


@dataclass(frozen=True, eq=False)
class Experiment:
    """What an experiment wrote: its recording (read back), the rig file that describes
    the machine's model and beliefs, and any other files."""

    #: The recording, read back (``.path`` its file).
    recording: "Recording"
    #: The rig file beside it (pass it to :func:`agvsim.diagnose` or :func:`agvsim.identify`).
    rig: Path
    #: Other files written (a floor run's dashes and scene).
    files: List[Path]
    #: What ``agvsim experiment`` printed.
    report: str
    #: The scratch folder the files live in when no ``out`` was given (kept alive with it).
    _scratch: Optional["_Scratch"] = field(default=None, repr=False)

    def __repr__(self) -> str:
        return f"Experiment({self.recording!r}, rig={str(self.rig)!r})"


def _written(report: str, label: str) -> List[Path]:
    return [Path(m.group(1)) for m in re.finditer(rf"^{label} +(\S.*)$", report, re.M)]


@_speaks_python
def experiment(
    kind: str,
    scene: Union["Scene", "PathLike"],
    out: Optional["PathLike"] = None,
    *,
    name: Optional[str] = None,
    seed: Optional[int] = None,
    interval_s: Optional[float] = None,
    duration_s: float = 15.0,
    pattern: str = "pulses",
    peak_demand_pct: float = 40.0,
    hold_samples: Tuple[int, int] = (4, 16),
    speed_noise_rad_s: float = 0.5,
    rig_error: float = 0.0,
) -> Experiment:
    """Runs one of the thesis's lab experiments on the simulated machine, as ``agvsim
    experiment``: ``kind`` is one of :data:`EXPERIMENTS`. Writes the recording and its rig
    to ``out`` (default: a temporary folder that lives as long as the result)."""
    from . import Recording, _Scratch, _scene

    s = _scene(scene)
    scratch = None
    if out is None:
        scratch = _Scratch("experiment")
        out = scratch.path
    path, values = s._args()
    report = _native.experiment(
        kind, path, values, Path(out), name=name, seed=seed, interval_s=interval_s,
        duration_s=duration_s, pattern=pattern, peak_demand_pct=peak_demand_pct,
        hold_samples=(int(hold_samples[0]), int(hold_samples[1])), speed_noise_rad_s=speed_noise_rad_s, rig_error=rig_error,
    )
    [recording] = _written(report, "recording")
    [rig] = _written(report, "rig")
    return Experiment(Recording.read(recording), rig, _written(report, "also"), report, scratch)


@dataclass(frozen=True)
class Study:
    """What a study wrote: its summary (Markdown, as ``summary.md``) and every file."""

    #: The study's name.
    name: str
    #: The summary (Markdown).
    summary: str
    #: Every file written.
    files: List[Path]
    #: The output folder.
    out: Path

    def file(self, name: str) -> Path:
        """The file written of this name (``"slip_cycle_onset.svg"``)."""
        for f in self.files:
            if f.name == name:
                return f
        raise KeyError(f"{name}: not written by the study (wrote: {', '.join(f.name for f in self.files)})")


@_speaks_python
def study(name: str, out: "PathLike", *, quick: bool = False, jobs: int = 0) -> Study:
    """Runs a shipped study (sweeps and an analysis), as ``agvsim study``: ``name`` is
    one of :data:`STUDIES`; ``quick`` a coarser grid with the same analysis; ``jobs``
    worker threads (0: one per core; the results do not depend on it)."""
    report = _native.study(name, Path(out), jobs=jobs, quick=quick)
    files = _written(report, "wrote")
    summary = report[: report.index("wrote      ")] if files else report
    return Study(name, summary, files, Path(out))
