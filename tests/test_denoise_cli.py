"""`evstar denoise`, run in-process as a user would."""
import numpy as np

from evstar import denoise, io
from evstar.cli import main


def test_classical_on_real_file_writes_kept_events_and_mask(real_dir, tmp_path, capsys):
    src = real_dir / "emlb_demo-01.aedat4"
    out, mask = tmp_path / "kept.h5", tmp_path / "mask.npy"
    assert main(["denoise", str(src), str(out), "--method", "classical", "--dt-ms", "2",
                 "--mask-out", str(mask)]) == 0
    assert "kept" in capsys.readouterr().out
    events = io.read(src).events
    keep = np.load(mask)
    assert keep.dtype == bool and keep.shape == (len(events),)
    np.testing.assert_array_equal(keep, denoise.ClassicalFilter(2_000).apply(events))
    assert io.read(out).events == events[keep]


def test_mr_ndsef_thresholds_and_csv_with_sensor_size(tmp_path, capsys):
    rng = np.random.default_rng(0)
    n = 4000
    src = tmp_path / "in.csv"
    import evstar
    ev = evstar.Events(np.sort(rng.integers(0, 40_000, n)), rng.integers(0, 30, n), rng.integers(0, 20, n),
                       rng.integers(0, 2, n), 30, 20)
    io.write(src, ev)
    out, mask = tmp_path / "out.npz", tmp_path / "m.npy"
    assert main(["denoise", str(src), str(out), "--method", "mr-ndsef", "--radii", "2", "4",
                 "--thresholds", "3", "6", "--sensor-size", "30", "20", "--mask-out", str(mask)]) == 0
    assert "thresholds [3, 6]" in capsys.readouterr().out
    expect = denoise.MRNDSEF(10_000, (2, 4), (3, 6)).apply(ev)
    np.testing.assert_array_equal(np.load(mask), expect)
    assert io.read(out).events == ev[expect]
    assert main(["denoise", str(src), str(out), "--method", "ndsef", "--auto", "--alpha", "0.01",
                 "--sensor-size", "30", "20"]) == 4           # OUT exists: refused, kept
    assert io.read(out).events == ev[expect]
    assert main(["denoise", str(src), str(out), "--method", "ndsef", "--auto", "--alpha", "0.01",
                 "--sensor-size", "30", "20", "--force"]) == 0


def test_option_misuse_is_a_user_error(real_dir, tmp_path, capsys):
    src = str(real_dir / "emlb_demo-01.aedat4")
    out = str(tmp_path / "o.h5")
    assert main(["denoise", src, out, "--method", "mr-ndsef", "--threshold", "5"]) == 2
    assert "--threshold is for --method ndsef" in capsys.readouterr().err
    assert main(["denoise", src, out, "--method", "mr-ndsef", "--radii", "5", "3"]) == 2
    assert "radii must be strictly increasing" in capsys.readouterr().err
    assert main(["denoise", src, out, "--method", "ndsef", "--device", "tpu"]) == 2
    assert "device" in capsys.readouterr().err
