r"""Per-episode statistics of each feature and their aggregate over the dataset.

As LeRobot's ``compute_stats``: for a vector feature, per component over the episode's
frames; for a camera, per colour channel (RGB) over the pixels of a sample of its frames,
scaled to [0, 1], each statistic shaped (3, 1, 1). ``count`` is the number of frames. The
dataset's statistics aggregate the episodes': ``mean`` weighted by ``count``, ``std`` from
the pooled variance, ``min``/``max`` over all, each quantile the count-weighted mean of
the episodes' (LeRobot's ``aggregate_stats``).

.. math::
    \sigma^2 = \sum_e \frac{n_e}{N} \left( \sigma_e^2 + (\mu_e - \mu)^2 \right)
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mearm.dataset.lerobot_format import QUANTILES

Stats = dict[str, np.ndarray]


def vector_stats(values: npt.ArrayLike) -> Stats:
    """Statistics of a (frames, n) feature, per component, each (n,); ``count`` (1,)."""
    a = np.asarray(values, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    out: Stats = {
        "min": a.min(axis=0),
        "max": a.max(axis=0),
        "mean": a.mean(axis=0),
        "std": a.std(axis=0),
        "count": np.array([a.shape[0]]),
    }
    for q, v in zip(QUANTILES, np.quantile(a, QUANTILES, axis=0), strict=True):
        out[f"q{round(q * 100):02d}"] = v
    return out


def image_stats(pixels_rgb: npt.ArrayLike, frames: int) -> Stats:
    """Per-channel statistics of sampled RGB pixels (k, 3) uint8, in [0, 1], each (3, 1, 1).

    Args:
        pixels_rgb: Pixels sampled from the episode's frames, (k, 3).
        frames: The episode's number of frames (``count``).
    """
    stats = vector_stats(np.asarray(pixels_rgb, dtype=np.float64) / 255.0)
    out = {k: v.reshape(3, 1, 1) for k, v in stats.items() if k != "count"}
    out["count"] = np.array([frames])
    return out


def aggregate(episodes: list[Stats]) -> Stats:
    """The statistics of the episodes together (module docstring)."""
    counts = np.array([float(s["count"][0]) for s in episodes])
    w = counts / counts.sum()

    def weighted(key: str) -> np.ndarray:
        return np.sum([wi * s[key] for wi, s in zip(w, episodes, strict=True)], axis=0)

    mean = weighted("mean")
    var = np.sum(
        [wi * (s["std"] ** 2 + (s["mean"] - mean) ** 2) for wi, s in zip(w, episodes, strict=True)],
        axis=0,
    )
    out: Stats = {
        "min": np.min([s["min"] for s in episodes], axis=0),
        "max": np.max([s["max"] for s in episodes], axis=0),
        "mean": mean,
        "std": np.sqrt(var),
        "count": np.array([int(counts.sum())]),
    }
    for q in QUANTILES:
        key = f"q{round(q * 100):02d}"
        out[key] = weighted(key)
    return out


def to_json(stats: dict[str, Stats]) -> dict[str, dict[str, object]]:
    """Feature → statistic → nested lists (``meta/stats.json``)."""
    return {f: {k: np.asarray(v).tolist() for k, v in s.items()} for f, s in stats.items()}


def from_json(data: dict[str, dict[str, object]]) -> dict[str, Stats]:
    """The inverse of :func:`to_json`."""
    return {f: {k: np.asarray(v) for k, v in s.items()} for f, s in data.items()}
