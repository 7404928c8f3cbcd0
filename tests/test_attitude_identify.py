"""Lost-in-space identification (evstar.attitude): catalogue fields projected at known
attitudes on both camera geometries, with missing and spurious stars; the frame
convention; failures as statuses; proper motion; the database cache; the simulator's
camera -> ICRS truth quaternion."""
import math

import numpy as np
import pytest

from evstar import DataError, ParameterError, sim
from evstar.attitude import Solver, catalog, identify, pixel_rays, quat_to_matrix
from evstar.attitude import solver as solver_module
from evstar.cli import main

# davis346 behind 16 mm (346 x 260, f ≈ 865 px) and evk4 behind 12 mm (1280 x 720, f ≈ 2469 px)
CAMERAS = {"davis346": sim.camera_preset("davis346", 16.0), "evk4": sim.camera_preset("evk4", 12.0)}


@pytest.fixture(scope="module")
def cache_folder(tmp_path_factory):
    return tmp_path_factory.mktemp("attitude-cache")


@pytest.fixture(scope="module")
def solvers(cache_folder):
    """One database per camera, built once (1-2 s each) in a private cache folder; the
    default settings (the search bounded by patterns tested, not by the clock)."""
    return {name: Solver.for_camera(cam, cache_dir=cache_folder) for name, cam in CAMERAS.items()}


def angle_deg(R_a, R_b):
    return math.degrees(math.acos(np.clip((np.trace(R_a.T @ R_b) - 1) / 2, -1, 1)))


def field(camera, ra, dec, roll, mag_limit=6.0):
    """Catalogue stars seen at (ra, dec, roll): R_cw, pixel positions, HIP numbers."""
    R_cw = sim.attitude_from_radec(ra, dec, roll)
    stars = sim.hipparcos_field(camera, R_cw, mag_limit=mag_limit)
    return R_cw, camera.project(stars.directions @ R_cw.T), stars.hip


@pytest.mark.parametrize("name", list(CAMERAS))
def test_identifies_random_fields_with_missing_and_spurious_stars(solvers, name):
    cam, rng = CAMERAS[name], np.random.default_rng(7)
    for _ in range(6):
        ra, dec, roll = sim.random_pointing(rng)
        R_cw, xy, _ = field(cam, ra, dec, roll)
        keep = rng.random(len(xy)) > 0.25                        # a quarter of the stars missed
        clean = xy[keep]
        noisy = clean + rng.normal(0, 0.3, clean.shape)          # centroid noise
        fake = rng.uniform([0, 0], [cam.width, cam.height], (8, 2))   # hot pixels, noise clusters
        fix = identify(np.concatenate([noisy, fake]), cam, 1234, solver=solvers[name])
        assert fix.ok and fix.status == "ok" and fix.t_us == 1234, (ra, dec, fix)
        assert angle_deg(fix.R_icrs_cam, R_cw.T) < 0.05
        real = fix.centroid_index < len(clean)
        assert real.mean() >= 0.95 and fix.n_matches >= 0.8 * len(clean)
        # each named star is where the centroid truly is (stars closer than a pixel, as in
        # the Trapezium, may swap names)
        named = cam.project(catalog.directions(fix.hip[real]) @ R_cw.T)
        assert np.abs(named - clean[fix.centroid_index[real]]).max() < 1.0
        assert fix.residual_arcsec < 2 * 0.3 * 206265 / cam.fx
        assert fix.false_match_probability < 1e-5


@pytest.mark.parametrize("name", list(CAMERAS))
def test_catalogue_stars_projected_with_the_fix_land_on_their_centroids(solvers, name):
    cam = CAMERAS[name]
    _, xy, _ = field(cam, 250.0, 36.5, 40.0)          # Hercules, rolled
    fix = identify(xy, cam, solver=solvers[name])
    R_icrs_cam = quat_to_matrix(fix.q_icrs_cam)
    assert fix.ok and np.isclose(np.linalg.norm(fix.q_icrs_cam), 1) and fix.q_icrs_cam[0] >= 0
    back = cam.project(fix.dir_icrs @ R_icrs_cam)       # ICRS -> camera is R_icrs_camᵀ
    assert np.abs(back - xy[fix.centroid_index]).max() < 0.1
    assert np.allclose(pixel_rays(xy[fix.centroid_index], cam) @ R_icrs_cam.T, fix.dir_icrs, atol=1e-6)


