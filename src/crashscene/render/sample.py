"""Sample scenes from a rendered program, index-deterministically: compiled (numpy) by default, or Scenic.

The default sampler, "compiled", draws from the sampling plan `render` writes
beside the program (`crashscene.render.compiled_sampler`): the same distribution and
requirements without Scenic's interpreter. "scenic" compiles the program and
runs Scenic's own sampler, the reference; it is described below.

Scene i depends only on (program, seed, i): before drawing it, Scenic's sources
of randomness (Python's `random` and numpy's global generator) are reseeded
from `numpy.random.SeedSequence([seed, i])`, and their previous states are
restored afterwards so nothing leaks into the caller. A campaign can therefore
sample [0, 100), [100, 200), ... and get exactly the scenes of one n = 2000 call.

Parameters are `VerifaiRange`s drawn by VerifAI's 'random' sampler
(`param verifaiSamplerType = 'random'` in every program), which reads the
reseeded global generators, so it is index-deterministic (measured). VerifAI's
default Halton sampler is not: it keeps a sequence position inside the compiled
scenario, so scene i would depend on how many scenes were drawn before it.
"""
from __future__ import annotations

import itertools
import json
import math
import multiprocessing
import random
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from crashscene.geometry import wrap_angle
from crashscene.render.errors import SampleError
from crashscene.scene import SampledActor, SampledScene

CARLA_MODEL = "scenic.simulators.carla.model"
NEWTONIAN_MODEL = "scenic.simulators.newtonian.driving_model"
MAX_ITERATIONS = 2000  # rejection-sampling attempts per scene before giving up
SAMPLERS = ("compiled", "scenic")
_SKIP_PARAMS = {"map", "map_options", "render", "use2DMap", "verifaiSamplerType", "verifaiSamplerParams",
                "snapToGroundDefault", "address", "port", "timeout", "timestep", "debugRender"}


def _cache_model_parses() -> None:
    """Memoise Scenic's parse of its own library modules (world models, behaviour libraries).

    Scenic re-parses those .scenic files on every compile with a pure-Python PEG parser: ~1.5 s of the ~2 s a
    compile costs here. Their source never changes within a process, so the parse tree is kept (keyed by file
    and source text) and a deep copy handed out each time; programs themselves are parsed as usual.
    """
    import ast

    import scenic
    from scenic.syntax import translator

    if getattr(translator.parse_string, "crashscene_memo", False):
        return
    library = str(Path(scenic.__file__).resolve().parent)
    original = translator.parse_string
    memo: dict[tuple[str, str], Any] = {}

    def parse_string(source, mode, *args, filename="<unknown>", **kwargs):
        if mode != "exec" or args or kwargs or not str(filename).startswith(library):
            return original(source, mode, *args, filename=filename, **kwargs)
        key = (str(filename), source)
        if key not in memo:
            memo[key] = original(source, mode, filename=filename)
        return _copy_tree(memo[key])

    def _copy_tree(node):
        # Scenic's AST node classes cannot go through copy.deepcopy (their __init__ needs arguments)
        if isinstance(node, list):
            return [_copy_tree(item) for item in node]
        if isinstance(node, ast.AST):
            new = type(node).__new__(type(node))
            for name, value in vars(node).items():
                setattr(new, name, _copy_tree(value))
            return new
        return node

    parse_string.crashscene_memo = True
    parse_string.original = original
    translator.parse_string = parse_string


def compile_program(program: Path, map_path: Path | None = None, model: str | None = None) -> Any:
    """Compile a rendered program in Scenic's 2D mode; `map_path` overrides its `param map`."""
    import scenic

    _cache_model_parses()

    program = Path(program)
    if not program.is_file():
        raise SampleError(f"program {program} not found (render it first: crashscene render FILE.yaml -o DIR)")
    params: dict[str, Any] = {"render": False}
    if map_path is not None:
        params["map"] = str(map_path)
    try:
        return scenic.scenarioFromFile(str(program), params=params, mode2D=True, model=model)
    except Exception as exc:  # Scenic raises many types (syntax, runtime, invalid scenario)
        raise SampleError(f"{program}: Scenic could not compile the program: {type(exc).__name__}: {exc}") from exc


def scene_seed(seed: int, index: int) -> tuple[int, int]:
    """(python random seed, numpy seed) for scene `index` of a batch seeded with `seed`."""
    state = np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFFFFFF, int(index)]).generate_state(2, dtype=np.uint32)
    return int(state[0]), int(state[1])


