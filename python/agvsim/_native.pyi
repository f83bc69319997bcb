"""Type stubs of agvsim's native module (python/src/lib.rs): each function is one agvsim
command, returning what the command printed. Use the `agvsim` package, not this module."""

import os
from typing import List, Optional, Sequence, Tuple, final

_Path = os.PathLike[str] | str

__all__ = ['AgvsimError', 'InputError', 'scene_info', 'check', 'new_scene', 'run', 'replay', 'calibrate', 'diagnose', 'identify', 'sweep', 'sweep_merge', 'batch', 'batch_merge', 'import_ros2', 'import_wpilib', 'read_recording', 'write_recording', 'keys_markdown', 'linearize', 'presets', 'experiment', 'study', 'NativeSim', 'NativeVecSim', 'NativeSaved']

class AgvsimError(Exception):
    """A command of agvsim that could not be done (the CLI's exit status 1)."""

class InputError(AgvsimError):
    """Input to mend: a scene, rig, recording, bag or argument that agvsim cannot use."""

def scene_info(
    path: _Path, set: Sequence[str]
) -> Tuple[str, List[Tuple[str, Optional[float], str]], str]: ...
def check(scene: _Path, set: Sequence[str]) -> str: ...
def new_scene(
    out: _Path,
    command: str,
    from_: Optional[_Path] = None,
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
) -> str: ...
def run(
    scene: _Path,
    set: Sequence[str],
    out: _Path,
    duration_s: Optional[float] = None,
    seed: Optional[int] = None,
) -> str: ...
def replay(scene: _Path, set: Sequence[str], recording: _Path, out: _Path) -> str: ...
def calibrate(
    scene: _Path,
    set: Sequence[str],
    recordings: Sequence[_Path],
    free: Sequence[str],
    effects: Sequence[str],
    json: _Path,
    write: _Path,
    validate: Sequence[_Path],
    report: Optional[_Path] = None,
    jobs: int = 0,
    html: Optional[_Path] = None,
    command: str = ...,
) -> str: ...
def diagnose(
    rig: Optional[_Path],
    scene: Optional[_Path],
    recordings: Sequence[_Path],
    effects: Sequence[str],
    json: _Path,
    validate: Optional[_Path] = None,
    report: Optional[_Path] = None,
    jobs: int = 0,
    html: Optional[_Path] = None,
    command: str = ...,
) -> str: ...
def identify(
    rig: _Path,
    recordings: Sequence[_Path],
    json: _Path,
    model: Optional[str] = None,
    free: Optional[Sequence[str]] = None,
    validate: Optional[_Path] = None,
    report: Optional[_Path] = None,
    starts: int = 3,
    max_iterations: int = 100,
    html: Optional[_Path] = None,
    command: str = ...,
) -> str: ...
def sweep(
    scene: _Path,
    set: Sequence[str],
    vary: Sequence[str],
    out: _Path,
    repeat: int = 1,
    jobs: int = 0,
    shard: Optional[str] = None,
    duration_s: Optional[float] = None,
    traces: bool = False,
    resume: bool = False,
    max_runs: Optional[int] = None,
) -> str: ...
def sweep_merge(shards: Sequence[_Path], out: _Path) -> str: ...
def batch(
    recordings: _Path,
    out: _Path,
    rig: Optional[_Path] = None,
    scene: Optional[_Path] = None,
    effects: Sequence[str] = ...,
    shard: Optional[str] = None,
    jobs: int = 0,
) -> str: ...
def batch_merge(shards: Sequence[_Path], out: _Path) -> str: ...
def import_ros2(
    bag: _Path,
    out: _Path,
    command: str,
    map: Optional[_Path] = None,
    wheel_radius_m: Optional[float] = None,
    track_m: Optional[float] = None,
    mass_kg: Optional[float] = None,
    controller_yaml: Optional[_Path] = None,
    battery_v: Optional[float] = None,
    motor_rated_v: Optional[float] = None,
    motor_no_load_rpm: Optional[float] = None,
    motor_stall_current_a: Optional[float] = None,
    motor_stall_torque_nm: Optional[float] = None,
    gear_ratio: Optional[float] = None,
    backlash_rad: Optional[float] = None,
) -> str: ...
def import_wpilib(
    file: _Path,
    out: _Path,
    routine: Optional[str] = None,
    motors: Sequence[str] = ...,
    mechanism: Optional[str] = None,
    wheel_radius_m: Optional[float] = None,
    resistance_ohm: Optional[float] = None,
    track_width_m: Optional[float] = None,
    supply_v: Optional[float] = None,
) -> str: ...
def read_recording(
    path: _Path,
) -> Tuple[str, List[Tuple[str, str]], List[str], bytes, List[bytes], List[int]]: ...
def write_recording(
    path: _Path,
    rig: str,
    meta: Sequence[Tuple[str, str]],
    names: Sequence[str],
    t_s: Sequence[float],
    columns: Sequence[Sequence[float]],
) -> None: ...
def keys_markdown() -> str: ...
def linearize(scene: _Path, set: Sequence[str]) -> Tuple[str, str]: ...
def presets() -> Tuple[
    List[Tuple[str, str, float, float, float, float, float]],
    List[Tuple[str, str]],
    List[Tuple[str, float, str]],
    str,
]: ...
def experiment(
    kind: str,
    scene: _Path,
    set: Sequence[str],
    out: _Path,
    name: Optional[str] = None,
    seed: Optional[int] = None,
    interval_s: Optional[float] = None,
    duration_s: float = 15.0,
    pattern: str = ...,
    peak_demand_pct: float = 40.0,
    hold_samples: Tuple[int, int] = ...,
    speed_noise_rad_s: float = 0.5,
    rig_error: float = 0.0,
) -> str: ...
def study(name: str, out: _Path, jobs: int = 0, quick: bool = False) -> str: ...

