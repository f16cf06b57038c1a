"""Episode videos as fragments: appended to a file by bytes, decoded frame for frame.

Each episode is encoded on its own (:class:`EpisodeWriter`); the second's fragment moved
past the first's frames (:meth:`EpisodeVideo.shifted`) and appended must decode as one
video whose frames are both episodes' in order, at consecutive frame times, whatever the
codec. A file written whole (not fragmented) is not appended to.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import av
import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.dataset.fragments import EpisodeVideo, FragmentError, file_header
from mearm.dataset.lerobot_format import VIDEO_CODECS
from mearm.dataset.sampler import DrawsRGB
from mearm.dataset.video_encoder import EpisodeWriter
from mearm.task import open_rig

FPS = 10
SIZE_HW = (48, 64)


def _frames(n: int, seed: int) -> list[np.ndarray]:
    """Flat colours far apart, so that each decoded frame says which one it was."""
    rng = np.random.default_rng(seed)
    return [np.full((*SIZE_HW, 3), rng.integers(20, 235, 3), np.uint8) for _ in range(n)]


def _episode(path: Path, frames: list[np.ndarray], codec: str) -> EpisodeVideo:
    writer = EpisodeWriter(av, path, FPS, SIZE_HW, codec)
    for frame in frames:
        writer.add(av.VideoFrame.from_ndarray(frame, format="rgb24"))
    writer.close()
    return EpisodeVideo.parse(path.read_bytes())


@pytest.mark.parametrize("codec", list(VIDEO_CODECS))
def test_a_fragment_appended_decodes_after_the_first_episode(codec: str, tmp_path: Path) -> None:
    """5 + 4 frames: 9 frames at k / fps, each the colour it was given, the codec kept."""
    first, second = _frames(5, 1), _frames(4, 2)
    a = _episode(tmp_path / "a.mp4", first, codec)
    b = _episode(tmp_path / "b.mp4", second, codec)
    assert a.header == b.header  # the same encoding: the same header, byte for byte
    joined = tmp_path / "joined.mp4"
    joined.write_bytes(a.header + a.shifted(0, FPS) + b.shifted(len(first), FPS))
    assert file_header(joined) == a.header
    with av.open(str(joined)) as container:
        stream = container.streams.video[0]
        assert stream.codec_context.name in VIDEO_CODECS[codec].decoders
        decoded = [
            (float(f.pts * f.time_base), f.to_ndarray(format="rgb24"))
            for f in container.decode(stream)
        ]
    assert [t for t, _ in decoded] == pytest.approx([k / FPS for k in range(9)], abs=1e-9)
    for (_, got), want in zip(decoded, first + second, strict=True):
        assert np.abs(got.astype(int) - want).max() <= 6  # lossy, but this frame's colour


@pytest.mark.skipif(not hasattr(os, "sched_getscheduler"), reason="Linux's scheduling")
@pytest.mark.parametrize("codec", list(VIDEO_CODECS))
def test_an_episode_leaves_its_thread_s_scheduling_as_it_was(codec: str, tmp_path: Path) -> None:
    """SVT-AV1, opened as root, put the thread at SCHED_FIFO 99 and left it there: a pytest
    worker after this file's AV1 test started every child realtime (a speed-0 virtual Uno
    held a core). Encoded in a thread of its own, so that a failure leaves the worker as
    it was."""
    policies = []

    def encode() -> None:
        policies.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))
        _episode(tmp_path / "a.mp4", _frames(2, 1), codec)
        policies.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))

    thread = threading.Thread(target=encode)
    thread.start()
    thread.join()
    assert len(policies) == 2 and policies[1] == policies[0]


def _realtime_threads() -> list[tuple[int, int]]:
    """This process's threads at a realtime policy: (thread id, policy)."""
    out = []
    for tid in map(int, os.listdir("/proc/self/task")):
        try:
            policy = os.sched_getscheduler(tid)
        except OSError:  # ended meanwhile
            continue
        if policy in (os.SCHED_FIFO, os.SCHED_RR):
            out.append((tid, policy))
    return out


