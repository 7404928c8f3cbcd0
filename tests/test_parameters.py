"""One declaration per parameter: Config, the stage classes and the command line accept and
reject the same values, with ParameterError (a ValueError too) naming the parameter."""
import pytest

import evstar
from evstar import denoise, parameters as P
from evstar.cli import main
from evstar.config import Config
from evstar.extract import Extractor
from evstar.motion import ParticleFilter
from evstar.tracking import Tracker


def bad_values(param):
    """Values the declaration must reject."""
    if param.kind is bool:
        return ["yes", 1]
    out = [True, "x"] if param.kind is not str else [3, "cuda:x" if param.choices or
                                                     param.name == "device" else ""]
    if param.choices:
        out.append("no-such-choice")
    if param.low is not None:
        out.append(param.low - 1 if param.kind is int else param.low - 0.5)
    if param.high is not None:
        out.append(param.high + 1)
    if param.kind is int:
        out.append(2.5)
    return out


ALL = [(section, name, bad) for section, params in {**P.SECTIONS, "": P.GLOBAL}.items()
       for name, param in params.items() for bad in bad_values(param)]


@pytest.mark.parametrize("section,name,bad", ALL)
def test_config_rejects_what_the_declaration_rejects(section, name, bad):
    key = f"{section}.{name}" if section else name
    with pytest.raises(evstar.ParameterError, match=key.replace(".", r"\.")):
        Config().replace(**{key: [bad] if P.SECTIONS.get(section, P.GLOBAL)[name].many else bad})


# (class, keyword, declaration) for the classes that take the declared parameters
CLASSES = [(denoise.NDSEF, "radius", P.DENOISE), (denoise.NDSEF, "threshold", P.DENOISE),
           (denoise.NDSEF, "alpha", P.DENOISE), (denoise.NDSEF, "rate_hz", P.DENOISE),
           (denoise.NDSEF, "dt_us", P.GLOBAL), (denoise.MRNDSEF, "dt_us", P.GLOBAL),
           (denoise.MRNDSEF, "radii", P.DENOISE), (denoise.ClassicalFilter, "k", P.DENOISE),
           (denoise.ClassicalFilter, "device", P.GLOBAL), (Extractor, "eps", P.EXTRACT),
           (Extractor, "min_samples", P.EXTRACT), (Extractor, "weighting", P.EXTRACT),
           (Extractor, "split_valley", P.EXTRACT), (Extractor, "dt_us", P.GLOBAL),
           (Extractor, "clustering", P.EXTRACT), (Extractor, "device", P.GLOBAL),
           (Tracker, "gate_px", P.TRACK), (Tracker, "max_gap", P.TRACK),
           (Tracker, "min_length", P.TRACK), (ParticleFilter, "n_particles", P.MOTION),
           (ParticleFilter, "seed", P.GLOBAL), (ParticleFilter, "pixel_sigma", P.PARTICLE_FILTER),
           (ParticleFilter, "resample_threshold", P.PARTICLE_FILTER),
           (ParticleFilter, "star_refine", P.PARTICLE_FILTER)]


@pytest.mark.parametrize("cls,name,params", CLASSES)
def test_classes_reject_what_config_rejects(cls, name, params):
    param = params[name]
    for bad in bad_values(param):
        value = [3, bad] if param.many else bad
        with pytest.raises(evstar.ParameterError, match=name):
            cls(**{name: value})
        with pytest.raises(ValueError):  # the builtin a caller may catch instead
            cls(**{name: value})


def test_the_cases_the_layers_used_to_disagree_on():
    with pytest.raises(evstar.ParameterError, match="dt_us"):
        denoise.MRNDSEF(dt_us=True)                       # was accepted as 1
    assert Config(dt_us=10_000.0).dt_us == 10_000 == Extractor(dt_us=10_000.0).dt_us
    for layer in (lambda: Config().replace(**{"denoise.radii": [3, 5, 100]}),
                  lambda: denoise.MRNDSEF(radii=(3, 5, 100))):
        with pytest.raises(evstar.ParameterError, match="64"):
            layer()
    assert denoise.NDSEF(threshold="auto").threshold == Config().denoise.threshold == "auto"


@pytest.mark.parametrize("argv,message", [
    (["--radius", "100000"], "argument --radius: radius must be a number in [0.5, 64]"),
    (["--radii", "3", "5", "100"], "argument --radii: radii must be a number in [0.5, 64]"),
    (["--radii", "5", "3"], "--radii must be strictly increasing"),
    (["--threshold", "0"], "argument --threshold: threshold must be 'auto' or an integer >= 1"),
    (["--dt-ms", "0"], "argument --dt-ms: must be a number in [0.001, 3.6e+06] ms, got 0"),
    (["--particles", "1000000000"], "argument --particles: n_particles must be an integer"),
    (["--compensate", "gyro"], "argument --compensate: invalid choice"),
    (["--thresholds", "3", "4"], "one integer per radius (5)"),
])
def test_cli_rejects_bad_options_in_one_line_before_any_work(tmp_path, capsys, argv, message):
    out = tmp_path / "c.csv"
    assert main(["extract", str(tmp_path / "missing.h5"), "-o", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not out.exists()


def test_every_declaration_documents_itself():
    for params in (*P.SECTIONS.values(), P.GLOBAL, P.KERNEL, P.PARTICLE_FILTER):
        for param in params.values():
            assert param.doc and param.check(param.default) == param.default, param.name
    assert "radius" in Config().denoise.__doc__ and "[0.5, 64]" in Config().denoise.__doc__


def test_docs_list_every_parameter_as_declared():
    from pathlib import Path

    doc = Path(__file__).parents[1] / "docs" / "parameters.md"
    assert doc.read_text() == P.markdown(), "regenerate: python -m evstar.parameters > docs/parameters.md"
