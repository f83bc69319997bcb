"""agvsim in Python: simulate a differential-drive robot, replay, calibrate, diagnose and
identify it from recordings, sweep its parameters, import its logs.

Every function here runs the same library job as the ``agvsim`` command of the same name
(the same request, the same files, the same numbers), on a thread of its own with the GIL
released; Ctrl-C raises ``KeyboardInterrupt``. Errors arrive as :class:`InputError` (input
to mend: a scene, rig, recording, bag or argument; the CLI's exit status 2) or
:class:`AgvsimError` (a job that failed), carrying the library's message.

Units are in the names, as in the scenes and recordings: ``duration_s``, ``mass_kg``.

>>> import agvsim
>>> scene = agvsim.Scene.load("scenes/lab_offset_120mm.toml")
>>> rec = agvsim.run(scene.with_values({"controller.gain_scale": 2}), duration_s=5)
>>> rec["lateral_error_m"].max()            # doctest: +SKIP
"""

from __future__ import annotations

import csv
import functools
import math
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence, TypeVar, Union, cast

import numpy as np

from . import _native
from ._native import AgvsimError, InputError
from .results import Calibration, Diagnosis, Identification

__all__ = [
    "AgvsimError",
    "InputError",
    "Scene",
    "Check",
    "Recording",
    "Calibration",
    "Diagnosis",
    "Identification",
    "Table",
    "Imported",
    "run",
    "replay",
    "calibrate",
    "diagnose",
    "identify",
    "sweep",
    "sweep_merge",
    "batch_calibrate",
    "batch_diagnose",
    "batch_merge",
    "import_ros2",
    "import_wpilib",
    "keys_reference",
    "Sim",
    "VecSim",
    "SimState",
    "Linearisation",
    "Presets",
    "Experiment",
    "Study",
    "linearize",
    "presets",
    "experiment",
    "study",
    "EXPERIMENTS",
    "STUDIES",
]

PathLike = Union[str, "os.PathLike[str]"]
_T = TypeVar("_T")
_F = TypeVar("_F", bound=Callable[..., Any])


class _Scratch:
    """A temporary folder that lives as long as the objects that hold it."""

    def __init__(self, prefix: str) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix=f"agvsim_{prefix}_")
        self.path = Path(self._dir.name)

    def cleanup(self) -> None:
        self._dir.cleanup()


def _set_text(key: str, value: Any) -> str:
    """One ``--set KEY=VALUE`` argument; numbers keep every digit (``repr``)."""
    if isinstance(value, bool):
        return f"{key}={'true' if value else 'false'}"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return f"{key}={float(value)!r}" if isinstance(value, (float, np.floating)) else f"{key}={int(value)}"
    return f"{key}={value}"


# The CLI's flags whose Python argument is not the flag's own name (lower case, ``-`` as
# ``_``), so that a message naming a flag names what a Python caller passed.
_RENAMED_FLAGS = {
    "recording": "recordings",
    "set": "with_values",
    "duration": "duration_s",
    "interval": "interval_s",
    "peak-demand": "peak_demand_pct",
    "hold": "hold_samples",
    "speed-noise": "speed_noise_rad_s",
    "track-width-m": "track_m",
    "supply-v": "battery_v",
    "from": "from_scene",
}

# The CLI's commands as this package's functions.
_COMMANDS = {
    "new": "Scene.new",
    "check": "Scene.check",
    "keys": "keys_reference",
    "import ros2": "import_ros2",
    "import wpilib": "import_wpilib",
    "sweep merge": "sweep_merge",
    "batch calibrate": "batch_calibrate",
    "batch diagnose": "batch_diagnose",
    "batch merge": "batch_merge",
}
_COMMANDS.update({c: c for c in ("run", "replay", "calibrate", "diagnose", "identify", "sweep",
                                  "study", "linearize", "presets", "experiment")})


def _argument(flag: str) -> str:
    """A CLI flag (without ``--``) as the Python argument it is."""
    name = flag.lower()
    return _RENAMED_FLAGS.get(name, name.replace("-", "_"))


def _value_text(token: str) -> str:
    """A command line's value as Python source: a placeholder (``SCENE``, ``DIR``) as
    it is, anything else quoted."""
    return token if re.fullmatch(r"[A-Z][A-Z_.]*", token) else repr(token)


