# SPDX-License-Identifier: Apache-2.0
"""`MultiWindow`: a base filter's search of many windows around a prediction from one feature computation: the
papers' 3x3 re-detection grid and (ours) the denser re-detection lattice."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from swir_tracker_ros.core.detection import Detection
from swir_tracker_ros.core.features import cosine_window, sample_patch, unwindowed_features
from swir_tracker_ros.core.kernels import corr_jit
from swir_tracker_ros.types import Box

LATTICE_RESCORED = 3  # lattice windows correlated in full after the screen on principal channels (ours)


class MultiWindow:
    """Grid and lattice detection for `BaseFilter` (a mixin: it uses the filter's template geometry
    `cell`, `tw`, `th`, `shape`, `kind`, its `filter`, `_scratch` buffers and `_detections`).

    Every window of a grid or lattice sits on whole feature cells of the union of the windows, so one
    feature computation on that union serves them all; each window's map is a slice of it.
    """

    cell: int
    tw: int
    th: int
    shape: tuple[int, int, int]
    kind: str
    filter: Any
    _train_features: tuple[np.ndarray, tuple[Box, ...], np.ndarray] | None

    def _scratch(self, name: str, shape: tuple[int, ...]) -> np.ndarray: ...  # BaseFilter's

    def _detections(self, responses: np.ndarray, windows: Sequence[Box],
                    scales: Sequence[float]) -> list[Detection]: ...  # BaseFilter's

    def grid_geometry(self, window: Box, overlap: float) -> tuple[int, int, list[Box]]:
        """3x3 re-detection grid around `window` with centre steps snapped to whole template cells.

        The step is (1 - overlap) x window as in `windows.grid_windows`, rounded to whole feature cells of
        the template so that all 9 windows share one pixel and cell lattice (the overlap then differs
        from `overlap` by less than half a cell). Returns (step_x, step_y) in cells and the 9 windows in
        image pixels, row-major, the centre window (index 4) equal to `window`.
        """
        c = self.cell
        sx = max(1, round((1.0 - overlap) * self.tw / c))
        sy = max(1, round((1.0 - overlap) * self.th / c))
        kx, ky = window.w / self.tw, window.h / self.th
        wins = [window.shifted(i * sx * c * kx, j * sy * c * ky) for j in (-1, 0, 1) for i in (-1, 0, 1)]
        return sx, sy, wins

    def grid_features(
        self,
        img: np.ndarray,
        window: Box,
        overlap: float,
        keep: Sequence[int] = tuple(range(9)),
        out: np.ndarray | None = None,
    ) -> tuple[np.ndarray, list[Box]]:
        """Windowed feature maps (len(keep), C, rows, cols) of the grid windows `keep` (row-major indices
        of the 3x3 grid) from ONE feature computation, and all 9 grid windows.

        The union of the 9 windows is resampled once at the template scale, its features computed once,
        and each kept window's map cut out of it (the windows sit on whole cells of the union), so the grid
        costs (1 + 2 (1 - overlap))^2 ~ 5.4 windows of features instead of 9. `out`: optional float32
        array of the result's shape written in place.
        """
        sx, sy, wins = self.grid_geometry(window, overlap)
        offsets = [(k % 3 - 1, k // 3 - 1) for k in keep]
        return self._union_maps(img, window, sx, sy, offsets, (-1, 1, -1, 1), "grid", out), wins

    def _union_maps(
        self,
        img: np.ndarray,
        window: Box,
        sx: int,
        sy: int,
        offsets: Sequence[tuple[int, int]],
        bounds: tuple[int, int, int, int],
        name: str,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Windowed feature maps (len(offsets), C, rows, cols) of the windows `window` shifted by (i sx,
        j sy) template cells for each (i, j) in `offsets`, cut from ONE feature computation on the union of
        the windows with i in [bounds[0], bounds[1]] and j in [bounds[2], bounds[3]] (the windows sit on
        whole cells of the union). `name` keys the reused union-patch buffer; `out`: optional float32 array
        of the result's shape written in place."""
        union = self._union_map(img, window, sx, sy, bounds, name)
        return self._cut(union, sx, sy, offsets, bounds, out)

    def _union_map(
        self, img: np.ndarray, window: Box, sx: int, sy: int, bounds: tuple[int, int, int, int], name: str
    ) -> np.ndarray:
        """Unwindowed feature map (C, H, W) of the union of the windows of `_union_maps`."""
        c = self.cell
        ilo, ihi, jlo, jhi = bounds
        uw, uh = self.tw + (ihi - ilo) * sx * c, self.th + (jhi - jlo) * sy * c
        kx, ky = window.w / self.tw, window.h / self.th
        ucx = window.cx + 0.5 * (ilo + ihi) * sx * c * kx
        ucy = window.cy + 0.5 * (jlo + jhi) * sy * c * ky
        union = Box.from_center(ucx, ucy, uw * kx, uh * ky)
        if img.dtype == np.float32 and img.ndim == 2:  # the conditioned frame: warp into a reused array
            patch = self._scratch(f"{name} union patch", (1, uh, uw))
            sample_patch(img, union, uw, uh, out=patch[0])
        else:
            patch = sample_patch(img, union, uw, uh)[None]
        return unwindowed_features(patch, self.kind, c)[0]

    def _cut(
        self,
        feats: np.ndarray,
        sx: int,
        sy: int,
        offsets: Sequence[tuple[int, int]],
        bounds: tuple[int, int, int, int],
        out: np.ndarray | None = None,
        squared_window: bool = False,
    ) -> np.ndarray:
        """The windowed maps (len(offsets), C, rows, cols) cut from the union map `feats` of `_union_map`
        (`squared_window`: times the cosine window squared, for the windows' energies)."""
        ilo, _ihi, jlo, _jhi = bounds
        fh, fw = self.shape[1:]
        win = cosine_window(fh, fw)
        if squared_window:
            win = (win * win).astype(np.float32)
        if out is None:
            out = np.empty((len(offsets), feats.shape[0], fh, fw), dtype=np.float32)
        # slices of the union map (steps are whole cells; gray: 1 px) times the window
        r0 = np.array([(j - jlo) * sy for _, j in offsets], dtype=np.intp)
        c0 = np.array([(i - ilo) * sx for i, _ in offsets], dtype=np.intp)
        cj = corr_jit()
        if cj is not None and feats.dtype == out.dtype == np.float32 and out.flags.c_contiguous:
            cj.cut_windows_kernel(np.ascontiguousarray(feats), win, r0, c0, out)  # same products, one pass
        else:
            for n in range(len(offsets)):
                np.multiply(feats[:, r0[n] : r0[n] + fh, c0[n] : c0[n] + fw], win, out=out[n])
        return out

    def detect_grid(
        self, img: np.ndarray, window: Box, overlap: float, scale: float = 1.0, skip_centre: bool = True
    ) -> tuple[list[Detection], list[Box]]:
        """Detections in the 3x3 re-detection grid around `window` (the centre one left out if asked,
        as normal mode already correlated it) and the 9 grid windows; `scale` is copied to each."""
        self._train_features = None
        keep = [k for k in range(9) if not (skip_centre and k == 4)]
        buf = self._scratch("grid features", (len(keep), *self.shape))  # consumed by `respond` below
        feats, wins = self.grid_features(img, window, overlap, keep, out=buf)
        responses = self.filter.respond(feats)
        dets = self._detections(responses, [wins[k] for k in keep], [scale] * len(keep))
        return dets, wins

    def lattice_geometry(
        self,
        window: Box,
        step: float,
        rings: int,
        image_size: tuple[int, int] | None = None,
        half: tuple[int, int] | None = None,
        centre: bool = False,
    ) -> tuple[int, int, list[tuple[int, int]], list[Box]]:
        """Re-detection lattice of (2 rings + 1)^2 windows around `window` (ours).

        Centre steps are `step` x the window, snapped to whole template cells so that every window is a
        slice of one feature map (as in `grid_geometry`). Offsets whose window centre falls outside the
        image (`image_size` = (width, height)) are left out, and so is the centre (normal mode already
        correlated it) unless `centre` (a tile of the long-loss sweep). With `half` = (ring r, parity 0
        or 1), the windows of rings r and beyond are kept only where (i + j) % 2 == parity: a
        checkerboard, the other half searched on the next frame (ours).
        Returns (step_x, step_y) in cells, the (i, j) offsets in steps and their windows.
        """
        c = self.cell
        sx = max(1, round(step * self.tw / c))
        sy = max(1, round(step * self.th / c))
        kx, ky = window.w / self.tw, window.h / self.th
        offsets, wins = [], []
        for j in range(-rings, rings + 1):
            for i in range(-rings, rings + 1):
                if i == 0 and j == 0 and not centre:
                    continue
                if half is not None and max(abs(i), abs(j)) >= half[0] and (i + j) % 2 != half[1]:
                    continue
                win = window.shifted(i * sx * c * kx, j * sy * c * ky)
                if image_size is not None and not (
                    0.0 <= win.cx < image_size[0] and 0.0 <= win.cy < image_size[1]
                ):
                    continue
                offsets.append((i, j))
                wins.append(win)
        return sx, sy, offsets, wins

    def detect_lattice(
        self,
        img: np.ndarray,
        window: Box,
        step: float,
        rings: int,
        scale: float = 1.0,
        half: tuple[int, int] | None = None,
        centre: bool = False,
        channels: int = 0,
    ) -> tuple[list[Detection], list[Box]]:
        """Detections in the re-detection lattice around `window` (see `lattice_geometry`) and its windows.

        The papers' 3x3 grid steps 2/3 of a window: a target midway between two windows sits a third of a
        window off both centres, where the cosine window (KCF, Henriques et al. TPAMI 2015 Sec. 6.1)
        has faded it out, and neither response finds it. Steps of about a third of a window keep every
        point within a sixth of a window of some centre. One feature computation on the union of the
        windows (kept inside the image); each window's map is a slice of it. `channels` > 0 (ours): the
        windows are screened on the filter's `channels` principal channel directions and only the
        LATTICE_RESCORED best ones are correlated in full.
        """
        self._train_features = None
        ih, iw = img.shape[:2]
        sx, sy, offsets, wins = self.lattice_geometry(window, step, rings, (iw, ih), half, centre)
        if not wins:
            return [], []
        cols = [i for i, _ in offsets] + [0]
        rows = [j for _, j in offsets] + [0]
        bounds = (min(cols), max(cols), min(rows), max(rows))
        n, respond_projected = len(wins), getattr(self.filter, "respond_projected", None)
        d = channels
        if respond_projected is None or not 0 < d < self.shape[0] or n <= LATTICE_RESCORED:
            # consumed by `respond` below; one buffer per count (the checkerboard halves differ at the border)
            buf = self._scratch(f"lattice features {n}", (n, *self.shape))
            feats = self._union_maps(img, window, sx, sy, offsets, bounds, "lattice", buf)
            return self._detections(self.filter.respond(feats), wins, [scale] * n), wins
        union = self._union_map(img, window, sx, sy, bounds, "lattice")
        # (ours) screen every window on the model's d principal channels, then correlate the best few in full
        basis = self.filter.projection(d)
        projected = np.tensordot(basis.T, union, axes=1)
        energy = np.einsum("chw,chw->hw", union, union)[None]
        zz = self._cut(energy, sx, sy, offsets, bounds, squared_window=True).sum(axis=(1, 2, 3))
        zp = self._scratch(f"lattice projected {n}", (n, d, *self.shape[1:]))
        self._cut(np.ascontiguousarray(projected, dtype=np.float32), sx, sy, offsets, bounds, zp)
        screen = respond_projected(zp, zz.astype(np.float64), d).reshape(n, -1).max(axis=1)
        best = sorted(np.argsort(screen)[::-1][:LATTICE_RESCORED].tolist())
        picked = [offsets[i] for i in best]
        buf = self._scratch("lattice rescored", (len(best), *self.shape))
        feats = self._cut(union, sx, sy, picked, bounds, buf)
        dets = self._detections(self.filter.respond(feats), [wins[i] for i in best], [scale] * len(best))
        return dets, wins
