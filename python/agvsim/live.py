"""Simulations held in memory: :class:`Sim` (one scene, stepped from Python) and
:class:`VecSim` (many, stepped together in Rust with the GIL released).

A :class:`Sim` is the simulator ``agvsim run`` drives, loaded as ``run`` loads the scene,
with no files written. Stepped with no command it drives as ``run`` does (the firmware
follows the wire; a velocity-commanded base drives its manoeuvre), so stepping it through
a run gives the numbers of ``run``'s recording. Given a command it drives with that:
demands ``(forward_pct, turn_pct)`` on a wire-following scene, ``cmd_vel``
``(linear_m_s, angular_rad_s)`` on a velocity-commanded base (``sim.command_names``).

>>> import agvsim
>>> sim = agvsim.Sim("scenes/lab_offset_120mm.toml")
>>> sim.output_names[:3]
['demand_fwd_pct', 'demand_turn_pct', 'left_voltage_V']
>>> out = sim.step(n=1000)                   # 1 s with the thesis's P-D law
>>> round(sim.time, 3)
1.0
>>> saved = sim.snapshot()
>>> a = sim.step(n=200)
>>> sim.restore(saved)
>>> bool((sim.step(n=200) == a).all())        # the same numbers again
True
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import InputError

if TYPE_CHECKING:  # pragma: no cover
    from . import PathLike, Scene

__all__ = ["Sim", "VecSim", "SimState"]


def _scene_args(scene: "Union[Scene, PathLike]") -> "Tuple[Path, List[str]]":
    from . import _scene

    s = _scene(scene)
    return s.path, s.values


def _steps(n: int) -> int:
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"step(n={n!r}): expected a whole number of physics steps, 1 or more")
    return int(n)


def _pair(command: Any, names: Sequence[str]) -> Optional[Tuple[float, float]]:
    if command is None:
        return None
    try:
        a, b = (float(x) for x in command)
    except (TypeError, ValueError):
        raise InputError(
            f"step(command={command!r}): expected two numbers ({', '.join(names)}) or None"
        ) from None
    return a, b


def _seed(name: str, seed: Optional[int]) -> Optional[int]:
    if seed is None:
        return None
    return _whole_seed(name, seed)


def _whole_seed(name: str, seed: int) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= 2**63 - 1:
        raise InputError(f"{name}={seed!r}: expected a whole number from 0 to 2**63 - 1")
    return int(seed)


class SimState:
    """A saved instant of a :class:`Sim` (``sim.snapshot()``); ``sim.restore(state)`` goes
    back to it, and the simulation then goes on exactly as it did the first time."""

    def __init__(self, native: "_native.NativeSaved") -> None:
        self._native = native

    @property
    def time(self) -> float:
        """The simulated time it was saved at, s."""
        return self._native.time_s

    def __repr__(self) -> str:
        return f"SimState(time={self.time:.4f} s)"


class Sim:
    """One scene's simulation in memory. ``scene`` is a :class:`agvsim.Scene` or a scene
    file; ``seed`` the sensor noise's seed (the scene's ``sim.seed`` if ``None``)."""

    def __init__(self, scene: "Union[Scene, PathLike]", seed: Optional[int] = None) -> None:
        path, values = _scene_args(scene)
        self._native = _native.NativeSim(path, values, _seed("seed", seed))
        #: What loading the scene said (its warnings); empty if nothing.
        self.warnings: str = self._native.warnings
        #: The names of :attr:`outputs`, units in the names: the columns of the recording
        #: ``agvsim run`` writes, but ``t_s``.
        self.output_names: List[str] = list(self._native.output_names)
        #: The names of :attr:`state`, units in the names.
        self.state_names: List[str] = list(self._native.state_names)
        #: What a command is: ``['demand_fwd_pct', 'demand_turn_pct']`` on a
        #: wire-following scene, ``['cmd_linear_m_s', 'cmd_angular_rad_s']`` on a
        #: velocity-commanded base.
        self.command_names: List[str] = list(self._native.command_names)
        #: The physics step, s.
        self.dt: float = self._native.dt_s
        #: The scene's run length (``sim.duration_s``), s.
        self.duration: float = self._native.duration_s
        #: The interval ``agvsim run`` records rows at (``sim.record_interval_s``), s.
        self.record_interval: float = self._native.record_interval_s
        #: Whether the scene is a velocity-commanded base.
        self.is_velocity_base: bool = self._native.is_velocity_base
        #: The base's top speed at the rim (the motors' no-load speed at the drive
        #: limit), m/s.
        self.top_speed: float = self._native.top_speed_m_s
        #: The drive wheels' track, m.
        self.track: float = self._native.track_m
        self._index = {n: i for i, n in enumerate(self.output_names)}

    def reset(self, seed: Optional[int] = None) -> np.ndarray:
        """Back to rest at the start pose (noise seeded by ``seed``, else as before);
        returns the outputs."""
        self._native.reset(_seed("reset(seed)", seed))
        return self.outputs

    def step(self, command: Optional[Sequence[float]] = None, n: int = 1) -> np.ndarray:
        """Steps ``n`` physics steps with ``command`` held (``None``: as ``agvsim run``
        drives the scene); returns the outputs after them."""
        self._native.step(_pair(command, self.command_names), _steps(n))
        return self.outputs

    @property
    def outputs(self) -> np.ndarray:
        """The outputs now (float64, in :attr:`output_names`' order)."""
        return np.frombuffer(self._native.outputs(), dtype="<f8").copy()

    @property
    def state(self) -> np.ndarray:
        """The mechanical and electrical state now (pose, body velocity, each side's motor
        angle, speed and current, wheel angle and speed, gear gap, slip; float64, in
        :attr:`state_names`' order)."""
        return np.frombuffer(self._native.state(), dtype="<f8").copy()

    def output(self, name: str) -> float:
        """One output now, by name (e.g. ``"lateral_error_m"``)."""
        try:
            i = self._index[name]
        except KeyError:
            raise KeyError(f"{name}: no such output (outputs: {', '.join(self.output_names)})") from None
        return float(self.outputs[i])

    def outputs_dict(self) -> Dict[str, float]:
        """The outputs now by name."""
        return dict(zip(self.output_names, self.outputs.tolist()))

    @property
    def time(self) -> float:
        """Simulated time, s."""
        return self._native.time_s

    @property
    def lost_wire(self) -> bool:
        """Whether the vehicle has lost its guide wire now (neither coil sees it)."""
        return self._native.lost_wire

    @property
    def dcmc_fault(self) -> Optional[str]:
        """The DCMC's fault now (it then brakes the motors), else ``None``. A non-zero
        demand within ``dcmc_enable_delay`` of the start faults it, as the real one."""
        return self._native.dcmc_fault

    @property
    def dcmc_enable_delay(self) -> float:
        """The time from the start in which a non-zero demand faults the DCMC
        (``dcmc.enable_delay_s``), s."""
        return self._native.dcmc_enable_delay_s

    def manoeuvre_command(self, t: Optional[float] = None) -> Optional[Tuple[float, float]]:
        """A velocity-commanded base's manoeuvre command at ``t`` (now if ``None``):
        ``(linear_m_s, angular_rad_s)``; ``None`` on a wire-following scene."""
        return self._native.manoeuvre_command(self.time if t is None else float(t))

    def snapshot(self) -> SimState:
        """Saves this instant (see :meth:`restore`)."""
        return SimState(self._native.save())

    def restore(self, state: SimState) -> None:
        """Goes back to a saved instant of this simulation."""
        if not isinstance(state, SimState):
            raise InputError(f"restore(state={state!r}): expected a SimState from Sim.snapshot()")
        self._native.restore(state._native)

    def rollout(self, duration: Optional[float] = None) -> "Recording":
        """Steps on for ``duration`` s (the rest of ``sim.duration_s`` if ``None``) as
        ``agvsim run`` drives the scene, a row every ``record_interval``; returns the rows
        (starting with now) as a :class:`agvsim.Recording`, as ``run`` would write them
        but at full precision."""
        from . import Recording

        if duration is None:
            duration = max(self.duration - self.time, 0.0)
        if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration >= 0):
            raise InputError(f"rollout(duration={duration!r}): expected a finite time, s, 0 or more")
        every = max(int(round(self.record_interval / self.dt)), 1)
        steps = int(round(duration / self.dt))
        rows = [self.outputs]
        times = [self.time]
        done = 0
        while done < steps:
            k = min(every, steps - done)
            rows.append(self.step(None, k))
            times.append(self.time)
            done += k
        table = np.vstack(rows)
        return Recording(times, {n: table[:, i] for i, n in enumerate(self.output_names)})

    def __repr__(self) -> str:
        kind = "velocity base" if self.is_velocity_base else "wire-following"
        return f"Sim({kind}, t={self.time:.4f} s, dt={self.dt} s)"


