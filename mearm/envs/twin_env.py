"""The physical twin as a Gymnasium environment: pick-and-place and the full sort.

``gymnasium.make("mearm/Sort-v0", config="sim_mujoco")`` (or ``mearm/PickPlace-v0``) on
any config whose ``simulator`` is ``mujoco``. Each episode is a seeded scene
(:func:`mearm.task.scene.random_scene`) with the seed's servo kit and noise
(:func:`mearm.experiment.trial_config`): the same seed, the same episode.

- **Observation** (LeRobot's keys): ``pixels/<camera>`` (uint8 H×W×3 RGB of the table
  camera, ``image_size`` (H, W), 96×128 by default), ``agent_pos`` (the measured joints,
  the tool settings and ``gripper_closed``: a recording's ``observation.state``) and
  ``environment_state`` (per object, in scene order: its centre x y z [cm] and its
  class's index in ``task.classes``).
  ``obs_type="state"`` leaves the pixels out (nothing is rendered).
- **Action**: absolute targets in the units of a recording's ``action``
  (:mod:`mearm.envs.actions`), held for one step of ``1 / fps`` [s] (``fps`` defaults to
  the servo stream's ``servo.rate_hz`` and must divide it; ``metadata["render_fps"]``).
  A value outside its limits is clipped (``info["clipped"]`` names it); a target whose
  straight way from the last command would bring the arm's body into the table or a bin,
  or put a passive joint outside its limits, is refused the way the sorter refuses a
  route, and the last command is held (``info["refused"]`` says why). The jaws may touch
  the objects: grasping is the task.
- **Reward**: the change in the number of objects at rest in their own class's bin
  (so an episode's return is the number it put there, less any it took out);
  ``info["is_success"]`` when every object is, which ends the episode.
- ``expert=True`` runs the sorter beside the episode (:mod:`mearm.envs.expert`):
  ``info["expert_action"]`` is its next action.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from mearm.config import Config, SceneObject, load_config
from mearm.config.base import MAX_SEED
from mearm.dataset.recorder import CAMERA_NAME, SCENE_TASK, task_sentence
from mearm.envs.actions import ActionSpec
from mearm.envs.errors import EnvOptionError
from mearm.errors import MearmError
from mearm.experiment import trial_config
from mearm.hardware.command import ArmCommand
from mearm.hardware.errors import JointLimitError, PulseRangeError, ServoError
from mearm.kinematics import ArmModel
from mearm.sim.table_collision import collision_model
from mearm.sim.twin.twin_bus import TwinArm
from mearm.sim.twin.twin_camera import CAMERA_NAME as TWIN_CAMERA
from mearm.task.scene import random_scene

if TYPE_CHECKING:
    from mearm.envs.expert import SorterExpert  # the sorter's thread: only with expert=True

Task = Literal["pick_place", "sort"]
ObsType = Literal["pixels_agent_pos", "state"]

#: The default size of ``pixels/<camera>``, (H, W) [px]: small, so that a step stays cheap.
IMAGE_SIZE = (96, 128)
#: The size of :meth:`TwinEnv.render`'s frames (videos), (H, W) [px].
RENDER_SIZE = (240, 320)
#: Objects of a sort's scene unless ``objects`` says otherwise.
SORT_OBJECTS = 12


def _config(config: str | Path | Config, overrides: Sequence[str]) -> Config:
    if isinstance(config, Config):
        return config
    return load_config(config, tuple(overrides))


class TwinEnv(gym.Env[dict[str, Any], np.ndarray]):
    """One scene of the twin per episode (module docstring).

    Args:
        config: A config (its name, its file, or the loaded one) whose simulator is
            ``mujoco``.
        task: ``pick_place`` (one object of a class the seed draws, to its bin) or
            ``sort`` (``objects`` objects, each to its class's bin).
        objects: Objects of a sort's scene (default :data:`SORT_OBJECTS`).
        fps: Steps per second [Hz]; must divide ``servo.rate_hz`` (default: equal to it).
        obs_type: ``pixels_agent_pos`` or ``state`` (no pixels).
        image_size: ``pixels``' (H, W) [px].
        render_mode: ``rgb_array`` or ``None``.
        expert: Run the sorter beside each episode (``info["expert_action"]``).
        overrides: ``dotted.key=value`` strings applied to a config loaded by name.

    Raises:
        EnvOptionError: an option out of range, or a config that is not the twin's.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        config: str | Path | Config = "sim_mujoco",
        *,
        task: Task = "sort",
        objects: int | None = None,
        fps: int | None = None,
        obs_type: ObsType = "pixels_agent_pos",
        image_size: tuple[int, int] = IMAGE_SIZE,
        render_mode: str | None = None,
        expert: bool = False,
        overrides: Sequence[str] = (),
    ):
        base = _config(config, overrides)
        if base.simulator != "mujoco":
            raise EnvOptionError(
                f"config {config}: simulator is {base.simulator!r}; the environments run "
                "on the physical twin (simulator: mujoco, e.g. config='sim_mujoco')"
            )
        if task not in ("pick_place", "sort"):
            raise EnvOptionError(f"task must be 'pick_place' or 'sort', got {task!r}")
        if obs_type not in ("pixels_agent_pos", "state"):
            raise EnvOptionError(
                f"obs_type must be 'pixels_agent_pos' or 'state', got {obs_type!r}"
            )
        if render_mode not in (None, "rgb_array"):
            raise EnvOptionError(f"render_mode must be 'rgb_array' or None, got {render_mode!r}")
        rate = float(base.servo.rate_hz)
        fps = int(round(rate)) if fps is None else int(fps)
        if fps < 1 or abs(rate / fps - round(rate / fps)) > 1e-9:
            raise EnvOptionError(f"fps must divide servo.rate_hz = {rate:g} Hz, got {fps}")
        n = 1 if task == "pick_place" else SORT_OBJECTS if objects is None else int(objects)
        if task == "pick_place" and objects not in (None, 1):
            raise EnvOptionError(f"pick_place moves one object; objects must be 1, got {objects}")
        if n < 1:
            raise EnvOptionError(f"objects must be at least 1, got {n}")
        h, w = (int(v) for v in image_size)
        if not (8 <= h <= base.camera.height_px and 8 <= w <= base.camera.width_px):
            raise EnvOptionError(
                f"image_size must be within 8…{base.camera.height_px} × 8…"
                f"{base.camera.width_px} px, got {h}×{w}"
            )
        self.base_config = base
        self.task_kind: Task = task
        self.objects = n
        self.fps = fps
        self.periods = int(round(rate / fps))
        self.obs_type: ObsType = obs_type
        self.image_size = (h, w)
        self.render_mode = render_mode
        self.use_expert = expert
        self.metadata = {**self.metadata, "render_fps": fps}
        self.spec_actions = ActionSpec.of(base)
        a = self.spec_actions
        self.action_space = spaces.Box(a.low.astype(np.float32), a.high.astype(np.float32))
        low, high = a.agent_pos_bounds()
        obs: dict[str, spaces.Space[Any]] = {
            "agent_pos": spaces.Box(low, high, dtype=np.float32),
            "environment_state": spaces.Box(-1e3, 1e3, (4 * n,), dtype=np.float32),
        }
        if obs_type == "pixels_agent_pos":
            obs["pixels"] = spaces.Dict(
                {CAMERA_NAME: spaces.Box(0, 255, (h, w, 3), dtype=np.uint8)}
            )
        self.observation_space = spaces.Dict(obs)
        self.model = ArmModel(base.arm)
        self.chain = self.model.chain
        # bins and the table only, at touch: the jaws may meet the objects they grasp
        self.collision = collision_model(base, self.model, clearance_cm=0.0)
        self.collision.set_world([])
        self.twin: TwinArm | None = None
        self.config: Config | None = None
        self.scene: list[SceneObject] = []
        self.scene_seed: int | None = None
        self.task = ""
        self.expert: SorterExpert | None = None
        self._renderers: dict[tuple[int, int], mujoco.Renderer] = {}
        self._in_bin = 0
        self._classes: list[str] = []

    # ----------------------------------------------------------------- episode

    def _scene(self, seed: int) -> tuple[Config, list[SceneObject]]:
        """The episode's config and scene of ``seed``."""
        config = trial_config(self.base_config, seed)
        if self.task_kind == "pick_place":
            names = config.task.class_names
            cls = names[int(np.random.default_rng(seed).integers(len(names)))]
            scene = random_scene(config, {cls: 1}, seed)
        else:
            scene = random_scene(config, self.objects, seed)
        task = config.task.model_copy(update={"scene": list(scene)})
        return config.model_copy(update={"task": task}), scene

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """A new scene: ``seed`` (else one drawn from the environment's generator).

        The arm starts at home with the jaws open, as a sort does (one step of the home
        command, the sorter's first).
        """
        super().reset(seed=seed)
        scene_seed = seed if seed is not None else int(self.np_random.integers(MAX_SEED))
        if not 0 <= scene_seed <= MAX_SEED:
            raise EnvOptionError(f"seed must be in [0, {MAX_SEED}], got {scene_seed}")
        self._close_episode()
        config, scene = self._scene(scene_seed)
        self.config, self.scene, self.scene_seed = config, scene, scene_seed
        self._classes = [o.color for o in scene]
        self.task = SCENE_TASK if self.task_kind == "sort" else task_sentence(scene[0].color)
        twin = TwinArm(config)
        twin.connect()
        self.twin = twin
        home = self.chain.named_actuated(self.model.home)
        tool = {t.name: t.setting("home") for t in config.arm.tool.actuators}
        self._send(ArmCommand(home, tool, gripper_closed=False))
        self._in_bin = self._count()
        if self.use_expert:
            from mearm.envs.expert import SorterExpert  # noqa: PLC0415

            self.expert = SorterExpert(config, twin, 1.0 / self.fps)
        return self._observation(), self._info()

    def step(self, action: np.ndarray) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Hold ``action`` for one step (``1 / fps``); the reward and whether all are sorted.

        Raises:
            ValueError: ``action`` is not the action vector's shape, or not finite.
            RuntimeError: before :meth:`reset`.
        """
        if self.twin is None or self.config is None:
            raise RuntimeError("call reset() before step()")
        clipped = self.spec_actions.clip(action)
        command = self.spec_actions.command(clipped.vector)
        refused = self._refusal(command)
        fault = None
        if refused is None:
            try:
                self._send(command)
            except (JointLimitError, PulseRangeError) as exc:
                refused = f"outside the servos' range: {exc}"
            except ServoError as exc:
                fault = str(exc)
        if refused is not None:
            assert self.twin.commanded is not None
            self._send(self.twin.commanded)
        count = self._count()
        reward = float(count - self._in_bin)
        self._in_bin = count
        if self.expert is not None:
            self.expert.advance()
        info = self._info()
        info["clipped"] = list(clipped.names)
        info["refused"] = refused or ""
        if fault is not None:
            info["fault"] = fault
        return (
            self._observation(),
            reward,
            bool(info["is_success"]) or fault is not None,
            False,
            info,
        )

    def _send(self, command: ArmCommand) -> None:
        """Send ``command`` for one step: ``periods`` commands of the servo stream."""
        assert self.twin is not None
        for _ in range(self.periods):
            self.twin.move(command)

    def _refusal(self, command: ArmCommand) -> str | None:
        """Why the way from the last command to ``command`` is refused, or ``None``."""
        assert self.twin is not None and self.twin.commanded is not None
        chain = self.chain
        q_to = chain.from_named(dict(command.joints))
        if not chain.within_limits(q_to, tol=1e-6):
            named = chain.named(q_to)
            out = [
                f"{n} {named[n]:.1f}"
                for i, n in enumerate(chain.names)
                if not chain.lower[i] - 1e-6 <= q_to[i] <= chain.upper[i] + 1e-6
            ]
            return "a passive joint outside its limits: " + ", ".join(out)
        q_from = chain.from_named(dict(self.twin.commanded.joints))
        contact = self.collision.first_contact(np.array([q_from, q_to]))
        if contact is None:
            return None
        return "collision: " + contact.describe(chain.names, chain.scale)

    def _count(self) -> int:
        """Objects at rest in their own class's bin."""
        assert self.twin is not None
        where = self.twin.objects_in_bin()
        ids = self.twin.object_ids
        return sum(1 for oid, cls in zip(ids, self._classes, strict=True) if where.get(oid) == cls)

    def _info(self) -> dict[str, Any]:
        assert self.twin is not None
        info: dict[str, Any] = {
            "is_success": self._in_bin == len(self.scene),
            "in_bins": self._in_bin,
            "objects": len(self.scene),
            "task": self.task,
            "scene_seed": self.scene_seed,
        }
        if self.expert is not None:
            proposal = self.expert.proposal
            held = self.twin.commanded if proposal is None else proposal
            assert held is not None
            info["expert_action"] = self.spec_actions.vector(held)
            info["expert_done"] = self.expert.outcome or ""
        return info

    def _observation(self) -> dict[str, Any]:
        twin = self.twin
        assert twin is not None
        names = self.base_config.task.class_names
        objects = np.array(
            [
                [*twin.object_pose(i).position_cm, names.index(cls)]
                for i, cls in zip(twin.object_ids, self._classes, strict=True)
            ]
        )
        obs: dict[str, Any] = {
            "agent_pos": self.spec_actions.agent_pos(twin),
            "environment_state": objects.reshape(-1).astype(np.float32),
        }
        if self.obs_type == "pixels_agent_pos":
            obs["pixels"] = {CAMERA_NAME: self._frame(self.image_size)}
        return obs

    def _frame(self, size: tuple[int, int]) -> np.ndarray:
        """The table camera's view now, (H, W, 3) uint8 RGB, no MSAA nor shadows."""
        assert self.twin is not None
        renderer = self._renderers.get(size)
        model = self.twin.model
        if renderer is None:
            quality = model.vis.quality
            kept = (quality.offsamples, quality.shadowsize)
            quality.offsamples, quality.shadowsize = 0, 0
            try:
                renderer = mujoco.Renderer(model, *size)
            except Exception as exc:  # MuJoCo raises plain errors for a missing GL
                raise MearmError(
                    f"cannot render offscreen ({type(exc).__name__}: {exc}); set "
                    "MUJOCO_GL=egl or osmesa, or pass obs_type='state'"
                ) from None
            finally:
                quality.offsamples, quality.shadowsize = kept
            renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
            self._renderers[size] = renderer
        renderer.update_scene(self.twin.data, camera=TWIN_CAMERA)
        return renderer.render().copy()

    def render(self) -> np.ndarray | None:
        """The table camera's view at :data:`RENDER_SIZE` (``render_mode="rgb_array"``)."""
        if self.render_mode != "rgb_array" or self.twin is None:
            return None
        return self._frame(RENDER_SIZE)

    def _close_episode(self) -> None:
        if self.expert is not None:
            self.expert.close()
            self.expert = None
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers = {}
        if self.twin is not None:
            self.twin.close()
            self.twin = None

    def close(self) -> None:
        """End the episode's expert and free the renderers."""
        self._close_episode()
        super().close()
