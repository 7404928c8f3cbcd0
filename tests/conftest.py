import pathlib

import numpy as np
import pytest

REAL = pathlib.Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real"


@pytest.fixture
def real_dir():
    if not REAL.is_dir():
        pytest.fail(f"real test data missing: {REAL} (shared/ must sit beside the repository)")
    return REAL


def random_events(n=1000, width=64, height=48, seed=0, duration_us=100_000):
    import evstar

    rng = np.random.default_rng(seed)
    t = np.sort(rng.integers(0, duration_us, n))
    return evstar.Events(t, rng.integers(0, width, n), rng.integers(0, height, n),
                         rng.integers(0, 2, n), width, height)


def cli_fails(capsys, argv, code, *texts):
    """Run `evstar argv` in-process: its exit code is `code`, stderr one line holding every
    text, no traceback; returns that line."""
    from evstar.cli import main

    assert main([str(a) for a in argv]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for text in texts:
        assert text in err, err
    return err


def write_orion_pan(d, camera):
    """cents.csv and camera.json in folder d: a 0.3 s, 15 °/s pan over Orion's stars through
    `camera`, centroids from the simulator's truth (σ 0.05 px, magnitude <= 5); returns the
    run's (truth, imu)."""
    from evstar import io, sim
    from evstar.attitude.oracle import synthetic_run

    traj = sim.ConstantRate(15.0, R0=sim.attitude_from_radec(83.8, -5.4, 10.0))
    c, truth, imu = synthetic_run(traj, camera, 0.3, sigma_px=0.05, mag_limit=5.0)
    io.write_centroids(d / "cents.csv", c)
    io.write_camera(d / "camera.json", camera)
    return truth, imu