def _python_call(command: str) -> Optional[str]:
    """``agvsim SUB ARGS...`` as the call of this package that does it, if there is one."""
    words = command.split()
    name = " ".join(words[:2]) if " ".join(words[:2]) in _COMMANDS else words[0] if words else ""
    if name not in _COMMANDS:
        return None
    rest = words[len(name.split()):]
    positional: List[str] = []
    keywords: Dict[str, List[str]] = {}
    i = 0
    while i < len(rest):
        w = rest[i]
        if w.startswith("--"):
            value = rest[i + 1] if i + 1 < len(rest) and not rest[i + 1].startswith("--") else None
            keywords.setdefault(_argument(w[2:]), []).append("True" if value is None else _value_text(value))
            i += 1 if value is None else 2
        else:
            positional.append(_value_text(w))
            i += 1
    args = positional + [f"{k}={v[0] if len(v) == 1 else '[' + ', '.join(v) + ']'}" for k, v in keywords.items()]
    return f"agvsim.{_COMMANDS[name]}({', '.join(args)})"


def _python_words(text: str) -> str:
    """A library message in this package's words: its commands as calls of this package,
    its flags as the arguments a Python caller passed."""
    def command(m: "re.Match[str]") -> str:
        call = _python_call(m.group(1))
        return f"`{call}`" if call is not None else m.group(0)

    text = re.sub(r"`agvsim ([^`]*)`", command, text)
    # A message that starts by naming a flag names the argument: "free: chassis.foo: ...".
    text = re.sub(r"^--([A-Za-z][\w-]*) ", lambda m: f"{_argument(m.group(1))}: ", text)
    return re.sub(r"(?<![\w`-])--([A-Za-z][\w-]*)", lambda m: _argument(m.group(1)), text)


def _in_python_words(call: Callable[[], _T]) -> _T:
    """Runs ``call``; an error naming the CLI's commands and flags names this package's."""
    try:
        return call()
    except AgvsimError as e:
        text = _python_words(str(e))
        if text == str(e):
            raise
        raise type(e)(text) from None


def _speaks_python(f: _F) -> _F:
    """``f``, its errors in this package's words (:func:`_in_python_words`)."""

    @functools.wraps(f)
    def speaking(*args: Any, **kwargs: Any) -> Any:
        return _in_python_words(lambda: f(*args, **kwargs))

    return cast(_F, speaking)


# --------------------------------------------------------------------------------------
# Scenes


class Check:
    """What ``agvsim check`` says of a scene: the report and its plausibility warnings."""

    def __init__(self, report: str) -> None:
        #: The report as the CLI prints it.
        self.report = report
        #: One line per plausibility warning (empty: none).
        self.warnings: List[str] = [l.strip() for l in report.splitlines() if l.startswith("warning")]

    def __bool__(self) -> bool:
        """True when the scene has no plausibility warning."""
        return not self.warnings

    def __repr__(self) -> str:
        return f"Check({len(self.warnings)} warnings)"


