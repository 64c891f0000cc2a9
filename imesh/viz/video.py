"""``imesh view --video``: the viewer page rendered frame by frame in headless Chromium and
encoded to H.264 mp4 by ffmpeg (the binary of the PyPI package ``imageio-ffmpeg``).

The video shows the robot (or the two robots of a pair, where their motions put them) with the
adapted markers beside it (and the human source on the other side when the scene has it), the
soles, support polygon and ZMP, and the scene's props; the camera follows the robot (the middle
of the pair). A scene with a DART check (``build_scene(..., physics=result)``) shows the
simulated robot instead, a blue-tinted copy beside the robot's right (the adapted markers then
stay on the robot, the human source on its left), with the check's verdict and each frame's
key-point error written in the corner; after a fall the copy holds where it lay, tinted red.
"""

from __future__ import annotations

import base64
import io
import logging
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from tqdm import tqdm

from ..core.lazy import optional
from ..errors import ImeshError
from ..io.atomic import atomic_path
from .browser import chromium_page, open_viewer
from .html import viewer_html

log = logging.getLogger(__name__)


def video_frames(n_motion: int, motion_fps: float, video_fps: float) -> np.ndarray:
    """(N,) motion frame shown in each video frame: N = round(duration x video_fps) frames
    covering the motion's duration ``n_motion / motion_fps`` [s], each the motion frame at or
    before its time."""
    n = max(1, int(round(n_motion / motion_fps * video_fps)))
    return np.minimum(np.floor(np.arange(n) * motion_fps / video_fps + 1e-9).astype(int),
                      n_motion - 1)


#: The page's options for a video (argument: the scene has a DART simulation): the simulated
#: robot takes the side the adapted markers take without it.
_VIDEO_OPTIONS = """(simulation) => {
    const on = ['opt-follow', 'opt-floor', 'opt-human'];
    const off = ['opt-sim-over'];
    if (simulation) { on.push('opt-sim'); off.push('opt-beside'); } else on.push('opt-beside');
    for (const id of on.concat(off)) {
        const el = document.getElementById(id);
        if (el.checked !== on.includes(id)) el.click();
    }
    for (const id of ['bar', 'banner']) document.getElementById(id).style.display = 'none';
    window.dispatchEvent(new Event('resize'));
}"""


def _ffmpeg_writer(path: Path, size: tuple[int, int], fps: float):
    imageio_ffmpeg = optional("imageio_ffmpeg", "pip install 'imesh-retarget[viz]'", "a video")
    writer = imageio_ffmpeg.write_frames(str(path), size, fps=fps, codec="libx264",
                                         pix_fmt_in="rgb24", pix_fmt_out="yuv420p",
                                         macro_block_size=2, quality=7,
                                         output_params=["-movflags", "+faststart"])
    writer.send(None)
    return writer


def write_video(path: str | os.PathLike, scene: dict, *, fps: float | None = None,
                size: tuple[int, int] = (960, 600), progress: str | None = None) -> int:
    """Render a scene (:func:`imesh.viz.scene.build_scene`) to an mp4 video.

    Args:
        path: the ``.mp4`` file to write (atomically).
        scene: the viewer scene (:func:`imesh.viz.scene.build_robots_scene`); a robot with a
            ``simulation`` (``build_scene(..., physics=result)`` of a
            :class:`imesh.physics.PhysicsResult`) has the simulated robot drawn beside it.
        fps: video frame rate [1/s] (default: the motion's).
        size: (width, height) [px] of the video (even numbers).
        progress: a tqdm description to show a bar, or None.

    Returns:
        the number of video frames written (:func:`video_frames`).

    Raises:
        ImeshError: Chromium, Playwright or imageio-ffmpeg missing (with how to install them).
    """
    image = optional("PIL.Image", "pip install 'imesh-retarget[viz]'", "a video")
    fps = float(fps or scene["fps"])
    frames = video_frames(int(scene["frames"]), float(scene["fps"]), fps)
    bar = None
    if progress:

        bar = tqdm(total=len(frames), desc=progress, unit="frame", file=sys.stderr)
    with tempfile.TemporaryDirectory(prefix="imesh-video-") as tmpdir:
        page_path = Path(tmpdir) / "viewer.html"
        page_path.write_text(viewer_html(scene), encoding="utf-8")
        with chromium_page(size[0], size[1]) as (page, errors), \
                atomic_path(path) as tmp:
            open_viewer(page, page_path.as_uri())
            page.evaluate(_VIDEO_OPTIONS, any("simulation" in r for r in scene["robots"]))
            writer = _ffmpeg_writer(tmp, size, fps)
            try:
                for k in frames:
                    url = page.evaluate(f"window.imeshViewer.setFrame({int(k)}), "
                                        "window.imeshViewer.snapshot('image/jpeg', 0.95)")
                    data = base64.b64decode(url.split(",", 1)[1])
                    img = image.open(io.BytesIO(data)).convert("RGB")
                    if img.size != size:
                        img = img.resize(size)
                    writer.send(np.asarray(img).tobytes())
                    if bar is not None:
                        bar.update(1)
            finally:
                writer.close()
                if bar is not None:
                    bar.close()
            if errors:
                raise ImeshError(f"the viewer page failed while rendering the video: {errors[0]}")
    log.info("wrote %d video frames at %g fps to %s", len(frames), fps, path)
    return len(frames)
