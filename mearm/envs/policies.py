"""Policies to evaluate: the sorter as expert, a random one, any ``module:callable``, a baseline.

A policy acts in one environment: ``act(observation, info) -> action`` (the action
vector of :mod:`mearm.envs.actions`), with ``reset(seed)`` before each episode. A user's
policy is named ``module:name``: a callable ``f(observation) -> action``, or a class
whose instances are (made once per worker, with no arguments; their ``reset()`` is called
before each episode if they have one). A file ``*.pt`` is a baseline saved by
``python -m mearm.learn.bc`` (it needs ``mearm[learn]``).
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
from gymnasium import spaces

from mearm.envs.errors import PolicyError


class Policy(Protocol):
    """What the evaluation runs in one environment."""

    #: Whether the environment must run the sorter beside it (``info["expert_action"]``).
    needs_expert: bool

    def reset(self, seed: int) -> None: ...  # noqa: D102
    def act(self, observation: dict[str, Any], info: dict[str, Any]) -> np.ndarray: ...  # noqa: D102


@runtime_checkable
class Resettable(Protocol):
    """A user's policy with episodes: ``reset()`` before each."""

    def reset(self) -> None: ...  # noqa: D102


class ExpertPolicy:
    """The sorter, stepped: the action it proposes (:mod:`mearm.envs.expert`)."""

    needs_expert = True

    def reset(self, seed: int) -> None:  # noqa: D102
        pass

    def act(self, observation: dict[str, Any], info: dict[str, Any]) -> np.ndarray:  # noqa: D102
        return np.asarray(info["expert_action"], dtype=np.float32)


class RandomPolicy:
    """Uniform actions within the limits, seeded by the episode's seed."""

    needs_expert = False

    def __init__(self, space: spaces.Box):
        self.space = space
        self.rng = np.random.default_rng(0)

    def reset(self, seed: int) -> None:  # noqa: D102
        self.rng = np.random.default_rng(seed)

    def act(self, observation: dict[str, Any], info: dict[str, Any]) -> np.ndarray:  # noqa: D102
        return self.rng.uniform(self.space.low, self.space.high).astype(np.float32)


class CallablePolicy:
    """A user's ``f(observation) -> action`` (or an object with ``reset()`` besides)."""

    needs_expert = False

    def __init__(self, fn: Callable[[dict[str, Any]], Any]):
        self.fn = fn

    def reset(self, seed: int) -> None:  # noqa: D102
        if isinstance(self.fn, Resettable):
            self.fn.reset()

    def act(self, observation: dict[str, Any], info: dict[str, Any]) -> np.ndarray:  # noqa: D102
        return np.asarray(self.fn(observation))


def load_policy(spec: str, action_space: spaces.Box) -> Policy:
    """The policy ``spec`` names: ``expert``, ``random``, ``module:name`` or a ``.pt`` file.

    Raises:
        PolicyError: a module that does not import, a name it lacks, something that is
            not callable, or a file that is not a baseline.
        ExtraMissingError: a baseline without ``mearm[learn]`` (PyTorch).
    """
    if spec == "expert":
        return ExpertPolicy()
    if spec == "random":
        return RandomPolicy(action_space)
    if spec.endswith(".pt"):
        from mearm.learn.baseline import load_baseline  # noqa: PLC0415

        return load_baseline(Path(spec))
    module_name, sep, name = spec.partition(":")
    if not sep or not module_name or not name:
        raise PolicyError(
            f"policy {spec!r}: give expert, random, module:callable or a baseline FILE.pt"
        )
    if module_name.endswith(".py"):  # a file's name: it would import as module "py" of it
        named = module_name.removesuffix(".py").replace("/", ".")
        raise PolicyError(
            f"policy {spec!r}: name the module, not its file: --policy {named}:{name} "
            f"(a module in this folder imports with PYTHONPATH=.)"
        )
    try:
        module = importlib.import_module(module_name)
    except Exception as exc:  # an import runs the module's code: any error is the user's
        here = (  # python does not look in the current folder for an installed command
            f"; a module in this folder imports with PYTHONPATH=. (e.g. PYTHONPATH=. mearm "
            f"eval-policy … --policy {spec})"
            if isinstance(exc, ModuleNotFoundError)
            and exc.name == module_name.split(".")[0]
            and Path(f"{module_name.split('.')[0]}.py").is_file()
            else ""
        )
        raise PolicyError(
            f"policy {spec!r}: module {module_name} does not import ({type(exc).__name__}: "
            f"{exc}){here}"
        ) from None
    obj: Any = module
    for part in name.split("."):
        if not hasattr(obj, part):
            raise PolicyError(f"policy {spec!r}: {module_name} has no {name}")
        obj = getattr(obj, part)
    if inspect.isclass(obj):
        try:
            obj = obj()
        except Exception as exc:
            raise PolicyError(
                f"policy {spec!r}: {name}() failed ({type(exc).__name__}: {exc})"
            ) from None
    if not callable(obj):
        raise PolicyError(f"policy {spec!r}: {name} is not callable")
    return CallablePolicy(obj)


def checked_action(action: Any, space: spaces.Box) -> np.ndarray:
    """A policy's action as the vector the environment takes.

    Whether it is finite is the episode's to check (:func:`not_finite`): a policy that
    gives NaN after some steps fails that episode, as one that raises does.

    Raises:
        PolicyError: not numbers, or not ``space.shape`` (the policy is wired wrong).
    """
    try:
        a = np.asarray(action, dtype=float)
    except (TypeError, ValueError):
        raise PolicyError(f"the policy's action is not numbers: {str(action)[:60]!r}") from None
    if a.shape != space.shape:
        raise PolicyError(
            f"the policy's action has shape {a.shape}; the environment takes {space.shape}"
        )
    return a


def not_finite(action: np.ndarray) -> str:
    """Why ``action`` cannot be taken, NaN or infinite values, or ``""``."""
    if np.all(np.isfinite(action)):
        return ""
    return f"the policy's action is not finite: {np.round(action, 3).tolist()}"
