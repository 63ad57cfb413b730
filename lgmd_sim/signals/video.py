"""Reading frames from a video file or a folder of images, and writing videos; RGB uint8.

>>> from lgmd_sim.signals.video import VideoReader, video_writer
>>> clip = VideoReader("run.mp4")          # or a folder of frame0001.png, frame0002.png...
>>> clip.fps, clip.frame_count
>>> for rgb in clip: ...                   # (H, W, 3) uint8 frames, in order
>>> with video_writer("out.mkv", fps=30, size=(270, 480)) as write:
...     write(rgb)                         # lossless FFV1 in .mkv / .avi, MPEG-4 in .mp4

Problems surface as a ValueError naming the file (and the frame, when a video stops
decoding part-way), so ``lgmd-sim`` can report them in one line; a video that could not
be written whole (a full disk) as an OSError naming it, and no file is left under its name.
"""

from __future__ import annotations

import contextlib
import errno
import os
import queue
import re
import shutil
import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np

from lgmd_sim.core.fileio import atomic_outputs

__all__ = ["CODECS", "DEFAULT_FOLDER_FPS", "IMAGE_SUFFIXES", "VideoReader", "encoder",
           "natural_key", "video_writer"]

#: Frames that may wait for `encoder`'s thread (270 x 480 RGB: 0.4 MB each).
ENCODER_QUEUE = 8
#: Frame rate assumed for image folders and for videos that do not state one.
DEFAULT_FOLDER_FPS = 30.0
#: Files of an image folder that are read as frames (case-insensitive); others are skipped.
IMAGE_SUFFIXES = frozenset(
    {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".ppm", ".pgm", ".pnm"}
)

#: Video codec per file suffix: FFV1 (lossless: frame differences stay exact) in Matroska
#: and AVI; MPEG-4 Part 2 (lossy, small, plays everywhere) in MP4. All read back by OpenCV
#: and FFmpeg.
CODECS = {".mkv": "FFV1", ".avi": "FFV1", ".mp4": "mp4v"}

#: Free space under which a video that came out short is put down to a full disk (FFmpeg
#: fills the disk to its last block before a write fails; others may have freed a little).
_FULL_BYTES = 1 << 20

# FFmpeg's own log lines ("moov atom not found"...) would precede our one-line error on a
# corrupt file; silence them unless the user asks (OpenCV reads this at the first open).
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")


def natural_key(name: str) -> list[str | int]:
    """Sort key that orders digit runs by value: frame2 before frame10."""
    return [int(part) if i % 2 else part.lower() for i, part in enumerate(re.split(r"(\d+)", name))]


