"""The physical twin as a Gymnasium environment: pick-and-place and the full sort.

``gymnasium.make("mearm/Sort-v0", config="sim_mujoco")`` (or ``mearm/PickPlace-v0``) on
any config whose ``simulator`` is ``mujoco``. Each episode is a seeded scene
(:func:`mearm.task.scene.random_scene`) with the seed's servo kit and noise
(:func:`mearm.experiment.trial_config`): the same seed, the same episode. ``scene=``
lays one fixed table every episode instead (a recorded sort's, :mod:`mearm.envs.replay`);
``reseed=False`` keeps the config's own servo and camera seeds, as ``mearm sort`` runs it.

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

import inspect
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces
from pydantic import TypeAdapter, ValidationError

from mearm.config import Config, SceneObject, load_config
from mearm.config.base import MAX_SEED, short_repr
from mearm.config.sections import MAX_SCENE_OBJECTS
from mearm.dataset.recorder import CAMERA_NAME, SCENE_TASK, task_sentence
from mearm.envs.actions import ActionSpec
from mearm.envs.errors import EnvOptionError
from mearm.errors import MearmError
from mearm.experiment import trial_config
from mearm.hardware.command import ArmCommand
from mearm.hardware.errors import JointLimitError, PulseRangeError, ServoError
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import TableContents, wall_height_m
from mearm.kinematics.collision import CollisionModel
from mearm.sim.table_collision import collision_model
from mearm.sim.twin.frame_drawer import close_renderer, offscreen_renderer
from mearm.sim.twin.twin_bus import TwinArm
from mearm.sim.twin.twin_camera import CAMERA_NAME as TWIN_CAMERA
from mearm.task.scene import SceneError, check_scene, random_scene

if TYPE_CHECKING:
    from mearm.envs.expert import SorterExpert  # the sorter's thread: only with expert=True

Task = Literal["pick_place", "sort"]
ObsType = Literal["pixels_agent_pos", "state"]

#: The default size of ``pixels/<camera>``, (H, W) [px]: small, so that a step stays cheap.
IMAGE_SIZE = (96, 128)
#: The size of :meth:`TwinEnv.render`'s frames (videos), (H, W) [px].
RENDER_SIZE = (240, 320)
#: Objects of a sort's scene unless ``objects`` says otherwise (fewer where the bins hold fewer).
SORT_OBJECTS = 12

_TABLE = TypeAdapter(list[SceneObject])


def _config(config: str | Path | Config, overrides: Sequence[str]) -> Config:
    """The config, loaded with ``overrides`` (refused on a loaded one: it is not reloaded).

    Raises:
        EnvOptionError: ``config`` is none of a name, a file and a loaded ``Config``;
            ``overrides`` is not a list of strings (one string was split into its
            characters), or is given with a loaded ``Config``.
        ConfigError: the config (an empty name said of ``config``), or an override
            (said of ``overrides``, not ``--set``).
    """
    if not isinstance(overrides, list | tuple) or not all(isinstance(o, str) for o in overrides):
        one = f" (one override: overrides=[{overrides!r}])" if isinstance(overrides, str) else ""
        raise EnvOptionError(
            f"overrides must be a list of 'dotted.key=value' strings, got {overrides!r}{one}"
        )
    if isinstance(config, Config):
        if overrides:
            raise EnvOptionError(
                "overrides apply to a config loaded by name or file; with a loaded Config "
                "apply them yourself (load_config(name, overrides))"
            )
        return config
    if not isinstance(config, str | Path):
        raise EnvOptionError(
            f"config must be a config's name, its file or a loaded Config, got {short_repr(config)}"
        )
    return load_config(config, tuple(overrides), path_as="config")


def default_fps(config: Config) -> int:
    """The steps per second of an environment not given ``fps``: the servo stream's rate."""
    return int(round(float(config.servo.rate_hz)))