def sample_scenes(program: Path, n: int, seed: int, first: int = 0, scenario: Any = None,
                  map_path: Path | None = None, model: str | None = None, workers: int = 1,
                  sampler: str = "compiled") -> list[SampledScene]:
    """Scenes for variation indices first .. first+n-1.

    `sampler` "compiled" (default) draws them with numpy from the sampling plan `render` wrote beside the
    program (`crashscene.render.compiled_sampler`); "scenic" runs Scenic's own sampler on the program (the reference:
    the same distribution, other draws). Pass a compiled Scenic `scenario` to skip compiling (implies "scenic").
    With Scenic, `workers` > 1 splits the index range into contiguous blocks sampled in forked processes that
    inherit the compiled program; scenes are index-deterministic, so the result is identical to workers=1.
    """
    program = Path(program)
    if n < 0 or first < 0 or workers < 1:
        raise SampleError(f"n and first must be >= 0 and workers >= 1 (got n={n}, first={first}, workers={workers})")
    if sampler not in SAMPLERS:
        raise SampleError(f"sampler {sampler!r} is not allowed; allowed: {', '.join(SAMPLERS)}")
    if not program.is_file():
        raise SampleError(f"program {program} not found (render it first: crashscene render FILE.yaml -o DIR)")
    digest, map_file = program_identity(program, map_path)
    if sampler == "compiled" and scenario is None:
        from crashscene.render.compiled_sampler import CompiledSampler, PlanError

        if model not in (None, CARLA_MODEL):
            raise SampleError(f"model {model!r}: the compiled sampler reproduces the program's own world model "
                              f"({CARLA_MODEL}); sample with sampler 'scenic' to override it")

        try:
            compiled = CompiledSampler(program, map_path)
        except PlanError as exc:
            raise SampleError(str(exc)) from exc
        except Exception as exc:  # Scenic's map parser and the placement helpers raise many types
            raise SampleError(f"{program}: the compiled sampler could not be built: {type(exc).__name__}: {exc}") \
                from exc
        return compiled.scenes(first, n, seed, digest, map_file, max_attempts=MAX_ITERATIONS)
    if scenario is None:
        scenario = compile_program(program, map_path, model)
    workers = min(workers, max(1, n // MIN_BLOCK))
    if workers == 1:
        return _generate(scenario, program, first, n, seed, digest, map_file)
    bounds = [first + n * k // workers for k in range(workers + 1)]
    blocks = [(program, start, stop - start, seed, digest, map_file) for start, stop in itertools.pairwise(bounds)]
    _INHERITED["scenario"] = scenario  # read by forked children only; cleared before returning
    try:
        context = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
            parts = list(pool.map(_sample_block, blocks))
    finally:
        _INHERITED.clear()
    return [scene for part in parts for scene in part]


MIN_BLOCK = 200  # scenes per process below which forking costs more than it saves
_INHERITED: dict[str, Any] = {}


def _sample_block(block: tuple[Path, int, int, int, str, str]) -> list[SampledScene]:
    program, start, count, seed, digest, map_file = block
    return _generate(_INHERITED["scenario"], program, start, count, seed, digest, map_file)


def _generate(scenario: Any, program: Path, first: int, n: int, seed: int, digest: str,
              map_file: str) -> list[SampledScene]:
    py_state, np_state = random.getstate(), np.random.get_state()
    scenes = []
    try:
        for index in range(first, first + n):
            py_seed, np_seed = scene_seed(seed, index)
            random.seed(py_seed)
            np.random.seed(np_seed)
            try:
                scene, _ = scenario.generate(maxIterations=MAX_ITERATIONS, verbosity=0)
            except Exception as exc:
                raise SampleError(f"{program}: scene {index} (seed {seed}) could not be sampled: "
                                  f"{type(exc).__name__}: {exc}") from exc
            scenes.append(to_sampled_scene(scene, index, seed, digest, map_file))
    finally:
        random.setstate(py_state)
        np.random.set_state(np_state)
    return scenes


def to_sampled_scene(scene: Any, index: int, seed: int, digest: str, map_file: str) -> SampledScene:
    """Convert a Scenic scene into the render -> simulate contract."""
    actors = [_actor(obj) for obj in scene.objects if getattr(obj, "cs_role", None)]
    params: dict[str, float | int | str] = {}
    for key, value in scene.params.items():
        if key in _SKIP_PARAMS:
            continue
        if isinstance(value, (bool, np.bool_, int, np.integer)):
            params[key] = int(value)
        elif isinstance(value, (float, np.floating)):
            params[key] = float(value)
        elif isinstance(value, str):
            params[key] = value
    if "npc1_INIT_DIST" in params:
        params.setdefault("NPC_INIT_DIST", params["npc1_INIT_DIST"])
    return SampledScene(index=index, seed=seed, scenario_hash=digest, map_file=map_file, params=params,
                        actors=actors)


def _actor(obj: Any) -> SampledActor:
    yaw = wrap_angle(float(obj.heading) + math.pi / 2)  # Scenic 0 = +y -> OpenDRIVE 0 = +x
    codes = str(obj.cs_dispositions or "")
    props = {key: _scalar(getattr(obj, key)) for key in ("cs_placement", "cs_maneuver", "cs_controlled_by",
                                                         "cs_target_speed", "cs_route_lanes")}
    props = {key[3:]: value for key, value in props.items()}
    return SampledActor(
        role=obj.cs_role, label=obj.cs_label, type=obj.cs_type, blueprint=str(obj.blueprint),
        behavior=obj.cs_behavior, x=float(obj.position.x), y=float(obj.position.y), yaw=yaw,
        speed=max(0.0, float(obj.speed)), length=float(obj.length), width=float(obj.width),
        lane_id=str(obj.cs_lane_id) if obj.cs_lane_id is not None else None, route_intent=obj.cs_route_intent,
        reference=obj.cs_reference, relation=obj.cs_relation, heading_relation=obj.cs_heading_relation,
        dispositions=[c for c in codes.split(",") if c], properties=props)


def _scalar(value: Any) -> float | int | str | bool | None:
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, np.generic):
        return value.item()
    return str(value)


def program_identity(program: Path, map_path: str | Path | None = None) -> tuple[str, str]:
    """The scenario hash scenes of `program` carry, and the map they run on (`map_path`, else the rendered one)."""
    meta = _render_meta(program)
    digest = meta.get("scenario_hash") or _program_hash(program)
    map_file = str(map_path) if map_path is not None else str(program.parent / meta.get("map", "map.xodr"))
    return digest, map_file


def _render_meta(program: Path) -> dict[str, Any]:
    meta = program.parent / "render.json"
    if meta.is_file():
        try:
            return json.loads(meta.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return {}
    return {}


def _program_hash(program: Path) -> str:
    import hashlib

    return hashlib.sha256(program.read_bytes()).hexdigest()[:16]
