"""Gymnasium environments on agvsim's simulator (needs ``pip install gymnasium``).

- :class:`WireFollowing` (``agvsim/WireFollowing-v0``): steer a wire-guided vehicle with
  the DCMC's demands. Observation: what its controller sees, the two coil readings
  (counts) and the two wheels' rim speeds (m/s). Reward: minus the lateral error over
  ``error_scale_m`` each control step. Terminated when the vehicle loses the wire or its
  DCMC faults; truncated at the scene's ``sim.duration_s``.
- :class:`VelocityBase` (``agvsim/VelocityBase-v0``): drive a velocity-commanded base
  (``cmd_vel``) along the path its scene's manoeuvre would drive a perfect unicycle.
  Observation: the path point's position in the robot's frame (m), the heading error
  (rad), the robot's forward speed (m/s) and yaw rate (rad/s), and the manoeuvre's own
  command (m/s, rad/s). Reward: minus the distance to the path point over
  ``error_scale_m``. Terminated when the robot is more than ``lost_m`` from it.

Each control step holds the action for ``control_period_s`` (whole physics steps).
``reset(seed=...)`` seeds the sensor noise; the start is the scene's.

``gymnasium.make("agvsim.gym:agvsim/WireFollowing-v0")`` imports this module and makes
the environment (importing it registers both ids).
"""

from __future__ import annotations

import math
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as e:  # pragma: no cover - depends on the environment
    raise ImportError("agvsim.gym needs gymnasium: pip install gymnasium") from e

from . import InputError, PathLike, Scene, _Scratch
from .live import Sim

__all__ = ["WireFollowing", "VelocityBase"]


def _thesis_machine(**values: float) -> Scene:
    """The thesis machine (a scene of no keys: every default is its measured value), with
    the given values; its file lives as long as the scene."""
    scratch = _Scratch("scene")
    path = scratch.path / "thesis_machine.toml"
    path.write_text("# The thesis machine: every key at its default (its measured value).\n")
    return Scene(path, _scratch=scratch).with_values(values)


def _period_steps(sim: Sim, control_period_s: float) -> int:
    if not (isinstance(control_period_s, (int, float)) and math.isfinite(control_period_s) and control_period_s > 0):
        raise InputError(f"control_period_s={control_period_s!r}: expected a positive time, s")
    return max(int(round(control_period_s / sim.dt)), 1)


class _AgvsimEnv(gymnasium.Env):  # type: ignore[misc]
    metadata: Dict[str, Any] = {"render_modes": []}

    def __init__(self, scene: Union[Scene, PathLike], control_period_s: float, error_scale_m: float) -> None:
        if not (math.isfinite(error_scale_m) and error_scale_m > 0):
            raise InputError(f"error_scale_m={error_scale_m!r}: expected a positive length, m")
        self.sim = Sim(scene)
        self.period_steps = _period_steps(self.sim, control_period_s)
        self.error_scale_m = float(error_scale_m)
        self._index = {n: i for i, n in enumerate(self.sim.output_names)}
        self._state_index = {n: i for i, n in enumerate(self.sim.state_names)}

    def _out(self, outputs: np.ndarray, name: str) -> float:
        return float(outputs[self._index[name]])

    def _reset_sim(self, seed: Optional[int]) -> None:
        super().reset(seed=seed)
        # A new episode draws its noise seed from the environment's generator, so that
        # episodes differ and reset(seed=s) repeats one exactly.
        self.sim.reset(int(self.np_random.integers(0, 2**63 - 1)))

    def _truncated(self) -> bool:
        return self.sim.time >= self.sim.duration - 0.5 * self.sim.dt


class WireFollowing(_AgvsimEnv):
    """Steer a wire-guided vehicle with the DCMC's demands: the action ``(forward, turn)``
    in [-1, 1] is the demand over 100 % (``forward_pct = 100 * forward``). ``scene``: a wire-following scene (if ``None``, the thesis
    machine on its straight wire, starting 120 mm off it, for 30 s: the thesis's floor
    experiment). Each episode starts once the DCMC is ready: the first
    ``dcmc.enable_delay_s`` are stepped with zero demand (a demand before it faults the
    real DCMC, and the simulated one). A DCMC fault later ends the episode."""

    def __init__(
        self,
        scene: Optional[Union[Scene, PathLike]] = None,
        control_period_s: float = 0.02,
        error_scale_m: float = 0.1,
    ) -> None:
        if scene is None:
            scene = _thesis_machine(**{"start.y_m": 0.12, "sim.duration_s": 30.0})
        super().__init__(scene, control_period_s, error_scale_m)
        if self.sim.is_velocity_base:
            raise InputError("WireFollowing(scene=...): the scene is a velocity-commanded base; use VelocityBase")
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(4,), dtype=np.float32)
        self._obs_names = ["sensor_left_adc", "sensor_right_adc", "left_wheel_speed_m_s", "right_wheel_speed_m_s"]

    def _observe(self, outputs: np.ndarray) -> np.ndarray:
        return np.array([self._out(outputs, n) for n in self._obs_names], dtype=np.float32)

    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None) -> Tuple[np.ndarray, Dict[str, Any]]:
        self._reset_sim(seed)
        ready = int(math.ceil(self.sim.dcmc_enable_delay / self.sim.dt)) + 1
        out = self.sim.step((0.0, 0.0), ready)
        return self._observe(out), {"lateral_error_m": self._out(out, "lateral_error_m")}

    def step(self, action: Any) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
        a = 100.0 * np.clip(np.asarray(action, dtype=float).reshape(2), -1.0, 1.0)
        out = self.sim.step((float(a[0]), float(a[1])), self.period_steps)
        error = self._out(out, "lateral_error_m")
        reward = -abs(error) / self.error_scale_m
        fault = self.sim.dcmc_fault
        terminated = bool(self.sim.lost_wire) or fault is not None
        info = {"lateral_error_m": error, "lost_wire": self.sim.lost_wire, "dcmc_fault": fault}
        return self._observe(out), float(reward), terminated, self._truncated(), info


