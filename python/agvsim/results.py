"""Typed results of ``calibrate``, ``diagnose`` and ``identify``.

Each is a dataclass built from the JSON the command writes (the same numbers, field for
field, under the same names), so that a type checker sees every field and its type. Units
are in the names, as in the JSON. Each result keeps the whole JSON as ``data`` and what the
command printed as ``report``; tables of keys, effects and parameters come as pandas
DataFrames on request (``to_pandas`` methods, which need pandas).

A value the library writes as ``null`` where a number is expected (a number that is not
finite) reads as ``nan``; a field that is absent or ``null`` by design (no standard
deviation, no bound reached) is ``None``.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Type, TypeVar, Union

import numpy as np

if typing.TYPE_CHECKING:  # pragma: no cover - for the annotations only
    from . import Scene

__all__ = [
    "Parameter",
    "LeftOut",
    "Alternative",
    "Effect",
    "Stage",
    "RegimeShare",
    "Unexplained",
    "DiagnosisValidation",
    "Diagnosis",
    "CalibratedKey",
    "HeldShift",
    "Correlation",
    "CalibratedEffect",
    "Switch",
    "RemovedEffect",
    "FitChange",
    "OutputFit",
    "ControllerMultipliers",
    "WheelGeometry",
    "Calibration",
    "CorrelationCheck",
    "OutputChecks",
    "Evaluation",
    "StateSpace",
    "Identification",
]

T = TypeVar("T")


# --------------------------------------------------------------------------------------
# From JSON


def _build(tp: Any, value: Any) -> Any:
    """``value`` (parsed JSON) as the type ``tp``: dataclasses field by field, lists and
    dicts item by item, numbers as floats (``null`` as ``nan``), arrays as numpy."""
    origin = typing.get_origin(tp)
    if origin is Union:
        options = [a for a in typing.get_args(tp) if a is not type(None)]
        return None if value is None else _build(options[0], value)
    if value is None:
        return math.nan if tp is float else None
    if dataclasses.is_dataclass(tp):
        return _from_json(typing.cast(Type[Any], tp), value)
    if origin is list:
        (item,) = typing.get_args(tp)
        return [_build(item, v) for v in value]
    if origin is dict:
        _, item = typing.get_args(tp)
        return {k: _build(item, v) for k, v in value.items()}
    if tp is np.ndarray:
        return np.array([[math.nan if v is None else v for v in row] for row in value], dtype=float)
    if tp is float:
        return float(value)
    return value


def _from_json(cls: Type[T], data: Dict[str, Any]) -> T:
    """A dataclass from a JSON object: each field from the key of its name (``json_name``
    in the field's metadata where they differ); absent keys take the field's default."""
    hints = typing.get_type_hints(cls)
    kwargs: Dict[str, Any] = {}
    for f in dataclasses.fields(typing.cast(Any, cls)):
        if not f.init:
            continue
        key = f.metadata.get("json_name", f.name)
        if key in data:
            kwargs[f.name] = _build(hints[f.name], data[key])
    return cls(**kwargs)


def _frame(rows: List[Any]):
    """Dataclass rows as a pandas DataFrame, one column per field (needs pandas)."""
    try:
        import pandas as pd  # type: ignore[import-untyped]
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("to_pandas needs pandas: pip install pandas") from e
    return pd.DataFrame([dataclasses.asdict(r) for r in rows])


def json_fields(cls: Type[Any]) -> Dict[str, Any]:
    """The JSON key each field of a result dataclass reads, with the field's type."""
    hints = typing.get_type_hints(cls)
    return {f.metadata.get("json_name", f.name): hints[f.name] for f in dataclasses.fields(cls) if f.init}


def uncovered(tp: Any, value: Any, where: str = "") -> List[str]:
    """The keys of ``value`` (parsed JSON) that the typed result ``tp`` has no field for,
    as paths (``effects[0].cannot_be_told_from``): what would be lost on the way to
    Python. Parts typed ``Any`` (kept as the JSON's objects) are not looked into."""
    if typing.get_origin(tp) is Union:
        tp = next(a for a in typing.get_args(tp) if a is not type(None))
    if value is None:
        return []
    if dataclasses.is_dataclass(tp):
        known = json_fields(typing.cast(Type[Any], tp))
        out = [f"{where}{k}" for k in value if k not in known]
        for k, v in value.items():
            if k in known:
                out += uncovered(known[k], v, f"{where}{k}.")
        return out
    if typing.get_origin(tp) is list:
        (item,) = typing.get_args(tp)
        return [m for i, v in enumerate(value) for m in uncovered(item, v, f"{where.rstrip('.')}[{i}].")]
    if typing.get_origin(tp) is dict:
        _, item = typing.get_args(tp)
        return [m for k, v in value.items() for m in uncovered(item, v, f"{where}{k}.")]
    return []


# --------------------------------------------------------------------------------------
# Shared


@dataclass(frozen=True)
class Parameter:
    """A fitted model parameter (``identify``'s parameters, a diagnosis's estimates)."""

    #: The parameter's name (its unit in the name).
    name: str
    #: The fitted value; for a parameter not fitted, the believed one.
    value: float
    #: The rig's belief (the search's start).
    nominal: Optional[float] = None
    #: Standard deviation; ``None`` where the record does not determine it, or where the
    #: search ended on a bound (then ``value`` is no estimate).
    std: Optional[float] = None
    #: Whether it was fitted.
    free: bool = False
    #: The bound the search ended on, if it did: no estimate then, but a sign that the
    #: belief or the model's structure is wrong.
    at_bound: Optional[float] = None
    #: What the record alone determines of it (its deviation without the belief).
    data_std: Optional[float] = None
    #: One standard deviation of the rig's belief, % of it (``None``: no belief).
    belief_sd_pct: Optional[float] = None
    #: Fitted, but held by its belief: the record determines it less well than the belief.
    held: bool = False

    @property
    def is_estimate(self) -> bool:
        """Fitted, not on a bound, with a standard deviation: a value the data give."""
        return self.free and self.at_bound is None and self.std is not None


@dataclass(frozen=True)
class LeftOut:
    """An output the recording measures but does not excite, left out of the fit."""

    #: The output column.
    output: str
    #: Why the record cannot show it.
    why: str


# --------------------------------------------------------------------------------------
# Diagnosis


@dataclass(frozen=True)
class Alternative:
    """An effect the record cannot tell from one found."""

    #: The effect's vocabulary name.
    name: str
    #: Its parameter's name.
    param: str
    #: Its fitted value.
    value: float
    #: How much less AIC it gains than the effect found.
    delta_aic_behind: float
    #: Why the record cannot tell them apart, and what record would.
    separated_by: str


@dataclass(frozen=True)
class Effect:
    """A missing physics found: a vocabulary effect, or a term outside it
    (``outside_vocabulary``), with its parameters as the contract names them."""

    #: The effect's vocabulary name, or the term's family.
    name: str
    #: Its parameters by contract name (a position-dependent term's ``knots`` and
    #: ``values`` are lists).
    params: Dict[str, Any]
    #: The main parameter's standard deviation (``None``: not determined).
    std: Dict[str, Optional[float]]
    #: The normalised fit with it, %, mean over outputs.
    fit_pct: float
    #: Why: where its residual lived and what it removed.
    evidence: str
    #: The physics in words.
    description: str = ""
    #: A term outside the vocabulary (a family of the contract).
    outside_vocabulary: bool = False
    #: Effects the record cannot tell from it.
    cannot_be_told_from: List[Alternative] = field(default_factory=list)
    #: AIC gain (terms).
    delta_aic: Optional[float] = None
    #: Share of the held-out blocks' residual its screen removed, % (terms).
    held_out_reduction_pct: Optional[float] = None
    #: The scene key it set (a diagnosis through the simulator).
    scene_key: Optional[str] = None
    #: The scene keys a term set (a diagnosis through the simulator).
    scene_keys: List[str] = field(default_factory=list)


@dataclass(frozen=True)
class Stage:
    """The model before the effects (``baseline``) or with them (``final``)."""

    #: Normalised fit, %, mean over outputs.
    fit_pct: float
    #: Normalised fit per output, %.
    fit_pct_per_output: Dict[str, float] = field(default_factory=dict)
    #: The fitted parameters by name.
    params: Dict[str, float] = field(default_factory=dict)
    #: Each parameter with its deviation and bounds (a diagnosis with a rig).
    estimates: List[Parameter] = field(default_factory=list)
    #: Free parameters whose search ended on a bound: no estimates (baseline).
    at_bound: Dict[str, float] = field(default_factory=dict)
    #: How long the final residual stays correlated, s (final).
    residual_correlation_s: Optional[float] = None


@dataclass(frozen=True)
class RegimeShare:
    """How much residual energy a regime holds against how much of the record it covers."""

    #: The regime, in words.
    regime: str
    #: Share of the samples, %.
    samples_pct: float
    #: Share of the energy, %.
    energy_pct: float
    #: The regime's energy as a share of the baseline's total residual energy, %.
    energy_of_baseline_pct: float


@dataclass(frozen=True)
class Unexplained:
    """Structure the residual keeps that no effect and no term explains."""

    #: Share of the residual the best failed term removed, %: what a model could gain.
    fit_gap_pct: float
    #: Where the residual concentrates and what it correlates with.
    where: str


@dataclass(frozen=True)
class DiagnosisValidation:
    """The diagnosed model on a held-out recording."""

    #: The held-out recording.
    recording: str
    #: The baseline's mean fit on it, %.
    baseline_fit_pct: float
    #: The diagnosed model's mean fit on it, %.
    final_fit_pct: float


@dataclass(frozen=True)
class Diagnosis:
    """What physics the model leaves out (the contract's diagnosis JSON, typed).

    ``effects`` lists what was found, in the order found (empty: nothing missing);
    ``baseline`` and ``final`` are the model before and after them.
    """

    #: The recording's file name.
    recording: str
    #: The model diagnosed.
    model: str
    #: The model without the effects.
    baseline: Stage
    #: The effects and terms found.
    effects: List[Effect]
    #: The model with them.
    final: Stage
    #: Input columns the model has no use for.
    ignored_inputs: List[str] = field(default_factory=list)
    #: Outputs measured but not excited, left out of the fit.
    left_out: List[LeftOut] = field(default_factory=list)
    #: Residual energy by regime before the effects.
    where_before: List[RegimeShare] = field(default_factory=list)
    #: Residual energy by regime after them.
    where_after: List[RegimeShare] = field(default_factory=list)
    #: Every candidate effect of each round, as fitted (the JSON's objects).
    candidates: List[List[Dict[str, Any]]] = field(default_factory=list)
    #: Each round's search of terms outside the vocabulary (``None``: none run).
    term_candidates: List[Optional[Dict[str, Any]]] = field(default_factory=list)
    #: The effective number of independent residuals the evidence was counted with.
    effective_n: Optional[float] = None
    #: Relative error per output, %, ``{"baseline": {...}, "final": {...}}``.
    relative_error_pct: Dict[str, Dict[str, float]] = field(default_factory=dict)
    #: Structure left that nothing named explains.
    unexplained: Optional[Unexplained] = None
    #: SysId's feedforward gains of the same record (voltage-driven records).
    sysid_feedforward: Optional[Dict[str, Any]] = None
    #: The diagnosed model on the held-out recording.
    validation: Optional[DiagnosisValidation] = None
    #: What the command printed.
    report: str = field(default="", metadata={"json_name": "-report"})
    #: The whole JSON.
    data: Dict[str, Any] = field(default_factory=dict, metadata={"json_name": "-data"})

    @classmethod
    def from_json(cls, data: Dict[str, Any], report: str = "") -> "Diagnosis":
        """From the diagnosis JSON (``agvsim diagnose --json``)."""
        return dataclasses.replace(_from_json(cls, data), report=report, data=data)

    @property
    def names(self) -> List[str]:
        """The names of the effects and terms found, in the order found."""
        return [e.name for e in self.effects]

    def effects_frame(self):
        """The effects found as a DataFrame: name, parameters, fit, evidence (pandas)."""
        return _frame(self.effects)

    def estimates_frame(self, stage: str = "final"):
        """The ``"baseline"`` or ``"final"`` model's parameters as a DataFrame (pandas)."""
        if stage not in ("baseline", "final"):
            raise ValueError(f"stage={stage!r}: expected 'baseline' or 'final'")
        return _frame(getattr(self, stage).estimates)

    def __repr__(self) -> str:
        found = ", ".join(self.names) or "nothing missing"
        return f"Diagnosis({self.recording!r}: {found}; fit {self.baseline.fit_pct:.1f} % -> {self.final.fit_pct:.1f} %)"


# --------------------------------------------------------------------------------------
# Calibration


@dataclass(frozen=True)
class Correlation:
    """Another key a calibrated key trades with."""

    #: The other key.
    key: str
    #: Their correlation, -1..1.
    correlation: float


@dataclass(frozen=True)
class HeldShift:
    """How an estimate moves with a key held because the recording could not tell it apart."""

    #: The held key.
    key: str
    #: The estimate's change (its unit) when the held key is 10 % above its held value.
    shift_per_10_pct: float


@dataclass(frozen=True)
class CalibratedKey:
    """A scene key before and after calibration."""

    #: The scene key (its unit in the name).
    key: str
    #: The scene's value.
    scene: float
    #: The value written to the calibrated scene.
    calibrated: float
    #: The value the fit reached.
    fitted: float
    #: Standard deviation (``None``: not determined, or on a bound).
    std: Optional[float] = None
    #: The bound the search ended on, if it did: no estimate then.
    at_bound: Optional[float] = None
    #: Held by the scene's belief: the record determines it less well than the belief.
    held_by_belief: bool = False
    #: Keys it trades with (strongly correlated estimates).
    trades_with: List[Correlation] = field(default_factory=list)
    #: Confounded with another key: the record cannot tell them apart.
    confounded: bool = False
    #: Whether the value is an estimate the data give (not on a bound, not held).
    estimate: bool = False
    #: An estimate whose 95 % interval reaches further than 10 % of it either side.
    loosely_determined: bool = False
    #: How the estimate moves with each key held because the recording could not tell it apart.
    moves_with_held: List[HeldShift] = field(default_factory=list)
    #: Its interval holds only given a held key's value (10 % of it moves the estimate by
    #: more than its standard deviation).
    conditional_on_held: bool = False


@dataclass(frozen=True)
class CalibratedEffect:
    """An effect tried through the simulator, with its verdict."""

    #: The effect's vocabulary name.
    name: str
    #: The scene key that switches it on.
    key: str
    #: Its fitted value (``None``: the trial failed).
    value: Optional[float] = None
    #: Standard deviation.
    std: Optional[float] = None
    #: The bound the search ended on, if it did.
    at_bound: Optional[float] = None
    #: AIC gain.
    delta_aic: Optional[float] = None
    #: Share of the weighted residual removed, %.
    rss_reduction_pct: Optional[float] = None
    #: Accepted into the calibrated scene.
    accepted: bool = False
    #: Accepted, then removed by a later round.
    removed: bool = False
    #: Only its race was run (it could not win).
    raced_only: bool = False
    #: Why an effect passing the rule was not confirmed (``"simulator"``,
    #: ``"validation"``), if it was not.
    unconfirmed: Optional[str] = None
    #: The key's value in the scene before.
    scene_value: Optional[float] = None


@dataclass(frozen=True)
class Switch:
    """A scene switch an effect set (a castor model, a drive mode)."""

    #: The effect.
    effect: str
    #: The key.
    key: str
    #: Its value.
    value: Any


@dataclass(frozen=True)
class RemovedEffect:
    """An effect the scene had that the recording did not support: switched off."""

    #: The effect.
    effect: str
    #: The key.
    key: str
    #: Its value before.
    was: float
    #: Its value now (off).
    now: float


@dataclass(frozen=True)
class FitChange:
    """A normalised fit on the original and the calibrated scene, %."""

    #: On the original scene, %.
    original: float
    #: On the calibrated scene, %.
    calibrated: float


@dataclass(frozen=True)
class OutputFit:
    """One output's replay fit on the original and the calibrated scene, %."""

    #: On the original scene, %.
    original_pct: float
    #: On the calibrated scene, %.
    calibrated_pct: float


@dataclass(frozen=True)
class ControllerMultipliers:
    """``diff_drive_controller``'s multipliers for the calibrated geometry (paste them
    into the controller's YAML)."""

    wheel_separation_multiplier: float
    left_wheel_radius_multiplier: float
    right_wheel_radius_multiplier: float


@dataclass(frozen=True)
class WheelGeometry:
    """The calibrated wheel geometry, with deviations and UMBmark's figures."""

    left_radius_m: float
    left_radius_std_m: Optional[float]
    right_radius_m: float
    right_radius_std_m: Optional[float]
    track_m: float
    track_std_m: Optional[float]
    configured_radius_m: float
    configured_separation_m: float
    #: UMBmark's wheel-diameter error (right over left radius).
    umbmark_ed: float
    #: UMBmark's wheelbase error (calibrated over configured track).
    umbmark_eb: float
    diff_drive_controller: ControllerMultipliers


@dataclass(frozen=True)
class Calibration:
    """A calibration: each key before and after, each effect tried, the fits, and the
    calibrated :class:`agvsim.Scene` (``scene``)."""

    #: The scene file calibrated.
    scene_file: str = field(metadata={"json_name": "scene"})
    #: The recording (or recordings).
    recording: str
    #: Each fitted key.
    keys: List[CalibratedKey]
    #: Each effect tried.
    effects: List[CalibratedEffect]
    #: The replay fit per output.
    replay_fit: Dict[str, OutputFit]
    #: The mean replay fit.
    mean_fit_pct: FitChange
    #: Scene switches effects set.
    switches: List[Switch] = field(default_factory=list)
    #: Effects switched off.
    removed: List[RemovedEffect] = field(default_factory=list)
    #: Outputs left out of the fit.
    left_out: List[LeftOut] = field(default_factory=list)
    #: The wheel geometry, where it was fitted.
    wheel_geometry: Optional[WheelGeometry] = None
    #: Solver iterations.
    iterations: Optional[int] = None
    #: The residual blocks' length, s, whose scores' spread gave the standard deviations.
    residual_correlation_s: Optional[float] = None
    #: The model check (the JSON's object): ``passes`` (False: the residual follows a
    #: signal the model knows, and the intervals are not to be trusted) and each output's
    #: strongest ``residual_links`` with their ``strength`` (1 is where the check fails).
    model_check: Optional[Dict[str, Any]] = None
    #: The search of terms outside the vocabulary, if run (the JSON's object).
    terms: Optional[Dict[str, Any]] = None
    #: The calibrated scene (see :attr:`scene`; typed there, as this module is imported
    #: before :class:`agvsim.Scene` exists).
    calibrated_scene: Any = field(default=None, repr=False, metadata={"json_name": "-scene"})
    #: What the command printed.
    report: str = field(default="", metadata={"json_name": "-report"})
    #: The whole JSON.
    data: Dict[str, Any] = field(default_factory=dict, metadata={"json_name": "-data"})

    @classmethod
    def from_json(cls, data: Dict[str, Any], report: str = "", scene: Any = None) -> "Calibration":
        """From ``calibrate.json`` (``agvsim calibrate --json``)."""
        return dataclasses.replace(_from_json(cls, data), report=report, data=data, calibrated_scene=scene)

    @property
    def scene(self) -> "Scene":
        """The calibrated scene (the CLI's ``--write``), an :class:`agvsim.Scene`."""
        return typing.cast("Scene", self.calibrated_scene)

    @property
    def accepted(self) -> List[CalibratedEffect]:
        """The effects accepted into the calibrated scene (and not removed)."""
        return [e for e in self.effects if e.accepted and not e.removed]

    def key(self, name: str) -> CalibratedKey:
        """One calibrated key by name."""
        for k in self.keys:
            if k.key == name:
                return k
        raise KeyError(f"{name}: not a calibrated key (calibrated: {', '.join(k.key for k in self.keys)})")

    def keys_frame(self):
        """The keys as a DataFrame: key, scene, calibrated, std, at_bound, ... (pandas)."""
        return _frame(self.keys)

    def effects_frame(self):
        """The effects tried as a DataFrame (pandas)."""
        return _frame(self.effects)

    def __repr__(self) -> str:
        names = ", ".join(e.name for e in self.accepted) or "no effect"
        return (
            f"Calibration({len(self.keys)} keys, {names}; fit {self.mean_fit_pct.original:.1f} %"
            f" -> {self.mean_fit_pct.calibrated:.1f} %)"
        )


# --------------------------------------------------------------------------------------
# Identification


@dataclass(frozen=True)
class CorrelationCheck:
    """A residual correlation over lags with its 99 % band."""

    #: Lags, samples.
    lags: List[int]
    #: Normalised correlation at each lag.
    values: List[float]
    #: Half-width of the 99 % band.
    band: float
    #: Lags outside the band.
    outside: int
    #: Whether the residual passes (few lags outside, none far outside).
    passes: bool


@dataclass(frozen=True)
class OutputChecks:
    """Residual checks of one output."""

    #: The output.
    output: str
    #: Autocorrelation of its residual.
    whiteness: CorrelationCheck
    #: Cross-correlation with each input, as ``[input, check]`` pairs.
    independence: List[Any]


@dataclass(frozen=True)
class Evaluation:
    """How the model matches one recording."""

    #: The recording's name.
    recording: str
    #: Rows compared.
    n_samples: int
    #: Normalised fit per output, %.
    fit_pct: Dict[str, float]
    #: Mean of the per-output fits, %.
    fit_pct_mean: float
    #: RMS residual per output (output units).
    rms: Dict[str, float]
    #: Loss: determinant of the residual covariance.
    loss: float
    #: Residual checks per output.
    checks: List[OutputChecks] = field(default_factory=list)


@dataclass(frozen=True, eq=False)
class StateSpace:
    """The thesis-style continuous-time A and B, with standard deviations (NaN: fixed
    or not determined)."""

    a: np.ndarray
    a_std: np.ndarray
    b: np.ndarray
    b_std: np.ndarray


@dataclass(frozen=True)
class Identification:
    """A rig's model fitted to recordings: parameters with deviations, loss, FPE, AIC,
    the fit per output and the residual checks."""

    #: The model's name.
    model: str
    #: The rig file.
    rig: str
    #: Every parameter.
    params: List[Parameter]
    #: Free parameters.
    n_free: int
    #: Residuals (measured output cells).
    n_residuals: int
    #: Akaike's final prediction error.
    fpe: float
    #: N ln V + 2 d.
    aic: float
    #: Solver iterations.
    iterations: int
    #: Model simulations.
    evaluations: int
    #: Whether the solver converged.
    converged: bool
    #: Starts tried.
    starts: int
    #: The fit on the estimation record.
    estimation: Evaluation
    #: The fit on the validation record.
    validation: Optional[Evaluation] = None
    #: Input columns the model has no use for.
    ignored_inputs: List[str] = field(default_factory=list)
    #: Outputs measured but not excited, left out.
    left_out: List[LeftOut] = field(default_factory=list)
    #: A and B (the DCMC structures).
    state_space: Optional[StateSpace] = None
    #: SysId's kS, kV, kA of the same record (voltage-driven records; the JSON's object).
    feedforward: Optional[Dict[str, Any]] = None
    #: What the command printed.
    report: str = field(default="", metadata={"json_name": "-report"})
    #: The whole JSON.
    data: Dict[str, Any] = field(default_factory=dict, metadata={"json_name": "-data"})

    @classmethod
    def from_json(cls, data: Dict[str, Any], report: str = "") -> "Identification":
        """From ``identify.json`` (``agvsim identify --json``)."""
        return dataclasses.replace(_from_json(cls, data), report=report, data=data)

    def param(self, name: str) -> Parameter:
        """One parameter by name."""
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(f"{name}: not a parameter of {self.model} (its parameters: {', '.join(p.name for p in self.params)})")

    def params_frame(self):
        """The parameters as a DataFrame: name, value, std, at_bound, ... (pandas)."""
        return _frame(self.params)

    def __repr__(self) -> str:
        return f"Identification({self.model!r}: {self.n_free} free, fit {self.estimation.fit_pct_mean:.1f} %)"