@pytest.mark.skipif(
    not hasattr(os, "sched_getscheduler") or os.geteuid() != 0,
    reason="SVT-AV1 makes its threads realtime as root, on Linux",
)
def test_no_thread_of_an_episode_being_encoded_runs_realtime(tmp_path: Path) -> None:
    """SVT-AV1, opened as root, started its 38 encoding threads at SCHED_FIFO 99: on two
    cores they took the CPU before anything else (the sort's own process too) while an
    episode was encoded. Mid-episode, no thread of the process is realtime."""
    assert _realtime_threads() == []
    writer = EpisodeWriter(av, tmp_path / "a.mp4", FPS, SIZE_HW, "av1")
    try:
        for frame in _frames(3, 3):
            writer.add(av.VideoFrame.from_ndarray(frame, format="rgb24"))
        assert _realtime_threads() == []
    finally:
        writer.close()


def test_a_file_written_whole_is_not_appended_to(tmp_path: Path) -> None:
    """FFmpeg's default MP4 (samples listed in its moov) has no header to append to."""
    path = tmp_path / "whole.mp4"
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=FPS)
        stream.height, stream.width = SIZE_HW
        for frame in _frames(3, 3):
            for packet in stream.encode(av.VideoFrame.from_ndarray(frame, format="rgb24")):
                out.mux(packet)
        for packet in stream.encode():
            out.mux(packet)
    assert file_header(path) is None
    with pytest.raises(FragmentError, match="not a fragmented MP4"):
        EpisodeVideo.parse(path.read_bytes())


@pytest.mark.heavy
def test_the_twins_frame_drawn_for_a_recording_is_its_peek() -> None:
    """peek_rgb draws into the encoder's buffer what peek shows (RGB), counting no frame."""
    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    with open_rig(config) as rig:
        camera = rig.camera
        assert isinstance(camera, DrawsRGB)
        out = np.zeros((config.camera.height_px, config.camera.width_px, 3), np.uint8)
        camera.peek_rgb(out)
        assert camera.frames_read == 0
        np.testing.assert_array_equal(out, camera.peek()[:, :, ::-1])


def _moving_states(twin, camera, n: int) -> list[np.ndarray]:
    """The twin's frame states at ``n`` moments of the arm swinging (each a copy)."""
    import mujoco

    m, d = twin.model, twin.data
    states = []
    for _ in range(n):
        d.ctrl[:] += 0.04
        mujoco.mj_step(m, d, nstep=7)
        state = np.empty(camera.frame_source().state_size)
        assert camera.frame_state(state)
        states.append(state)
    return states


@pytest.mark.heavy
@pytest.mark.parametrize("bump", [False, True], ids=["mounted", "bumped"])
def test_the_twins_frame_drawn_from_its_state_elsewhere_is_its_peek(bump: bool) -> None:
    """A frame drawn from its state by a renderer built from the pickled source (as the
    encoder's process does) is peek_rgb's, pixel for pixel, while the arm moves (its
    poses are those of the last step's start) and with the camera bumped."""
    import pickle

    from mearm.dataset.sampler import DrawsElsewhere

    fault = ["twin.faults=[{kind: camera_bump, at_s: 0, shift_cm: [1, 0.5, 0]}]"] if bump else []
    config = load_config(ROOT / "configs" / "sim_mujoco.yaml", fault)
    shape = (config.camera.height_px, config.camera.width_px, 3)
    with open_rig(config) as rig:
        camera = rig.camera
        assert isinstance(camera, DrawsElsewhere)
        drawer = pickle.loads(pickle.dumps(camera.frame_source())).open()
        try:
            for _ in range(4):
                (state,) = _moving_states(rig.bus, camera, 1)
                here, there = np.zeros(shape, np.uint8), np.ones(shape, np.uint8)
                camera.peek_rgb(here)
                drawer.draw(state, there)
                np.testing.assert_array_equal(there, here)
        finally:
            drawer.close()
        assert camera.frames_read == 0


