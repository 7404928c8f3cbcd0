"""Star targets and camera presets: photometry, placement, Hipparcos fields."""
import math

import numpy as np
import pytest

from evstar import sim


def test_pogson_five_magnitudes_are_a_factor_100():
    assert sim.star_flux(3.0) == pytest.approx(sim.FLUX_MAG3)
    assert sim.star_flux(1.0) / sim.star_flux(6.0) == pytest.approx(100.0)


def test_camera_presets_have_true_resolutions_and_pitches():
    expect = {"dvxplorer-lite": (320, 240, 18.5), "dvxplorer": (640, 480, 9.0),
              "davis346": (346, 260, 18.5), "evk4": (1280, 720, 4.86)}
    for name, (w, h, pitch) in expect.items():
        cam = sim.camera_preset(name, focal_length_mm=16.0)
        assert (cam.width, cam.height) == (w, h)
        assert cam.fx == pytest.approx(16e3 / pitch) and cam.cx == (w - 1) / 2
    assert sim.camera_preset("IMX636") == sim.camera_preset("evk4")
    with pytest.raises(ValueError, match="unknown camera preset"):
        sim.camera_preset("davis240")


def test_paper_camera_field_of_view():
    cam = sim.camera_preset("dvxplorer-lite")
    hfov = 2 * math.degrees(math.atan(cam.width / 2 / cam.fx))
    vfov = 2 * math.degrees(math.atan(cam.height / 2 / cam.fy))
    assert hfov == pytest.approx(27.7, abs=0.05) and vfov == pytest.approx(21.0, abs=0.05)


def test_star_at_pixel_images_where_asked():
    cam = sim.camera_preset("davis346")
    R = sim.attitude_from_radec(10.0, 20.0, roll_deg=15.0)
    star = sim.star_at_pixel(cam, R, (40.25, 200.5), magnitude=4.0)
    assert cam.project((R @ star.directions.T).T)[0] == pytest.approx([40.25, 200.5], abs=1e-9)
    assert star.magnitudes[0] == 4.0 and star.hip[0] == -1


def test_hipparcos_field_around_orion():
    cam = sim.camera_preset("dvxplorer-lite")
    R = sim.attitude_from_radec(83.8, -5.4)
    field = sim.hipparcos_field(cam, R, mag_limit=5.0)
    assert 10 < len(field) < 200
    assert np.all(np.diff(field.magnitudes) >= 0)              # brightest first
    uv = cam.project(field.directions @ R.T)
    assert np.all((uv[:, 0] >= -0.5) & (uv[:, 0] < cam.width - 0.5))
    assert np.all((uv[:, 1] >= -0.5) & (uv[:, 1] < cam.height - 0.5))
    # Alnilam (HIP 26311, ε Ori, Hp ≈ 1.6) sits in Orion's belt, near this boresight
    i = int(np.flatnonzero(field.hip == 26311)[0])
    assert field.magnitudes[i] == pytest.approx(1.6, abs=0.2)
    assert field.ra_deg[i] == pytest.approx(84.05, abs=0.05) and field.dec_deg[i] == pytest.approx(-1.20, abs=0.05)
    assert len(sim.hipparcos_field(cam, R, mag_limit=5.0, max_stars=3)) == 3


def test_star_field_simulation_labels_each_star():
    cam = sim.camera_preset("dvxplorer-lite")
    R = sim.attitude_from_radec(83.8, -5.4)
    field = sim.hipparcos_field(cam, R, mag_limit=4.0, max_stars=6)
    scn = sim.Scenario(cam, field, sim.ConstantRate(5.0, R0=R), 0.2, sensor=sim.SensorSpec.ideal())
    run = sim.simulate(scn, seed=0)
    labels = run.truth.labels
    assert set(np.unique(labels)) == set(range(6))
    # brighter stars (lower id) give more events
    counts = np.bincount(labels, minlength=6)
    assert counts[0] > counts[5]


def test_star_field_validation():
    with pytest.raises(ValueError, match="differ in length"):
        sim.StarField([[0, 0, 1]], [3.0, 4.0], [-1])
    with pytest.raises(ValueError, match="finite"):
        sim.StarField([[0, 0, 1]], [np.nan], [-1])


def test_field_along_a_slew_includes_the_stars_that_come_into_view():
    cam = sim.camera_preset("dvxplorer-lite")
    motion = sim.ConstantRate(20.0, R0=sim.attitude_from_radec(83.8, -5.4))
    start = sim.hipparcos_field(cam, motion.rotation([0.0])[0], mag_limit=5.0)
    end = sim.hipparcos_field(cam, motion.rotation([3.0])[0], mag_limit=5.0)
    along = sim.hipparcos_field_along(cam, motion, 3.0, mag_limit=5.0)
    assert len(set(start.hip) & set(end.hip)) == 0             # 60° apart: different stars
    assert set(start.hip) | set(end.hip) <= set(along.hip)
    assert len(set(along.hip)) == len(along) and np.all(np.diff(along.magnitudes) >= 0)
    top = sim.hipparcos_field_along(cam, motion, 3.0, mag_limit=5.0, max_stars=5)
    assert np.array_equal(top.hip, along.hip[:5])


def test_field_scenario_pans_or_swings_and_names_a_bad_motion():
    from evstar import sim
    from evstar.errors import ParameterError

    cam = sim.camera_preset("davis346", 16.0)
    pan = sim.field_scenario(cam, 83.8, -5.4, 8.0, 0.5)
    sine = sim.field_scenario(cam, 83.8, -5.4, 8.0, 1.0, motion="sine", mag_limit=5.0)
    assert 0 < len(sine.stars.magnitudes) < len(pan.stars.magnitudes)
    assert sine.stars.magnitudes.max() <= 5.0 < pan.stars.magnitudes.max() <= 6.5
    assert isinstance(pan.trajectory, sim.ConstantRate) and isinstance(sine.trajectory, sim.Sinusoid)
    with pytest.raises(ParameterError, match="'spin'"):
        sim.field_scenario(cam, 83.8, -5.4, 8.0, 0.5, motion="spin")


def test_a_field_rolling_about_the_boresight_turns_its_stars_about_the_centre():
    from evstar import sim
    from evstar.errors import ParameterError

    cam = sim.camera_preset("davis346", 16.0)
    roll = sim.field_scenario(cam, 83.8, -5.4, 10.0, 0.5, axis=(0.0, 0.0, 1.0))
    R0, R1 = roll.trajectory.rotation(np.array([0.0, 0.4]))      # 0.4 s: 4° about the centre
    p0, p1 = (cam.project(roll.stars.directions @ R.T) for R in (R0, R1))
    c = np.array([cam.cx, cam.cy])
    seen = (np.abs(p0 - c) < c).all(axis=1)
    r0, r1 = np.hypot(*(p0[seen] - c).T), np.hypot(*(p1[seen] - c).T)
    turn = np.degrees(np.arctan2(*(p1[seen] - c).T[::-1]) - np.arctan2(*(p0[seen] - c).T[::-1]))
    far = r0 > 40
    assert seen.sum() >= 10 and np.allclose(r0, r1, atol=0.05)
    assert np.allclose(np.abs((turn[far] + 180) % 360 - 180), 4.0, atol=0.05)
    with pytest.raises(ParameterError, match="axis"):
        sim.field_scenario(cam, 83.8, -5.4, 8.0, 0.5, axis=(0.0, 0.0, 0.0))