class Scene:
    """A scene: a TOML file as agvsim reads it, with values set on top of it.

    A scene is immutable: :meth:`with_values` returns a new one. Values set are passed to
    every command as the CLI's ``--set KEY=VALUE``, so a scene from
    ``Scene.load(p).with_values({"chassis.mass_kg": 60})`` behaves exactly as
    ``agvsim run p --set chassis.mass_kg=60``. Files a scene names (a wire map, a manoeuvre's
    commands) are found beside its file.
    """

    def __init__(self, path: PathLike, values: Sequence[str] = (), _scratch: Optional[_Scratch] = None) -> None:
        self._path = Path(path)
        self._set = list(values)
        self._scratch = _scratch
        warnings, keys, toml = _in_python_words(lambda: _native.scene_info(self._path, self._set))
        self._warnings = warnings
        self._keys = {k: v for k, v, _ in keys}
        self._units = {k: u for k, _, u in keys}
        self._toml = toml

    @classmethod
    def load(cls, path: PathLike) -> "Scene":
        """Reads and validates a scene file (every error names its line and key)."""
        return cls(path)

    @classmethod
    def new(
        cls,
        path: Optional[PathLike] = None,
        *,
        from_scene: Optional[PathLike] = None,
        force: bool = False,
        mass_kg: Optional[float] = None,
        track_m: Optional[float] = None,
        wheel_radius_m: Optional[float] = None,
        battery_v: Optional[float] = None,
        motor_rated_v: Optional[float] = None,
        motor_no_load_rpm: Optional[float] = None,
        motor_stall_current_a: Optional[float] = None,
        motor_stall_torque_nm: Optional[float] = None,
        gear_ratio: Optional[float] = None,
        backlash_rad: Optional[float] = None,
        tyre: Optional[str] = None,
        castors: Optional[bool] = None,
        guidance: Optional[str] = None,
        length_m: Optional[float] = None,
        width_m: Optional[float] = None,
        description: Optional[str] = None,
    ) -> "Scene":
        """A new robot's scene from the numbers its builder knows, as ``agvsim new``.

        Written to ``path`` (refused if it exists, unless ``force``), or to a temporary
        file that lives as long as the scene. ``guidance`` is ``"wire"``, ``"none"`` (a
        velocity-commanded base) or ``"open-loop"``. The derivation (each derived value and
        how) is in ``scene.report``.
        """
        args: Dict[str, Any] = dict(
            mass_kg=mass_kg, track_m=track_m, wheel_radius_m=wheel_radius_m, battery_v=battery_v,
            motor_rated_v=motor_rated_v, motor_no_load_rpm=motor_no_load_rpm,
            motor_stall_current_a=motor_stall_current_a, motor_stall_torque_nm=motor_stall_torque_nm,
            gear_ratio=gear_ratio, backlash_rad=backlash_rad, tyre=tyre, castors=castors,
            guidance=guidance, length_m=length_m, width_m=width_m, description=description,
        )
        given = {k: v for k, v in args.items() if v is not None}
        scratch = None
        if path is None:
            scratch = _Scratch("scene")
            path = scratch.path / "robot.toml"
        command = "agvsim.Scene.new(" + ", ".join(f"{k}={v!r}" for k, v in given.items()) + ")"
        report = _in_python_words(
            lambda: _native.new_scene(
                Path(path), command, from_=None if from_scene is None else Path(from_scene), force=force, **args
            )
        )
        scene = cls(path, _scratch=scratch)
        scene.report = report
        return scene

    #: What created the scene printed (``Scene.new``), else ``None``.
    report: Optional[str] = None

    @property
    def path(self) -> Path:
        """The scene's file."""
        return self._path

    @property
    def values(self) -> List[str]:
        """The values set on the file, as ``KEY=VALUE`` (the CLI's ``--set``)."""
        return list(self._set)

    @property
    def warnings(self) -> str:
        """The plausibility warnings as the CLI prints them (empty: none)."""
        return self._warnings

    def with_values(self, values: Mapping[str, Any]) -> "Scene":
        """A new scene with these keys set (``{"chassis.mass_kg": 60}``), validated now:
        a key that is not the scene's, or a value outside its range, raises InputError."""
        extra = [_set_text(k, v) for k, v in values.items()]
        return Scene(self._path, self._set + extra, _scratch=self._scratch)

    def keys(self) -> Dict[str, Optional[float]]:
        """Every numeric scene key and its value (``None``: an optional key left out)."""
        return dict(self._keys)

    def units(self) -> Dict[str, str]:
        """Every numeric scene key's unit, as declared."""
        return dict(self._units)

    def __getitem__(self, key: str) -> Optional[float]:
        """A numeric key's value (``scene["motor.resistance_ohm"]``)."""
        try:
            return self._keys[key]
        except KeyError:
            raise KeyError(f"{key}: not a numeric scene key (agvsim.keys_reference() lists them)") from None

    def check(self) -> Check:
        """The scene's plausibility, as ``agvsim check``."""
        return Check(_in_python_words(lambda: _native.check(self._path, self._set)))

    def to_toml(self) -> str:
        """The scene as agvsim reads it (every value set applied), as TOML."""
        return self._toml

    def save(self, path: PathLike) -> Path:
        """Writes the scene: the file as it is when no value is set (its comments kept),
        else :meth:`to_toml`. Files the scene names are found beside the new file."""
        path = Path(path)
        text = self._path.read_text() if not self._set else self._toml
        tmp = path.with_name(path.name + ".partial")
        tmp.write_text(text)
        os.replace(tmp, path)
        return path

    def _args(self) -> tuple:
        return self._path, self._set

    def __repr__(self) -> str:
        extra = f", values={self._set!r}" if self._set else ""
        return f"Scene({str(self._path)!r}{extra})"


def _scene(scene: Union[Scene, PathLike]) -> Scene:
    return scene if isinstance(scene, Scene) else Scene.load(scene)


# --------------------------------------------------------------------------------------
# Recordings