def test_distorted_camera(solvers):
    cam = sim.camera_preset("davis346", 16.0)
    bent = type(cam)(cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy, k1=-0.2, k2=0.05)
    R_cw = sim.attitude_from_radec(120.0, -40.0, 10.0)
    stars = sim.hipparcos_field(bent, R_cw, mag_limit=6.0)
    xy = bent.project(stars.directions @ R_cw.T)
    rays = pixel_rays(xy, bent)
    assert np.allclose(rays, stars.directions @ R_cw.T, atol=1e-9)
    fix = identify(xy, bent, solver=solvers["davis346"])
    assert fix.ok and angle_deg(fix.R_icrs_cam, R_cw.T) < 0.01


def test_failures_are_statuses_not_exceptions(solvers, cache_folder):
    cam, solver = CAMERAS["davis346"], solvers["davis346"]
    _, xy, _ = field(cam, 83.8, -5.4, 0.0)
    for few in (xy[:3], np.zeros((0, 2)), np.full((10, 2), np.nan)):
        fix = identify(few, cam, 5, solver=solver)
        assert (fix.ok, fix.status, fix.t_us) == (False, "too_few_stars", 5)
        assert np.all(np.isnan(fix.q_icrs_cam)) and fix.n_matches == 0
    # an exhaustive search of 40 random points takes seconds: the work bound ends it
    quick = Solver.for_camera(cam, cache_dir=cache_folder, max_patterns=200)   # the same file
    assert quick.path == solver.path
    rng = np.random.default_rng(3)
    for _ in range(3):
        garbage = rng.uniform([0, 0], [cam.width, cam.height], (40, 2))
        fix = identify(garbage, cam, solver=quick)
        assert not fix.ok and fix.status in ("no_solution", "rejected")
        assert np.all(np.isnan(fix.q_icrs_cam))
    # stars displaced far beyond the verification limit: the solution is rejected
    squeezed = (xy - [cam.cx, cam.cy]) * 1.06 + [cam.cx, cam.cy]
    fix = identify(squeezed, cam, solver=solver)
    assert fix.status in ("rejected", "no_solution") and not fix.ok
    with pytest.raises(DataError, match="xy must be an"):
        identify(np.zeros(5), cam, solver=solver)
    with pytest.raises(ParameterError, match="epoch"):
        identify(xy, cam, solver=solver, epoch="2026")


def test_proper_motion_moves_barnards_star():
    then, now = catalog.directions([87937], None)[0], catalog.directions([87937], 2026.9)[0]
    moved = math.degrees(math.acos(then @ now)) * 3600
    # pmRA* -798.58, pmDE 10328.12 mas/yr over 35.65 years
    assert moved == pytest.approx(math.hypot(798.58, 10328.12) * 35.65e-3, rel=1e-4)
    north = np.array([0, 0, 1.0])
    assert (now - then) @ north > 0                       # it runs north
    assert catalog.check_epoch(None) == 1991.25
    # a slow star hardly moves
    vega_then, vega_now = catalog.directions([91262], None)[0], catalog.directions([91262], 2026.9)[0]
    assert math.degrees(math.acos(min(1, vega_then @ vega_now))) * 3600 < 15


def test_fix_directions_are_at_the_epoch(solvers):
    cam = CAMERAS["evk4"]
    _, xy, _ = field(cam, 100.0, 20.0, 0.0)
    fix = identify(xy, cam, solver=solvers["evk4"], epoch=2026.9)
    assert fix.ok and np.array_equal(fix.dir_icrs, catalog.directions(fix.hip, 2026.9))


def test_database_is_cached_on_disk_and_reused(tmp_path):
    cam = CAMERAS["davis346"]
    first = Solver.for_camera(cam, cache_dir=tmp_path, mag_limit=4.0)
    assert first.built and Solver.for_camera(cam, cache_dir=tmp_path, mag_limit=4.0) is first
    solver_module.clear_cache()
    again = Solver.for_camera(cam, cache_dir=tmp_path, mag_limit=4.0)
    assert not again.built and again.path == first.path and again is not first
    assert [p.name for p in tmp_path.iterdir()] == [first.path.split("/")[-1]]
    assert again.database.num_patterns == first.database.num_patterns
    other = Solver.for_camera(cam, cache_dir=tmp_path, mag_limit=4.5)
    assert other.built and other.path != first.path
    with pytest.raises(ParameterError, match="mag_limit"):
        Solver.for_camera(cam, cache_dir=tmp_path, mag_limit="bright")
    with pytest.raises(ParameterError, match="unknown identify setting"):
        Solver.for_camera(cam, cache_dir=tmp_path, magnitude=4.0)


