"""The outside tester's list (hardening issue), case by case through the command line: each
bad input ends in one line on stderr with its exit code, and no input file is modified."""
import hashlib

import pytest

from evstar import io, sim
from evstar.cli import main


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cases")
    run = sim.simulate(sim.paper_preset(12.0, duration_s=0.1), seed=2)
    other = sim.simulate(sim.paper_preset(12.0, duration_s=0.05), seed=3)
    io.write(d / "a.h5", run.events, imu=run.imu, camera=run.camera)
    io.write(d / "c.csv", run.events)
    sim.save_truth(d / "other_truth.npz", other.truth)
    (d / "big_t.csv").write_text("t,x,y,p\n0,1,1,1\n99999999999999999999999,2,2,0\n")
    (d / "min_t.csv").write_text(f"t,x,y,p\n{-2**63},1,1,1\n")
    (d / "frac_t.csv").write_text("t,x,y,p\n0.5,1,1,1\n10.25,2,2,0\n")
    (d / "two_x.csv").write_text("t,x,x,y,p\n0,1,1,1,1\n")
    (d / "file.json").write_text("{}")
    (d / "adir.h5").mkdir()
    return d


def digest(folder):
    return {f.name: hashlib.sha256(f.read_bytes()).hexdigest()
            for f in sorted(folder.iterdir()) if f.is_file()}


CASES = [  # argv (with {d}: the case folder, {r}: the real recordings), exit code, message
    ("denoise {d}/a.h5 {d}/a.h5 --method mr-ndsef", 4, "never overwrites its inputs"),
    ("extract {d}/c.csv -o {d}/c.csv", 4, "never overwrites its inputs"),
    ("run {d}/a.h5 -o {d}/a.h5", 4, "a.h5"),
    ("info {d}/big_t.csv", 3, "99999999999999999999999"),
    ("info {d}/min_t.csv", 3, "outside the valid time range"),
    ("denoise {d}/a.h5 {d}/o.h5 --method ndsef --threshold 0", 2, "--threshold"),
    ("simulate {d}/sim0 --duration 0", 2, "--duration"),
    ("run {d}/a.h5 -o {d}/out1 --truth {d}/other_truth.npz", 3, "another recording"),
    ("info {d}/two_x.csv", 3, "'x' appears 2 times"),
    ("extract {d}/a.h5 -o {d}/cent.xyz", 2, "-o/--output"),
    ("extract {r}/expelliarmus_evt2_sample.raw -o {d}/c2.csv --compensate imu", 2, "--imu FILE"),
    ("extract {r}/emlb_demo-01.aedat4 -o {d}/c3.csv --compensate imu", 2, "--camera FILE"),
    ("denoise {d}/a.h5 {d}/o.h5 --method ndsef --radius 100000", 2, "--radius"),
    ("denoise {d}/a.h5 {d}/o.h5 --method mr-ndsef --radii 3 5 100", 2, "--radii"),
    ("denoise {d}/a.h5 /proc/o.h5 --method ndsef", 4, "/proc/o.h5"),
    ("denoise {d}/a.h5 {d}/file.json/out.h5 --method ndsef", 4, "file.json"),
    ("denoise {d}/a.h5 {d}/adir.h5 --method ndsef", 4, "adir.h5"),
    ("bench --events 0", 2, "--events"),
    ("bench --device cuda --events 1000", 5, "no CUDA GPU"),
    ("run {d}/a.h5 -o {d}/out2 --compensate pf --particles 1000000000", 2, "--particles"),
]


@pytest.mark.parametrize("argv,code,message", CASES, ids=[c[0].split()[0] + str(i) for i, c in enumerate(CASES)])
def test_bad_input_is_one_line_with_its_exit_code_and_inputs_stay(files, real_dir, capsys, argv,
                                                                  code, message):
    d, r = files, real_dir
    before = digest(d)
    assert main(argv.format(d=d, r=r).split()) == code
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err, err
    assert digest(d) == before


def test_fractional_times_are_rounded_with_a_warning(files):
    d = files
    with pytest.warns(UserWarning, match="fractional µs"):
        rec = io.read(d / "frac_t.csv", sensor_size=(4, 4))
    assert rec.events.t.tolist() == [0, 10]   # to the nearest µs, halves to even (numpy)


def test_a_star_too_faint_to_fire_is_a_noise_only_run(files, capsys):
    d = files
    assert main(["simulate", str(d / "faint"), "--magnitude", "30", "--duration", "0.05"]) == 0
    assert "gave no events" in capsys.readouterr().out
