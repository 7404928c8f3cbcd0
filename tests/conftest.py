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