@pytest.mark.heavy
def test_the_twins_frame_source_unpickles_without_the_twin(tmp_path: Path) -> None:
    """The encoder's process draws the twin's frames with NumPy and MuJoCo alone: the
    pickled source brings in neither the kinematic simulator, the twin's model and camera
    modules, the kinematics nor the config, whose imports its start-up (which the sort's
    first frames wait for) would otherwise be."""
    import pickle
    import subprocess
    import sys

    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    with open_rig(config) as rig:
        (tmp_path / "source.pkl").write_bytes(pickle.dumps(rig.camera.frame_source()))
    code = (
        "import pickle, sys; pickle.loads(open(sys.argv[1], 'rb').read()); "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pinocchio', 'cv2') "
        "or m.startswith(('mearm.config', 'mearm.kinematics', 'mearm.sim.kinematic', "
        "'mearm.sim.twin.twin_', 'mearm.sim.twin.mjcf'))))"
    )
    run = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "source.pkl")],
        capture_output=True, text=True, check=True, cwd=ROOT,
    )  # fmt: skip
    assert run.stdout.strip() == "[]"


@pytest.mark.heavy
def test_a_black_frame_is_drawn_where_the_twin_runs() -> None:
    """Under a camera fault the frame has no state to send: frame_state says so."""
    config = load_config(
        ROOT / "configs" / "sim_mujoco.yaml", ["twin.faults=[{kind: camera_black, at_s: 0}]"]
    )
    with open_rig(config) as rig:
        state = np.zeros(rig.camera.frame_source().state_size)
        assert not rig.camera.frame_state(state)
        assert not state.any()


@pytest.mark.heavy
@pytest.mark.parametrize("codec", list(VIDEO_CODECS))
def test_an_episode_drawn_in_the_encoders_process_is_the_one_drawn_here(
    codec: str, tmp_path: Path
) -> None:
    """The encoder process drawing from states writes the very file (byte for byte) and
    pixel samples that encoding frames drawn here gives: the same frames, the same encoder."""
    from mearm.dataset.video_encoder import EncoderProcess, InlineEncoder

    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    shape = (config.camera.height_px, config.camera.width_px, 3)
    remote, inline = EncoderProcess(shape, FPS, codec), InlineEncoder(shape, FPS, codec)
    try:
        with open_rig(config) as rig:
            camera = rig.camera
            assert remote.scene(camera.frame_source())
            remote.open(0, tmp_path / "remote.mp4")
            inline.open(0, tmp_path / "inline.mp4")
            state = np.empty(0)
            for k in range(6):
                if k != 3:  # the fourth frame: nothing moved (not drawn again)
                    (state,) = _moving_states(rig.bus, camera, 1)
                slot, _ = remote.slot()
                remote.state(slot)[: len(state)] = state
                remote.draw(0, slot, repeat=1 + k % 2)
                _, rgb = inline.slot()
                camera.peek_rgb(rgb)
                inline.frame(0, 0, repeat=1 + k % 2)
            remote.finish(0)
            inline.finish(0)
            done, error, pixels = remote.done(0, wait=True)
            assert (done, error) == (True, None)
            _, _, want = inline.done(0, wait=True)
    finally:
        remote.close()
        inline.close()
    assert (tmp_path / "remote.mp4").read_bytes() == (tmp_path / "inline.mp4").read_bytes()
    assert pixels is not None and want is not None and pixels.shape == want.shape
    np.testing.assert_array_equal(pixels, want)


def _record_twin(root: Path, overrides: list[str]) -> np.ndarray:
    """Two episodes of the twin's arm swinging, recorded; the video's frames, decoded."""
    from mearm.dataset.format_check import check_dataset
    from mearm.dataset.recorder import DatasetRecorder
    from mearm.hardware.command import ArmCommand

    config = load_config(ROOT / "configs" / "sim_mujoco.yaml", overrides)
    rec = DatasetRecorder(root, config, fps=FPS, codec="h264")
    home = ArmCommand.home(config.arm)
    with open_rig(config) as rig, rig.bus:
        rec.attach(rig.bus, rig.camera)
        for k in range(2):
            rec.begin("red")
            for i in range(12):
                joints = {n: v + 6 * np.sin(i / 4 + k) for n, v in home.joints.items()}
                rig.bus.move(ArmCommand(joints, home.tool, False))
            rec.end()
        rec.close()
    assert check_dataset(root) == []
    (video,) = root.glob("videos/**/*.mp4")
    with av.open(str(video)) as container:
        return np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])


