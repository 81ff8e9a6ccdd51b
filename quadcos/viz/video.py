"""Headless rendering of a rollout to mp4 (MuJoCo's OpenGL renderer, no display needed).

The OpenGL backend: `MUJOCO_GL` when it says `egl` or `osmesa`, else EGL when libEGL is installed
(NVIDIA's driver on a GPU machine; Mesa's software renderer on a CPU-only one), else OSMesa. The
context is opened here rather than through `mujoco.Renderer`, which takes its backend from
`MUJOCO_GL` as it was when `mujoco` was first imported — before a CLI can choose one. Frames go to
the ffmpeg that the `imageio-ffmpeg` package ships (`pip install 'quadcos[video]'`).
"""

import copy
import ctypes.util
import os
import pathlib
import warnings
from typing import Any

import mujoco
import numpy as np

_LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
_DEBIAN_PACKAGES = {"egl": "libegl1", "osmesa": "libosmesa6"}


class VideoError(RuntimeError):
    """Rendering cannot work here: no headless OpenGL library or no mp4 writer."""


def headless_gl_backend() -> str:
    """The backend to render with, "egl" or "osmesa" (see the module docstring).

    Raises:
      VideoError: naming the missing system library.
    """
    requested = os.environ.get("MUJOCO_GL", "").strip().lower()
    if requested in _LIBRARIES:
        backend = requested
    else:
        backend = "egl" if ctypes.util.find_library("EGL") else "osmesa"
    if not ctypes.util.find_library(_LIBRARIES[backend]):
        raise VideoError(
            f"--video needs the system library lib{_LIBRARIES[backend]} for headless rendering"
            f" (MUJOCO_GL={backend}) and it is not installed; on Debian/Ubuntu: apt-get install"
            f" {_DEBIAN_PACKAGES[backend]}"
        )
    return backend


def _gl_context(width: int, height: int) -> Any:
    backend = headless_gl_backend()
    try:
        if backend == "egl":
            from mujoco.egl import GLContext
        else:
            from mujoco.osmesa import GLContext
        context = GLContext(width, height)
        context.make_current()
    except Exception as error:  # noqa: BLE001 -- PyOpenGL and the drivers raise many types
        raise VideoError(
            f"--video: cannot open a headless OpenGL context with MUJOCO_GL={backend}: {error}"
        ) from None
    return context


def _ffmpeg() -> Any:
    try:
        import imageio_ffmpeg
    except ImportError:
        raise VideoError(
            "--video needs imageio-ffmpeg (an mp4 writer with its own ffmpeg):"
            " pip install 'quadcos[video]'"
        ) from None
    return imageio_ffmpeg


def check_video_support() -> None:
    """Raises VideoError when `render_video` cannot work here; cheap, for checks up front."""
    _ffmpeg()
    _gl_context(16, 16).free()


def render_video(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    path: str | os.PathLike[str],
    *,
    fps: float,
    width: int = 640,
    height: int = 360,
    distance: float = 3.0,
    azimuth: float = 90.0,
    elevation: float = -15.0,
) -> pathlib.Path:
    """Renders one frame per row of `qpos` (frames, nq) to an H.264 mp4, written atomically.

    A free camera follows the free body's position (qpos[:3]) from the side: azimuth 90° looks
    along +y, so a robot walking along +x crosses the frame left to right.

    Args:
      model: the host MuJoCo model (an env's `mj_model`; not modified).
      fps: frames per second (the control rate for one frame per control step).
      width, height: pixels, even, >= 16.

    Raises:
      VideoError: no headless OpenGL or no mp4 writer.
      ValueError: odd or too small frame size.
    """
    if width < 16 or height < 16 or width % 2 or height % 2:
        raise ValueError(f"video size must be even and >= 16; got {width}x{height}")
    imageio_ffmpeg = _ffmpeg()
    model = _with_framebuffer(model, width, height)
    path = pathlib.Path(path)
    temporary = path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")
    context = _gl_context(width, height)
    try:
        scene = mujoco.MjvScene(model, maxgeom=1000)
        render_context = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, render_context)
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.distance, camera.azimuth, camera.elevation = distance, azimuth, elevation
        option, perturb = mujoco.MjvOption(), mujoco.MjvPerturb()
        viewport = mujoco.MjrRect(0, 0, width, height)
        data = mujoco.MjData(model)
        frame = np.empty((height, width, 3), np.uint8)
        writer = imageio_ffmpeg.write_frames(
            str(temporary), (width, height), fps=fps, macro_block_size=2
        )
        with warnings.catch_warnings():
            # JAX warns on any fork; ffmpeg is exec'd right after it, so no JAX thread matters.
            warnings.filterwarnings("ignore", message=r"os\.fork\(\) was called")
            writer.send(None)  # starts ffmpeg
        try:
            for positions in qpos:
                data.qpos[:] = positions
                mujoco.mj_forward(model, data)
                camera.lookat[:] = data.qpos[:3]
                mujoco.mjv_updateScene(
                    model, data, option, perturb, camera, mujoco.mjtCatBit.mjCAT_ALL, scene
                )
                mujoco.mjr_render(viewport, scene, render_context)
                mujoco.mjr_readPixels(frame, None, viewport, render_context)
                writer.send(np.ascontiguousarray(frame[::-1]))  # OpenGL rows run bottom-up
        finally:
            writer.close()
            render_context.free()
        os.replace(temporary, path)
    finally:
        context.free()
        temporary.unlink(missing_ok=True)
    return path


def _with_framebuffer(model: mujoco.MjModel, width: int, height: int) -> mujoco.MjModel:
    """`model`, or a copy with an offscreen framebuffer of at least width x height."""
    buffer = model.vis.global_
    if buffer.offwidth >= width and buffer.offheight >= height:
        return model
    model = copy.deepcopy(model)
    model.vis.global_.offwidth = max(buffer.offwidth, width)
    model.vis.global_.offheight = max(buffer.offheight, height)
    return model
