"""The behaviour-cloning policy: an MLP from the state to the next action, and its file.

Input: ``agent_pos``, ``environment_state`` and the episode's clock (its steps so far
over ``fps``: the expert holds still while the jaws close, and the state alone cannot
tell the first step of that hold from the last), standardised by the training set's
mean and spread. Output: the joints' step from where they are measured (the expert's
action less ``agent_pos``), each tool actuator's setting (a few discrete values) and
``gripper_closed`` (a logit), standardised too. Saved with :func:`save_baseline` as one
``.pt`` file with the environment it was trained for.
"""

from __future__ import annotations

import io
import pickle
from pathlib import Path
from typing import Any

import numpy as np

from mearm.envs.errors import PolicyError
from mearm.learn.errors import import_torch

#: The hidden layers' width [-].
HIDDEN = 128


def build_mlp(n_in: int, n_out: int, hidden: int = HIDDEN) -> Any:
    """The network: two hidden layers of ``hidden`` with ReLU."""
    nn = import_torch().nn
    return nn.Sequential(
        nn.Linear(n_in, hidden), nn.ReLU(),
        nn.Linear(hidden, hidden), nn.ReLU(),
        nn.Linear(hidden, n_out),
    )  # fmt: skip


#: The episode's clock is counted in seconds at this rate [Hz] (the environments' 50 Hz).
CLOCK_HZ = 50.0


def features(agent_pos: np.ndarray, environment_state: np.ndarray, step: np.ndarray) -> np.ndarray:
    """The network's input, (…, n + m + 1): the state, the objects, the clock [s]."""
    clock = (np.asarray(step, dtype=np.float32) / CLOCK_HZ)[..., None]
    return np.concatenate([agent_pos, environment_state, clock], axis=-1).astype(np.float32)


def to_action(agent_pos: np.ndarray, out: np.ndarray, joints: int) -> np.ndarray:
    """The action of the network's (unscaled) output: joint steps added, the gripper's logit."""
    action = out.copy()
    action[..., :joints] += agent_pos[..., :joints]
    action[..., -1] = (out[..., -1] > 0.0).astype(action.dtype)
    return action.astype(np.float32)


class BaselinePolicy:
    """A trained network acting in the environment (the ``Policy`` of eval-policy).

    Args:
        net: The network.
        mean: The inputs' mean, (d,).
        std: Their spread, (d,).
        scaling: The outputs' mean and scale, (2, n).
        joints: How many outputs are joint steps.
        meta: What it was trained for (``env_id``, ``env_options``).
    """

    needs_expert = False

    def __init__(
        self,
        net: Any,
        mean: np.ndarray,
        std: np.ndarray,
        scaling: np.ndarray,
        joints: int,
        meta: dict[str, Any],
    ):
        self.torch = import_torch()
        self.net = net.eval()
        self.mean, self.std, self.scaling = mean, std, scaling
        self.joints = joints
        self.meta = meta
        self.steps = 0

    def reset(self, seed: int) -> None:
        """A new episode: the clock starts again."""
        self.steps = 0

    def act(self, observation: dict[str, Any], info: dict[str, Any]) -> np.ndarray:
        """The next action (:func:`to_action` of the network's output)."""
        pos = np.asarray(observation["agent_pos"], dtype=np.float32)
        state = np.asarray(observation["environment_state"], dtype=np.float32)
        x = (features(pos, state, np.array(self.steps)) - self.mean) / self.std
        self.steps += 1
        torch = self.torch
        with torch.no_grad():
            out = self.net(torch.from_numpy(x[None])).numpy()[0]
        return to_action(pos, out * self.scaling[1] + self.scaling[0], self.joints)


def save_baseline(
    path: Path,
    net: Any,
    mean: np.ndarray,
    std: np.ndarray,
    scaling: np.ndarray,
    joints: int,
    meta: dict[str, Any],
) -> None:
    """Write the network, its input scaling and ``meta`` to ``path``, in one step.

    Serialised in memory first, then :func:`mearm.fileio.write_atomic`: a full disk or a
    signal leaves the old file (or none), never an empty or half ``.pt``.

    Raises:
        OSError: the file cannot be written.
    """
    from mearm.fileio import write_atomic  # noqa: PLC0415

    torch = import_torch()
    n_in = int(mean.shape[0])
    n_out = int(net[-1].out_features)
    buffer = io.BytesIO()
    torch.save(
        {"state_dict": net.state_dict(), "mean": mean, "std": std, "scaling": scaling,
         "n_in": n_in, "n_out": n_out, "hidden": int(net[0].out_features), "joints": joints,
         "meta": meta, "format": "mearm-bc-3"},
        buffer,
    )  # fmt: skip
    write_atomic(path, buffer.getvalue())


def _clipped(text: str, limit: int = 80) -> str:
    """``text`` on one line, cut at a word before ``limit`` characters (``…`` said)."""
    line = " ".join(text.split())
    if len(line) <= limit:
        return line
    return line[:limit].rsplit(" ", 1)[0] + " …"


#: What a numpy array in a baseline file needs to load under ``weights_only``: its
#: reconstructor, the array and dtype classes (the input scaling is saved as arrays).
_ARRAY_GLOBALS: list[Any] = [
    np.zeros(0).__reduce__()[0],
    np.ndarray,
    np.dtype,
    type(np.dtype(np.float32)),
    type(np.dtype(np.float64)),
]


def load_baseline(path: Path) -> BaselinePolicy:
    """The policy saved in ``path``.

    Raises:
        PolicyError: no such file, a folder, or not a baseline mearm saved.
        LearnExtraMissingError: PyTorch is not installed.
    """
    torch = import_torch()
    if path.is_dir():
        raise PolicyError(f"policy {path}: is a folder, not a baseline file (.pt)")
    if not path.is_file():
        raise PolicyError(f"policy {path}: no such file")
    try:
        # tensors, plain values and numpy arrays only: a file from anywhere is read without
        # running what its pickle asks for (torch's weights_only unpickler)
        with torch.serialization.safe_globals(_ARRAY_GLOBALS):
            saved = torch.load(path, map_location="cpu", weights_only=True)
        if saved.get("format") != "mearm-bc-3":
            raise ValueError("not a mearm-bc-3 file")
        net = build_mlp(int(saved["n_in"]), int(saved["n_out"]), int(saved["hidden"]))
        net.load_state_dict(saved["state_dict"])
    except pickle.UnpicklingError as exc:
        # torch's own text advises loading it unsafely: a stranger's file is not run
        what = (
            "it holds more than tensors, plain values and arrays"
            if "GLOBAL" in str(exc)  # a class or function its pickle asks for
            else "it is not a PyTorch file"  # bytes no pickle reads (text, another format)
        )
        raise PolicyError(
            f"policy {path}: not a baseline saved by mearm.learn ({what}, and was not run)"
        ) from None
    except Exception as exc:
        why = _clipped(str(exc))
        raise PolicyError(
            f"policy {path}: not a baseline saved by mearm.learn ({type(exc).__name__}"
            f"{': ' + why if why else ''})"
        ) from None
    return BaselinePolicy(
        net,
        np.asarray(saved["mean"]),
        np.asarray(saved["std"]),
        np.asarray(saved["scaling"]),
        int(saved["joints"]),
        saved["meta"],
    )
