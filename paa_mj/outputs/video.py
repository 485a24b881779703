"""Offscreen video of a rollout (MuJoCo ``Renderer`` + mediapy), and a filmstrip of key poses.

Frames are rendered at the video's frame rate only: the trajectory is
interpolated at t = k / fps, whatever the physics time step, so the video plays
in real time. The links are coloured by controller mode (warm colours during
swing-up (40), gold once the LQR (67) balances) and the feet leave a fading
trace (:class:`~paa_mj.view.renderer.GymnastRenderer`). Select the GL backend with
:func:`paa_mj.view.gl.select_backend` first.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import PaaError
from ..io import atomic_path
from ..model.robot import Robot
from ..sim.trajectory import Trajectory
from ..view.renderer import GymnastRenderer

TRACE_SECONDS = 1.5
VIDEO_SUFFIXES = (".mp4", ".gif")


def _ffmpeg():
    import imageio_ffmpeg
    import mediapy

    mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())
    return mediapy


def states_at(traj: Trajectory, times):
    """Joint angles (interpolated) and controller modes (of the last sample) at ``times``."""
    q = np.column_stack([np.interp(times, traj.t, traj.q[:, i]) for i in range(traj.q.shape[1])])
    idx = np.clip(np.searchsorted(traj.t, times, side="right") - 1, 0, len(traj.t) - 1)
    return q, traj.mode[idx]


def frame_states(traj: Trajectory, fps: float):
    """Times t = k / fps, with the joint angles and modes there."""
    if not fps > 0:
        raise PaaError(f"--fps must be > 0, got {fps}")
    times = np.arange(0.0, traj.t[-1] + 1e-9, 1.0 / fps)
    return (times, *states_at(traj, times))


#: The most frames of 640 x 480 one video may have (about 1.9 h at 30 fps); beyond, rendering would take hours.
MAX_FRAMES = 200_000
#: Rendering cost per frame of 640 x 480 assumed when a request is refused [s]; larger frames cost in proportion.
FRAME_SECONDS = 0.01
#: GIF frame delays are whole hundredths of a second, at most 65535 (and players slow delays below 2 down).
GIF_FPS_RANGE = (100.0 / 65535, 50.0)


def check_video_request(traj: Trajectory, fps, width, height, saved=False):
    """Refuse a video that would take too long, before anything is rendered (frames are streamed to disk);
    ``saved``: the trajectory comes from a file, whose duration no option shortens."""
    if not (np.isfinite(fps) and fps > 0):
        raise PaaError(f"--fps must be a positive finite number, got {fps}")
    frames = int(np.floor(float(traj.t[-1]) * fps)) + 1
    cost = frames * max(1.0, width * height / (640 * 480))  # in frames of 640 x 480
    if cost > MAX_FRAMES:
        hours = cost * FRAME_SECONDS / 3600
        raise PaaError(f"would need {frames} frames of {width} x {height} (about {hours:.3g} h to render, the limit"
                       f" is {MAX_FRAMES * FRAME_SECONDS / 3600:.3g} h); lower --fps"
                       + (" or the size" if saved else ", --t-final or the size"))
    return frames


def check_fps_for(path, fps):
    """A GIF cannot play faster than 50 frames per second or slower than one frame in 655 s."""
    low, high = GIF_FPS_RANGE
    if Path(path).suffix.lower() == ".gif" and not (low <= fps <= high):
        raise PaaError(f"a GIF plays between {low:.3g} and {high:g} frames per second, got --fps {fps:g}:"
                       " choose a rate in that range or write an .mp4")


def frames(robot: Robot, traj: Trajectory, fps=30, width=640, height=480, camera="side", progress=False):
    """The labelled frames of the video of ``traj``, one at a time (uint8, (height, width, 3)).

    ``progress``: a count of the frames on stderr, as a bar on a terminal and as lines in a log.
    """
    from ..progress import progress as counter

    times, q, modes = frame_states(traj, fps)
    trace_len = max(1, int(round(TRACE_SECONDS * fps)))
    with GymnastRenderer(robot, width, height, camera) as gr:
        feet = gr.feet_positions(q)
        with counter(range(len(times)), desc="render", unit="frame", enabled=progress) as bar:
            for k in bar:
                yield _label(gr.render(q[k], modes[k], feet[max(0, k - trace_len):k + 1]), times[k], modes[k])


def render_frames(robot: Robot, traj: Trajectory, fps=30, width=640, height=480, camera="side", progress=False):
    """All frames of the video of ``traj`` as an array (n, height, width, 3) (short videos; see :func:`frames`)."""
    return np.stack(list(frames(robot, traj, fps, width, height, camera, progress)))


def _label(frame, t, mode):
    """Write the time and the controller mode in the corner of a frame."""
    from PIL import Image, ImageDraw

    img = Image.fromarray(frame)
    draw = ImageDraw.Draw(img)
    label = f"t = {t:5.2f} s   " + ("balance: LQR (67)" if mode == 1 else "swing-up")
    draw.rectangle([6, 6, 12 + 7 * len(label), 24], fill=(0, 0, 0))
    draw.text((10, 9), label, fill=(255, 215, 60) if mode == 1 else (255, 255, 255))
    return np.asarray(img)


def write_video(path, frame_source, fps, width, height):
    """Encode frames to ``path`` (.mp4 or .gif) as they come, with ffmpeg from imageio-ffmpeg.

    The video is written to a temporary file renamed on success: an error or an
    interruption leaves no file behind, and memory holds one frame at a time.
    """
    path = Path(path)
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise PaaError(f"video file must end in .mp4 or .gif, got {path.name}")
    check_fps_for(path, fps)
    mediapy = _ffmpeg()
    codec = "gif" if path.suffix.lower() == ".gif" else "h264"
    try:
        with atomic_path(path) as tmp:
            with mediapy.VideoWriter(tmp, shape=(height, width), fps=fps, codec=codec) as writer:
                for frame in frame_source:
                    writer.add_image(frame)
    except (OSError, RuntimeError) as err:
        # Ctrl-C to the process group stops ffmpeg too; its failure on closing then hides the interruption
        cause = err.__context__
        while cause is not None and not isinstance(cause, KeyboardInterrupt):
            cause = cause.__context__
        if cause is not None:
            raise cause from None
        raise PaaError(f"cannot write video {path}: {' '.join(str(err).split())}") from None
    return path


def render_trajectory(robot: Robot, traj: Trajectory, path, fps=30, width=640, height=480, camera="side",
                      progress=False):
    """Render ``traj`` and stream it to ``path``; returns the path."""
    check_video_request(traj, fps, width, height)
    renderer = GymnastRenderer(robot, width, height, camera)  # fails early (size, camera, GL) before ffmpeg starts
    renderer.close()
    return write_video(path, frames(robot, traj, fps, width, height, camera, progress), fps, width, height)


def filmstrip(robot: Robot, traj: Trajectory, path, n_poses=8, width=320, height=400, camera="side"):
    """A PNG of key poses side by side (like the paper's Fig. 1): evenly spaced up to the balance."""
    from PIL import Image, ImageDraw

    end = traj.switch_time + 2.0 if traj.switch_time is not None else traj.t[-1]
    times = np.linspace(0.0, min(end, traj.t[-1]), n_poses)
    q, modes = states_at(traj, times)
    with GymnastRenderer(robot, width, height, camera) as gr:
        tiles = [gr.render(q[k], modes[k]) for k in range(n_poses)]
    strip = Image.fromarray(np.concatenate(tiles, axis=1))
    draw = ImageDraw.Draw(strip)
    for k, t in enumerate(times):
        draw.text((k * width + 8, 8), f"t = {t:.1f} s", fill=(255, 255, 255))
    with atomic_path(path, suffix=".png") as tmp:
        strip.save(tmp, format="PNG")
    return path


def render_side_by_side(robot: Robot, trajectories: dict, path, fps=30, width=320, height=360, camera="side"):
    """One video of several controllers' kips side by side, each tile titled; shorter runs hold their last frame."""
    from PIL import Image, ImageDraw

    runs = {name: Trajectory(traj["t"], traj["q"], traj["qd"], traj["tau"], np.zeros(len(traj["t"])),
                             np.zeros(len(traj["t"])), traj["mode"]) for name, traj in trajectories.items()}
    end = max(float(traj.t[-1]) for traj in runs.values())
    for traj in runs.values():
        check_video_request(traj, fps, width * len(runs), height)

    def tiles():
        sources = {name: frames(robot, traj, fps, width, height, camera) for name, traj in runs.items()}
        last = {}
        for _ in range(int(np.floor(end * fps)) + 1):
            row = []
            for name, source in sources.items():
                last[name] = next(source, last.get(name))
                img = Image.fromarray(last[name])
                ImageDraw.Draw(img).text((10, height - 22), name, fill=(255, 255, 255))
                row.append(np.asarray(img))
            yield np.concatenate(row, axis=1)

    return write_video(path, tiles(), fps, width * len(runs), height)