def test_simulated_truth_quaternion_is_the_identified_attitude(solvers, tmp_path):
    """evstar simulate --pointing random: truth.npz's quat_icrs_cam is the rotation identify
    returns from the true star positions."""
    out = tmp_path / "sky"
    args = ["simulate", str(out), "--preset", "davis346", "--focal-length", "16", "--stars", "60",
            "--pointing", "random", "--seed", "5", "--rate", "5", "--duration", "0.02",
            "--noise-hz", "0", "--hot-pixels", "0"]
    assert main(args) == 0
    truth = sim.load_truth(out / "truth.npz")
    p = truth.meta["pointing_deg"]
    assert (p["ra"], p["dec"], p["roll"]) == sim.random_pointing(5)
    table = truth.quat_icrs_cam
    assert table.shape == (len(truth.t_us), 5) and np.array_equal(table[:, 0], truth.t_us)
    i = 10
    xy = truth.star_xy[i]
    inside = np.all(np.isfinite(xy), axis=1) & (xy[:, 0] > 0) & (xy[:, 0] < 345) & (xy[:, 1] > 0) & (xy[:, 1] < 259)
    fix = identify(xy[inside], truth.camera, int(truth.t_us[i]), solver=solvers["davis346"])
    assert fix.ok
    q = table[i, 1:]
    assert min(np.abs(q - fix.q_icrs_cam).max(), np.abs(q + fix.q_icrs_cam).max()) < 1e-6
    assert np.allclose(truth.q_icrs_cam_at([truth.t_us[i]])[0], q, atol=1e-9)
    assert np.allclose(quat_to_matrix(q), truth.rotation_at([truth.t_us[i]])[0].T, atol=1e-9)
    start = sim.attitude_from_radec(p["ra"], p["dec"], p["roll"])
    assert angle_deg(quat_to_matrix(table[0, 1:]), start.T) < 1e-9


def test_old_truth_files_without_the_icrs_quaternion_still_load(tmp_path):
    run = sim.simulate(sim.paper_preset(10.0, duration_s=0.01), seed=0)
    sim.save_truth(tmp_path / "t.npz", run.truth)
    with np.load(tmp_path / "t.npz") as z:
        old = {k: z[k] for k in z.files if k != "quat_icrs_cam"}
    old["format_version"] = np.int64(1)
    np.savez(tmp_path / "old.npz", **old)
    back = sim.load_truth(tmp_path / "old.npz")
    assert np.allclose(back.quat_icrs_cam, run.truth.quat_icrs_cam)


def test_pointing_option_errors(tmp_path):
    for bad in (["10"], ["10", "95"], ["north", "pole"]):
        assert main(["simulate", str(tmp_path / "x"), "--stars", "5", "--pointing", *bad]) == 2


def test_the_search_is_bounded_by_patterns_tested_not_by_the_clock(solvers, cache_folder):
    """max_patterns decides whether a field solves (the same on every machine): a true field
    behind six spurious centroids that come first (brightest) needs the patterns of those
    six to be tried and refused before the stars' own; with a generous clock, too few
    patterns fail it and the default solves it."""
    cam = CAMERAS["davis346"]
    R_cw, xy, _ = field(cam, 83.8, -5.4, 0.0)
    junk = np.random.default_rng(5).uniform([0, 0], [cam.width, cam.height], (6, 2))
    xy = np.concatenate([junk, xy])
    few = Solver.for_camera(cam, cache_dir=cache_folder, max_patterns=5, timeout_ms=600_000)
    assert few.settings["max_patterns"] == 5 and few.path == solvers["davis346"].path
    assert identify(xy, cam, solver=few).status == "no_solution"
    fix = identify(xy, cam, solver=solvers["davis346"])
    assert fix.ok and angle_deg(fix.R_icrs_cam, R_cw.T) < 0.05
    assert solvers["davis346"].settings["max_patterns"] == 1000
    with pytest.raises(ParameterError, match="max_patterns"):
        Solver.for_camera(cam, cache_dir=cache_folder, max_patterns=0)