class VideoReader:
    """The frames of a video file (anything OpenCV can open) or of an image folder.

    Opening checks that the source exists and can be read; iterating decodes the frames
    one at a time (each iteration starts again from the first frame).

    Attributes:
        path: the video file or folder.
        fps: frames per second (the file's, or `DEFAULT_FOLDER_FPS` for a folder or a
            file that states none).
        frame_count: the number of frames when known in advance, else None.
        is_folder: whether ``path`` is an image folder.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.is_folder = self.path.is_dir()
        self._images: list[Path] = []
        if self.is_folder:
            self._images = sorted(
                (p for p in self.path.iterdir()
                 if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES),
                key=lambda p: natural_key(p.name),
            )
            if not self._images:
                raise ValueError(f"cannot read image folder '{self.path}': no images found "
                                 f"(looked for {', '.join(sorted(IMAGE_SUFFIXES))})")
            self.fps = DEFAULT_FOLDER_FPS
            self.frame_count: int | None = len(self._images)
            return
        if not self.path.exists():
            raise ValueError(f"cannot read video '{self.path}': no such file or folder")
        cap = self._open()
        try:
            fps = cap.get(cv2.CAP_PROP_FPS)
            count = cap.get(cv2.CAP_PROP_FRAME_COUNT)
        finally:
            cap.release()
        self.fps = float(fps) if np.isfinite(fps) and 0 < fps < 10_000 else DEFAULT_FOLDER_FPS
        self.frame_count = int(count) if np.isfinite(count) and 0 < count < 2**31 else None

    def __repr__(self) -> str:
        return f"VideoReader('{self.path}', fps={self.fps:g}, frame_count={self.frame_count})"

    def _open(self) -> cv2.VideoCapture:
        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            cap.release()
            raise ValueError(f"cannot read video '{self.path}': OpenCV cannot open it "
                             "(not a video, corrupt, or an unsupported codec)")
        return cap

    def __iter__(self) -> Iterator[np.ndarray]:
        return self._folder_frames() if self.is_folder else self._video_frames()

    def _folder_frames(self) -> Iterator[np.ndarray]:
        size = None
        for i, image in enumerate(self._images):
            bgr = cv2.imread(str(image), cv2.IMREAD_COLOR)
            if bgr is None:
                raise ValueError(f"cannot read image '{image}' (frame {i} of folder "
                                 f"'{self.path}')")
            if size is None:
                size = bgr.shape[:2]
            elif bgr.shape[:2] != size:
                raise ValueError(
                    f"image '{image}' is {bgr.shape[0]}x{bgr.shape[1]}, unlike the "
                    f"{size[0]}x{size[1]} of the folder's first image (frame {i} of '{self.path}')"
                )
            yield cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)

    def _video_frames(self) -> Iterator[np.ndarray]:
        cap = self._open()
        n = 0
        try:
            while True:
                ok, bgr = cap.read()
                if not ok:
                    break
                n += 1
                yield cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        finally:
            cap.release()
        if n == 0:
            raise ValueError(f"cannot read video '{self.path}': no frames decoded")
        # OpenCV's read() says False both at the end and on a decoding error; a file that
        # stops short of the frame count its container states is damaged.
        if self.frame_count is not None and n < self.frame_count:
            raise ValueError(f"cannot read video '{self.path}': decoding failed at frame {n} "
                             f"(the file states {self.frame_count} frames)")


@contextlib.contextmanager
def encoder(path: str | os.PathLike, fourcc: str, fps: float, size: tuple[int, int], *,
            name: str | os.PathLike | None = None) -> Iterator[Callable[[np.ndarray], None]]:
    """Yield a function that appends an RGB uint8 frame of `size` (height, width) to the
    video `path`, encoded with OpenCV's `fourcc`; when the block completes, check that the
    file holds every frame written.

    Frames are encoded on a thread of their own (OpenCV lets go of the GIL while it
    encodes), so that the caller renders the next frame meanwhile; at most
    `ENCODER_QUEUE` frames wait, and the file is the same as encoding each in line.
    OpenCV's warnings are off for the whole block (see `_opencv_quiet`).

    OpenCV's writer reports no failure: on a full disk FFmpeg drops the frames (and the
    file's index) and the file stays short, so it is read back: its frame count and its
    last frame. Errors name `name` (default: `path`); a file that is short is an OSError
    whose ``filename`` is `name`.
    """
    path = Path(path)
    name = path if name is None else Path(name)
    height, width = size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (width, height))
    if not writer.isOpened():
        raise OSError(f"cannot write video '{name}': OpenCV has no {fourcc} encoder here")
    waiting: queue.Queue[np.ndarray | None] = queue.Queue(ENCODER_QUEUE)
    failed: list[BaseException] = []

    def encode() -> None:
        while (bgr := waiting.get()) is not None:
            if not failed:  # after a failure, only drained: the caller must not block
                try:
                    writer.write(bgr)
                except BaseException as exc:  # handed to the caller's thread
                    failed.append(exc)

    thread = threading.Thread(target=encode, name=f"encoder {name.name}", daemon=True)
    written = 0

    def write(rgb: np.ndarray) -> None:
        nonlocal written
        if failed:
            raise failed[0]
        if rgb.shape != (height, width, 3) or rgb.dtype != np.uint8:
            raise ValueError(f"video '{name}': frames must be ({height}, {width}, 3) uint8, "
                             f"got {rgb.shape} {rgb.dtype}")
        waiting.put(cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))  # a copy: the caller keeps rgb
        written += 1

    # OpenCV's log level is process-wide: set once here for the whole block, never by the
    # encoding thread while this one works
    with _opencv_quiet():
        thread.start()
        try:
            yield write
        finally:
            waiting.put(None)
            thread.join()
            writer.release()
    if failed:
        raise failed[0]
    _check_written(path, written, name)


@contextlib.contextmanager
def _opencv_quiet() -> Iterator[None]:
    """OpenCV's warnings off: a failed write would print one per frame, before the one
    line `_check_written` reports."""
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    try:
        yield
    finally:
        cv2.utils.logging.setLogLevel(level)


def _check_written(path: Path, written: int, name: Path) -> None:
    cap = cv2.VideoCapture(str(path))
    try:
        count = cap.get(cv2.CAP_PROP_FRAME_COUNT) if cap.isOpened() else 0
        # the last frame, read back: a count restored from a header is not proof enough
        complete = count == written and (written == 0 or (
            cap.set(cv2.CAP_PROP_POS_FRAMES, written - 1) and cap.read()[0]))
    finally:
        cap.release()
    if complete:
        return
    readable = _decodable_frames(path)
    # the filename, so that a caller can tell where the write failed: str() puts it last
    if shutil.disk_usage(path.parent).free < _FULL_BYTES:
        raise OSError(errno.ENOSPC, "cannot write video: no space left on device "
                      f"({readable} of {written} frames written)", str(name))
    raise OSError(errno.EIO, f"cannot write video: the file holds {readable} of {written} "
                  "frames written", str(name))


def _decodable_frames(path: Path) -> int:
    cap = cv2.VideoCapture(str(path))
    n = 0
    try:
        while cap.isOpened() and cap.grab():
            n += 1
    finally:
        cap.release()
    return n


@contextlib.contextmanager
def video_writer(path: str | os.PathLike, fps: float, size: tuple[int, int]
                 ) -> Iterator[Callable[[np.ndarray], None]]:
    """Yield a function that appends an RGB uint8 frame of `size` (height, width) to the
    video `path`; the file appears only once the block completes and the file is checked
    (see `encoder`, `lgmd_sim.core.fileio`). The codec follows the suffix (`CODECS`)."""
    path = Path(path)
    codec = CODECS.get(path.suffix.lower())
    if codec is None:
        raise ValueError(f"cannot write video '{path}': use a suffix among "
                         f"{', '.join(CODECS)} (.mkv and .avi are lossless)")
    # atomic_outputs, not atomic_output: the encoder's errors name `path` already
    with atomic_outputs([path]) as (tmp,), encoder(tmp, codec, fps, size, name=path) as write:
        yield write