class Recording:
    """A recording in agvsim's exchange format: time, named columns (numpy arrays, NaN
    where a value was not measured), the rig kind and the metadata.

    ``rec["left_voltage_V"]`` is a column; ``rec.t_s`` the time, s; ``rec.to_pandas()`` a
    DataFrame indexed by time.
    """

    def __init__(
        self,
        t_s: Iterable[float],
        columns: Mapping[str, Iterable[float]],
        rig: str = "vehicle",
        meta: Optional[Mapping[str, str]] = None,
    ) -> None:
        #: Time of each row, s.
        self.t_s = np.asarray(t_s, dtype=float)
        self._data: Dict[str, np.ndarray] = {k: np.asarray(v, dtype=float) for k, v in columns.items()}
        #: The rig kind (``drive_axis``, ``vehicle`` or ``drive_pair``).
        self.rig = rig
        #: The metadata lines, in the file's order.
        self.meta: Dict[str, str] = dict(meta or {})
        #: The rows where each joined segment starts.
        self.segment_starts: List[int] = [0]
        #: The file it was read from, if any.
        self.path: Optional[Path] = None
        #: What the command that made it printed (``run``, ``replay``), else ``None``.
        self.report: Optional[str] = None

    @classmethod
    @_speaks_python
    def read(cls, path: PathLike) -> "Recording":
        """Reads a recording (the contract's reader: every check the CLI makes)."""
        rig, meta, names, t, cols, starts = _native.read_recording(Path(path))
        data = {n: np.frombuffer(c, dtype="<f8").copy() for n, c in zip(names, cols)}
        rec = cls(np.frombuffer(t, dtype="<f8").copy(), data, rig, dict(meta))
        rec.segment_starts = list(starts)
        rec.path = Path(path)
        return rec

    def write(self, path: PathLike) -> Path:
        """Writes the recording in the exchange format (each value's shortest decimal that
        reads back the same; NaN as an empty cell). The text is read back by the contract's
        reader before it is written, and the file appears whole or not at all."""
        _native.write_recording(
            Path(path),
            self.rig,
            list(self.meta.items()),
            list(self._data),
            [float(x) for x in self.t_s],
            [[float(x) for x in c] for c in self._data.values()],
        )
        return Path(path)

    @property
    def columns(self) -> List[str]:
        """The column names in the file's order, without ``t_s`` (as a DataFrame's
        ``columns``); ``rec[name]`` is a column's values."""
        return list(self._data)

    @property
    def names(self) -> List[str]:
        """The column names (the same as :attr:`columns`)."""
        return list(self._data)

    def to_dict(self) -> Dict[str, np.ndarray]:
        """The columns by name, ``t_s`` left out (a new dict of the same arrays)."""
        return dict(self._data)

    def __contains__(self, name: object) -> bool:
        return name == "t_s" or name in self._data

    def __getitem__(self, name: str) -> np.ndarray:
        if name == "t_s":
            return self.t_s
        try:
            return self._data[name]
        except KeyError:
            raise KeyError(f"{name}: no such column (columns: {', '.join(self._data)})") from None

    def __setitem__(self, name: str, values: Iterable[float]) -> None:
        """Sets or adds a column (as many values as rows)."""
        column = np.asarray(values, dtype=float)
        if column.shape != self.t_s.shape:
            raise ValueError(f"{name}: {column.shape[0] if column.ndim else 1} values for {len(self.t_s)} rows")
        self._data[name] = column

    def __len__(self) -> int:
        return len(self.t_s)

    def to_pandas(self):
        """The columns as a pandas DataFrame indexed by ``t_s`` (needs pandas)."""
        try:
            import pandas as pd  # type: ignore[import-untyped]
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("Recording.to_pandas needs pandas: pip install pandas") from e
        return pd.DataFrame(self._data, index=pd.Index(self.t_s, name="t_s"))

    def __repr__(self) -> str:
        span = f"{self.t_s[-1] - self.t_s[0]:.3g} s" if len(self.t_s) else "empty"
        return f"Recording(rig={self.rig!r}, {len(self)} rows, {span}, columns={self.names!r})"


def _recording_paths(recordings: Any, scratch: _Scratch) -> List[Path]:
    """Paths for the command: a path stays as given; a Recording is written to the scratch
    folder under its file's name (so reports name it as they would the file)."""
    if isinstance(recordings, (str, os.PathLike, Recording)):
        recordings = [recordings]
    paths = []
    for i, r in enumerate(recordings):
        if isinstance(r, Recording):
            name = r.path.name if r.path is not None else f"recording_{i}.csv"
            folder = scratch.path / f"in_{i}"
            folder.mkdir(parents=True, exist_ok=True)
            paths.append(r.write(folder / name))
        else:
            paths.append(Path(r))
    if not paths:
        raise InputError("recordings: expected at least one recording")
    return paths