def _whole(name: str, value: object) -> int:
    """``value`` as an int: a whole number, not a bool nor a float (2.5 was truncated to 2).

    Raises:
        EnvOptionError: anything else.
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise EnvOptionError(f"{name} must be a whole number, got {value!r}")
    return int(value)


def _image_size(value: object) -> tuple[int, int]:
    """``image_size`` as (H, W): two whole numbers.

    Raises:
        EnvOptionError: a string, or not two whole numbers.
    """
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
        raise EnvOptionError(f"image_size must be (height, width) in px, got {value!r}")
    if len(value) != 2:
        raise EnvOptionError(
            f"image_size must be two numbers, (height, width) in px, got {len(value)}: {value!r}"
        )
    return _whole("image_size's height", value[0]), _whole("image_size's width", value[1])


def _twin_config(config: str | Path | Config, overrides: Sequence[str]) -> Config:
    """The config, loaded: the twin's, with a still table.

    Raises:
        EnvOptionError: not the twin's (``simulator: mujoco``), or a belt's.
    """
    base = _config(config, overrides)
    # a loaded Config by what it is, not its repr (thousands of characters)
    named = f"config {config}" if isinstance(config, str | Path) else "the Config given"
    if base.simulator != "mujoco":
        raise EnvOptionError(
            f"{named}: simulator is {base.simulator!r}; the environments run on the "
            "physical twin (simulator: mujoco, e.g. config='sim_mujoco')"
        )
    if base.belt is not None:  # its objects arrive as the episode runs: not a scene
        raise EnvOptionError(
            f"{named} has a belt (belt: ...): the environments sort a still table; "
            "give a config without one (e.g. config='sim_mujoco')"
        )
    return base


def options_taken() -> list[str]:
    """The keyword options :class:`TwinEnv` takes (``gym.make``'s, besides its own)."""
    params = inspect.signature(TwinEnv.__init__).parameters.values()
    return [p.name for p in params if p.name != "self" and p.kind is not p.VAR_KEYWORD]


def _objects(config: Config, task: str, objects: object) -> int:
    """The objects of an episode's scene: ``objects`` checked against the task and the bins.

    Raises:
        EnvOptionError: not a whole number, not 1 for ``pick_place``, or more than the
            bins hold (refused here, not at ``reset()`` by the scene or the twin's model).
    """
    if task == "pick_place":
        if objects is not None and (
            isinstance(objects, bool) or objects != 1 or not isinstance(objects, int | np.integer)
        ):
            raise EnvOptionError(f"pick_place moves one object; objects must be 1, got {objects!r}")
        return 1
    n = SORT_OBJECTS if objects is None else _whole("objects", objects)
    most = max_objects(config)
    if most < 1:
        raise EnvOptionError(
            "the bins of this config hold no object: their walls reach where the arm "
            "releases one (raise bin_cm z, task.classes)"
        )
    if objects is None:  # the default: as many as its bins hold, up to SORT_OBJECTS
        return min(n, most)
    if not 1 <= n <= most:
        given = "objects"
        raise EnvOptionError(
            f"{given} must be at least 1 and at most {most}, got {n}: {most} is what the "
            f"bins of this config hold, the objects dealt to its {len(config.task.classes)} "
            "classes in turn (more: raise bin_cm z, task.classes)"
        )
    return n


def max_objects(config: Config) -> int:
    """The most objects a sort's scene of ``config`` may hold: what its bins hold.

    A scene of N deals its objects to the classes in turn (:func:`random_scene`); the
    twin stacks each class's in its bin, whose walls grow with them
    (:func:`~mearm.kinematics.bodies.wall_height_m`) and must stay below where the arm
    releases one (as the twin's model checks: ``bin_cm`` z less the tool's
    ``tcp_above_grip_cm`` and the class's ``grip_z_cm``), with what the belt brings
    besides. At most :data:`~mearm.config.sections.MAX_SCENE_OBJECTS`. 0: the bins hold
    not even one.
    """
    names = config.task.class_names
    brought = _brought(config)
    n = 0
    while n < MAX_SCENE_OBJECTS:
        # the i-th class's share of n + 1, in turn
        dealt = {c: len(range(i, n + 1, len(names))) for i, c in enumerate(names)}
        if _overfull(config, dealt, brought) is not None:
            break
        n += 1
    return n


def _brought(config: Config) -> dict[str, int]:
    """The objects of each class the belt brings besides the table's."""
    return dict(TableContents.of(config.with_scene([]).task, config.belt).belt)


def _overfull(config: Config, counts: Mapping[str, int], brought: Mapping[str, int]) -> str | None:
    """The first class whose bin does not hold its ``counts`` with what is ``brought``.

    The twin stacks a class's objects in its bin, whose walls grow with them
    (:func:`~mearm.kinematics.bodies.wall_height_m`): they must stay below where the arm
    releases one. ``None``: every bin holds its class's.
    """
    for c in config.task.classes:
        release_m = (c.bin_cm[2] - config.arm.tool.tcp_above_grip_cm - c.grip_z_cm) / 100
        if wall_height_m(c, counts.get(c.name, 0) + brought.get(c.name, 0)) > release_m:
            return c.name
    return None


def _table(
    config: Config, task: str, scene: object, objects: object
) -> tuple[SceneObject, ...] | None:
    """``scene``, the fixed table of every episode, checked; ``None``: drawn per seed.

    Raises:
        EnvOptionError: not a list of objects ``{color, x, y}`` (``yaw_deg`` optional) of
            the config's classes, with ``pick_place``, with an ``objects`` that is not its
            length, more than the bins hold, or a table the sort could not see whole
            (:func:`~mearm.task.scene.check_scene`).
    """
    if scene is None:
        return None
    if task != "sort":
        raise EnvOptionError("scene lays a sort's table; pick_place draws its object from the seed")
    if isinstance(scene, str | bytes | Mapping) or not isinstance(scene, Sequence):
        raise EnvOptionError(
            f"scene must be a list of objects {{color, x, y}} [cm], got {short_repr(scene)}"
        )
    try:
        table = tuple(_TABLE.validate_python(list(scene)))
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(map(str, first["loc"]))
        raise EnvOptionError(
            f"scene must be a list of objects {{color, x, y}} [cm]: [{where}]: {first['msg']}"
        ) from None
    if not 1 <= len(table) <= MAX_SCENE_OBJECTS:
        raise EnvOptionError(f"scene must hold 1 to {MAX_SCENE_OBJECTS} objects, got {len(table)}")
    names = config.task.class_names
    unknown = sorted({o.color for o in table} - set(names))
    if unknown:
        raise EnvOptionError(f"scene: no class {unknown[0]!r} (classes: {', '.join(names)})")
    if objects is not None and _whole("objects", objects) != len(table):
        raise EnvOptionError(
            f"objects is the scene's length, {len(table)}, when a scene is given; got {objects!r}"
        )
    counts = {c: sum(1 for o in table if o.color == c) for c in names}
    full = _overfull(config, counts, _brought(config))
    if full is not None:
        raise EnvOptionError(
            f"scene: the {full} bin of this config does not hold its {counts[full]} objects: "
            "their walls reach where the arm releases one (raise bin_cm z, task.classes)"
        )
    try:
        check_scene(config, table, "scene")
    except SceneError as exc:
        raise EnvOptionError(str(exc)) from None
    return table


class TwinEnv(gym.Env[dict[str, Any], np.ndarray]):
    """One scene of the twin per episode (module docstring).

    Args:
        config: A config (its name, its file, or the loaded one) whose simulator is
            ``mujoco``.
        task: ``pick_place`` (one object of a class the seed draws, to its bin) or
            ``sort`` (``objects`` objects, each to its class's bin).
        objects: Objects of a sort's scene (default :data:`SORT_OBJECTS`, or what the
            config's bins hold where that is fewer): a whole number from 1 to what they
            hold (:func:`max_objects`).
        scene: A sort's fixed table, laid every episode instead of one drawn from the
            seed: a list of :class:`~mearm.config.SceneObject` or ``{color, x, y}``
            dicts [cm] (``yaw_deg`` optional), as a ``--scene`` file holds them; its
            length is ``objects``. ``None``: drawn.
        reseed: Draw each episode's servo and camera noise (a ``twin.kit`` with
            ``per_trial``: its servo kit) from its seed, as an experiment's trial; ``False``:
            the config's own seeds, as ``mearm sort`` runs it.
        fps: Steps per second [Hz], a whole number; must divide ``servo.rate_hz``
            (default: equal to it).
        obs_type: ``pixels_agent_pos`` or ``state`` (no pixels).
        image_size: ``pixels``' (H, W) [px], two whole numbers.
        render_mode: ``rgb_array`` or ``None``. (``gym.make(..., render_mode="human")``
            makes this one ``rgb_array`` and wraps it in Gymnasium's ``HumanRendering``,
            which needs pygame: the environment never sees "human".)
        expert: Run the sorter beside each episode (``info["expert_action"]``): a bool.
        overrides: A list of ``dotted.key=value`` strings applied to a config loaded by
            name or file (not to a loaded ``Config``; one string is refused, not split).

    Raises:
        EnvOptionError: an option out of range or of the wrong type, or a config that is
            not the twin's.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(
        self,
        config: str | Path | Config = "sim_mujoco",
        *,
        task: Task = "sort",
        objects: int | None = None,
        scene: Sequence[SceneObject | Mapping[str, Any]] | None = None,
        reseed: bool = True,
        fps: int | None = None,
        obs_type: ObsType = "pixels_agent_pos",
        image_size: tuple[int, int] = IMAGE_SIZE,
        render_mode: str | None = None,
        expert: bool = False,
        overrides: Sequence[str] = (),
        **unknown: object,
    ):
        if unknown:  # named with what is allowed (Python's TypeError named neither)
            raise EnvOptionError(
                f"{sorted(unknown)[0]!r} is not an option of the environments; they take "
                + ", ".join(options_taken())
            )
        base = _twin_config(config, overrides)
        if task not in ("pick_place", "sort"):
            raise EnvOptionError(f"task must be 'pick_place' or 'sort', got {task!r}")
        if obs_type not in ("pixels_agent_pos", "state"):
            raise EnvOptionError(
                f"obs_type must be 'pixels_agent_pos' or 'state', got {obs_type!r}"
            )
        if render_mode not in (None, "rgb_array"):
            raise EnvOptionError(f"render_mode must be 'rgb_array' or None, got {render_mode!r}")
        if not isinstance(expert, bool | np.bool_):  # "no" is true: it ran the sorter
            raise EnvOptionError(f"expert must be True or False, got {expert!r}")
        if not isinstance(reseed, bool | np.bool_):
            raise EnvOptionError(f"reseed must be True or False, got {reseed!r}")
        rate = float(base.servo.rate_hz)
        fps = default_fps(base) if fps is None else _whole("fps", fps)
        if fps < 1 or abs(rate / fps - round(rate / fps)) > 1e-9:
            raise EnvOptionError(f"fps must divide servo.rate_hz = {rate:g} Hz, got {fps}")
        table = _table(base, task, scene, objects)
        n = _objects(base, task, objects) if table is None else len(table)
        h, w = _image_size(image_size)
        if not (8 <= h <= base.camera.height_px and 8 <= w <= base.camera.width_px):
            raise EnvOptionError(
                f"image_size must be within 8…{base.camera.height_px} × 8…"
                f"{base.camera.width_px} px, got {h}×{w}"
            )
        self.base_config = base
        self.task_kind: Task = task
        self.objects = n
        #: The fixed table every episode lays, or ``None``: one drawn from its seed.
        self.table = table
        self.reseed = bool(reseed)
        self.fps = fps
        self.periods = int(round(rate / fps))
        self.obs_type: ObsType = obs_type
        self.image_size = (h, w)
        self.render_mode = render_mode
        self.use_expert = bool(expert)
        self._ended = ""  # why the episode ended (terminated): "success", or the fault
        self._warned = False  # that a step came after it ended
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
        self._collisions: dict[tuple[int, ...], CollisionModel] = {}
        self.collision = self._collision_of(base)
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
        config = trial_config(self.base_config, seed) if self.reseed else self.base_config
        if self.table is not None:
            scene = list(self.table)
        elif self.task_kind == "pick_place":
            names = config.task.class_names
            cls = names[int(np.random.default_rng(seed).integers(len(names)))]
            scene = random_scene(config, {cls: 1}, seed)
        else:
            scene = random_scene(config, self.objects, seed)
        return config.with_scene(scene), scene

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """A new scene: ``seed`` (else one drawn from the environment's generator).

        The arm starts at home with the jaws open, as a sort does (one step of the home
        command, the sorter's first).

        Raises:
            EnvOptionError: ``options`` has a key (this environment takes none: a key it
                ignored would look as though it had been applied), or the seed is out of
                range.
        """
        if options:
            raise EnvOptionError(
                f"reset() takes no options (options=None or {{}}), got {sorted(options)}; "
                "the scene's options are gym.make's (objects, scene, reseed, fps, obs_type, "
                "image_size, expert, overrides, config)"
            )
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
        self.collision = self._collision_of(config)
        home = self.chain.named_actuated(self.model.home)
        tool = {t.name: t.setting("home") for t in config.arm.tool.actuators}
        self._send(ArmCommand(home, tool, gripper_closed=False))
        self._in_bin = self._count()
        self._ended, self._warned = "", False
        if self.use_expert:
            from mearm.envs.expert import SorterExpert  # noqa: PLC0415

            self.expert = SorterExpert(config, twin, 1.0 / self.fps)
        return self._observation(), self._info()

    def step(self, action: np.ndarray) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Hold ``action`` for one step (``1 / fps``); the reward and whether all are sorted.

        Raises:
            ValueError: ``action`` is not the action vector's shape, or not finite.
            RuntimeError: before :meth:`reset`, or after a step that ended the episode on
                a fault (``info["fault"]``: the physics diverged). After one that ended it
                on success a step warns once, as Gymnasium's own environments do.
        """
        if self.twin is None or self.config is None:
            raise RuntimeError("call reset() before step()")
        if self._ended.startswith("fault"):  # a fault stops motion: no step moves it on
            raise RuntimeError(f"the episode ended on a {self._ended}: call reset() first")
        if self._ended and not self._warned:  # Gymnasium's convention (its CartPole): warn
            gym.logger.warn(
                "step() after the episode returned terminated=True: call reset(); steps "
                "after the end are undefined behaviour (Gymnasium's API)"
            )
            self._warned = True
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
            try:  # holding faults too when the physics diverges: a fault, not a crash
                self._send(self.twin.commanded)
            except ServoError as exc:
                fault = str(exc)
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
        terminated = bool(info["is_success"]) or fault is not None
        if fault is not None:
            self._ended = f"fault: {fault}"
        elif terminated and not self._ended:
            self._ended = "success"
        return self._observation(), reward, terminated, False, info

    def _send(self, command: ArmCommand) -> None:
        """Send ``command`` for one step: ``periods`` commands of the servo stream."""
        assert self.twin is not None
        for _ in range(self.periods):
            self.twin.move(command)

    def _collision_of(self, config: Config) -> CollisionModel:
        """What a command's way is checked against: the bins and the table, at touch.

        Not the objects: the jaws may meet the ones they grasp. The bins' walls are the
        ones the twin builds for ``config``'s table, which grow with its objects of each
        class (:func:`~mearm.kinematics.bodies.wall_height_m`); one model is kept for each
        count of them.
        """
        table = TableContents.of(config.task, config.belt)
        key = tuple(table.objects(name) for name in table.class_names)
        model = self._collisions.get(key)
        if model is None:
            model = self._collisions[key] = collision_model(config, self.model, clearance_cm=0.0)
            model.set_world([])
        return model

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
        return sum(self.twin.in_bin_counts().values())

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
            h, w = size
            try:
                renderer = offscreen_renderer(model, (w, h), msaa_samples=0, shadows=False)
            except Exception as exc:  # MuJoCo raises plain errors for a missing GL
                raise MearmError(
                    f"cannot render offscreen ({type(exc).__name__}: {exc}); set "
                    "MUJOCO_GL=egl or osmesa, or pass obs_type='state'"
                ) from None
            self._renderers[size] = renderer
        renderer.update_scene(self.twin.data, camera=TWIN_CAMERA)
        return renderer.render().copy()

    def render(self) -> np.ndarray | None:
        """The table camera's view at :data:`RENDER_SIZE` (``render_mode="rgb_array"``)."""
        if self.render_mode != "rgb_array" or self.twin is None:
            return None
        return self._frame(RENDER_SIZE)

    def _close_episode(self) -> None:
        """End the episode's expert, free its renderers, close its twin.

        Each renderer is forgotten before it is freed (:func:`close_renderer`: a Ctrl-C
        is taken after the free, not inside it), so a Ctrl-C that stops this part-way
        leaves the others to the next :meth:`close` and none is freed twice.
        """
        if self.expert is not None:
            self.expert.close()
            self.expert = None
        while self._renderers:
            close_renderer(self._renderers.popitem()[1])
        if self.twin is not None:
            self.twin.close()
            self.twin = None

    def close(self) -> None:
        """End the episode's expert and free the renderers."""
        self._close_episode()
        super().close()


def _own_task(env_id: str, task: Task, options: dict[str, Any]) -> None:
    """Refuse a ``task`` that is not the one the environment's id names."""
    given = options.pop("task", task)
    if given != task:
        other = "mearm/Sort-v0" if task == "pick_place" else "mearm/PickPlace-v0"
        raise EnvOptionError(
            f"{env_id} is the {task} task, got task={given!r}: for the other, make {other}"
        )


class PickPlaceEnv(TwinEnv):
    """``mearm/PickPlace-v0``: :class:`TwinEnv` with ``task="pick_place"``, set by the id."""

    def __init__(self, config: str | Path | Config = "sim_mujoco", **options: Any):
        _own_task("mearm/PickPlace-v0", "pick_place", options)
        super().__init__(config, task="pick_place", **options)


class SortEnv(TwinEnv):
    """``mearm/Sort-v0``: :class:`TwinEnv` with ``task="sort"``, set by the id."""

    def __init__(self, config: str | Path | Config = "sim_mujoco", **options: Any):
        _own_task("mearm/Sort-v0", "sort", options)
        super().__init__(config, task="sort", **options)
