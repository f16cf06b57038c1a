"""Gymnasium environments on the physical twin, registered when this package is imported.

    import gymnasium as gym
    import mearm.envs  # noqa: F401  (registers mearm/PickPlace-v0 and mearm/Sort-v0)

    env = gym.make("mearm/Sort-v0", config="sim_mujoco")

``mearm/PickPlace-v0``: one object to its bin; ``mearm/Sort-v0``: a scene of objects
(12 unless ``objects=``), each to its class's bin. Both step at the servo stream's rate
(``metadata["render_fps"]``, 50 Hz on the reference configs) and stop at
``max_episode_steps`` (:data:`MAX_EPISODE_STEPS`; ``gym.make(..., max_episode_steps=N)``
changes it). :mod:`mearm.envs.twin_env` describes the observations, actions and reward;
docs/learning.md the whole workflow.
"""

from __future__ import annotations

try:
    import gymnasium as gym
except ModuleNotFoundError as exc:  # the gym extra: a command's one line, else named
    if exc.name != "gymnasium":
        raise
    from mearm.cli import extra_missing

    raise extra_missing("Gymnasium", "gym") from None

from mearm.envs.actions import ActionSpec
from mearm.envs.errors import EnvOptionError, PolicyError
from mearm.envs.twin_env import TwinEnv

__all__ = ["MAX_EPISODE_STEPS", "ActionSpec", "EnvOptionError", "PolicyError", "TwinEnv"]

#: Steps before an episode is cut short: 10 s of a pick-and-place and 80 s of a sort at
#: 50 Hz, about 5× and 3× what the expert takes (about 100 and 1,300 steps for 12
#: objects: docs/learning.md).
MAX_EPISODE_STEPS = {"mearm/PickPlace-v0": 500, "mearm/Sort-v0": 4000}


def _register() -> None:
    # one class per id, which sets its task: a task= given to the other's id is refused
    for env_id, name in (("mearm/PickPlace-v0", "PickPlaceEnv"), ("mearm/Sort-v0", "SortEnv")):
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=f"mearm.envs.twin_env:{name}",
                max_episode_steps=MAX_EPISODE_STEPS[env_id],
            )


_register()