# --------------------------------------------------------------------------------------
# Results


class Table:
    """A results table (a sweep's ``results.csv``, a batch's ``summary.csv``): numeric
    columns as float arrays (NaN where empty), the others as lists of text."""

    def __init__(self, path: PathLike, report: str = "") -> None:
        #: The CSV file.
        self.path = Path(path)
        #: What the command printed.
        self.report = report
        with open(self.path, newline="") as f:
            rows = list(csv.reader(f))
        header, body = (rows[0], rows[1:]) if rows else ([], [])
        self._data: Dict[str, Any] = {}
        for i, name in enumerate(header):
            cells = [r[i] if i < len(r) else "" for r in body]
            self._data[name] = _numeric(cells)

    @property
    def columns(self) -> List[str]:
        """The column names, in the file's order; ``table[name]`` is a column."""
        return list(self._data)

    def __getitem__(self, name: str) -> Any:
        try:
            return self._data[name]
        except KeyError:
            raise KeyError(f"{name}: no such column (columns: {', '.join(self._data)})") from None

    def __len__(self) -> int:
        return len(next(iter(self._data.values()), []))

    @property
    def rows(self) -> List[Dict[str, Any]]:
        """One dict per row."""
        return [{k: v[i] for k, v in self._data.items()} for i in range(len(self))]

    def to_pandas(self):
        """The table as a pandas DataFrame (needs pandas)."""
        import pandas as pd  # type: ignore[import-untyped]

        return pd.DataFrame(self._data)

    def __repr__(self) -> str:
        return f"Table({len(self)} rows, columns={self.columns!r})"


def _numeric(cells: List[str]) -> Any:
    """Floats when every non-empty cell is a number (and one is), else the text."""
    if all(c == "" for c in cells):
        return cells
    values = []
    for c in cells:
        if c == "":
            values.append(math.nan)
            continue
        try:
            values.append(float(c))
        except ValueError:
            return cells
    return np.asarray(values, dtype=float)


class Imported:
    """What an import wrote: its recordings, the rig or scene beside them, the report."""

    def __init__(self, report: str) -> None:
        #: What the import printed (how each column was made).
        self.report = report
        found: Dict[str, List[Path]] = {"recording": [], "rig": [], "scene": []}
        for line in report.splitlines():
            m = re.match(r"^(recording|rig|scene) +(\S.*)$", line)
            if m:
                found[m.group(1)].append(Path(m.group(2)))
        #: The recordings written, read back.
        self.recordings = [Recording.read(p) for p in found["recording"]]
        #: The rig file written (SysId logs), if any.
        self.rig: Optional[Path] = found["rig"][0] if found["rig"] else None
        #: The scene written (where the robot's geometry is known), if any.
        self.scene: Optional[Scene] = Scene.load(found["scene"][0]) if found["scene"] else None

    @property
    def recording(self) -> Recording:
        """The (first) recording."""
        return self.recordings[0]

    def __repr__(self) -> str:
        return f"Imported({len(self.recordings)} recordings, rig={self.rig}, scene={self.scene})"


def _out(out: Optional[PathLike], prefix: str):
    """The output folder: the one given, or a scratch folder."""
    if out is not None:
        return Path(out), None
    s = _Scratch(prefix)
    return s.path / "out", s


# --------------------------------------------------------------------------------------
# Commands


@_speaks_python
def run(
    scene: Union[Scene, PathLike],
    duration_s: Optional[float] = None,
    seed: Optional[int] = None,
    out: Optional[PathLike] = None,
) -> Recording:
    """Simulates the scene, as ``agvsim run``; returns its recording (``.report`` holds the
    run's summary). ``out``: keep the recording and the scene as run in this folder."""
    scene = _scene(scene)
    folder, scratch = _out(out, "run")
    try:
        path, values = scene._args()
        report = _native.run(path, values, folder, duration_s=duration_s, seed=seed)
        rec = Recording.read(folder / f"{path.stem}.csv")
        rec.report = report
        if scratch is not None:
            rec.path = None
        return rec
    finally:
        if scratch is not None:
            scratch.cleanup()