class VelocityBase(_AgvsimEnv):
    """Drive a velocity-commanded base with ``cmd_vel`` along its manoeuvre's path: the
    action ``(linear, angular)`` in [-1, 1] is the command over what the base's motors
    can reach (``linear_m_s = linear * top speed at the rim``, ``angular_rad_s =
    angular * 2 * top speed / track``, a turn on the spot at the top speed). ``scene``: a
    velocity-commanded scene (if ``None``, the thesis machine made a velocity base,
    ``Scene.new(from_scene=..., guidance="none")``: a 1 m square)."""

    def __init__(
        self,
        scene: Optional[Union[Scene, PathLike]] = None,
        control_period_s: float = 0.02,
        error_scale_m: float = 0.1,
        lost_m: float = 1.0,
    ) -> None:
        if scene is None:
            thesis = _thesis_machine()  # held: its file must outlive the call
            scene = Scene.new(from_scene=thesis.path, guidance="none")
        super().__init__(scene, control_period_s, error_scale_m)
        if not self.sim.is_velocity_base:
            raise InputError("VelocityBase(scene=...): the scene follows a wire; use WireFollowing")
        if not (math.isfinite(lost_m) and lost_m > 0):
            raise InputError(f"lost_m={lost_m!r}: expected a positive length, m")
        self.lost_m = float(lost_m)
        v = self.sim.top_speed
        w = 2.0 * v / self.sim.track
        self._limit = np.array([v, w])
        self.action_space = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)
        self.observation_space = spaces.Box(-np.inf, np.inf, shape=(7,), dtype=np.float32)
        self._path = np.zeros(3)

    def _advance_path(self, t0: float, steps: int) -> None:
        # The manoeuvre's command driven by a perfect unicycle, a physics step at a time.
        x, y, th = self._path
        dt = self.sim.dt
        for k in range(steps):
            v, w = self.sim.manoeuvre_command(t0 + k * dt) or (0.0, 0.0)
            x += v * math.cos(th) * dt
            y += v * math.sin(th) * dt
            th += w * dt
        self._path = np.array([x, y, th])

    def _observe(self) -> Tuple[np.ndarray, float]:
        s = self.sim.state
        i = self._state_index
        x, y, th = s[i["x_m"]], s[i["y_m"]], s[i["heading_rad"]]
        dx, dy = self._path[0] - x, self._path[1] - y
        c, sn = math.cos(th), math.sin(th)
        heading_error = math.atan2(math.sin(self._path[2] - th), math.cos(self._path[2] - th))
        v_ref, w_ref = self.sim.manoeuvre_command() or (0.0, 0.0)
        obs = np.array(
            [c * dx + sn * dy, -sn * dx + c * dy, heading_error,
             s[i["forward_speed_m_s"]], s[i["yaw_rate_rad_s"]], v_ref, w_ref],
            dtype=np.float32,
        )
        return obs, math.hypot(dx, dy)

    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None) -> Tuple[np.ndarray, Dict[str, Any]]:
        self._reset_sim(seed)
        s = self.sim.state
        i = self._state_index
        self._path = np.array([s[i["x_m"]], s[i["y_m"]], s[i["heading_rad"]]])
        obs, distance = self._observe()
        return obs, {"path_error_m": distance}

    def step(self, action: Any) -> Tuple[np.ndarray, float, bool, bool, Dict[str, Any]]:
        a = self._limit * np.clip(np.asarray(action, dtype=float).reshape(2), -1.0, 1.0)
        t0 = self.sim.time
        self.sim.step((float(a[0]), float(a[1])), self.period_steps)
        self._advance_path(t0, self.period_steps)
        obs, distance = self._observe()
        reward = -distance / self.error_scale_m
        return obs, float(reward), distance > self.lost_m, self._truncated(), {"path_error_m": distance}


def _register() -> None:
    for cls in (WireFollowing, VelocityBase):
        name = cls.__name__
        env_id = f"agvsim/{name}-v0"
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=f"agvsim.gym:{cls.__name__}")


_register()
