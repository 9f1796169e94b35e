"""Videos of runs: frames (H, W, 3) ``uint8`` written as an MP4 (imageio's ffmpeg plugin,
H.264) or, where ffmpeg is absent, as a GIF.

:class:`VideoWriter` streams frames to disk as they come (a 4000-step run at 640 x 240 would hold
1.8 GB in memory otherwise); :func:`write_video` writes a list of frames at once and
:class:`EpisodeVideo` films one episode of :func:`agents.rollout.run_episode`. The runners
(``python -m eval track|benchmark|compare|estimation --video``) write one video per run next to
its CSV, at the env's ``metadata["render_fps"]`` (its control rate: one frame per control step,
the first right after ``reset``), so the video plays in simulated real time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Sequence

import gymnasium as gym
import numpy as np

from soft_gym.envs.rendering import check_panels, default_panels, render_frame


def ffmpeg_available() -> bool:
    """Whether imageio can write MP4 (the ``imageio-ffmpeg`` package and its ffmpeg binary)."""
    try:
        import imageio_ffmpeg  # here: may be missing (GIF then); +24 ms per eval.runner import

        return bool(imageio_ffmpeg.get_ffmpeg_exe())
    except Exception:  # not installed, or no binary for this platform
        return False


def _check_fps(fps: float) -> float:
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise ValueError(f"fps must be a positive number, got {fps!r}") from None
    if not np.isfinite(value) or value <= 0.0:
        raise ValueError(f"fps must be a positive number, got {fps!r}")
    return value


class VideoWriter:
    """Append frames to an MP4 at ``path`` (a GIF next to it, same stem, without ffmpeg).

    Every frame must have the first one's shape, (H, W, 3) ``uint8``; odd sizes are padded by one
    black row or column (H.264 in yuv420p needs even sizes). The file is opened on the first
    frame; :meth:`close` returns the path written (``ValueError`` when no frame came).

    Args:
        path: output file; its directory is created. Its suffix becomes ``.mp4`` (``.gif`` when
            ``gif`` or without ffmpeg).
        fps: frames per second (the env's ``metadata["render_fps"]``).
        gif: write a GIF even where ffmpeg is available.
    """

    def __init__(self, path: str | Path, fps: float, gif: bool = False) -> None:
        self.fps = _check_fps(fps)
        self.gif = bool(gif) or not ffmpeg_available()
        self.path = Path(path).with_suffix(".gif" if self.gif else ".mp4")
        self.frames = 0
        self._shape: tuple[int, ...] | None = None
        self._writer = None

    def append(self, frame: np.ndarray) -> None:
        """Write one frame (H, W, 3) ``uint8``."""
        image = np.asarray(frame)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise ValueError(f"frames must be (H, W, 3) uint8 arrays, got {image.dtype} "
                             f"{image.shape}")
        if self._shape is None:
            self._open(image.shape)
        elif image.shape != self._shape:
            raise ValueError(f"every frame must have the first frame's shape {self._shape}, "
                             f"frame {self.frames} has {image.shape}")
        if not self.gif and (image.shape[0] % 2 or image.shape[1] % 2):
            image = np.pad(image, ((0, image.shape[0] % 2), (0, image.shape[1] % 2), (0, 0)))
        self._writer.append_data(image)
        self.frames += 1

    def _open(self, shape: tuple[int, ...]) -> None:
        import imageio.v2 as imageio  # here: +33 ms for every eval.runner import (-X importtime)

        self._shape = shape
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.gif:
            # GIF delays are whole hundredths of a second
            self._writer = imageio.get_writer(self.path, mode="I", duration=1000.0 / self.fps,
                                              loop=0)
        else:
            self._writer = imageio.get_writer(
                self.path, format="FFMPEG", mode="I", fps=self.fps, codec="libx264",
                pixelformat="yuv420p", quality=7, macro_block_size=1,
                ffmpeg_log_level="error")

    def close(self) -> Path:
        """Finish the file; returns its path. ``ValueError`` if no frame was appended."""
        if self._writer is None:
            raise ValueError(f"no frames to write to {self.path}: a video needs at least one")
        self._writer.close()
        self._writer = None
        return self.path

    def __enter__(self) -> "VideoWriter":
        return self

    def __exit__(self, kind, error, traceback) -> None:
        if self._writer is not None:
            self._writer.close()
            self._writer = None
        elif kind is None:
            self.close()  # raises: nothing was written


class EpisodeVideo:
    """The frames of one episode streamed into a video file: the
    :class:`~agents.rollout.FrameSink` that :func:`agents.rollout.run_episode` hands a frame
    after ``reset`` and after every step (:func:`soft_gym.envs.rendering.render_frame`, at the
    env's ``metadata["render_fps"]``).

    Args:
        env: the env filmed.
        path: the video file (:class:`VideoWriter`: ``.mp4``, or ``.gif`` without ffmpeg).
        panels: panels of each frame; ``None``: the scene, and the camera sensors beside it
            when the env has any.
    """

    def __init__(self, env: gym.Env, path: str | Path, panels: Sequence[str] | None) -> None:
        self.env = env
        self.panels = default_panels(env) if panels is None else check_panels(env, panels)
        self.writer = VideoWriter(path, env.unwrapped.metadata["render_fps"])

    def capture(self) -> None:
        """Append the env's frame now."""
        self.writer.append(render_frame(self.env, self.panels))

    def close(self) -> Path:
        """Finish the file; returns its path."""
        return self.writer.close()


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float,
                gif: bool = False) -> Path:
    """Write ``frames`` ((H, W, 3) ``uint8``, all one shape) as an MP4 at ``fps`` (a GIF
    without ffmpeg or with ``gif``); returns the path written. ``ValueError`` for no frames."""
    writer = VideoWriter(path, fps, gif=gif)
    for frame in frames:
        writer.append(frame)
    return writer.close()


def read_video(path: str | Path) -> np.ndarray:
    """All frames of a video written here, (n, H, W, 3) ``uint8`` (for tests and checks)."""
    import imageio.v2 as imageio  # here: +33 ms for every eval.runner import (-X importtime)

    path = Path(path)
    if path.suffix == ".gif":
        frames = np.asarray(imageio.mimread(path, memtest=False))
        return frames[..., :3]
    reader = imageio.get_reader(path, format="FFMPEG")
    try:
        return np.asarray([frame for frame in reader])
    finally:
        reader.close()