@final
class NativeSaved:
    """A saved instant of a NativeSim."""
    @property
    def time_s(self) -> float: ...

@final
class NativeSim:
    """One scene's simulation held in memory."""
    def __new__(cls, scene: _Path, set: Sequence[str], seed: Optional[int] = None) -> NativeSim: ...
    @property
    def warnings(self) -> str: ...
    def reset(self, seed: Optional[int] = None) -> None: ...
    def step(self, command: Optional[Tuple[float, float]], n: int) -> None: ...
    def outputs(self) -> bytes: ...
    def state(self) -> bytes: ...
    @property
    def output_names(self) -> List[str]: ...
    @property
    def output_decimals(self) -> List[int]: ...
    @property
    def state_names(self) -> List[str]: ...
    @property
    def command_names(self) -> List[str]: ...
    @property
    def is_velocity_base(self) -> bool: ...
    @property
    def time_s(self) -> float: ...
    @property
    def dt_s(self) -> float: ...
    @property
    def duration_s(self) -> float: ...
    @property
    def record_interval_s(self) -> float: ...
    @property
    def top_speed_m_s(self) -> float: ...
    @property
    def track_m(self) -> float: ...
    @property
    def dcmc_fault(self) -> Optional[str]: ...
    @property
    def dcmc_enable_delay_s(self) -> float: ...
    @property
    def lost_wire(self) -> bool: ...
    def manoeuvre_command(self, t_s: float) -> Optional[Tuple[float, float]]: ...
    def save(self) -> NativeSaved: ...
    def restore(self, saved: NativeSaved) -> None: ...

@final
class NativeVecSim:
    """Many simulations held in memory, stepped together."""
    def __new__(cls, members: Sequence[Tuple[_Path, Sequence[str], Optional[int]]]) -> NativeVecSim: ...
    @property
    def warnings(self) -> str: ...
    def __len__(self) -> int: ...
    def step(self, commands: Optional[Sequence[float]], n: int) -> None: ...
    def reset(self, seeds: Optional[Sequence[int]] = None) -> None: ...
    def outputs(self) -> bytes: ...
    def state(self) -> bytes: ...
    def times_s(self) -> List[float]: ...
