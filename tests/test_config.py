import pytest

from evstar import FormatError, ParameterError
from evstar.config import Config


def test_defaults_round_trip_json_and_toml(tmp_path):
    cfg = Config().replace(**{"denoise.method": "ndsef", "dt_us": 5000, "motion.compensate": "pf"})
    (tmp_path / "c.toml").write_text(cfg.to_toml())
    (tmp_path / "c.json").write_text(cfg.to_json())
    assert Config.load(tmp_path / "c.toml") == cfg == Config.load(tmp_path / "c.json")
    assert cfg.denoise.method == "ndsef" and cfg.dt_us == 5000


@pytest.mark.parametrize("data,key", [
    ({"dt_us": 0}, "'dt_us'"), ({"denoise": {"method": "median"}}, "'denoise.method'"),
    ({"denoise": {"radii": [5, 3]}}, "'denoise.radii'"),
    ({"denoise": {"thresholds": [1, 2]}}, "'denoise.thresholds'"),
    ({"extract": {"eps": -1}}, "'extract.eps'"), ({"track": {"max_gap": -1}}, "'track.max_gap'"),
    ({"motion": {"compensate": "gyro"}}, "'motion.compensate'"),
    ({"denoise": {"radiuss": 3}}, "'denoise.radiuss'"), ({"devise": "cpu"}, "'devise'"),
    ({"device": "tpu"}, "'device'"),
])
def test_bad_values_name_the_key(data, key):
    with pytest.raises(ValueError, match=key):
        Config.from_dict(data)


def test_bad_file_names_file_and_key(tmp_path):
    p = tmp_path / "c.toml"
    p.write_text("[denoise]\nalpha = 2.0\n")
    with pytest.raises(ParameterError, match=r"c\.toml: config key 'denoise\.alpha'"):
        Config.load(p)
    p.write_text("[denoise\n")
    with pytest.raises(FormatError, match="cannot parse"):
        Config.load(p)


def test_a_relative_pixel_lag_file_is_read_beside_the_config(tmp_path):
    """A config file naming lag.json means the lag.json beside it, from any working folder
    (it was resolved against the working folder: a rerun from elsewhere could not read it)."""
    import evstar

    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "cfg.toml").write_text('[estimate]\npixel_lag_file = "lag.json"\n')
    cfg = evstar.Config.load(tmp_path / "sub" / "cfg.toml")
    assert cfg.estimate.pixel_lag_file == str(tmp_path / "sub" / "lag.json")
    (tmp_path / "abs.toml").write_text(f'[estimate]\npixel_lag_file = "{tmp_path / "x.json"}"\n')
    assert evstar.Config.load(tmp_path / "abs.toml").estimate.pixel_lag_file == str(tmp_path / "x.json")