class VecSim:
    """Many simulations stepped together in Rust (on the library's worker threads, the GIL
    released): ``n`` copies of one scene, or one per scene given, optionally with values
    per member (``values[i]`` a mapping of keys) and seeds. Arrays are shaped
    ``(n, ...)``; each member's numbers are those of a :class:`Sim` of it."""

    def __init__(
        self,
        scenes: "Union[Scene, PathLike, Sequence[Union[Scene, PathLike]]]",
        n: Optional[int] = None,
        values: Optional[Sequence[Mapping[str, object]]] = None,
        seeds: Optional[Sequence[int]] = None,
    ) -> None:
        from . import _scene

        many = isinstance(scenes, (list, tuple))
        members = [_scene(s) for s in scenes] if many else None  # type: ignore[union-attr]
        count = len(members) if members is not None else (n if n is not None else (len(values) if values else 1))
        if members is not None and n is not None and n != len(members):
            raise InputError(f"VecSim(n={n}): {len(members)} scenes given; give n or the scenes, not both")
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise InputError(f"VecSim(n={n!r}): expected a whole number of simulations, 1 or more")
        if members is None:
            members = [_scene(scenes)] * count  # type: ignore[arg-type]
        if values is not None:
            if len(values) != count:
                raise InputError(f"VecSim(values=...): {len(values)} mappings, expected one per simulation ({count})")
            members = [m.with_values(v) for m, v in zip(members, values)]
        if seeds is not None and len(seeds) != count:
            raise InputError(f"VecSim(seeds=...): {len(seeds)} seeds, expected one per simulation ({count})")
        seed_list = [_seed(f"seeds[{i}]", s) for i, s in enumerate(seeds)] if seeds is not None else [None] * count
        self._native = _native.NativeVecSim([(m.path, m.values, s) for m, s in zip(members, seed_list)])
        first = _native.NativeSim(members[0].path, members[0].values, seed_list[0])
        #: What loading the scenes said (their warnings); empty if nothing.
        self.warnings: str = self._native.warnings
        self.output_names: List[str] = list(first.output_names)
        self.state_names: List[str] = list(first.state_names)
        self.command_names: List[str] = list(first.command_names)
        #: The physics step of the first member, s.
        self.dt: float = first.dt_s
        self.n: int = count

    def __len__(self) -> int:
        return self.n

    def reset(self, seeds: Optional[Sequence[int]] = None) -> np.ndarray:
        """Every member back to rest (the i-th seeded ``seeds[i]`` if given); returns the
        outputs."""
        s = [_whole_seed(f"seeds[{i}]", x) for i, x in enumerate(seeds)] if seeds is not None else None
        self._native.reset(s)
        return self.outputs

    def step(self, commands: Optional[object] = None, n: int = 1) -> np.ndarray:
        """Steps every member ``n`` physics steps; ``commands`` of shape ``(len, 2)``, one
        pair per member (``None``: each drives as its scene does). Returns the outputs."""
        flat = None
        if commands is not None:
            a = np.asarray(commands, dtype=float)
            if a.shape != (self.n, 2):
                raise InputError(f"step(commands=...): shape {a.shape}, expected ({self.n}, 2)")
            flat = a.ravel().tolist()
        self._native.step(flat, _steps(n))
        return self.outputs

    @property
    def outputs(self) -> np.ndarray:
        """Every member's outputs, shape ``(n, len(output_names))``."""
        return np.frombuffer(self._native.outputs(), dtype="<f8").reshape(self.n, -1).copy()

    @property
    def state(self) -> np.ndarray:
        """Every member's state, shape ``(n, len(state_names))``."""
        return np.frombuffer(self._native.state(), dtype="<f8").reshape(self.n, -1).copy()

    @property
    def times(self) -> np.ndarray:
        """Each member's simulated time, s."""
        return np.asarray(self._native.times_s())

    def __repr__(self) -> str:
        return f"VecSim({self.n} simulations, dt={self.dt} s)"


if TYPE_CHECKING:  # pragma: no cover
    from . import Recording
