"""Bad settings found by a fuzz of the library API: each raises evstar's own error naming
the setting and its value (never a raw exception, a numpy warning, or a silently wrong
result), and the limits themselves still work."""
import json
import warnings

import numpy as np
import pytest

import evstar
import evstar.denoise as D
from evstar import Config
from evstar.errors import DataError, FormatError, ParameterError, ParameterTypeError
from evstar.frames import check_frame_count, frame_offsets
from evstar.parameters import MAX_FRAMES, MAX_THRESHOLD, MIN_ALPHA
from evstar_kernels.reference import denoise as ref


@pytest.fixture(scope="module")
def ev():
    import evstar.sim

    return evstar.sim.simulate(evstar.sim.paper_preset(20.0, duration_s=0.15), seed=1).events[:3000]


# -- false-alarm probabilities: the Poisson tail is computed reliably down to MIN_ALPHA --------
@pytest.mark.parametrize("alpha", [1e-13, 1e-20, 0.0])
def test_alpha_below_the_reliable_tail_is_refused(alpha):
    with pytest.raises(ParameterError, match=f"alpha must be a number in \\[1e-12, 1\\), got {alpha}"):
        D.NDSEF(alpha=alpha)
    with pytest.raises(ParameterError, match="'denoise.alpha'"):
        Config().replace(**{"denoise.alpha": alpha})
    with pytest.raises(ParameterError, match="'hotpixels.alpha'"):
        Config().replace(**{"hotpixels.alpha": alpha})


def test_smallest_alpha_still_filters(ev):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loose, strict = D.NDSEF(alpha=1e-3), D.NDSEF(alpha=MIN_ALPHA)
        n_loose, n_strict = loose.apply(ev).sum(), strict.apply(ev).sum()
    assert 0 < n_strict < n_loose < len(ev)
    assert loose.threshold_ < strict.threshold_ < 100


def test_reference_thresholds_raise_instead_of_nan():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="alpha=1e-20 .* no threshold below 2\\*\\*31"):
            ref.poisson_thresholds(100.0, 10_000, [3, 5], 1e-20)


def test_auto_threshold_beyond_int32_counts_is_a_parameter_error(ev):
    flt = D.NDSEF(dt_us=3_600_000_000, radius=64, rate_hz=1e6)
    with pytest.raises(ParameterError, match="auto thresholds at 1e\\+06 events/pixel/s in frames "
                                             "of dt_us=3600000000: alpha=0.001"):
        flt.apply(ev)


# -- integer thresholds: the kernels count in int32 ---------------------------------------------
@pytest.mark.parametrize("make", [lambda th: D.NDSEF(threshold=th),
                                  lambda th: D.MRNDSEF(radii=(3, 5), thresholds=(1, th)),
                                  lambda th: Config().replace(**{"denoise.threshold": th}),
                                  lambda th: Config().replace(**{"denoise.thresholds": [th] * 5})])
def test_threshold_beyond_int32_is_refused(make):
    with pytest.raises(ParameterError, match="below 2\\*\\*31.*got 2147483648"):
        make(2**31)


@pytest.mark.parametrize("backend", ["taichi", "reference"])
def test_largest_threshold_keeps_nothing(ev, backend):
    assert not D.NDSEF(threshold=MAX_THRESHOLD, backend=backend).apply(ev).any()


