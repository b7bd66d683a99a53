"""Render step 2, map: generated OpenDRIVE (default) or a CARLA town, cached by input hash.

`prepare_map` returns a cached `.xodr` plus, once Scenic has parsed it, the
matching `.snet` (Scenic's pickled network, keyed by the map's content hash),
so every output directory that copies both skips the parse.
"""
from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

from crashscene.render.errors import RenderError
from crashscene.render.plan import CARLA_TOWNS, RenderPlan

MAP_FORMAT_VERSION = "3"  # bump when generated maps change, to invalidate caches
MAP_MODES = ("generated", "carla")


def default_cache_dir() -> Path:
    """`$CRASHSCENE_CACHE/maps`, else `$XDG_CACHE_HOME/crashscene/maps`, else ~/.cache/crashscene/maps."""
    if os.environ.get("CRASHSCENE_CACHE"):
        return Path(os.environ["CRASHSCENE_CACHE"]) / "maps"
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "crashscene" / "maps"


def carla_town(plan: RenderPlan) -> str:
    """Town of the reference pipeline: straight 2-lane and curve -> Town02, straight 3+ lanes -> Town04,
    intersections and T-intersections -> Town05."""
    if plan.topology == "straight":
        multilane = plan.map.lanes_forward > 1 or plan.number_of_lanes > 2
        return CARLA_TOWNS["straight_multilane" if multilane else "straight"]
    return CARLA_TOWNS[plan.topology]


def prepare_map(plan: RenderPlan, mode: str = "generated", carla_maps: Path | None = None,
                cache_dir: Path | None = None, town_override: dict[str, str] | None = None,
                warm: bool = True) -> tuple[Path, str | None]:
    """Return (cached .xodr path, CARLA town name or None) for the plan.

    `town_override` maps a town name to another (e.g. {"Town05": "Town10HD"} where Town05 is absent).
    `warm` parses the map once with Scenic so its `.snet` sits beside the cached map.
    """
    cache = Path(cache_dir) if cache_dir else default_cache_dir()
    if mode == "generated":
        key = hashlib.sha256((MAP_FORMAT_VERSION + plan.map.model_dump_json()).encode()).hexdigest()[:16]
        path = cache / f"generated_{plan.topology}_{key}.xodr"
        if not path.exists():
            from crashscene.render.opendrive import build_map  # scenariogeneration: ~1 s to import, only on a miss

            tmp = path.with_suffix(f".{os.getpid()}.tmp.xodr")
            try:
                build_map(plan.map, tmp)
            except Exception as exc:  # scenariogeneration raises its own exception types
                raise RenderError(f"could not generate the {plan.topology} map ({plan.map.model_dump_json()}): "
                                  f"{type(exc).__name__}: {exc}") from exc
            os.replace(tmp, path)
        town = None
    elif mode == "carla":
        if carla_maps is None:
            raise RenderError("--map carla needs --carla-maps DIR: a folder holding the CARLA towns' .xodr files "
                              "(Town02.xodr, Town04.xodr, Town05.xodr)")
        town = carla_town(plan)
        town = (town_override or {}).get(town, town)
        source = Path(carla_maps) / f"{town}.xodr"
        if not source.is_file():
            raise RenderError(f"CARLA map {source} not found: the {plan.topology} topology needs {town}.xodr in "
                              f"{carla_maps} (towns used: Town02 straight 2-lane/curve, Town04 straight multi-lane, "
                              f"Town05 intersections)")
        data = source.read_bytes()
        key = hashlib.sha256(data).hexdigest()[:16]
        path = cache / f"{town}_{key}.xodr"
        if not path.exists():
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp.xodr")
            tmp.write_bytes(data)
            os.replace(tmp, path)
    else:
        raise RenderError(f"unknown map mode {mode!r}; allowed: {', '.join(MAP_MODES)}")
    if warm and not path.with_suffix(".snet").exists():
        import warnings

        from scenic.domains.driving.roads import Network

        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # OpenDRIVE features Scenic skips (shoulders, objects...)
                Network.fromFile(path)  # writes <map>.snet beside the cached map
        except Exception as exc:  # Scenic's OpenDRIVE parser raises many types
            source = f"{carla_maps}/{town}.xodr" if town else str(path)
            raise RenderError(f"Scenic cannot read the map {source}: {type(exc).__name__}: {exc}") from exc
    return path, town


def install_map(cached: Path, out_dir: Path, name: str = "map.xodr") -> Path:
    """Copy the cached map (and its .snet, when present) into out_dir."""
    target = out_dir / name
    shutil.copyfile(cached, target)
    snet = cached.with_suffix(".snet")
    if snet.exists():
        shutil.copyfile(snet, target.with_suffix(".snet"))
    return target
