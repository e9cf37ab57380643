"""Pictures and videos as files: RGB images written as PNG, RGB frames as .mp4 or .avi, each atomically
(aaai.files: a temporary file beside the target, renamed to it when complete)."""

from __future__ import annotations

import os
from pathlib import Path
from types import TracebackType

import cv2
import numpy as np

from aaai.files import PendingFile, atomic_path

VIDEO_CODECS = {".mp4": "mp4v", ".avi": "MJPG"}


def save_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Writes an RGB image as PNG atomically (aaai.files: a temporary file beside it, then a rename)."""
    path = Path(path)
    ok, data = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError(f"could not encode {path} as PNG")
    with atomic_path(path) as temporary:
        temporary.write_bytes(data.tobytes())
    return path


class VideoWriter:
    """Writes RGB frames of one size to .mp4 (mp4v) or .avi (MJPG) with OpenCV, atomically
    (aaai.files): frames go to a temporary file beside ``path``, renamed to it on ``close``."""

    def __init__(self, path: str | os.PathLike, fps: float):
        self.path = Path(path)
        suffix = self.path.suffix.lower()
        if suffix not in VIDEO_CODECS:
            raise ValueError(video_extension_error(str(path)))
        self.fps = fps
        self.codec = VIDEO_CODECS[suffix]
        self.pending = PendingFile(self.path)
        self.temporary = self.pending.temporary
        self.writer: cv2.VideoWriter | None = None  # opened on the first frame, whose size it takes
        self.size = (0, 0)  # (width, height) of every frame, padded to even numbers
        self.frames = 0

    def write(self, frame: np.ndarray) -> None:
        height, width = frame.shape[:2]
        if self.writer is None:
            self.size = (width + width % 2, height + height % 2)  # codecs want even sizes
            self.writer = cv2.VideoWriter(
                str(self.temporary), cv2.VideoWriter.fourcc(*self.codec), float(self.fps), self.size
            )
            if not self.writer.isOpened():
                raise RuntimeError(f"OpenCV could not open a {self.codec} video writer for {self.path}")
        padded = np.zeros((self.size[1], self.size[0], 3), np.uint8)
        padded[:height, :width] = frame[: self.size[1], : self.size[0]]
        self.writer.write(cv2.cvtColor(padded, cv2.COLOR_RGB2BGR))
        self.frames += 1

    def close(self) -> Path:
        if self.writer is None:
            self.pending.discard()
            raise RuntimeError(f"no frames were written to {self.path}")
        self.writer.release()
        return self.pending.commit()

    def abort(self) -> None:
        if self.writer is not None:
            self.writer.release()
        self.pending.discard()

    def __enter__(self) -> VideoWriter:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        if kind is None:
            self.close()
        else:
            self.abort()


def video_extension_error(path: str) -> str:
    allowed = " or ".join(VIDEO_CODECS)
    message = f"--video: got {path!r}; allowed: a path ending in {allowed}"
    if path.lower().endswith(".gif"):
        message += " (OpenCV cannot write GIF; make an .mp4 and convert it, e.g. with ffmpeg)"
    return message
