"""Drawing the table into an RGB array with numpy alone (fast enough for
video: no plotting library in the rgb_array path)."""
from __future__ import annotations

from typing import List, Optional

import numpy as np

CLOTH = (20, 110, 50)
CUSHION = (90, 50, 20)
POCKET = (0, 0, 0)
BALLS = ((245, 245, 245), (210, 30, 30), (230, 200, 40))  # cue, reward, other
TRAIL = ((200, 200, 255), (255, 150, 150), (255, 235, 140))


class Renderer:
    """Frames of width x height pixels: the table (cloth inside a cushion
    border), the six pockets, the last shot's trajectories and the balls."""

    def __init__(self, cfg, width: int, height: int) -> None:
        if width < 20 or height < 10:
            raise ValueError(f"render size: at least 20 x 10 pixels (got {width} x {height})")
        self.w, self.h = width, height
        self.L, self.W = cfg.number("table.length"), cfg.number("table.width")
        self.R = cfg.number("table.ball_radius")
        self.reward_balls = int(cfg.number("table.reward_balls"))
        border = max(2, round(0.04 * min(width, height)))
        # metres to pixels, the table centred with its aspect ratio kept
        self.s = min((width - 2 * border) / self.L, (height - 2 * border) / self.W)
        self.cx, self.cy = width / 2, height / 2
        base = np.empty((height, width, 3), dtype=np.uint8)
        base[:] = CUSHION
        x0, x1 = self._px(-self.L / 2, self.W / 2), self._px(self.L / 2, -self.W / 2)
        base[x0[1]:x1[1] + 1, x0[0]:x1[0] + 1] = CLOTH
        pr = cfg.number("table.pocket_radius")
        for i in range(3):
            for y in (-self.W / 2, self.W / 2):
                self._disc(base, -self.L / 2 + i * self.L / 2, y, pr, POCKET)
        self.base = base
        self.fig = None

    def _px(self, x, y):
        """Pixel column and row of table point(s) (x, y); y up."""
        return (np.rint(self.cx + np.asarray(x) * self.s).astype(int),
                np.rint(self.cy - np.asarray(y) * self.s).astype(int))

    def _disc(self, img, x, y, r, colour):
        rp = max(1.0, r * self.s)
        c, row = self.cx + x * self.s, self.cy - y * self.s
        c0, c1 = int(max(0, np.floor(c - rp))), int(min(self.w - 1, np.ceil(c + rp)))
        r0, r1 = int(max(0, np.floor(row - rp))), int(min(self.h - 1, np.ceil(row + rp)))
        if c0 > c1 or r0 > r1:
            return
        yy, xx = np.ogrid[r0:r1 + 1, c0:c1 + 1]
        img[r0:r1 + 1, c0:c1 + 1][(xx - c) ** 2 + (yy - row) ** 2 <= rp * rp] = colour

    def _trails(self, img, trace):
        """Straight segments between consecutive records of each ball (balls
        move in straight lines between events)."""
        for b in np.unique(trace[:, 3]).astype(int):
            p = trace[trace[:, 3] == b]
            if len(p) < 2:
                continue
            cols, rows = self.cx + p[:, 1] * self.s, self.cy - p[:, 2] * self.s
            steps = np.maximum(1, np.ceil(np.hypot(np.diff(cols), np.diff(rows)))).astype(int)
            seg = np.repeat(np.arange(len(steps)), steps)
            f = (np.arange(steps.sum()) - np.repeat(np.cumsum(steps) - steps, steps)) / \
                steps[seg]
            c = np.rint(cols[seg] + f * np.diff(cols)[seg]).astype(int)
            r = np.rint(rows[seg] + f * np.diff(rows)[seg]).astype(int)
            ok = (c >= 0) & (c < self.w) & (r >= 0) & (r < self.h)
            img[r[ok], c[ok]] = TRAIL[min(2, 0 if b == 0 else 1 if b <= self.reward_balls else 2)]

    def frame(self, positions: Optional[np.ndarray], trace: Optional[np.ndarray]) -> np.ndarray:
        img = self.base.copy()
        if trace is not None:
            self._trails(img, trace)
        if positions is not None:
            pos = np.asarray(positions).reshape(-1, 2)
            for b, (x, y) in enumerate(pos):  # a pocketed ball sits on its pocket
                kind = 0 if b == 0 else 1 if b <= self.reward_balls else 2
                self._disc(img, x, y, self.R, BALLS[kind])
        return img

    def clip(self, final: np.ndarray, trace: np.ndarray,
             times: np.ndarray, positions: np.ndarray) -> List[np.ndarray]:
        """The frames of a shot after its start: the balls at each of times
        (positions (len(times), 2*n_balls)) with the trails so far, and the
        final frame. Frames after which no ball moves by half a pixel any
        more are left out (the exponential law's long, invisible tail)."""
        moving = np.nonzero(np.abs(positions - final).max(axis=1) * self.s >= 0.5)[0]
        n = moving[-1] + 1 if len(moving) else 0
        frames = []
        for t, pos in zip(times[:n], positions[:n]):
            now = np.column_stack([np.full(len(pos) // 2, t), pos.reshape(-1, 2),
                                   np.arange(len(pos) // 2)])
            upto = np.vstack([trace[trace[:, 0] < t], now])
            frames.append(self.frame(pos, upto[np.lexsort((upto[:, 0], upto[:, 3]))]))
        frames.append(self.frame(final, trace))
        return frames

    def show(self, frame: np.ndarray, pause: float = 1e-3) -> None:
        import matplotlib.pyplot as plt
        if self.fig is None:
            plt.ion()
            self.fig, ax = plt.subplots(figsize=(self.w / 100, self.h / 100), dpi=100)
            ax.set_axis_off()
            self.im = ax.imshow(frame)
        else:
            self.im.set_data(frame)
        self.fig.canvas.draw_idle()
        plt.pause(pause)

    def close(self) -> None:
        if self.fig is not None:
            import matplotlib.pyplot as plt
            plt.close(self.fig)
            self.fig = None