@pytest.fixture(scope="module")
def drawn_there(tmp_path_factory: pytest.TempPathFactory) -> np.ndarray:
    """The frames of :func:`_record_twin` with an encoder that keeps up, the sort's
    renderer refusing to draw one (the two tests below read them; neither writes)."""
    from mearm.dataset import video_encoder
    from mearm.dataset.encoder_server import SLOTS
    from mearm.sim.twin.twin_camera import TwinCamera

    def refuse(self, out):
        raise AssertionError("a recorded frame was drawn in the sort's process")

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(video_encoder, "DRAW_HERE_BEHIND", SLOTS, raising=False)  # never behind
        patch.setattr(TwinCamera, "peek_rgb", refuse)
        return _record_twin(tmp_path_factory.mktemp("there") / "ds", [])


@pytest.mark.heavy
def test_a_twin_recording_draws_no_frame_in_the_sorts_process(drawn_there: np.ndarray) -> None:
    """While the encoder keeps up, the twin's frames are drawn by the encoder's process: the
    sort's renderer never runs for them (it refuses, in :func:`drawn_there`), and the
    episodes are written, moving pictures."""
    frames = drawn_there
    assert len(frames) >= 4 and frames.mean() > 40
    assert np.abs(np.diff(frames.astype(np.int16), axis=0)).max() > 50  # the arm moved


@pytest.mark.heavy
def test_an_encoder_behind_has_the_frames_drawn_here_the_same(
    monkeypatch, tmp_path: Path, drawn_there: np.ndarray
) -> None:
    """An encoder whose process falls behind has the sort's process draw the next frames
    (its renderer, peek_rgb): the video decodes to the very frames drawn over there."""
    from mearm.dataset import video_encoder
    from mearm.sim.twin.twin_camera import TwinCamera

    there = drawn_there
    drawn_here = []
    peek_rgb = TwinCamera.peek_rgb

    def counted(self, out):
        drawn_here.append(1)
        peek_rgb(self, out)

    monkeypatch.setattr(video_encoder, "DRAW_HERE_BEHIND", 0, raising=False)  # always behind
    monkeypatch.setattr(TwinCamera, "peek_rgb", counted)
    here = _record_twin(tmp_path / "here", [])
    assert len(drawn_here) >= len(here) // 2  # repeats are drawn once
    assert here.shape == there.shape
    np.testing.assert_array_equal(here, there)


@pytest.mark.heavy
def test_the_encoder_starts_with_the_trial_before_the_rig(tmp_path: Path) -> None:
    """An experiment's trial starts the encoder's process (its imports run while the rig is
    built), not the first episode's rig: one process, stopped when the recorder closes."""
    import multiprocessing

    from mearm.dataset.recorder import DatasetRecorder

    def encoders() -> list[multiprocessing.Process]:
        return [p for p in multiprocessing.active_children() if p.name == "mearm-encoder"]

    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    rec = DatasetRecorder(tmp_path / "ds", config, fps=FPS, codec="h264")
    try:
        assert encoders() == []
        rec.start_trial(101)
        (process,) = encoders()
        rec.start_trial(102)
        assert encoders() == [process]
    finally:
        rec.close()
    assert encoders() == []


@pytest.mark.heavy
def test_a_black_camera_is_recorded_black(tmp_path: Path) -> None:
    """Under a camera fault the frames are drawn where the twin runs: black, as it sees."""
    frames = _record_twin(tmp_path / "ds", ["twin.faults=[{kind: camera_black, at_s: 0}]"])
    assert len(frames) >= 4 and frames.max() <= 20  # lossy black