@_speaks_python
def replay(
    scene: Union[Scene, PathLike],
    recording: Union[Recording, PathLike],
    out: Optional[PathLike] = None,
) -> Recording:
    """Drives the scene with the recording's inputs, as ``agvsim replay``; returns the
    simulated recording (``.report``: the fit per output)."""
    scene = _scene(scene)
    folder, scratch = _out(out, "replay")
    inputs = _Scratch("inputs")
    try:
        [rec_path] = _recording_paths(recording, inputs)
        path, values = scene._args()
        report = _native.replay(path, values, rec_path, folder)
        sim = Recording.read(folder / f"{rec_path.stem}.replay.csv")
        sim.report = report
        if scratch is not None:
            sim.path = None
        return sim
    finally:
        inputs.cleanup()
        if scratch is not None:
            scratch.cleanup()


@_speaks_python
def calibrate(
    scene: Union[Scene, PathLike],
    recordings: Any,
    free: Sequence[str] = (),
    effects: Sequence[str] = ("all",),
    validate: Any = (),
    out: Optional[PathLike] = None,
    jobs: int = 0,
    html: Optional[PathLike] = None,
) -> Calibration:
    """Fits the scene to recordings through the simulator, as ``agvsim calibrate``.

    ``free``: scene keys to fit (empty: the recording kind's set); ``effects``: ``"all"``,
    ``"none"`` or effect names; ``validate``: recordings to compare the scenes on; ``jobs``:
    worker threads (0: one per core). Returns the JSON's fields, the report and the
    calibrated :class:`Scene`; ``out`` keeps ``calibrated.toml``, ``calibrate.json`` and the
    plots there; ``html`` writes the self-contained report (the CLI's ``--html``).
    """
    import json

    scene = _scene(scene)
    if isinstance(effects, str):
        effects = [effects]
    scratch = _Scratch("calibrate")
    folder = Path(out) if out is not None else scratch.path / "out"
    folder.mkdir(parents=True, exist_ok=True)
    try:
        paths = _recording_paths(recordings, scratch)
        check = _recording_paths(validate, scratch) if validate else []
        path, values = scene._args()
        report = _native.calibrate(
            path, values, paths, list(free), list(effects),
            folder / "calibrate.json", folder / "calibrated.toml", check,
            report=folder / "plots" if out is not None else None, jobs=jobs,
            html=None if html is None else Path(html), command="agvsim.calibrate (Python)",
        )
        data = json.loads((folder / "calibrate.json").read_text())
    except BaseException:
        scratch.cleanup()
        raise
    # The calibrated scene keeps the scratch folder alive when it lives there.
    calibrated = Scene(folder / "calibrated.toml", _scratch=None if out is not None else scratch)
    if out is not None:
        scratch.cleanup()
    return Calibration.from_json(data, report, calibrated)


@_speaks_python
def diagnose(
    recordings: Any,
    rig: Optional[PathLike] = None,
    scene: Union[Scene, PathLike, None] = None,
    effects: Sequence[str] = ("all",),
    validate: Union[Recording, PathLike, None] = None,
    out: Optional[PathLike] = None,
    jobs: int = 0,
    html: Optional[PathLike] = None,
) -> Diagnosis:
    """Finds what physics the model leaves out, as ``agvsim diagnose``: with a ``rig``
    (the fitting models) or a ``scene`` (through the simulator). Returns the contract's
    diagnosis JSON as fields (``result.findings``, ``result.baseline``, ...)."""
    import json

    if (rig is None) == (scene is None):
        raise InputError("diagnose: give one of rig= or scene=")
    if isinstance(effects, str):
        effects = [effects]
    scratch = _Scratch("diagnose")
    try:
        folder = Path(out) if out is not None else scratch.path / "out"
        folder.mkdir(parents=True, exist_ok=True)
        paths = _recording_paths(recordings, scratch)
        check = _recording_paths(validate, scratch)[0] if validate is not None else None
        scene_path = None
        if scene is not None:
            s = _scene(scene)
            if s.values:
                raise InputError("diagnose: a scene with values set cannot be diagnosed; save it first (scene.save(path))")
            scene_path = s.path
        report = _native.diagnose(
            None if rig is None else Path(rig), scene_path, paths, list(effects),
            folder / "diagnosis.json", validate=check,
            report=folder / "report" if out is not None else None, jobs=jobs,
            html=None if html is None else Path(html), command="agvsim.diagnose (Python)",
        )
        return Diagnosis.from_json(json.loads((folder / "diagnosis.json").read_text()), report)
    finally:
        scratch.cleanup()


