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
