"""The camera's sensor and its processing, applied to the scene's light as the lens delivers
it: auto-exposure with its lag, white-balance drift, vignetting, shot and read noise, JPEG
compression, rolling shutter and motion blur. Deterministic for a seed.

Each step is one or two whole-frame uint8 OpenCV operations (docs/rendering.md gives the
cost of each); nothing here loops over pixels in Python.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from lfctl.config import CameraConfig

__all__ = ["Sensor"]

NOISE_FRAMES = 6  # the bank of noise frames one is drawn from per frame


class Sensor:
    """One camera's sensor: call :meth:`expose` on each rendered frame, in time order.

    Parameters
    ----------
    camera : CameraConfig
        Size, noise, exposure, white balance, vignetting, JPEG, rolling shutter, motion blur.
    seed : int
        Seeds the noise bank, the choice of noise frame and the white-balance drift.
    """

    def __init__(self, camera: CameraConfig, seed: int) -> None:
        self.cfg = camera
        w, h = camera.width_px, camera.height_px
        rng = np.random.default_rng(seed + 20)
        # noise: variance read^2 + shot I, fitted as a^2 + (b I)^2 over 16..240 DN: a read
        # part (uint8 halves of a normal bank, one add and one subtract) and a part that
        # scales with the signal, folded with the vignetting into one multiplier frame:
        # cv2.multiply(I, 128 v (1 + b n), scale=1/128) is I v (1 + b n)
        read, shot = camera.noise_sigma, camera.shot_noise
        xs = np.linspace(16, 240, 15)
        if shot > 0:
            b2 = float(np.sum(shot * xs * xs**2) / np.sum(xs**4))  # least squares of shot I ~ b^2 I^2
            self.sigma_a, self.sigma_b = read, math.sqrt(b2)
        else:
            self.sigma_a, self.sigma_b = read, 0.0
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
        r2 = ((xx - (w - 1) / 2) ** 2 + (yy - (h - 1) / 2) ** 2) / (((w - 1) / 2) ** 2 + ((h - 1) / 2) ** 2)
        vmap = (1.0 - camera.vignetting * r2)[..., None]  # cos^4-like fall-off, 1 - v r^2, r = 1 in the corners
        self._mult: list[np.ndarray] = []
        self._read: list[tuple[np.ndarray, np.ndarray]] = []
        frames = NOISE_FRAMES if (self.sigma_a > 0 or self.sigma_b > 0) else 1
        for _ in range(frames):
            if self.sigma_b > 0 or camera.vignetting > 0:
                n = rng.standard_normal((h, w, 3), dtype=np.float32) if self.sigma_b > 0 else 0.0
                m = np.broadcast_to(128.0 * vmap * (1.0 + self.sigma_b * n), (h, w, 3))
                self._mult.append(np.clip(np.round(m), 0, 255).astype(np.uint8))
            if self.sigma_a > 0:
                n = np.round(rng.standard_normal((h, w, 3), dtype=np.float32) * self.sigma_a)
                self._read.append((np.clip(n, 0, 255).astype(np.uint8), np.clip(-n, 0, 255).astype(np.uint8)))
        self._pick = np.random.default_rng(seed + 21)
        # white balance drift: two slow sums of sines per channel (B, R), periods 7..40 s
        wb = np.random.default_rng(seed + 22)
        self._wb = [(wb.uniform(7, 40, 2), wb.uniform(0, 2 * math.pi, 2)) for _ in range(2)]
        self.gain = 1.0  # the exposure gain now (auto-exposure), relative to the nominal
        self._last_t: float | None = None

    def white_balance(self, t_s: float) -> np.ndarray:
        """The BGR gains of the white balance at ``t_s`` (green 1).

        Parameters
        ----------
        t_s : float
            Time, s.
        """
        d = self.cfg.white_balance_drift
        if d <= 0:
            return np.ones(3)
        out = [1.0, 1.0, 1.0]
        for ch, (periods, phases) in zip((0, 2), self._wb, strict=True):
            s = sum(math.sin(2 * math.pi * t_s / p + ph) for p, ph in zip(periods, phases, strict=True)) / 2
            out[ch] = 1.0 + d * s
        return np.array(out)

    def expose(
        self, img: np.ndarray, t_s: float, light_bgr: np.ndarray, yaw_rate_radps: float, fx: float
    ) -> np.ndarray:
        """The frame as the camera delivers it: the scene's light ``img`` (BGR uint8, the
        nominal exposure) times ``light_bgr`` (the scene's gain and tint), exposed, balanced,
        vignetted, noisy, and (when configured) smeared, sheared and compressed.

        Parameters
        ----------
        img : np.ndarray
            The rendered scene, modified in place where possible.
        t_s : float
            The frame's time, s (exposure lag, white-balance drift).
        light_bgr : np.ndarray
            The scene's light, BGR factors (key frames, flicker).
        yaw_rate_radps : float
            The camera's yaw rate: motion blur and rolling shutter.
        fx : float
            Focal length, px.
        """
        cfg = self.cfg
        if cfg.motion_blur and abs(yaw_rate_radps) > 1e-3:
            length = int(min(31, abs(yaw_rate_radps) / 60.0 * fx))
            if length >= 2:
                img = cv2.blur(img, (length, 1))
        if cfg.rolling_shutter_s > 0 and abs(yaw_rate_radps) > 1e-3:
            img = self._rolling_shutter(img, yaw_rate_radps * cfg.rolling_shutter_s * fx)
        gains = np.asarray(light_bgr, float) * self.white_balance(t_s)
        if cfg.auto_exposure:
            # the meter reads this frame's light; the gain the frame gets is the one the
            # previous frames set (a real camera meters what it has already captured)
            level = float(np.mean(cv2.mean(img[::8, ::8])[:3])) * float(np.mean(np.asarray(light_bgr, float)))
            applied = self.gain
            if level > 1.0:
                want = min(4.0, max(0.25, cfg.exposure_target * 255.0 / level))
                dt = 0.0 if self._last_t is None else max(0.0, t_s - self._last_t)
                if self._last_t is None:
                    self.gain = applied = want  # a camera starts metered
                else:
                    alpha = 1.0 - math.exp(-dt / cfg.exposure_lag_s) if cfg.exposure_lag_s > 0 else 1.0
                    # the exposure moves in stops: follow in log space
                    self.gain = math.exp(math.log(self.gain) + alpha * (math.log(want) - math.log(self.gain)))
            self._last_t = t_s
            gains = gains * applied
        if np.any(np.abs(gains - 1.0) > 1e-6):
            img = cv2.transform(img, np.diag(gains).astype(np.float32))
        k = int(self._pick.integers(NOISE_FRAMES))
        if self._mult:
            cv2.multiply(img, self._mult[k % len(self._mult)], dst=img, scale=1.0 / 128.0)
        if self._read:
            plus, minus = self._read[k % len(self._read)]
            cv2.add(img, plus, dst=img)
            cv2.subtract(img, minus, dst=img)
        if cfg.jpeg_quality > 0:
            ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, int(cfg.jpeg_quality)])
            if ok:
                img = cv2.imdecode(buf, cv2.IMREAD_COLOR)
        return img

    @staticmethod
    def _rolling_shutter(img: np.ndarray, shift_px: float) -> np.ndarray:
        """Rows read later see the scene turned further: row y moves by ``shift_px`` times
        (y / height - 1/2), in bands of 8 rows (whole pixels; the edge column repeats)."""
        h, w = img.shape[:2]
        out = np.empty_like(img)
        band = 8
        for y0 in range(0, h, band):
            y1 = min(h, y0 + band)
            # turning right (positive yaw rate) moves the scene left in later rows
            s = int(round(-shift_px * ((y0 + y1) / 2 / h - 0.5)))
            s = max(-w + 1, min(w - 1, s))
            if s > 0:
                out[y0:y1, s:] = img[y0:y1, : w - s]
                out[y0:y1, :s] = img[y0:y1, :1]
            elif s < 0:
                out[y0:y1, : w + s] = img[y0:y1, -s:]
                out[y0:y1, w + s :] = img[y0:y1, -1:]
            else:
                out[y0:y1] = img[y0:y1]
        return out