@_speaks_python
def identify(
    rig: PathLike,
    recordings: Any,
    model: Optional[str] = None,
    free: Optional[Sequence[str]] = None,
    validate: Union[Recording, PathLike, None] = None,
    starts: int = 3,
    max_iterations: int = 100,
    out: Optional[PathLike] = None,
    html: Optional[PathLike] = None,
) -> Identification:
    """Fits a rig's model to recordings, as ``agvsim identify``; returns the JSON report's
    fields (parameters with standard deviations, fits, loss)."""
    import json

    scratch = _Scratch("identify")
    try:
        folder = Path(out) if out is not None else scratch.path / "out"
        folder.mkdir(parents=True, exist_ok=True)
        paths = _recording_paths(recordings, scratch)
        check = _recording_paths(validate, scratch)[0] if validate is not None else None
        report = _native.identify(
            Path(rig), paths, folder / "identify.json", model=model,
            free=None if free is None else list(free), validate=check,
            report=folder / "plots" if out is not None else None,
            starts=starts, max_iterations=max_iterations,
            html=None if html is None else Path(html), command="agvsim.identify (Python)",
        )
        return Identification.from_json(json.loads((folder / "identify.json").read_text()), report)
    finally:
        scratch.cleanup()


def _vary_text(key: str, values: Any) -> str:
    """``--vary KEY=VALUES``: a list becomes ``a,b,c``; text (``"1..4:7"``,
    ``"log:0.1..10:5"``) is passed as the CLI takes it."""
    if isinstance(values, str):
        return f"{key}={values}"
    items = []
    for v in values:
        items.append(_set_text(key, v).split("=", 1)[1])
    return f"{key}={','.join(items)}"


@_speaks_python
def sweep(
    scene: Union[Scene, PathLike],
    vary: Mapping[str, Any],
    repeat: int = 1,
    duration_s: Optional[float] = None,
    shard: Optional[str] = None,
    out: Optional[PathLike] = None,
    jobs: int = 0,
    traces: bool = False,
    resume: bool = False,
    max_runs: Optional[int] = None,
) -> Table:
    """Runs the scene over a grid, as ``agvsim sweep``; returns ``results.csv`` as a table.

    ``vary``: ``{"controller.gain_scale": [1, 2, 3], "tyre.compound": "hard,soft"}``, the
    first key the slowest. ``shard="I/N"`` runs the I-th of N slices (merge them with
    :func:`sweep_merge`). Ctrl-C stops after the runs in progress, which are kept in
    ``out`` (``resume=True`` goes on).
    """
    scene = _scene(scene)
    folder, scratch = _out(out, "sweep")
    try:
        path, values = scene._args()
        report = _native.sweep(
            path, values, [_vary_text(k, v) for k, v in vary.items()], folder,
            repeat=repeat, jobs=jobs, shard=shard, duration_s=duration_s,
            traces=traces, resume=resume, max_runs=max_runs,
        )
        return _table(folder / "results.csv", report, scratch)
    finally:
        if scratch is not None:
            scratch.cleanup()


def _table(path: Path, report: str, scratch: Optional[_Scratch]) -> Table:
    t = Table(path, report)
    if scratch is not None:
        t.path = None  # type: ignore[assignment]
    return t


@_speaks_python
def sweep_merge(shards: Sequence[PathLike], out: PathLike) -> Table:
    """Joins sweep shard folders into one ``results.csv`` in ``out``, as ``agvsim sweep
    merge``: the same bytes as the unsharded sweep."""
    report = _native.sweep_merge([Path(s) for s in shards], Path(out))
    return Table(Path(out) / "results.csv", report)


def _batch(recordings: PathLike, out: Optional[PathLike], **kw: Any) -> Table:
    effects = kw.pop("effects")
    if isinstance(effects, str):
        effects = [effects]
    folder, scratch = _out(out, "batch")
    try:
        report = _native.batch(Path(recordings), folder, effects=list(effects), **kw)
        return _table(folder / "summary.csv", report, scratch)
    finally:
        if scratch is not None:
            scratch.cleanup()


