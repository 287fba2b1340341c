"""RecordVideo: Gymnasium's RecordVideo wrapper, recording every frame of an
`rgb_array_list` render, so that each shot becomes a clip.

Gymnasium's own RecordVideo (1.x) calls `render()` after every reset and
step and, when the environment returns a list of frames, keeps only the
last one: a PocketEnv episode (one shot) would be recorded as two frames.
This subclass keeps all of them, at the environment's
`metadata["render_fps"]`; everything else (triggers, `video_length`, file
names, MoviePy for writing) is Gymnasium's.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import logger
from gymnasium.wrappers import RecordVideo as _GymRecordVideo


class RecordVideo(_GymRecordVideo):  # type: ignore[misc]
    """gymnasium.wrappers.RecordVideo for render_mode="rgb_array_list":
    every frame of each list the environment renders goes into the clip
    (the start state after a reset, then the shot's frames). With
    render_mode="rgb_array" it records as Gymnasium's does.

        env = gymnasium.make("poolreps/PocketEnv-v0", render_mode="rgb_array_list")
        env = poolreps.video.RecordVideo(env, "videos", episode_trigger=lambda e: True)
    """

    def _capture_frame(self) -> None:
        assert self.recording, "Cannot capture a frame, recording wasn't started."
        out: Any = self.env.render()
        frames = out if isinstance(out, list) else [out]
        if isinstance(out, list):
            if not out:
                logger.warn("Trying to capture render frame but 'env.render()' has just been "
                            "called. The frame cannot be captured.")
                return
            self.render_history += out  # what a later render() returns, as Gymnasium's
        if not all(isinstance(f, np.ndarray) for f in frames):
            self.stop_recording()
            logger.warn("Recording stopped: expected render to return numpy arrays, got "
                        f"{type(out)}.")
            return
        self.recorded_frames += frames
