"""An environment with the expert closes wherever a Ctrl-C left the two threads' turn.

``eval-policy --jobs 1`` hung at a Ctrl-C now and then (3 of 70), waiting for good for the
expert's thread: a ``KeyboardInterrupt`` raised inside the environment's side of a turn
can leave the expert asleep beside the item meant to wake it. Here that turn is left so
by hand (the item queued, no wake-up call), and the environment closes all the same.
"""

from __future__ import annotations

import threading

import gymnasium as gym
import pytest

import mearm.envs  # noqa: F401  (registers the environments)


def _expert_env_after_a_step():  # noqa: ANN202
    env = gym.make("mearm/PickPlace-v0", expert=True)
    _, info = env.reset(seed=0)
    for _ in range(3):
        _, _, _, _, info = env.step(info["expert_action"])
    return env


def _closes(env, within_s: float = 30.0) -> bool:  # noqa: ANN001
    """Whether the environment's expert closes within ``within_s``, then the environment.

    The expert's close runs in a thread of its own (a close that hangs fails the test,
    not the run); the environment's own in this one, whose GL context its renderers are.
    """
    closing = threading.Thread(target=env.unwrapped.expert.close, daemon=True)
    closing.start()
    closing.join(within_s)
    if closing.is_alive():
        return False
    env.close()
    return True


@pytest.mark.heavy
def test_a_turn_queued_without_its_wake_up_call_does_not_hang_the_close() -> None:
    env = _expert_env_after_a_step()
    expert = env.unwrapped.expert
    turn = expert.handoff._to_expert
    with turn.mutex:  # what a put cut short between its item and its notify leaves
        turn.queue.append(True)
    assert _closes(env)
    assert not expert._thread.is_alive()


@pytest.mark.heavy
def test_a_proposal_the_environment_never_took_does_not_hang_the_close() -> None:
    """A Ctrl-C in the environment's wait for the next proposal: the expert gave it."""
    env = _expert_env_after_a_step()
    expert = env.unwrapped.expert
    expert.handoff.resume()  # its turn given; the proposal it makes is never taken
    assert _closes(env)
    assert not expert._thread.is_alive()