@_speaks_python
def batch_calibrate(
    recordings: PathLike,
    scene: PathLike,
    effects: Sequence[str] = ("all",),
    shard: Optional[str] = None,
    out: Optional[PathLike] = None,
    jobs: int = 0,
) -> Table:
    """Calibrates the scene to every recording of a fleet (a folder or a list file), as
    ``agvsim batch calibrate``; returns ``summary.csv``. ``shard="I/N"`` runs a slice;
    :func:`batch_merge` joins the slices."""
    return _batch(recordings, out, scene=Path(scene), rig=None, effects=effects, shard=shard, jobs=jobs)


@_speaks_python
def batch_diagnose(
    recordings: PathLike,
    rig: Optional[PathLike] = None,
    effects: Sequence[str] = ("all",),
    shard: Optional[str] = None,
    out: Optional[PathLike] = None,
    jobs: int = 0,
) -> Table:
    """Diagnoses every recording of a fleet, as ``agvsim batch diagnose`` (each recording's
    ``NAME.rig.toml`` unless ``rig`` is given); returns ``summary.csv``."""
    return _batch(
        recordings, out, rig=None if rig is None else Path(rig), scene=None, effects=effects, shard=shard, jobs=jobs
    )


@_speaks_python
def batch_merge(shards: Sequence[PathLike], out: PathLike) -> Table:
    """Joins batch shard folders into one ``summary.csv`` in ``out``, as ``agvsim batch
    merge``."""
    report = _native.batch_merge([Path(s) for s in shards], Path(out))
    return Table(Path(out) / "summary.csv", report)


@_speaks_python
def import_ros2(
    bag: PathLike,
    out: PathLike,
    *,
    map: Optional[PathLike] = None,
    wheel_radius_m: Optional[float] = None,
    track_m: Optional[float] = None,
    mass_kg: Optional[float] = None,
    controller_yaml: Optional[PathLike] = None,
    battery_v: Optional[float] = None,
    motor_rated_v: Optional[float] = None,
    motor_no_load_rpm: Optional[float] = None,
    motor_stall_current_a: Optional[float] = None,
    motor_stall_torque_nm: Optional[float] = None,
    gear_ratio: Optional[float] = None,
    backlash_rad: Optional[float] = None,
) -> Imported:
    """Converts a ROS 2 (or ROS 1) bag, as ``agvsim import ros2``: ``out/BAG.csv`` and,
    where the track and wheel radius are known, ``out/BAG.scene.toml``."""
    given: Dict[str, Any] = {k: v for k, v in dict(
        map=map, wheel_radius_m=wheel_radius_m, track_m=track_m, mass_kg=mass_kg,
        controller_yaml=controller_yaml, battery_v=battery_v, motor_rated_v=motor_rated_v,
        motor_no_load_rpm=motor_no_load_rpm, motor_stall_current_a=motor_stall_current_a,
        motor_stall_torque_nm=motor_stall_torque_nm, gear_ratio=gear_ratio, backlash_rad=backlash_rad,
    ).items() if v is not None}
    command = f"agvsim.import_ros2({str(bag)!r}" + "".join(f", {k}={v!r}" for k, v in given.items()) + ")"
    for k in ("map", "controller_yaml"):
        if k in given:
            given[k] = Path(given[k])
    report = _native.import_ros2(Path(bag), Path(out), command, **given)
    return Imported(report)


@_speaks_python
def import_wpilib(
    file: PathLike,
    out: PathLike,
    *,
    routine: Optional[str] = None,
    motors: Sequence[str] = (),
    mechanism: Optional[str] = None,
    wheel_radius_m: Optional[float] = None,
    resistance_ohm: Optional[float] = None,
    track_m: Optional[float] = None,
    battery_v: Optional[float] = None,
) -> Imported:
    """Converts a WPILib SysId log (``.json`` or ``.wpilog``), as ``agvsim import wpilib``:
    a recording per test and a rig."""
    report = _native.import_wpilib(
        Path(file), Path(out), routine=routine, motors=list(motors), mechanism=mechanism,
        wheel_radius_m=wheel_radius_m, resistance_ohm=resistance_ohm,
        track_width_m=track_m, supply_v=battery_v,
    )
    return Imported(report)


def keys_reference() -> str:
    """Every scene key with its unit, range, default and meaning (``agvsim keys``)."""
    return _native.keys_markdown()


# The simulations held in memory (they use Scene and Recording above).
from .live import Sim, SimState, VecSim  # noqa: E402
from .lab import (  # noqa: E402
    EXPERIMENTS,
    STUDIES,
    Experiment,
    Linearisation,
    Presets,
    Study,
    experiment,
    linearize,
    presets,
    study,
)