# -- select masks ----------------------------------------------------------------------------------
@pytest.mark.parametrize("select", [lambda n: np.full(n, 0.5), lambda n: np.full(n, np.nan),
                                    lambda n: np.arange(n), lambda n: [None, "x"] * (n // 2)],
                         ids=["float", "nan", "index", "object"])
def test_select_must_be_a_bool_mask(ev, select):
    with pytest.raises(ParameterTypeError, match="select must be a bool array"):
        D.MRNDSEF().apply(ev, select=select(len(ev)))
    with pytest.raises(ParameterTypeError, match="among must be a bool array"):
        D.NDSEF(t0_us=0, rate_hz=10.0).kept_among(ev, select(len(ev)))


def test_select_as_bool_list_is_accepted(ev):
    flt = D.MRNDSEF()
    full = flt.apply(ev)
    half = np.arange(len(ev)) % 2 == 0
    assert np.array_equal(flt.apply(ev, select=list(half)), full & half)


# -- Config ----------------------------------------------------------------------------------------
def test_array_thresholds_are_a_list():
    cfg = Config().replace(**{"denoise.thresholds": np.array([1, 2, 3, 4, 5])})
    assert cfg.denoise.thresholds == [1, 2, 3, 4, 5]
    assert D.MRNDSEF(radii=(3, 5), thresholds=np.array([1, 2])).thresholds == (1, 2)


@pytest.mark.parametrize("radii", [{1: 2}, {3, 5}, np.array(5.0), "3 5"])
def test_radii_must_be_a_list(radii):
    with pytest.raises(ParameterError, match="'denoise.radii' must be a non-empty list"):
        Config().replace(**{"denoise.radii": radii})


def test_unknown_key_in_the_constructor_as_in_replace():
    with pytest.raises(ParameterError) as by_replace:
        Config().replace(foo=1)
    with pytest.raises(ParameterError) as by_constructor:
        Config(foo=1)
    assert str(by_constructor.value) == str(by_replace.value)
    assert str(by_constructor.value).startswith("unknown config key 'foo'")
    with pytest.raises(ParameterError, match="unknown config key 'denoise.foo'"):
        evstar.config.DenoiseConfig(foo=1)


def test_load_needs_a_path(tmp_path):
    with pytest.raises(ParameterTypeError, match="config path must be a str or os.PathLike, got None"):
        Config.load(None)
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000)
    with pytest.raises(FormatError, match="deep.json: cannot parse configuration"):
        Config.load(deep)
    ok = tmp_path / "ok.json"
    ok.write_text(json.dumps({"denoise": {"radii": [2, 4]}}))
    assert Config.load(str(ok)).denoise.radii == [2, 4]


# -- frame origin and from_config -----------------------------------------------------------------
def test_t0_after_the_first_event_is_a_data_error(ev):
    message = f"t0_us=1000000 is after the first event \\({int(ev.t[0])} µs\\)"
    with pytest.raises(DataError, match=message):
        D.NDSEF(t0_us=10**6).apply(ev)
    with pytest.raises(DataError, match=message):
        D.NDSEF(t0_us=10**6, rate_hz=10.0).kept_among(ev, np.ones(len(ev), bool))


@pytest.mark.parametrize("config", [{"method": "ndsef"}, None])
def test_from_config_needs_a_config(config):
    with pytest.raises(ParameterTypeError, match="config must be an evstar.Config"):
        D.from_config(config)


# -- sparse timestamps: per-frame arrays over the whole span ---------------------------------
@pytest.mark.parametrize("backend", ["taichi", "reference"])
def test_span_of_too_many_frames_is_a_data_error(backend):
    sparse = evstar.Events([0, 10**18], [1, 2], [1, 2], [1, 0], 64, 64)
    with pytest.raises(DataError, match="0 to 1000000000000000000 µs spans 100000000000001 frames"):
        D.MRNDSEF(backend=backend).apply(sparse)
    with pytest.raises(DataError, match="spans 100000000000001 frames of dt_us=10000"):
        frame_offsets(sparse.t, 10_000, 0)


def test_far_frame_origin_is_a_data_error(ev):
    with pytest.raises(DataError, match=f"-{2**60} to {int(ev.t[-1])} µs spans"):
        D.NDSEF(t0_us=-2**60).apply(ev)


def test_frame_count_limit_is_inclusive():
    check_frame_count(MAX_FRAMES, 0, 1, 10)
    with pytest.raises(DataError, match="more than 100_000_000"):
        check_frame_count(MAX_FRAMES + 1, 0, 1, 10)
