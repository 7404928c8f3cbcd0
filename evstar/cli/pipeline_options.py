"""Options shared by `evstar extract` and `evstar run`, mapped onto evstar.Config keys."""
from __future__ import annotations

from ..config import Config
from ..errors import EvstarError

# option dest -> config key (options left unset keep the configuration file's value)
KEYS = {"device": "device", "seed": "seed", "chunk_frames": "chunk_frames",
        "method": "denoise.method", "radius": "denoise.radius", "radii": "denoise.radii",
        "threshold": "denoise.threshold", "thresholds": "denoise.thresholds",
        "alpha": "denoise.alpha", "k": "denoise.k", "eps": "extract.eps",
        "min_samples": "extract.min_samples", "time_ref": "extract.time_ref",
        "weighting": "extract.weighting", "compensate": "motion.compensate",
        "particles": "motion.n_particles"}


def add_pipeline_options(p):
    p.add_argument("--config", help="configuration file (.toml or .json); options override it")
    p.add_argument("--device", help="cpu or cuda (default cpu)")
    p.add_argument("--seed", type=int, help="random seed (particle filter)")
    p.add_argument("--dt-ms", type=float, help="pseudo-frame length, ms (default 10)")
    p.add_argument("--method", choices=("none", "classical", "ndsef", "mr-ndsef"),
                   help="denoising filter (default mr-ndsef)")
    p.add_argument("--radius", type=int, help="NDSEF radius, px")
    p.add_argument("--radii", type=int, nargs="+", metavar="R", help="MR-NDSEF radii, px")
    p.add_argument("--threshold", type=int, help="NDSEF density threshold (default auto)")
    p.add_argument("--thresholds", type=int, nargs="+", metavar="N", help="MR-NDSEF thresholds (default auto)")
    p.add_argument("--auto", action="store_true", help="auto thresholds (the default)")
    p.add_argument("--alpha", type=float, help="false-alarm probability of auto thresholds (1e-3)")
    p.add_argument("--k", type=int, help="classical filter: supporting neighbours (1)")
    p.add_argument("--eps", type=float, help="DBSCAN radius, px (2.5)")
    p.add_argument("--min-samples", type=int, help="DBSCAN min_samples (5)")
    p.add_argument("--time-ref", choices=("mean", "mid"), help="centroid time: members' mean or frame mid-time")
    p.add_argument("--weighting", choices=("events", "pixels", "polarity"), help="centroid weighting")
    p.add_argument("--compensate", choices=("none", "imu", "pf"), help="motion compensation (needs --imu, --camera)")
    p.add_argument("--particles", type=int, help="particle-filter size (4096)")
    p.add_argument("--chunk-frames", type=int, help="frames per streaming chunk (200)")


def config_from_args(args):
    try:
        cfg = Config.load(args.config) if args.config else Config()
        changes = {key: getattr(args, dest) for dest, key in KEYS.items()
                   if getattr(args, dest, None) is not None}
        if args.dt_ms is not None:
            changes["dt_us"] = int(round(args.dt_ms * 1000))
        if args.auto:
            changes["denoise.thresholds"], changes["denoise.threshold"] = "auto", None
        return cfg.replace(**changes)
    except ValueError as exc:
        raise EvstarError(f"invalid option: {exc}") from None
